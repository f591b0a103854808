//! pumpcyl: model, analyse, identify and design pump-controlled hydraulic cylinders.
//!
//! Library first; the `pumpcyl` binary is a thin command-line layer over it. Modules:
//! - [`bulk`] — effective bulk modulus against pressure: gas fraction, β_e(p), margins there;
//! - [`cli`] — the command-line interface: argument parsing and formatting only;
//! - [`design`] — the design method: the largest position gain meeting margin targets;
//! - [`emulator`] — the nonlinear rig emulator and the emulated article records;
//! - [`figures`] — the figures of results (signals, drive step, β_e(p), Bode, landscape) as SVG and PNG;
//! - [`ident`] — identification from records: drive gain, leakage, grid search, refinement;
//! - [`input`] — decoding user files and locating their errors;
//! - [`loops`] — the loop a command analyses or exports (a rig's or a JSON model's) and its view;
//! - [`lti`] — generic state-space analysis: poles, frequency response, margins, ZOH responses;
//! - [`matfile`] — MAT-files (level 5): the writer and the record reader;
//! - [`matlab`] — MATLAB/Octave function files: the model as `ss`, the grey-box function;
//! - [`model`] — the 10-state DPM model, its variants, open and closed loops;
//! - [`output`] — safe result files and folders: whole or not at all, never over an input;
//! - [`record`] — measured or emulated records (CSV), read by column name;
//! - [`report`] — the plotting primitives (panels, Bode, heat map; SVG and PNG) and the HTML report;
//! - [`reproduce`] — the article's whole workflow as one call: numbers, figures, report;
//! - [`response`] — step, tracking and recorded-reference responses and their metrics;
//! - [`rig`] — the rig parameters, their validation and their TOML form.
//!
//! Method manual: docs/README.md. It cites Gøytil, Hansen & Tvilde, *Effective Bulk
//! Modulus in Low-Pressure Pump-Controlled Hydraulic Cylinders*, Actuators 2025, 14(8), 366.
//!
//! Quick start: the stability margins of a rig (docs/analysis.md#margins).
//!
//! ```
//! use pumpcyl::{lti::margins, model::Plant, rig::Rig};
//!
//! // the article's rig with a lighter load, read as a TOML rig file would be
//! let rig = Rig::from_toml_str("mass_kg = 4898.0\n", "my-rig.toml")?;
//! // margins of the position loop, opened as the article opens it (sum-pressure loop open)
//! let m = margins(&Plant::new(&rig).open_loop(false))?;
//! println!("GM {:.2} dB, PM {:.1} deg", m.gain_margin_db.unwrap(), m.phase_margin_deg.unwrap());
//! assert!(m.closed_loop_stable);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

pub mod bulk;
pub mod cli;
pub mod design;
pub mod emulator;
pub mod figures;
#[doc(hidden)]
pub mod fuzzing;
pub mod ident;
pub mod input;
pub mod limits;
pub mod loops;
pub mod lti;
pub mod matfile;
pub mod matlab;
pub mod model;
pub mod output;
pub mod record;
pub mod report;
pub mod reproduce;
pub mod response;
pub mod rig;
