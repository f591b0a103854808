//! The plotting toolkit: analysis results drawn as figures.
//!
//! Everything here renders into memory (an SVG document as a `String`, a PNG
//! file as bytes); writing the result to disk is the caller's job. Text is
//! drawn with an embedded copy of DejaVu Sans, so no system fonts are needed.

mod axes;
mod bode;
mod error;
pub(crate) mod font;
mod layout;
mod legend;
mod overlap;
mod precise;
mod render;
mod series;
mod stack;
pub use error::ReportError;
pub use layout::{sig, text_collisions, text_overflow};

pub use bode::{bode_png, bode_svg, BodeMarkers, BodeSeries, DEFAULT_HEIGHT_PX, DEFAULT_WIDTH_PX};
mod timeseries;
pub use timeseries::*;

mod heatmap;
pub use heatmap::*;
