//! `pumpcyl fmu` (docs/fmu.md): the archive holds what FMI 2.0 asks (modelDescription.xml,
//! the configuration, the shared library with every FMI function), and bad options or
//! parameters are refused before any file is written. FMPy runs the FMUs in the Python suite
//! (python/tests/test_fmu.py).

use fmi_schema::traits::FmiModelDescription;
use std::io::Read;
use std::path::Path;

#[path = "common/run.rs"]
#[allow(dead_code)]
mod run;

fn entry(archive: &Path, name: &str) -> Vec<u8> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(archive).unwrap()).unwrap();
    let mut f = zip.by_name(name).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut out = Vec::new();
    f.read_to_end(&mut out).unwrap();
    out
}

#[test]
fn the_fmu_holds_its_description_configuration_and_library() {
    let dir = tempfile::tempdir().unwrap();
    let out = run::pumpcyl(
        dir.path(),
        &[
            "fmu",
            "--model",
            "linear",
            "--loop",
            "open",
            "--out",
            "plant.fmu",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let fmu = dir.path().join("plant.fmu");
    let xml = String::from_utf8(entry(&fmu, "modelDescription.xml")).unwrap();
    let body = xml.split_once("?>").unwrap().1.trim();
    let md = fmi_schema::fmi2::Fmi2ModelDescription::deserialize(body).unwrap();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(
        md.co_simulation.as_ref().unwrap().model_identifier,
        "pumpcyl"
    );
    // the open loop's inputs are the speed commands and the force; every rig scalar is a parameter
    let inputs: Vec<&str> = md
        .model_variables
        .variables
        .iter()
        .filter(|v| v.causality == fmi_schema::fmi2::Causality::Input)
        .map(|v| v.name.as_str())
        .collect();
    assert_eq!(
        inputs,
        ["omega_ref1_rad_per_s", "omega_ref2_rad_per_s", "f_ext_n"]
    );
    assert!(md.model_variable_by_name("c12_m5_per_ns").is_ok());
    assert!(xml.contains(r#"unit="m5/(N.s)""#));
    // the configuration carries the same GUID
    let config = String::from_utf8(entry(&fmu, "resources/pumpcyl-fmu.toml")).unwrap();
    assert!(
        config.contains(&format!("guid = \"{}\"", md.guid)),
        "{config}"
    );
    // the library is an x86-64 ELF shared object exporting the FMI functions
    let so = entry(&fmu, "binaries/linux64/pumpcyl.so");
    assert_eq!(&so[..4], b"\x7fELF");
    for f in [
        "fmi2Instantiate",
        "fmi2DoStep",
        "fmi2ExitInitializationMode",
        "fmi2FreeInstance",
    ] {
        assert!(
            so.windows(f.len()).any(|w| w == f.as_bytes()),
            "{f} not exported"
        );
    }
}

#[test]
fn bad_options_and_parameters_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    run::refused(
        dir.path(),
        &["fmu", "--out", "rig.zip"],
        &["rig.zip", ".fmu"],
    );
    run::refused(
        dir.path(),
        &["fmu", "--set", "mass_kg=nan", "--out", "x.fmu"],
        &["mass_kg"],
    );
    run::refused(
        dir.path(),
        &[
            "fmu",
            "--set",
            "beta_bar=0",
            "--model",
            "linear",
            "--out",
            "x.fmu",
        ],
        &["beta_bar"],
    );
    run::refused(
        dir.path(),
        &[
            "fmu",
            "--model",
            "linear",
            "--controller",
            "external",
            "--out",
            "x.fmu",
        ],
        &["--loop open"],
    );
    run::refused(
        dir.path(),
        &["fmu", "--set", "motor_model=first_order", "--out", "x.fmu"],
        &["motor_model"],
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn an_emulator_that_would_rest_outside_its_cylinder_is_not_written() {
    // kp 1e-6 rests 1 373 m below the cylinder, kp 1e-3 about a metre: refused when the file
    // is written (docs/emulator.md#end-stops), not in the user's simulator
    let dir = tempfile::tempdir().unwrap();
    for (kp, rest) in [("kp=1e-6", "x = -1373"), ("kp=1e-3", "x = -10")] {
        run::refused(
            dir.path(),
            &["fmu", "--set", kp, "--out", "weak.fmu"],
            &["would not start", rest, "outside the stroke 0…500 mm"],
        );
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
