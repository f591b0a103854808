//! The identification problem: datasets prepared for fast evaluation and the cost of a candidate
//! (docs/identification.md#the-cost): the mean over datasets of the mean squared position error (mm²) inside each fit
//! window, the model driven by the recorded reference from the record's initial steady state.

use super::grid::Candidate;
use super::leakage::Standstill;
use super::IdentError;
use crate::lti::{eigenvalues, is_stable, Simulator, StateSpace, Zoh};
use crate::model::Plant;
use crate::record::Record;
use crate::rig::Rig;
use nalgebra::DVector;

/// One dataset of an experiment, as the user describes it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetSpec {
    /// Record file (docs/formats.md#record-csv), relative to the experiment file.
    pub file: String,
    /// Position gain used in the experiment (normalised command per metre).
    pub kp: f64,
    /// Effective mass during the experiment (kg).
    pub mass_kg: f64,
    /// End of the fit window on the record's time axis (s).
    pub fit_end_s: f64,
}

/// A dataset ready for thousands of evaluations.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Label (the file name as given).
    pub name: String,
    /// The record.
    pub record: Record,
    /// The rig with this dataset's Kp and mass.
    pub rig: Rig,
    /// End of the fit window (s).
    pub fit_end_s: f64,
    /// Sample times inside the window (s).
    t: Vec<f64>,
    /// Reference deviations from the initial steady state (m).
    u: Vec<f64>,
    /// Measured position deviations (mm).
    meas_mm: Vec<f64>,
    /// Balancing scale of the nominal model's ZOH block, reused for every candidate.
    scale: Vec<f64>,
    /// First sample whose held input is non-zero: the model stays at rest up to and including
    /// it, so simulation starts there.
    start: usize,
    /// Squared error (mm²) of the samples at rest (up to and including `start`).
    rest_sse: f64,
    /// Sum of the measured deviations (mm) of the samples at rest (the model's are 0).
    rest_sum: f64,
    /// The controller's period (s) when the model samples it as a PLC does
    /// ([`Problem::with_sampled_controller`]); `None`: the continuous loop.
    sampled_h: Option<f64>,
}

impl Prepared {
    /// Prepare a record for fitting with the dataset's gain and mass on top of `rig`.
    pub fn new(spec: &DatasetSpec, record: Record, rig: &Rig) -> Result<Prepared, IdentError> {
        let err = |m: String| IdentError::Input(format!("dataset `{}`: {m}", spec.file));
        let (t0, t1) = (record.time_s[0], record.time_s[record.len() - 1]);
        if !(spec.fit_end_s.is_finite() && spec.fit_end_s > t0 && spec.fit_end_s <= t1) {
            return Err(err(format!(
                "fit_end_s = {} lies outside the record ({t0} … {t1} s)",
                spec.fit_end_s
            )));
        }
        record.check_units(rig.stroke_mm)?;
        let rig = Rig {
            kp: spec.kp,
            mass_kg: spec.mass_kg,
            ..rig.clone()
        };
        rig.validate("kp and mass_kg")
            .map_err(|e| err(e.to_string()))?;
        let n = record
            .time_s
            .iter()
            .take_while(|&&t| t <= spec.fit_end_s)
            .count();
        let (r0, x0) = (
            record.initial_mean(&record.x_ref_mm),
            record.initial_mean(&record.x_mm),
        );
        let sys = Plant::new(&rig).closed_loop(rig.sum_pressure);
        let scale = Zoh::balancing_scale(&sys.a, &sys.b, 1.0)?;
        let u: Vec<f64> = record.x_ref_mm[..n]
            .iter()
            .map(|r| (r - r0) * 1e-3)
            .collect();
        let meas_mm: Vec<f64> = record.x_mm[..n].iter().map(|x| x - x0).collect();
        let start = u.iter().position(|&v| v != 0.0).unwrap_or(n - 1);
        let rest_sse = meas_mm[..=start].iter().map(|e| e * e).sum();
        let rest_sum = meas_mm[..=start].iter().sum();
        Ok(Prepared {
            name: spec.file.clone(),
            t: record.time_s[..n].to_vec(),
            u,
            meas_mm,
            start,
            rest_sse,
            rest_sum,
            sampled_h: None,
            record,
            rig,
            fit_end_s: spec.fit_end_s,
            scale,
        })
    }

    /// Samples inside the fit window.
    pub fn window_len(&self) -> usize {
        self.t.len()
    }
}

/// The datasets, the standstill point and the rig they share.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Prepared datasets.
    pub datasets: Vec<Prepared>,
    /// Standstill point for c1, c2.
    pub standstill: Standstill,
}

impl Problem {
    /// The rig of dataset `ds` with a candidate's β, b, c12 and the c1, c2 that hold the
    /// standstill point with that c12.
    pub fn rig_for(&self, c: &Candidate, ds: &Prepared) -> Result<Rig, IdentError> {
        let l = self.standstill.leakage(&ds.rig, c.c12_m5_per_ns)?;
        Ok(Rig {
            beta_bar: c.beta_bar,
            viscous_friction_ns_per_m: c.viscous_friction_ns_per_m,
            c12_m5_per_ns: c.c12_m5_per_ns,
            c1_m5_per_ns: l.c1_m5_per_ns,
            c2_m5_per_ns: l.c2_m5_per_ns,
            ..ds.rig.clone()
        })
    }

    /// Closed-loop model x_ref → x of a dataset for a candidate.
    fn model(&self, c: &Candidate, ds: &Prepared) -> Result<StateSpace, IdentError> {
        let rig = self.rig_for(c, ds)?;
        Ok(Plant::new(&rig).closed_loop(rig.sum_pressure))
    }

    /// The same records with the model's controller sampled as a PLC runs it: the position
    /// and pressures read at each sample, the speed commands held until the next, at the
    /// window's mean sample period (docs/identification.md#sweeps-and-steps-together). The
    /// article's step identification (§2.4.4) keeps the continuous loop.
    pub fn with_sampled_controller(mut self) -> Problem {
        for ds in &mut self.datasets {
            let n = ds.t.len();
            ds.sampled_h = (n > 1).then(|| (ds.t[n - 1] - ds.t[0]) / (n - 1) as f64);
        }
        self
    }

    /// Feed the position errors (mm, model − measured) after the samples at rest of dataset
    /// `ds` to `each`, in order, until it returns false; false when the model cannot be built
    /// or simulated.
    fn errors(&self, c: &Candidate, ds: &Prepared, mut each: impl FnMut(f64) -> bool) -> bool {
        if let Some(h) = ds.sampled_h {
            return self.sampled_errors(c, ds, h, each);
        }
        let Ok(sys) = self.model(c, ds) else {
            return false;
        };
        let x0 = vec![0.0; sys.order()];
        let (t, u, meas) = (
            &ds.t[ds.start..],
            &ds.u[ds.start..],
            &ds.meas_mm[ds.start..],
        );
        Simulator::with_scale(&sys, &ds.scale)
            .run_with(t, u, &x0, |k, x| k == 0 || each(x[0] * 1e3 - meas[k]))
            .is_ok()
    }

    /// [`Problem::errors`] of the loop sampled every `h`: x_{k+1} = (Φ + Γ Kx) x_k + Γ Kr r_k,
    /// Φ, Γ the plant's zero-order hold over `h`, u = Kx·x + Kr·r the control law.
    fn sampled_errors(
        &self,
        c: &Candidate,
        ds: &Prepared,
        h: f64,
        mut each: impl FnMut(f64) -> bool,
    ) -> bool {
        let Ok(rig) = self.rig_for(c, ds) else {
            return false;
        };
        let plant = Plant::new(&rig);
        let Ok(zoh) = Zoh::new(&plant.a, &plant.b, h) else {
            return false;
        };
        let (kx, kr) = plant.controller(rig.sum_pressure);
        let phi = &zoh.phi + &zoh.gamma * kx;
        let gamma = (&zoh.gamma * kr).column(0).into_owned();
        let (pos, n) = (plant.position(), plant.n());
        let (mut x, mut next) = (DVector::zeros(n), DVector::zeros(n));
        let (u, meas) = (&ds.u[ds.start..], &ds.meas_mm[ds.start..]);
        for k in 1..u.len() {
            phi.mul_to(&x, &mut next);
            next.axpy(u[k - 1], &gamma, 1.0);
            std::mem::swap(&mut x, &mut next);
            if !each(x[pos] * 1e3 - meas[k]) {
                break;
            }
        }
        true
    }

    /// Mean squared position error (mm²) of dataset `ds`; +∞ when not finite. The simulation
    /// stops early, returning a lower bound above `stop_above`, once the partial sum already
    /// exceeds `stop_above` (the caller cannot use the candidate then).
    fn dataset_cost(&self, c: &Candidate, ds: &Prepared, stop_above: f64) -> f64 {
        let n = ds.t.len() as f64;
        let limit = stop_above * n;
        let mut sse = ds.rest_sse;
        let ok = self.errors(c, ds, |e| {
            sse += e * e;
            sse <= limit
        });
        let mse = sse / n;
        if ok && mse.is_finite() {
            mse
        } else {
            f64::INFINITY
        }
    }

    /// Sum of squared position errors (mm²) of dataset `ds` over its fit window with the
    /// record's initial position fitted too: the errors' mean over the window is removed (the
    /// least-squares constant offset). +∞ when not finite.
    pub fn dataset_sse_offset_free(&self, c: &Candidate, ds: &Prepared) -> f64 {
        let (mut sum, mut sse) = (-ds.rest_sum, ds.rest_sse);
        let ok = self.errors(c, ds, |e| {
            sum += e;
            sse += e * e;
            true
        });
        let v = sse - sum * sum / ds.t.len() as f64;
        if ok && v.is_finite() {
            v.max(0.0)
        } else {
            f64::INFINITY
        }
    }

    /// The cost of a candidate: the mean of the datasets' MSE (mm²); +∞ when not finite.
    pub fn cost(&self, c: &Candidate) -> f64 {
        self.cost_below(c, f64::INFINITY).unwrap_or(f64::INFINITY)
    }

    /// The cost if it is at most `bound`, else `None` — decided as early as possible: datasets
    /// are simulated in turn and each stops once the running total proves the cost exceeds the
    /// bound (exact pruning for a search that only keeps candidates below a bound).
    pub fn cost_below(&self, c: &Candidate, bound: f64) -> Option<f64> {
        let count = self.datasets.len() as f64;
        let mut total = 0.0;
        for ds in &self.datasets {
            let remaining = bound * count - total;
            total += self.dataset_cost(c, ds, remaining);
            if total > bound * count {
                return if total.is_finite() {
                    None
                } else {
                    Some(f64::INFINITY)
                };
            }
        }
        Some(total / count)
    }

    /// Mean squared position error (mm²) of one dataset, simulated over its whole window.
    pub fn dataset_mse(&self, c: &Candidate, ds: &Prepared) -> f64 {
        self.dataset_cost(c, ds, f64::INFINITY)
    }

    /// The position errors (mm, model − measured) of dataset `ds` over its fit window, their
    /// mean removed (the record's initial position fitted, as in
    /// [`Problem::dataset_sse_offset_free`]); `None` when not finite.
    pub fn residuals_offset_free(&self, c: &Candidate, ds: &Prepared) -> Option<Vec<f64>> {
        let mut r: Vec<f64> = ds.meas_mm[..=ds.start].iter().map(|m| -m).collect();
        let ok = self.errors(c, ds, |e| {
            r.push(e);
            true
        });
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        (ok && mean.is_finite() && r.iter().all(|v| v.is_finite()))
            .then(|| r.iter().map(|v| v - mean).collect())
    }

    /// Sum of squared position errors (mm²) over every dataset's fit window, each record's
    /// initial position fitted as well (one constant per dataset). With Gaussian noise of one
    /// level on every sample this is the likelihood's statistic; the cost instead weights each
    /// dataset by 1/(its samples) and takes the initial position from the samples at rest.
    pub fn sse_offset_free(&self, c: &Candidate) -> f64 {
        self.datasets
            .iter()
            .map(|ds| self.dataset_sse_offset_free(c, ds))
            .sum()
    }

    /// Samples inside the fit windows, over all datasets.
    pub fn samples(&self) -> usize {
        self.datasets.iter().map(Prepared::window_len).sum()
    }

    /// Whether every dataset's closed loop is stable for this candidate (closed-loop
    /// eigenvalues).
    pub fn is_stable(&self, c: &Candidate) -> bool {
        self.datasets.iter().all(|ds| {
            self.model(c, ds)
                .ok()
                .and_then(|sys| eigenvalues(&sys.a).ok())
                .is_some_and(|p| is_stable(&p))
        })
    }

    /// Simulated absolute position (mm) over the whole record of dataset `ds` for a candidate.
    pub fn simulate(
        &self,
        c: &Candidate,
        ds: &Prepared,
    ) -> Result<crate::response::Signals, IdentError> {
        let rig = self.rig_for(c, ds)?;
        let rec = &ds.record;
        let base = crate::response::Baseline::of_record(rec, &rig);
        Ok(crate::response::simulate(
            &rig,
            &rec.time_s,
            &rec.x_ref_mm,
            &base,
        )?)
    }
}
