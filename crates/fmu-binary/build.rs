//! Build crates/fmu (the FMU's shared library) and put it in OUT_DIR for `include_bytes!`.
//!
//! Cargo cannot depend on another crate's shared library (artifact dependencies are
//! unstable), so this runs a second cargo: profile `fmu` (optimised, stripped), its own
//! target folder `<target>/fmu-lib` shared by every outer build (test, maturin, release), so
//! it compiles once. On a host other than Linux x86-64 the library is empty and `pumpcyl fmu`
//! says so.

use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dest = out.join("pumpcyl.so");
    let target = std::env::var("TARGET").unwrap_or_default();
    println!("cargo:rerun-if-env-changed=PUMPCYL_FMU_LIBRARY");
    if target != "x86_64-unknown-linux-gnu" {
        std::fs::write(&dest, b"").expect("write OUT_DIR");
        return;
    }
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let root = manifest
        .join("../..")
        .canonicalize()
        .expect("the workspace root");
    for watched in [
        "crates/fmu",
        "crates/core/src",
        "crates/core/Cargo.toml",
        "Cargo.lock",
        "Cargo.toml",
    ] {
        println!("cargo:rerun-if-changed={}", root.join(watched).display());
    }
    // <target>/<profile>/build/<crate>/out → <target>
    let target_dir = out.ancestors().nth(4).unwrap_or(&out).join("fmu-lib");
    build(&root, &target_dir);
    let built = target_dir.join("fmu").join("libpumpcyl_fmu.so");
    std::fs::copy(&built, &dest).unwrap_or_else(|e| panic!("{}: {e}", built.display()));
}

/// `cargo build -p pumpcyl-fmu --profile fmu` in `root`, into `target_dir`.
fn build(root: &Path, target_dir: &Path) {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(root)
        .args([
            "build",
            "--locked",
            "-p",
            "pumpcyl-fmu",
            "--profile",
            "fmu",
            "--target-dir",
        ])
        .arg(target_dir);
    // the outer build's settings are not this library's: a wrapper (clippy), its flags and
    // its target folder would change or break the inner build
    for var in [
        "RUSTC_WRAPPER",
        "RUSTC_WORKSPACE_WRAPPER",
        "CARGO_ENCODED_RUSTFLAGS",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET",
        "CARGO_BUILD_TARGET_DIR",
        "CARGO_PRIMARY_PACKAGE",
        "RUSTDOCFLAGS",
    ] {
        cmd.env_remove(var);
    }
    let status = cmd.status().expect("run cargo for crates/fmu");
    assert!(status.success(), "building crates/fmu failed: {status}");
}
