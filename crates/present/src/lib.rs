//! pumpcyl-present: the presentation layer of pumpcyl (docs/architecture.md).
//!
//! Everything a front end shows or writes is made here, once, for the command line, the Python
//! package and any Rust program: figures, the article workflow and its report, and every JSON,
//! text, CSV and MAT document. The numerics are in the core crate (`pumpcyl`); front ends only
//! parse, call and show. Modules:
//! - [`plot`] — the plotting toolkit (panels, Bode, heat map; SVG and PNG);
//! - [`html`] — the self-contained HTML page of a report;
//! - [`analysis`] — margins as a JSON document and as text; poles, Bode CSV, the model as text;
//! - [`time`] — step, tracking and replay documents: JSON, text, signal CSV, MAT-files;
//! - [`bulk`] — the gas fraction and β_e against pressure: JSON, text, CSV;
//! - [`advise`] — experiment advice as JSON and text;
//! - [`chatter`] — will a single-pump rig chatter: the scan over loads as JSON, text, CSV and a
//!   figure;
//! - [`design`] — the design results in words: verdict, deciding margin, nominal and robust
//!   design as text and JSON, leakage loop;
//! - [`emulated`] — what the emulator used on a rig, in words;
//! - [`figures`] — the figures of results (signals, drive step, β_e(p), Bode, landscape);
//! - [`frf`] — a frequency-response estimate as text, JSON, CSV and a Bode figure with its band;
//! - [`identification`] — the files of an identification (result.json, landscape, fits, MAT);
//! - [`matfile`] — the MAT-file writer (the reader is the core's);
//! - [`matlab`] — MATLAB/Octave files: the model as `ss`, the grey-box function, MAT-files;
//! - [`files`] — safe result files and folders: whole or not at all, never over an input;
//! - [`mod@format`] — numbers, names and JSON documents as the outputs show them;
//! - [`records`] — the one CSV writer; records, drive records and the emulated article records'
//!   folder (CSV, README, identify experiment);
//! - [`reproduce`] — the article's whole workflow as one call: numbers, figures, report;
//! - [`request`] — the commands as requests: options in, the document both front ends show out;
//! - [`table`] — tables of text cells, for terminals and reports;
//! - [`uncertainty`] — the uncertainty of an identification: JSON fields, text, profile figures.

#![warn(missing_docs)]

pub mod advise;
pub mod analysis;
pub mod bulk;
pub mod chatter;
pub mod design;
pub mod documents;
pub mod emulated;
pub mod energy;
pub mod figures;
pub mod files;
pub mod fmu;
pub mod format;
pub mod frf;
pub mod html;
pub mod identification;
pub mod matfile;
pub mod matlab;
pub mod origin;
pub mod plot;
pub mod records;
pub mod reproduce;
pub mod request;
pub mod robustness;
pub mod select;
pub mod table;
pub mod time;
pub mod uncertainty;
