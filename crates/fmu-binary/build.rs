//! Build crates/fmu (the FMU's shared library) and put it in OUT_DIR for `include_bytes!`.
//!
//! Cargo cannot depend on another crate's shared library (artifact dependencies are
//! unstable). This script links it itself: `pumpcyl` is one of its build dependencies, and
//! the workspace's `build-override` profiles give build dependencies the settings of the
//! outer build, so Cargo compiles the core and its dependencies once, for both (a unit
//! shared between a build dependency and a normal dependency when host and target are the
//! same). The script then runs rustc on crates/fmu's one source file against those rlibs: a
//! few seconds, instead of a second cargo compiling every numeric dependency again in a
//! profile of its own (docs/architecture.md#build-times). On a host other than Linux x86-64
//! the library is empty and `pumpcyl fmu` says so.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let dest = out.join("pumpcyl.so");
    let target = std::env::var("TARGET").unwrap_or_default();
    if target != "x86_64-unknown-linux-gnu" {
        std::fs::write(&dest, b"").expect("write OUT_DIR");
        return;
    }
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let source = manifest.join("../fmu/src/lib.rs");
    println!("cargo:rerun-if-changed={}", source.display());
    // <target>/<profile>/build/<crate>/out → <target>/<profile>/deps
    let deps = out.ancestors().nth(3).unwrap_or(&out).join("deps");
    let core = newest_core_rlib(&deps);
    // the core's rlib is a build dependency: a change to it reruns this script
    link(&source, &core, &deps, &dest);
}

/// The `pumpcyl` rlib this script was linked with: the newest `libpumpcyl-*.rlib` in `deps`.
/// Cargo compiles a build dependency before running the script, so a core changed since the
/// last run is the newest; more than one exists only where builds with other feature sets
/// share the folder.
fn newest_core_rlib(deps: &Path) -> PathBuf {
    let listing = std::fs::read_dir(deps).unwrap_or_else(|e| panic!("{}: {e}", deps.display()));
    listing
        .filter_map(Result::ok)
        .filter(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.starts_with("libpumpcyl-") && name.ends_with(".rlib")
        })
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .max()
        .map(|(_, path)| path)
        .unwrap_or_else(|| panic!("no libpumpcyl-*.rlib in {}", deps.display()))
}

/// rustc: crates/fmu's `source` as a stripped cdylib at `dest`, against the `core` rlib and
/// the dependencies in `deps`, at the outer build's optimisation and flags.
fn link(source: &Path, core: &Path, deps: &Path, dest: &Path) {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let opt = std::env::var("OPT_LEVEL").unwrap_or_else(|_| "3".into());
    let mut extern_core = OsString::from("pumpcyl=");
    extern_core.push(core);
    let mut search = OsString::from("dependency=");
    search.push(deps);
    let mut cmd = Command::new(rustc);
    cmd.args(["--crate-name", "pumpcyl_fmu", "--crate-type", "cdylib"])
        .args(["--edition", "2021", "--cap-lints", "allow"])
        .args(["-C", &format!("opt-level={opt}"), "-C", "strip=symbols"])
        .arg("--extern")
        .arg(extern_core)
        .arg("-L")
        .arg(search)
        .arg("-o")
        .arg(dest)
        .arg(source);
    // the flags the rlibs were compiled with (target features and the like) apply here too
    if let Ok(flags) = std::env::var("CARGO_ENCODED_RUSTFLAGS") {
        cmd.args(flags.split('\x1f').filter(|f| !f.is_empty()));
    }
    let status = cmd.status().expect("run rustc for crates/fmu");
    assert!(status.success(), "linking crates/fmu failed: {status}");
}
