//! pumpcyl: model, analyse, identify and design pump-controlled hydraulic cylinders.
//!
//! This is the core of the workspace (docs/architecture.md): typed inputs and typed results
//! with units in their field names, typed errors, progress and cancellation through callbacks
//! the caller passes in. It reads the files it is given (rigs, experiments, records) but never
//! writes a file, prints, installs a signal handler or ends the process, so the command line,
//! the Python package or any Rust program can embed it. Figures, the article workflow and every
//! writer are in `pumpcyl-present`; the command line is `pumpcyl-cli`. Modules:
//! - [`bulk`] — effective bulk modulus against pressure: gas fraction, β_e(p), margins there;
//! - [`cavitation`] — the lowest pressure a chamber can hold, checked in every steady state;
//! - [`circuit`] — the hydraulic circuits behind one interface, each linearised from its own equations;
//! - [`design`] — the design method: the largest position gain meeting margin targets;
//! - [`emulator`] — the nonlinear rig emulator and the emulated article records;
//! - [`frf`] — frequency response from sweep records: excitations, estimate, experiment design;
//! - [`ident`] — identification from records: drive gain, leakage, grid search, refinement;
//! - [`source_files`] — reading the files a user writes and locating their errors;
//! - [`loops`] — the loop a command analyses or exports (a rig's or a JSON model's) and its view;
//! - [`lti`] — generic state-space analysis: poles, frequency response, margins, ZOH responses;
//! - [`matfile`] — MAT-files (level 5): the reader of records;
//! - [`model`] — the 10-state DPM model, its variants, open and closed loops;
//! - [`record`] — measured or emulated records (CSV), read by column name;
//! - [`response`] — step, tracking and recorded-reference responses and their metrics;
//! - [`rig`] — the rig parameters, their validation and their TOML form;
//! - [`units`] — conversions between the user-facing units and SI, and readable numbers.
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
// The core never prints or ends the process (docs/architecture.md): its callers decide.
#![deny(clippy::print_stdout, clippy::print_stderr, clippy::exit)]

pub mod anchor;
pub mod bulk;
pub mod cavitation;
pub mod circuit;
pub mod design;
pub mod emulator;
pub mod fmu;
pub mod frf;
#[doc(hidden)]
pub mod fuzzing;
pub mod ident;
pub mod limits;
pub mod loops;
pub mod lti;
pub mod matfile;
pub mod model;
pub mod record;
pub mod response;
pub mod rig;
pub mod select;
pub mod source_files;
pub mod units;
