//! The article's whole workflow (docs/README.md) on the embedded rig and the embedded emulated
//! records, as one library call: the drive gain (the article §2.4.1), the leakages and the
//! two-stage identification (§2.4), the robustness record, the bulk modulus against pressure,
//! the damping studies (Figures 11 and 14), the stroke (§3.3, Figure 15), the sinusoidal tracking and the
//! design check (§2.2), and pumpcyl's own studies: how sure the identification is, which
//! circuit (§4), and the article's Figure 1 circuits on its own application (§2.1, §4).
//!
//! [`reproduce`] returns a [`Reproduction`]: the numbers (typed, and as the `summary.json`
//! document), the comparison with the article's printed values, the figures (SVG and PNG in
//! memory), the report's body and the other result files. Nothing is printed and nothing is
//! written until [`Reproduction::write`], which puts the whole folder in place or nothing.
//!
//! (`no_run` here: about 15 s in a debug build; tests/workflow.rs runs it and checks these
//! numbers.)
//!
//! ```no_run
//! use pumpcyl_present::reproduce::{reproduce, ReproduceOptions};
//!
//! let r = reproduce(&ReproduceOptions::default())?;
//! // the emulated records were made with beta_e = 165 bar at their mean pressure
//! assert!((r.identified.beta_bar - 165.0).abs() < 10.0);
//! // the default rig's gain margin, as the article prints it (6.5 dB, §2.3.3)
//! assert!((r.default_margins.gain_margin_db.unwrap() - 6.5).abs() < 0.1);
//! // every registered figure, in the registry's order
//! assert_eq!(r.figures.len(), pumpcyl_present::reproduce::FIGURES.len());
//! // the whole result folder, swapped in at once: figures/, records/, identification/,
//! // summary.json, report.html
//! r.write(std::path::Path::new("reproduced"))?;
//! # Ok::<(), anyhow::Error>(())
//! ```

mod bias;
mod case;
mod certainty;
mod circuit;
mod energy;
mod figure1_circuits;
mod identification;
mod pressure;
mod registry;
mod studies;
pub mod summary;
mod sweep;
mod tracking;
mod valve_or_pump;
pub use certainty::Certainty;
pub use registry::{Registered, FIGURES};
pub use summary::Summary;

use crate::figures::{bode_markers, Chart};
use crate::files::{Committed, OutDir, Protected};
use crate::format::fmt_opt;
use crate::html::{html_page, Block};
use crate::plot::BodeSeries;
use anyhow::Result;
use pumpcyl::emulator::article::{self, EMBEDDED};
use pumpcyl::ident::Candidate;
use pumpcyl::lti::{self, Margins};
use pumpcyl::model::Plant;
use pumpcyl::response::{self, Signals, StepMetrics};
use pumpcyl::rig::Rig;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The number of steps [`reproduce`] announces through [`ReproduceOptions::on_step`].
pub const STEPS: usize = 14;

/// What the article prints, for the side-by-side tables (the article §2.1, §2.3, §2.4).
mod printed {
    pub const KM: f64 = 0.026;
    pub const BETA_BAR: f64 = 165.0;
    pub const B_NS_PER_M: f64 = 100.0;
    pub const C12: f64 = 1.2e-10;
    pub const C1: f64 = 5.49e-11;
    pub const C2: f64 = -1.19e-11;
    pub const COST_MM2: f64 = 0.0353;
    pub const GM_DB: f64 = 6.5;
    pub const PM_DEG: f64 = 34.0;
    pub const ROBUST_BETA_BAR: f64 = 220.0;
    pub const ROBUST_C12: f64 = 1.0e-10;
    pub const KP: f64 = 25.0;
    /// Margins at 1 bar mean pressure (dB, deg): the article's bulk-modulus study.
    pub const GM_1BAR_DB: f64 = -6.1;
    pub const PM_1BAR_DEG: f64 = -38.0;
    /// Margins at 10 bar mean pressure (dB, deg): the article's bulk-modulus study.
    pub const GM_10BAR_DB: f64 = 13.2;
    pub const PM_10BAR_DEG: f64 = 43.6;
    /// Kp for the nominal PM: below 25 % of 25 at 1 bar, about +40 % at 10 bar.
    pub const KP_RATIO_1BAR_BELOW: f64 = 0.25;
    pub const KP_CHANGE_10BAR: f64 = 0.40;
    /// PM change at −50 mm and +50 mm of stroke (deg).
    pub const PM_CHANGE_MINUS50_DEG: f64 = 1.4;
    pub const PM_CHANGE_PLUS50_DEG: f64 = -2.0;
    /// Maximum control error measured on the real rig (mm): 0.1 Hz ±50 mm, 0.2 Hz ±35 mm,
    /// 0.25 Hz ±20 mm.
    pub const TRACK_MAX_ERROR_MM: [f64; 3] = [8.52, 11.8, 8.82];
    /// Wave reduction measured on the real rig, same waves.
    pub const WAVE_REDUCTION: [f64; 3] = [0.83, 0.66, 0.56];
    /// The gas fraction from β 165 bar at 4.4 bar (the article's bulk-modulus study).
    pub const GAS_FRACTION: f64 = 0.0264;
    /// The introduction's example: a gas fraction of 1 % gives about 6300 bar at 100 bar and
    /// about 100 bar at 1 bar, 63 times less.
    pub const INTRO_GAS_FRACTION: f64 = 0.01;
    pub const INTRO_BETA_100BAR: f64 = 6300.0;
    pub const INTRO_BETA_1BAR: f64 = 100.0;
    pub const INTRO_RATIO: f64 = 63.0;
    /// The article's §4: the identified β is "approximately forty-fold" below β_e at 100 bar.
    pub const FORTY_FOLD: f64 = 40.0;
    /// The 10–90 % rise time of the identification step (s; Figure 6).
    pub const RISE_TIME_S: f64 = 0.36;
    /// The first grid: best cost (mm²) and candidates below 0.25 mm².
    pub const FIRST_GRID_BEST_MM2: f64 = 0.0694;
    pub const FIRST_GRID_BELOW: u64 = 48;
    /// The bounds of that threshold set: β (bar), b (N·s/m), c12 (m⁵/(N·s)).
    pub const FIRST_GRID_BOUNDS: [[f64; 2]; 3] = [[150.0, 200.0], [200.0, 500.0], [1e-10, 1e-10]];
    /// The PLC's sum-pressure set-point (bar).
    pub const P_SUM_REF_BAR: f64 = 10.0;
    /// The standstill record: motor speeds (rpm) and chamber 1 pressure (bar).
    pub const STANDSTILL_W1_RPM: f64 = -160.0;
    pub const STANDSTILL_W2_RPM: f64 = 245.0;
    pub const STANDSTILL_P1_BAR: f64 = 3.95;
    /// The identification step's mean chamber pressures (bar; the bulk-modulus study).
    pub const STEP_MEAN_P_BAR: [f64; 2] = [4.1, 4.7];
}

/// Which of the article's figures a report figure answers (docs/choices.md#article-figures): the
/// article's own number, from its caption.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// The article's figure with this number: the report's figure shows what its caption names.
    Article(u8),
    /// The article's figure with this number, whose other panels are the article's figures
    /// listed (the identification step's position, with its pressures and motor velocities).
    ArticleWithPanels(u8, &'static [(u8, &'static str)]),
    /// pumpcyl's own figure beside the article's figure with this number: the same study shown
    /// another way (a step where the article draws a Bode diagram, or the reverse).
    Extends(u8),
    /// A study of pumpcyl's own, not in the article.
    Own,
}

impl Source {
    /// The label that heads the figure's caption.
    pub fn label(self) -> String {
        match self {
            Source::Article(n) => format!("Article Figure {n}. "),
            Source::ArticleWithPanels(n, panels) => {
                let panels: Vec<String> = panels
                    .iter()
                    .map(|(k, what)| format!("its {what} panel is Article Figure {k}"))
                    .collect();
                format!("Article Figure {n} ({}). ", panels.join(", "))
            }
            Source::Extends(n) => {
                format!("pumpcyl's own, extending Article Figure {n}. ")
            }
            Source::Own => "pumpcyl's own study, not in the article. ".to_string(),
        }
    }
}

/// The rig of every number compared with the article's: its Table 1 parameters, β 165 bar at
/// 4.4 bar mean pressure.
pub(super) const TABLE1_RIG: &str = "the article's Table 1 rig";
/// The rig of the numbers from the emulated records: the Table 1 rig with the identified β, b,
/// c12 and the leakages c1, c2 from the standstill record.
pub(super) const IDENTIFIED_RIG: &str = "the rig identified from the records";

/// Whether `ours` rounds to `article` at the article's printed precision (half its last digit).
fn agrees(ours: f64, article: f64, last_digit: f64) -> bool {
    (ours - article).abs() <= 0.5 * last_digit + 1e-9
}

/// The notice that heads the report and summary.json: the inputs are emulated.
pub const EMULATED: &str =
    "Every record used here is EMULATED, not measured: the article's measurements are \
not public, so pumpcyl's nonlinear rig emulator made them from a known truth (records/README.md). \
Numbers identified from them show that the method recovers that truth; they are not the article's \
measurements.";

/// A step callback: (step from 1, [`STEPS`], what the step does).
pub type OnStep<'a> = &'a (dyn Fn(usize, usize, &str) + Sync);

/// A search callback: (candidates just evaluated, all candidates); `false` stops the search.
pub type OnCandidates<'a> = &'a (dyn Fn(u64, u64) -> bool + Sync);

/// How [`reproduce`] reports its progress; the default reports nothing.
#[derive(Default, Clone, Copy)]
pub struct ReproduceOptions<'a> {
    /// Called as each step starts with (step, [`STEPS`], what the step does), steps from 1.
    pub on_step: Option<OnStep<'a>>,
    /// Called during the identification's grid search with (candidates just evaluated, all
    /// candidates of the search); returning `false` stops the workflow with an error that
    /// says it was interrupted.
    pub on_candidates: Option<OnCandidates<'a>>,
}

/// One row of the comparison with the article: pumpcyl's value, the article's printed value,
/// the truth the emulated records were made with ("-" where there is none) and one line on why
/// pumpcyl differs (empty when it agrees to the article's printed precision).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ComparisonRow {
    /// The quantity, with its unit.
    pub quantity: String,
    /// pumpcyl's value, formatted.
    pub pumpcyl: String,
    /// The article's printed value.
    pub article: String,
    /// The emulator's truth, or "-".
    pub truth: String,
    /// Why pumpcyl differs from the article, or "".
    pub why: String,
}

/// The comparison with the article for a terminal `width` characters wide: a table of the
/// quantity, pumpcyl's value, the article's and the emulator's truth (cells wrapped to fit),
/// each row with a difference pointing to a numbered note below the table.
pub fn comparison_text(rows: &[ComparisonRow], width: usize) -> String {
    let mut notes = Vec::new();
    let cells: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            let note = if r.why.is_empty() {
                String::new()
            } else {
                notes.push(r.why.as_str());
                format!("[{}]", notes.len())
            };
            vec![
                r.quantity.clone(),
                r.pumpcyl.clone(),
                r.article.clone(),
                r.truth.clone(),
                note,
            ]
        })
        .collect();
    let header = ["quantity", "pumpcyl", "article", "emulator truth", "note"];
    let mut out = crate::table::wrapped_text(&header, &cells, width);
    if !notes.is_empty() {
        out.push_str("\nnotes: why pumpcyl differs from the article\n");
    }
    for (k, note) in notes.iter().enumerate() {
        let mark = format!("[{}] ", k + 1);
        let indent = " ".repeat(mark.len());
        for (i, line) in crate::table::wrap(note, width - mark.len())
            .iter()
            .enumerate()
        {
            out.push_str(if i == 0 { &mark } else { &indent });
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

/// A figure of the workflow, rendered: written as `figures/STEM.svg` and `figures/STEM.png`.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name without extension.
    pub stem: String,
    /// The caption in the report.
    pub caption: String,
    /// The SVG document.
    pub svg: String,
    /// The PNG file.
    pub png: Vec<u8>,
}

/// The workflow's result. The typed fields hold the headline numbers; [`Reproduction::summary`]
/// holds every number, as written to summary.json.
#[derive(Debug, Clone)]
pub struct Reproduction {
    /// Drive gain Km from the drive step (N·m·s/rad; the article §2.4.1).
    pub km_nms_per_rad: f64,
    /// The identified rig: the default rig with the identified β (bar), b (N·s/m), c12 and the
    /// leakages c1, c2 from the standstill record (m⁵/(N·s)).
    pub identified: Rig,
    /// The identification cost at the identified point (mm²).
    pub cost_mm2: f64,
    /// Margins of the identified rig (sum-pressure loop open, the article §2.3.3).
    pub identified_margins: Margins,
    /// Margins of the default (the article's) rig.
    pub default_margins: Margins,
    /// Gas fraction from the identified β at the records' mean pressure (docs/bulk-modulus.md).
    pub gas_fraction: f64,
    /// The identification records' mean chamber pressure (bar).
    pub p_mean_bar: f64,
    /// The largest Kp meeting PM 34° and GM 6 dB at the identified operating point (the
    /// article §2.2).
    pub design_kp: f64,
    /// How sure the identification is: intervals, the design over them, the next experiment
    /// (step 9).
    pub certainty: Certainty,
    /// pumpcyl beside the article's printed values.
    pub comparison: Vec<ComparisonRow>,
    /// Every number, as written to summary.json.
    pub summary: Summary,
    /// The report's body (after the notice, the introduction and the comparison table).
    pub blocks: Vec<Block>,
    /// The figures, in the order of the report.
    pub figures: Vec<Figure>,
    /// The other files of the result folder: the records under `records/`, the identification
    /// under `identification/` (paths relative to the folder).
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// Wall-clock time of the workflow (s).
    pub seconds: f64,
}

/// The report being assembled: the HTML blocks, the comparison, the files.
struct Run<'a> {
    opts: &'a ReproduceOptions<'a>,
    blocks: Vec<Block>,
    table: Vec<ComparisonRow>,
    figures: Vec<Figure>,
    /// The chart of each figure, rasterised to its PNG at the end ([`Run::render_pngs`]).
    charts: Vec<Chart>,
    files: Vec<(PathBuf, Vec<u8>)>,
    step: usize,
    /// The steps a run computed [`Run::apart`] has headed, announced when it is merged.
    unannounced: Vec<(usize, String)>,
}

impl<'a> Run<'a> {
    /// A run for `opts` from its first step.
    fn new(opts: &'a ReproduceOptions<'a>, files: Vec<(PathBuf, Vec<u8>)>) -> Self {
        Run {
            opts,
            blocks: Vec::new(),
            table: Vec::new(),
            figures: Vec::new(),
            charts: Vec::new(),
            files,
            step: 0,
            unannounced: Vec::new(),
        }
    }

    /// A run whose steps follow step `after` and are computed beside the run that reaches it,
    /// on another thread; `opts` without the step callback, so its steps are announced in
    /// order when [`Run::merge`] appends it, not as they start.
    fn apart(opts: &'a ReproduceOptions<'a>, after: usize) -> Self {
        Run {
            step: after,
            ..Run::new(opts, Vec::new())
        }
    }

    /// Append `part`, computed [`Run::apart`] from this run's current step, announcing its
    /// steps as if they had run here.
    fn merge(&mut self, part: Run) {
        debug_assert_eq!(part.unannounced.first().map(|s| s.0), Some(self.step + 1));
        for (k, what) in &part.unannounced {
            self.announce(*k, what);
        }
        self.step = part.step;
        self.blocks.extend(part.blocks);
        self.table.extend(part.table);
        self.figures.extend(part.figures);
        self.charts.extend(part.charts);
        self.files.extend(part.files);
    }

    /// Announce a step (progress) and head its section of the report.
    fn step(&mut self, what: &str) {
        self.step += 1;
        self.announce(self.step, what);
        self.blocks
            .push(Block::Heading(format!("{}. {what}", self.step)));
    }

    /// Step `k` starts: the progress callback, or a note for [`Run::merge`] where there is none.
    fn announce(&mut self, k: usize, what: &str) {
        match self.opts.on_step {
            Some(f) => f(k, STEPS, what),
            None => self.unannounced.push((k, what.to_string())),
        }
    }

    /// A record of the embedded folder (read through [`article::Embedded`]).
    fn record(&self, file: &str) -> PathBuf {
        Path::new(article::FOLDER).join(file)
    }

    /// Render `chart` as SVG and PNG under figures/`stem`, and inline the SVG; the caption is
    /// headed by the article figure it answers.
    fn figure(&mut self, stem: &str, source: Source, caption: &str, chart: &Chart) -> Result<()> {
        registry::check(stem, source)?;
        let svg = chart.svg()?;
        let caption = self.inline(&svg, stem, source, caption);
        self.figures.push(Figure {
            stem: stem.to_string(),
            caption,
            svg,
            png: Vec::new(),
        });
        self.charts.push(chart.clone());
        Ok(())
    }

    /// Rasterise every figure's chart to its PNG, in parallel (the same pixels as one by one).
    fn render_pngs(&mut self) -> Result<()> {
        use rayon::prelude::*;
        let pngs = self
            .charts
            .par_iter()
            .map(Chart::png)
            .collect::<Result<Vec<_>, _>>()?;
        for (figure, png) in self.figures.iter_mut().zip(pngs) {
            figure.png = png;
        }
        Ok(())
    }

    /// Inline the SVG document of the figure file `name` (without extension) in the report,
    /// its caption headed by the article figure it answers; returns the caption.
    fn inline(&mut self, svg: &str, name: &str, source: Source, caption: &str) -> String {
        let caption = format!("{}{caption}", source.label());
        self.blocks.push(Block::Figure {
            svg: svg.to_string(),
            caption: caption.clone(),
            name: name.to_string(),
        });
        caption
    }

    /// A row of the comparison: quantity, pumpcyl, the article's printed value, the truth the
    /// emulated records were made with ("-" where there is none).
    fn compare(&mut self, quantity: &str, ours: String, article: &str, truth: &str) {
        self.compare_why(quantity, ours, article, truth, "");
    }

    /// As [`Run::compare`], with one line on why pumpcyl differs from the article (empty when
    /// it agrees to the article's printed precision).
    fn compare_why(&mut self, quantity: &str, ours: String, article: &str, truth: &str, why: &str) {
        self.table.push(ComparisonRow {
            quantity: quantity.to_string(),
            pumpcyl: ours,
            article: article.to_string(),
            truth: truth.to_string(),
            why: why.to_string(),
        });
    }

    fn table(&mut self, caption: &str, header: &[&str], rows: Vec<Vec<String>>) {
        self.blocks.push(Block::Table {
            caption: caption.into(),
            header: header.iter().map(|h| h.to_string()).collect(),
            rows,
        });
    }

    fn text(&mut self, p: &str) {
        self.blocks.push(Block::Paragraph(p.into()));
    }
}

/// Run the article's workflow on the embedded emulated records (about 1.5 s in a release
/// build, `cargo bench -p pumpcyl-bench --bench reproduce`). Progress goes to the callbacks of `opts`; nothing is printed or written.
///
/// # Errors
/// A failure of a step (none is expected on the embedded records), the system's temporary
/// folder not writable (the records are laid out there to be read as a user's would be), or
/// the search stopped by [`ReproduceOptions::on_candidates`].
pub fn reproduce(opts: &ReproduceOptions) -> Result<Reproduction> {
    let start = Instant::now();
    let files = EMBEDDED
        .iter()
        .map(|(file, text)| {
            (
                Path::new(article::FOLDER).join(file),
                text.as_bytes().to_vec(),
            )
        })
        .collect();
    let mut run = Run::new(opts, files);
    // the Figure 1 circuits (step 11) and the valve-or-pump comparison (step 13) need nothing of
    // the steps before them, and the sweep (step 12) only the step intervals of step 9: each is
    // computed beside the steps it follows, in a run of its own merged in order (the same numbers
    // as one after the other)
    let quiet = ReproduceOptions {
        on_step: None,
        ..*opts
    };
    let figure1 = || -> Result<_> {
        let mut part = Run::apart(&quiet, STEPS - 4);
        let found = figure1_circuits::figure1_circuits(&mut part)?;
        Ok((found, part))
    };
    // the energy study (step 14) costs step 13's valve beside the Figure 1 circuits
    let valve = || -> Result<_> {
        let mut part = Run::apart(&quiet, STEPS - 2);
        let found = valve_or_pump::valve_or_pump(&mut part)?;
        let energy = energy::energy_study(&mut part, &found)?;
        Ok((found, energy, part))
    };
    std::thread::scope(|scope| {
        let figure1 = scope.spawn(|| Ok::<_, anyhow::Error>((figure1()?, valve()?)));
        let (drive, km) = identification::drive_step(&mut run)?;
        let records = article::records()?;
        let emulator = emulator_used(&records)?;
        let truth = records[0].truth.clone();
        let (exp, nominal, identified, cost_mm2) =
            identification::identification(&mut run, &truth)?;
        let record_conditions = identification::conditions(&mut run, &exp, &records[0].truth)?;
        let rise_time = identification::rise_time(&mut run, &exp, &nominal)?;
        let robustness = identification::robustness(&mut run, &exp, &nominal)?;
        let pressure = pressure::pressure_study(&mut run, &nominal, &exp, &truth)?;
        let damping = studies::damping_study(&mut run, &nominal)?;
        let stroke = studies::stroke_study(&mut run, &nominal)?;
        let tracking = tracking::tracking(&mut run, &nominal)?;
        let (design, design_kp) = studies::design_check(&mut run, &nominal)?;
        let truth_point = Candidate {
            beta_bar: truth.rig.beta_bar,
            viscous_friction_ns_per_m: truth.rig.viscous_friction_ns_per_m,
            c12_m5_per_ns: truth.rig.c12_m5_per_ns,
        };
        let (certainty, how_sure) =
            certainty::how_sure(&mut run, &exp, &nominal, pressure.p_mean_bar, &truth_point)?;
        let mut sweep_run = Run::apart(&quiet, STEPS - 3);
        let (which_circuit, sweep_beside_steps) = rayon::join(
            || {
                circuit::which_circuit(
                    &mut run,
                    &certainty.robust.region,
                    certainty::CONFIDENCE,
                    pressure.p_mean_bar,
                )
            },
            || {
                sweep::sweep_beside_steps(
                    &mut sweep_run,
                    &exp,
                    &certainty.uncertainty,
                    (&truth, &truth_point),
                    certainty::CONFIDENCE,
                )
            },
        );
        let (which_circuit, sweep_beside_steps) = (which_circuit?, sweep_beside_steps?);
        let ((figure1_circuits, figure1_run), (valve_or_pump, energy, valve_run)) = figure1
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        run.merge(figure1_run);
        run.merge(sweep_run);
        run.merge(valve_run);
        registry::check_all(run.figures.iter().map(|f| f.stem.as_str()))?;
        run.render_pngs()?;
        let seconds = start.elapsed().as_secs_f64();
        let summary = Summary {
            emulated_inputs: true,
            note: EMULATED.to_string(),
            emulator,
            drive,
            leakage: identified.leakage.clone(),
            identified,
            record_conditions,
            rise_time,
            robustness,
            margins: pressure.study.clone(),
            gas_fraction: pressure.gas_fraction,
            gas_fraction_article_basis: pressure.gas_fraction_article_basis,
            article_gas_fraction: printed::GAS_FRACTION,
            intro_example: pressure.intro.clone(),
            p_mean_bar: pressure.p_mean_bar,
            damping,
            stroke,
            tracking,
            design,
            how_sure,
            which_circuit,
            figure1_circuits,
            sweep_beside_steps,
            valve_or_pump,
            energy,
            seconds,
        };
        Ok(Reproduction {
            km_nms_per_rad: km,
            identified: nominal,
            cost_mm2,
            identified_margins: pressure.study.identified_rig.nominal,
            default_margins: pressure.study.default_rig,
            gas_fraction: pressure.gas_fraction,
            p_mean_bar: pressure.p_mean_bar,
            design_kp,
            certainty,
            comparison: run.table,
            summary,
            blocks: run.blocks,
            figures: run.figures,
            files: run.files,
            seconds,
        })
    })
}

/// What the emulator used for each embedded record.
fn emulator_used(records: &[article::ArticleRecord]) -> Result<Vec<summary::EmulatorUsed>> {
    records
        .iter()
        .map(|r| {
            Ok(summary::EmulatorUsed {
                record: r.file.to_string(),
                basis: crate::emulated::basis(&r.truth.rig, &r.truth.effects)?,
            })
        })
        .collect()
}

/// One row per distinct emulator basis, naming every record made with it, in the records'
/// order: the records share most of what the emulator used, said once.
fn emulator_rows(used: &[summary::EmulatorUsed]) -> Vec<Vec<String>> {
    let mut rows: Vec<(Vec<&str>, &str)> = Vec::new();
    for e in used {
        match rows.iter_mut().find(|(_, basis)| *basis == e.basis) {
            Some((records, _)) => records.push(&e.record),
            None => rows.push((vec![&e.record], &e.basis)),
        }
    }
    (rows.into_iter())
        .map(|(records, basis)| vec![records.join(", "), basis.to_string()])
        .collect()
}

impl Reproduction {
    /// The self-contained report.html: the notice that the inputs are emulated, the comparison
    /// with the article, then every step with its tables and inlined figures.
    pub fn report_html(&self) -> String {
        let mut blocks = vec![
            Block::Notice(EMULATED.into()),
            Block::Paragraph(format!(
                "The workflow of Gøytil, Hansen & Tvilde, Actuators 2025, 14(8), 366, run by pumpcyl {} \
                 in {:.1} s. Every number is also in summary.json; every figure is in figures/ \
                 as SVG and PNG.",
                env!("CARGO_PKG_VERSION"),
                self.seconds
            )),
            Block::Table {
                caption: "pumpcyl beside the article's printed values".into(),
                header: ["quantity", "pumpcyl", "article", "emulator truth", "why they differ"]
                    .map(String::from)
                    .to_vec(),
                rows: self
                    .comparison
                    .iter()
                    .map(|r| {
                        vec![
                            r.quantity.clone(),
                            r.pumpcyl.clone(),
                            r.article.clone(),
                            r.truth.clone(),
                            r.why.clone(),
                        ]
                    })
                    .collect(),
            },
            Block::Table {
                caption: "What the emulator used for each record (docs/emulator.md#what-a-user-rig-gets)"
                    .into(),
                header: vec!["records".into(), "emulator".into()],
                rows: emulator_rows(&self.summary.emulator),
            },
        ];
        blocks.extend(self.blocks.iter().cloned());
        html_page(
            "pumpcyl: the article reproduced on emulated records",
            &blocks,
        )
    }

    /// Every file of the result folder, paths relative to it: records/, identification/,
    /// figures/ (SVG and PNG), summary.json and report.html.
    pub fn folder(&self) -> Result<Vec<(PathBuf, Vec<u8>)>> {
        let mut out = self.files.clone();
        for f in &self.figures {
            let base = Path::new("figures").join(&f.stem);
            out.push((base.with_extension("png"), f.png.clone()));
            out.push((base.with_extension("svg"), f.svg.clone().into_bytes()));
        }
        out.push((
            "summary.json".into(),
            (serde_json::to_string_pretty(&self.summary)? + "\n").into_bytes(),
        ));
        out.push(("report.html".into(), self.report_html().into_bytes()));
        Ok(out)
    }

    /// Write the result folder `dir` whole or not at all ([`OutDir`]): built aside, then swapped
    /// in, every file of the user's in it kept; refused over a non-empty folder that holds no
    /// earlier pumpcyl result. [`Reproduction::write_with`] with nothing forced.
    ///
    /// # Errors
    /// The folder refused, or a write failed (the folder is then left as it was).
    pub fn write(&self, dir: &Path) -> Result<Committed> {
        self.write_with(dir, &Protected::none())
    }

    /// [`Reproduction::write`], never over (or around) a `protected` file, and forced as
    /// `protected` says ([`Protected::forcing`]). Returns what happened to the files of the
    /// user's in the folder.
    ///
    /// # Errors
    /// The folder refused, or a write failed (the folder is then left as it was).
    pub fn write_with(&self, dir: &Path, protected: &Protected) -> Result<Committed> {
        let out = OutDir::begin(dir, protected)?;
        for (path, bytes) in &self.folder()? {
            out.write(path, bytes)?;
        }
        out.commit()
    }
}

/// The least-damped open-loop pole pair of `rig` in the band `(lo, hi)` (Hz): (Hz, damping
/// ratio).
fn resonance(rig: &Rig, (lo, hi): (f64, f64)) -> Result<(Option<f64>, Option<f64>)> {
    let poles = lti::eigenvalues(&Plant::new(rig).open_loop(false).a)?;
    let r = lti::resonance(&poles, lo, hi);
    Ok(r.map_or((None, None), |r| (Some(r.natural_freq_hz), r.damping)))
}

fn margins_of(rig: &Rig) -> Result<Margins> {
    Ok(lti::margins(&Plant::new(rig).open_loop(false))?)
}

/// A row of a margins table: the margins `m` of `rig`'s analysed loop and two stabilities,
/// each naming its loop: the position loop closed around the analysed loop (sum-pressure loop
/// open, as the article analyses it) and the loop as simulated (sum-pressure loop as the rig
/// says), with the rightmost pole where it is unstable.
fn margins_row(label: &str, rig: &Rig, m: &Margins) -> Vec<String> {
    let simulated = match lti::require_stable(&Plant::new(rig).closed_loop(rig.sum_pressure).a) {
        Ok(()) => "yes".to_string(),
        Err(lti::LtiError::Unstable {
            real_per_s,
            imag_rad_per_s,
            ..
        }) => format!(
            "NO: the simulated loop diverges (pole {real_per_s:+.3} ±{imag_rad_per_s:.3}j rad/s)"
        ),
        Err(_) => "undecided".to_string(),
    };
    let open = Plant::new(rig).open_loop(false);
    // the disk margin presumes a stable closed loop (docs/analysis.md#disk-margins)
    let disk = (lti::disk_margins(&open, 0.0).ok())
        .filter(|_| m.closed_loop_stable)
        .map_or("-".to_string(), |d| {
            format!("{:.3}, {:.2}", d.disk.disk_margin, d.sensitivity_peak.value)
        });
    let (h, delay) = rig.plc_sampling();
    let sampled = lti::sampled_margins(&open, h, delay).map_or("-".to_string(), |s| {
        format!(
            "{} / {}",
            fmt_opt(s.gain_margin_db, 2),
            fmt_opt(s.phase_margin_deg, 1)
        )
    });
    vec![
        label.to_string(),
        fmt_opt(m.gain_margin_db, 2),
        fmt_opt(m.phase_margin_deg, 1),
        fmt_opt(m.gain_crossover_hz, 3),
        disk,
        sampled,
        if m.closed_loop_stable { "yes" } else { "NO" }.to_string(),
        simulated,
    ]
}

const MARGIN_HEADER: [&str; 8] = [
    "case",
    "GM (dB)",
    "PM (deg)",
    "gain crossover (Hz)",
    "disk margin α, M_s (balanced; docs/analysis.md#disk-margins)",
    "GM (dB) / PM (deg) as the 100 Hz PLC runs it (docs/analysis.md#sampled-data-margins)",
    "stable, sum-pressure loop open (as analysed)",
    "stable, sum-pressure loop as simulated",
];

fn bode_series(rig: &Rig, label: &str, freqs: &[f64]) -> Result<BodeSeries> {
    let b = lti::bode(&Plant::new(rig).open_loop(false), freqs)?;
    Ok(BodeSeries {
        label: label.to_string(),
        freq_hz: b.freq_hz,
        mag_db: b.mag_db,
        phase_deg: b.phase_deg,
    })
}

/// The step of the studies (mm): the identification records' 5 mm step (the article §2.4).
const STEP_MM: f64 = 5.0;

/// How the step figure of [`variants`] shows the position.
#[derive(Clone, Copy, PartialEq)]
enum Position {
    /// As simulated (mm).
    Absolute,
    /// About each rig's own operating point, x − x0 (mm), so steps at different strokes overlay.
    AboutX0,
}

/// A study of rig variants: its file stem, what it is, where each variant's step is drawn, and
/// the article figures its Bode diagram and its steps answer.
struct Study<'a> {
    stem: &'a str,
    what: &'a str,
    /// The rig the variants start from, in words.
    rig: &'a str,
    position: Position,
    bode: Source,
    step: Source,
}

/// How far a diverging step is drawn (mm from the operating point): far enough to show the
/// growth, near enough that the stable variants stay readable beside it.
const DIVERGING_BOUND_MM: f64 = 3.0 * STEP_MM;

/// The 5 mm step of one variant `rig` with the sum-pressure loop closed, which the margins open
/// (docs/analysis.md#the-loop-that-is-analysed): its legend label, the signals to draw (about
/// x0 where `position` asks) and its metrics. A step that diverges has no metrics; it is drawn
/// until it leaves the operating point by [`DIVERGING_BOUND_MM`], its label naming its pole.
fn variant_step(
    label: &str,
    rig: &Rig,
    position: Position,
) -> Result<(String, Signals, Option<StepMetrics>)> {
    let (duration_s, rate_hz) = (6.0, 100.0);
    let (name, s, metrics) = match response::step(rig, STEP_MM, duration_s, rate_hz) {
        Ok(s) => {
            let metrics = response::step_metrics_of(rig, &s, STEP_MM);
            (label.to_string(), s, Some(metrics))
        }
        Err(lti::LtiError::Unstable {
            real_per_s,
            imag_rad_per_s,
            ..
        }) => {
            let s =
                response::diverging_step(rig, STEP_MM, DIVERGING_BOUND_MM, duration_s, rate_hz)?;
            let name = format!(
                "{label}: unstable (pole {real_per_s:+.3} ±{imag_rad_per_s:.3}j rad/s), diverging: drawn until |x − x0| > {DIVERGING_BOUND_MM} mm"
            );
            (name, s, None)
        }
        Err(e) => return Err(e.into()),
    };
    let s = match position {
        Position::AboutX0 => {
            let x0 = response::Baseline::of_rig(rig).x_mm;
            crate::figures::about_operating_point(&s, x0)
        }
        Position::Absolute => s,
    };
    Ok((name, s, metrics))
}

/// Margins table, Bode overlay and step overlay of rig variants; their margins and steps.
fn variants(run: &mut Run, study: &Study, rigs: &[(String, Rig)]) -> Result<Vec<summary::Case>> {
    let Study {
        stem,
        what,
        rig: base,
        position,
        ..
    } = *study;
    let freqs = lti::log_grid(0.01, 100.0, 401);
    let mut series = Vec::new();
    let mut markers = Vec::new();
    let mut rows = Vec::new();
    let mut steps = Vec::new();
    let mut out = Vec::new();
    for (label, rig) in rigs {
        let m = margins_of(rig)?;
        rows.push(margins_row(label, rig, &m));
        series.push(bode_series(rig, label, &freqs)?);
        markers.push(Some(bode_markers(&m)));
        let (name, signals, step) = variant_step(label, rig, position)?;
        steps.push((name, signals));
        out.push(summary::Case {
            case: label.clone(),
            step_closed_loop_stable: step.is_some(),
            margins: m,
            step,
        });
    }
    run.table(&format!("Margins: {what}, on {base}"), &MARGIN_HEADER, rows);
    let title = format!("Bode diagram: {what}");
    run.figure(
        &format!("bode_{stem}"),
        study.bode,
        &format!("{title}, on {base}"),
        &Chart::bode(&title, series, markers),
    )?;
    let refs: Vec<(String, &Signals)> = steps.iter().map(|(l, s)| (l.clone(), s)).collect();
    let steps_from = match position {
        Position::Absolute => {
            let x0 = rigs.first().map_or(f64::NAN, |(_, r)| r.x0_mm);
            format!("{x0} → {} mm", x0 + STEP_MM)
        }
        Position::AboutX0 => format!("x0 → x0 + {STEP_MM} mm at each position"),
    };
    let title = format!("Model step {steps_from}: {what} (sum-pressure loop closed)");
    let mut chart = Chart::signals(&title, None, &refs, None, None);
    if let (crate::figures::Plot::Time(panels), Position::AboutX0) = (&mut chart.plot, position) {
        panels[0].y_label = "Position about x0, x − x0 (mm)".into();
    }
    run.figure(
        &format!("step_{stem}"),
        study.step,
        &format!("{title}, on {base}; the model steps from its operating point, where the records step 340 → 345 mm"),
        &chart,
    )?;
    Ok(out)
}
