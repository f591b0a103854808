//! pumpcyl: model, analyse, identify and design pump-controlled hydraulic cylinders.
//!
//! Library first; the `pumpcyl` binary is a thin command-line layer over it. Modules:
//! - [`rig`] — the rig parameters and their TOML form (SPEC §2);
//! - [`model`] — the 10-state DPM model and its variants (SPEC §3–4);
//! - [`lti`] — generic state-space analysis: poles, frequency response, margins (SPEC §4);
//! - [`report`] — figures;
//! - [`input`] — decoding user files and locating their errors.
//!
//! SPEC refers to `shared/SPEC.md`, the restatement of Gøytil, Hansen & Tvilde, *Effective Bulk
//! Modulus in Low-Pressure Pump-Controlled Hydraulic Cylinders*, Actuators 2025, 14(8), 366.

pub mod bulk;
pub mod cli;
pub mod design;
pub mod emulator;
#[doc(hidden)]
pub mod fuzzing;
pub mod ident;
pub mod input;
pub mod limits;
pub mod lti;
pub mod model;
pub mod record;
pub mod report;
pub mod response;
pub mod rig;
