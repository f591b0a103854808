//! Embedded font for plot text.
//!
//! plotters is built without its `ttf` feature (no system font lookup), so
//! every text it measures or rasterises needs a font registered through
//! [`plotters::style::register_font`]. We embed DejaVu Sans (licence in
//! `assets/fonts/LICENSE-DejaVu.txt`) and register it, once, under the family
//! name [`FAMILY`]; all report code must use that family for its text.

use super::error::ReportError;
use std::sync::OnceLock;

use plotters::style::{register_font, FontStyle};

/// Font family name under which the embedded font is registered. Every text
/// drawn by the report module uses this family (it is also the family
/// plotters uses by default for axis labels).
pub(crate) const FAMILY: &str = "sans-serif";

/// The family name inside the embedded font file.
pub(crate) const EMBEDDED_FAMILY: &str = "DejaVu Sans";

/// DejaVu Sans 2.37 (Bitstream Vera licence), embedded in the binary.
pub(crate) static DEJAVU_SANS: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../assets/fonts/DejaVuSans.ttf"
));

/// Outcome of the one registration attempt (whether the font parsed), shared by all threads.
static REGISTERED: OnceLock<bool> = OnceLock::new();

/// Register the embedded font with plotters under [`FAMILY`] (normal style;
/// plotters falls back to it for the other styles). Thread-safe; the
/// registration runs only on the first call, later calls return its outcome.
pub(crate) fn ensure_registered() -> Result<(), ReportError> {
    let parsed =
        *REGISTERED.get_or_init(|| register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok());
    if parsed {
        Ok(())
    } else {
        Err(ReportError::Plot(
            "the embedded DejaVu Sans font could not be parsed".into(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registers_once_and_is_idempotent() {
        assert!(ensure_registered().is_ok());
        assert!(ensure_registered().is_ok());
        // The font is a TrueType file (version tag 0x00010000).
        assert_eq!(&DEJAVU_SANS[..4], &[0, 1, 0, 0]);
    }
}
