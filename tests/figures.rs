//! Every figure `pumpcyl reproduce` makes: no text of an SVG runs outside its view box (extents
//! from the embedded font's metrics), and every PNG decodes at the size the command asks for
//! with anti-aliased curves (docs/formats.md, "Figures").

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// One reproduce run shared by the tests of this file; its figures folder.
fn figures() -> &'static PathBuf {
    static RUN: OnceLock<PathBuf> = OnceLock::new();
    RUN.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("figures-test");
        let _ = std::fs::remove_dir_all(&dir);
        let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
            .args(["reproduce", "--out", dir.to_str().unwrap()])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        dir.join("figures")
    })
}

/// The files of the figures folder with extension `ext`, sorted.
fn files(ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(figures())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

#[test]
fn no_text_runs_outside_any_svg() {
    let svgs = files("svg");
    // The article's figures: Bode and step diagrams, sines, drive step, robustness, β_e.
    assert!(svgs.len() >= 15, "{svgs:?}");
    let mut bad = Vec::new();
    for p in &svgs {
        let svg = std::fs::read_to_string(p).unwrap();
        assert!(svg.contains("<text"), "{} has no text", p.display());
        for t in pumpcyl::report::text_overflow(&svg) {
            bad.push(format!("{}: {t}", p.file_name().unwrap().to_string_lossy()));
        }
    }
    assert!(
        bad.is_empty(),
        "texts outside the figure:\n{}",
        bad.join("\n")
    );
}

#[test]
fn titles_print_rounded_numbers() {
    let svg = std::fs::read_to_string(figures().join("bulk_modulus.svg")).unwrap();
    // No number in a text with more than 6 significant digits (167.122791980682 was one).
    for t in svg.split("<text").skip(1) {
        let content = &t[t.find('>').unwrap() + 1..t.find("</text>").unwrap()];
        let longest = content
            .split(|c: char| !c.is_ascii_digit())
            .map(str::len)
            .max()
            .unwrap_or(0);
        assert!(longest <= 6, "unrounded number in {content:?}");
    }
}

#[test]
fn pngs_have_the_asked_size_and_anti_aliased_curves() {
    let pngs = files("png");
    assert_eq!(pngs.len(), files("svg").len());
    for p in &pngs {
        let img = image::open(p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .to_rgb8();
        // reproduce asks for 1500 px wide figures: 1500 x 1125 Bode diagrams, 1500 x 1200 for
        // β_e against pressure, 1500 x 1500 for the stacked time series.
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        let height = if name.starts_with("bode_") {
            1125
        } else if name == "bulk_modulus.png" {
            1200
        } else {
            1500
        };
        assert_eq!((img.width(), img.height()), (1500, height), "{name}");
        // The first series' blue (0, 114, 178) over white: anti-aliased curves have edge pixels
        // blending it with white about as often as fully blue pixels; jagged curves drawn
        // without anti-aliasing (plotters' bitmap backend) had 0.10-0.15 blends per blue pixel on the step figures (0.3-1.5 here).
        let (mut blend, mut pure) = (0usize, 0usize);
        for p in img.pixels() {
            let a = (255.0 - f64::from(p.0[0])) / 255.0;
            let on_line = [0.0, 114.0, 178.0]
                .iter()
                .zip(p.0)
                .all(|(c, v)| (a * c + (1.0 - a) * 255.0 - f64::from(v)).abs() < 8.0);
            if on_line && a >= 0.95 {
                pure += 1;
            } else if on_line && a > 0.05 {
                blend += 1;
            }
        }
        assert!(pure > 500, "{name}: {pure} blue pixels");
        let ratio = blend as f64 / pure as f64;
        assert!(
            ratio > 0.22,
            "{name}: {ratio:.2} edge blends per blue pixel"
        );
    }
}
