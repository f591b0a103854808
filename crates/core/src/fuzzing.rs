//! The entry points of the fuzz targets (`fuzz/`, run with `cargo fuzz`, see fuzz/README.md).
//! Each takes arbitrary bytes and must return, never panic, whatever the bytes are; a test runs
//! every one over the bad-input and awkward-input corpora so they stay compiled and exercised
//! on the stable toolchain.

use crate::ident::Experiment;
use crate::lti::{eigenvalues, margins, ModelJson};
use crate::model::Plant;
use crate::record::{Record, Table};
use crate::rig::Rig;
use crate::source_files;
use std::path::Path;

/// A record and a drive-step table from CSV bytes (any dialect).
pub fn record_csv(data: &[u8]) {
    let _ = Record::parse(data, "fuzz.csv");
    let _ = Table::parse(data, "fuzz.csv", &["time_s", "w_ref_rpm", "w_rpm"], &[]);
}

/// A record from MAT-file bytes (level 5, any variables, compressed or not).
pub fn record_mat(data: &[u8]) {
    let _ = Record::parse_mat(data, "fuzz.mat");
}

/// A rig from TOML bytes; a rig that validates is modelled and its margins computed, so odd but
/// valid values (1e300 kg) reach the numerics too.
pub fn rig_toml(data: &[u8]) {
    let Ok(text) = source_files::decode(data.to_vec()) else {
        return;
    };
    let _ = source_files::toml_line(&text, &[source_files::Key::Name("mass_kg")]);
    if let Ok(rig) = Rig::from_toml_str(&text, "fuzz.toml") {
        let _ = margins(&Plant::new(&rig).open_loop(false));
    }
}

/// An identification experiment from TOML bytes, in a folder without records.
pub fn experiment_toml(data: &[u8]) {
    if let Ok(text) = source_files::decode(data.to_vec()) {
        let _ = Experiment::from_text(&text, Path::new("/nonexistent/fuzz.toml"));
    }
}

/// A `--ss` model from JSON bytes; a model that parses gets its poles and margins computed.
pub fn ss_json(data: &[u8]) {
    let Ok(text) = source_files::decode(data.to_vec()) else {
        return;
    };
    if let Ok((sys, _)) = ModelJson::parse(&text) {
        let _ = eigenvalues(&sys.a);
        let _ = margins(&sys);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every file under `dir` (recursively).
    fn files(dir: &Path) -> Vec<std::path::PathBuf> {
        let mut out = Vec::new();
        for entry in std::fs::read_dir(dir).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                out.extend(files(&path));
            } else {
                out.push(path);
            }
        }
        out
    }

    #[test]
    fn every_target_survives_every_corpus_file() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut corpus = files(&root.join("tests/bad-inputs"));
        corpus.extend(files(&root.join("tests/awkward-inputs")));
        corpus.extend(files(&root.join("data/article")));
        assert!(corpus.len() > 80, "{}", corpus.len());
        for path in corpus {
            let data = std::fs::read(&path).unwrap();
            for target in [record_csv, record_mat, rig_toml, experiment_toml, ss_json] {
                target(&data);
            }
        }
    }
}
