//! Limits on sizes and work derived from input: a size that would exhaust memory is refused
//! outright; work that would take hours is refused unless the caller allows a long run (the
//! command line's `--allow-long-run`). Every refusal states the limit.

use crate::units::readable;

/// The most samples, frequency points or grid candidates any single array may hold: 50 million
/// (0.4 GB of f64), far above any record or figure and below an allocation abort.
pub const MAX_POINTS: f64 = 5e7;

/// The most samples one simulated or emulated record may hold: 5·10⁶, so its eight signals
/// (time, reference, position, error, two pressures, two speeds) take 0.3 GB of f64 and its CSV
/// about 0.5 GB: a response computed, written and plotted within memory, not an allocation
/// abort.
pub const MAX_SAMPLES: f64 = 5e6;

/// Emulator controller steps (duration × rate) done without allowing a long run: 10⁷ is about
/// three hours of rig time at 1 kHz, already minutes of computing.
pub const MAX_EMULATED_STEPS: f64 = 1e7;

/// At most what one controller step of a calm loop costs the emulator's integrator, in
/// right-hand-side evaluations of the rig's equations (docs/emulator.md#the-work-limit): 57 to
/// 315 measured on the three circuits' 5 mm steps and 0.2 Hz ±35 mm and 1 Hz ±10 mm sines at
/// 100 Hz, with and without sensor noise; a loop whose drives saturate, or that is unstable,
/// takes 20 000 and more.
pub const CALM_STEP_WORK: f64 = 500.0;

/// The emulator integrator's work done without allowing a long run (right-hand-side
/// evaluations): the work of [`MAX_EMULATED_STEPS`] calm controller steps
/// ([`CALM_STEP_WORK`] each), about ten minutes of computing.
pub const MAX_EMULATOR_WORK: f64 = MAX_EMULATED_STEPS * CALM_STEP_WORK;

/// The share of [`MAX_EMULATOR_WORK`] an emulation does before its work is projected
/// ([`EmulatorWork::check`]): a thousandth, a second or two of computing.
pub const PROJECT_AFTER: f64 = 1e-3;

/// How far beyond [`MAX_EMULATOR_WORK`] a projection must reach before it stops a run
/// ([`EmulatorWork::check`]): a run that saturates for a while and then calms down is
/// projected high until its calm part dominates the window, and is stopped only if even then
/// it would need ten times the limit; one that falls short of that is stopped when it reaches
/// the limit itself **\[choice\]**.
pub const PROJECTED_FACTOR: f64 = 10.0;

/// Grid candidates × record samples simulated without allowing a long run: 10⁹ is about 200
/// times the article's identification (6 817 candidates × 2 × 370 samples), minutes of work.
pub const MAX_CANDIDATE_SAMPLES: f64 = 1e9;

/// Margin analyses (one margins computation of a loop, about 0.1 ms) done without allowing a long
/// run: 10⁵ is seconds of work; a bulk-modulus table or a design grid beyond it could run for
/// hours.
pub const MAX_MARGIN_ANALYSES: f64 = 1e5;

/// Load × pressure-level cases a selection evaluates without allowing a long run (each a gain
/// design over the stroke and tracking and step simulations over the gas-fraction range, tens
/// of milliseconds): 400 is seconds of work, the article's application a small part of it; 200
/// loads at its levels ran for a minute, 10⁵ would run for days.
pub const MAX_SELECT_CASES: f64 = 400.0;

/// Record samples × models the nonlinear refinement emulates without allowing a long run
/// (docs/identification.md#nonlinear-refinement): each sample is emulated about 1 500 times a
/// model (the search, the profile, the datasets' own X); 5·10⁴ is minutes of work, three levels
/// of two 3 s steps each under the five models about 9 000.
pub const MAX_REFINED_SAMPLES: f64 = 5e4;

/// The most shards one identification is split into (`identify --shard I/N`,
/// docs/identification.md#sharding): each shard is a process and a partial result the merge
/// reads and checks; a thousand already leaves each a few candidates of the article's grids.
pub const MAX_SHARDS: usize = 1000;

/// A size or an amount of work beyond its limit.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitError {
    /// The caller asked the work to stop before its end ([`Work::advance`]).
    #[error("stopped before its end, as asked")]
    Cancelled,
    /// More items in one array than [`MAX_POINTS`] (or a count that is not a finite number).
    #[error("{what}: {} points, more than the limit of {limit:e}", readable(*count))]
    TooLarge {
        /// What is counted, in the caller's words (its option or argument names).
        what: String,
        /// The count asked for.
        count: f64,
        /// The limit.
        limit: f64,
    },
    /// A table (points × values per point) holding more values than [`MAX_POINTS`].
    #[error(
        "{what}: {} points × {columns} values each, more than the limit of {limit:e} values",
        readable(*rows)
    )]
    TooManyValues {
        /// What is counted, in the caller's words (its option or argument names).
        what: String,
        /// The points asked for.
        rows: f64,
        /// Values per point (columns).
        columns: usize,
        /// The limit (values).
        limit: f64,
    },
    /// A duration or a rate that sets a count of samples is not a positive number.
    #[error("{name} = {value}: must be > 0")]
    NotPositive {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// Work that could take hours, not allowed by the caller.
    #[error(
        "{what}: about {} units of work, more than the {limit:e} done without allowing a long \
         run (this could take hours); reduce it or allow a long run",
        readable(work.round())
    )]
    LongRun {
        /// What the work is, in the caller's words.
        what: String,
        /// The estimated work.
        work: f64,
        /// The limit.
        limit: f64,
    },
}

/// Refuse `count` items of `what` beyond [`MAX_POINTS`] (or non-finite); `what` names the
/// caller's options or arguments that set the count.
pub fn check_size(what: &str, count: f64) -> Result<usize, LimitError> {
    within(what, count, MAX_POINTS)
}

/// `count` as a size when it lies in 0 … `limit` (a non-finite count does not).
fn within(what: &str, count: f64, limit: f64) -> Result<usize, LimitError> {
    if !(0.0..=limit).contains(&count) {
        return Err(LimitError::TooLarge {
            what: what.to_string(),
            count,
            limit,
        });
    }
    Ok(count as usize)
}

/// The samples of a record of `duration_s` sampled at `rate_hz`, both ends included:
/// ⌊duration × rate⌋ + 1 (with room for rounding in the product).
pub fn sample_count(duration_s: f64, rate_hz: f64) -> f64 {
    (duration_s * rate_hz + 1e-9).floor() + 1.0
}

/// Refuse a table of `rows` points of `columns` values each beyond [`MAX_POINTS`] values in all
/// (or a non-finite count): the memory a result takes, computed before it is allocated.
pub fn check_table(what: &str, rows: f64, columns: usize) -> Result<usize, LimitError> {
    if !(0.0..=MAX_POINTS).contains(&(rows * columns.max(1) as f64)) {
        return Err(LimitError::TooManyValues {
            what: what.to_string(),
            rows,
            columns,
            limit: MAX_POINTS,
        });
    }
    Ok(rows as usize)
}

/// The number of samples of a record of `duration_s` sampled at `rate_hz` (both > 0, the count
/// within [`MAX_SAMPLES`]): the one check of every record pumpcyl simulates or emulates.
pub fn check_samples(duration_s: f64, rate_hz: f64) -> Result<usize, LimitError> {
    for (name, value) in [("duration_s", duration_s), ("rate_hz", rate_hz)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(LimitError::NotPositive { name, value });
        }
    }
    within(
        "duration_s × rate_hz",
        sample_count(duration_s, rate_hz),
        MAX_SAMPLES,
    )
}

/// The samples of an emulated record of `duration_s` at the controller's `rate_hz`: refused
/// beyond [`MAX_SAMPLES`] always (the record's memory: no flag lifts it), and its controller
/// steps beyond [`MAX_EMULATED_STEPS`] unless `allow_long_run` (the work).
pub fn check_emulation(
    duration_s: f64,
    rate_hz: f64,
    allow_long_run: bool,
) -> Result<usize, LimitError> {
    let samples = check_samples(duration_s, rate_hz)?;
    check_work(
        "duration_s × rate_hz (controller steps)",
        duration_s * rate_hz,
        MAX_EMULATED_STEPS,
        allow_long_run,
    )?;
    Ok(samples)
}

/// An emulation's integrator work watched as it runs, against [`MAX_EMULATOR_WORK`]
/// (docs/emulator.md#the-work-limit): the controller steps alone
/// ([`check_emulation`]) cannot see a step that costs thousands of times a calm one, as where
/// the drives saturate or the loop is unstable.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorWork {
    allowed: bool,
    total_steps: u64,
    period_s: f64,
    /// The next step count at which the work is projected (a power of two).
    next_check: u64,
    /// The steps and the work at the last projection (half of `next_check`'s steps).
    half: (u64, u64),
}

impl EmulatorWork {
    /// A run of `total_steps` controller steps of `period_s` (s), its work unlimited when
    /// `allow_long_run`.
    pub fn new(total_steps: u64, period_s: f64, allow_long_run: bool) -> EmulatorWork {
        EmulatorWork {
            allowed: allow_long_run,
            total_steps,
            period_s,
            next_check: 1,
            half: (0, 0),
        }
    }

    /// After `steps` controller steps that cost the integrator `work` right-hand-side
    /// evaluations in all: refused when `work` exceeds [`MAX_EMULATOR_WORK`], or when, at a
    /// power of two of steps once [`PROJECT_AFTER`] of the limit is done, the rate of the
    /// second half of the steps so far kept over the steps left would take the run beyond
    /// [`PROJECTED_FACTOR`] times the limit. The error names the run's rate against a calm
    /// loop's ([`CALM_STEP_WORK`]).
    pub fn check(&mut self, steps: u64, work: u64) -> Result<(), LimitError> {
        if self.allowed {
            return Ok(());
        }
        let (done, w) = (steps as f64, work as f64);
        let t_s = done * self.period_s;
        let whole_s = self.total_steps as f64 * self.period_s;
        if w > MAX_EMULATOR_WORK {
            return Err(LimitError::LongRun {
                what: format!(
                    "the emulator's integrator at t = {t_s:.2} s of {whole_s:.2} s \
                     (right-hand-side evaluations; {:.0} a controller step, a calm loop's at \
                     most {CALM_STEP_WORK})",
                    w / done.max(1.0)
                ),
                work: w,
                limit: MAX_EMULATOR_WORK,
            });
        }
        if steps < self.next_check {
            return Ok(());
        }
        let (s0, w0) = self.half;
        self.half = (steps, work);
        self.next_check = steps.saturating_mul(2);
        if w < PROJECT_AFTER * MAX_EMULATOR_WORK || steps <= s0 {
            return Ok(());
        }
        let rate = (work - w0) as f64 / (steps - s0) as f64;
        let projected = w + rate * self.total_steps.saturating_sub(steps) as f64;
        if projected <= PROJECTED_FACTOR * MAX_EMULATOR_WORK {
            return Ok(());
        }
        // an estimate: two significant digits
        let digit = 10f64.powf(projected.log10().floor() - 1.0);
        Err(LimitError::LongRun {
            what: format!(
                "the emulator's integrator over {whole_s:.2} s, projected from its rate over \
                 t = {:.2}-{t_s:.2} s (right-hand-side evaluations; {rate:.0} a controller step, \
                 a calm loop's at most {CALM_STEP_WORK})",
                s0 as f64 * self.period_s
            ),
            work: (projected / digit).round() * digit,
            limit: MAX_EMULATOR_WORK,
        })
    }
}

/// How a caller lets work run beyond its limit and follows it: the one switch of every front
/// end (the command line's `--allow-long-run`, Python's `allow_long_run=True`) and a callback
/// given the units of work done since its last call (a progress bar; may be called from
/// several threads).
#[derive(Clone, Copy)]
pub struct Work<'a> {
    /// Whether work beyond its limit may run.
    pub allow_long_run: bool,
    /// Called with the units of work just done; `false` asks the work to stop, which it does
    /// at its next unit with [`LimitError::Cancelled`].
    pub progress: &'a (dyn Fn(u64) -> bool + Sync),
}

/// A progress callback that shows nothing and never stops the work.
fn silent(_: u64) -> bool {
    true
}

impl Work<'_> {
    /// Work within its limits, followed by nobody.
    pub const QUIET: Work<'static> = Work {
        allow_long_run: false,
        progress: &silent,
    };
}

impl Work<'_> {
    /// Report `n` more units done.
    ///
    /// # Errors
    /// [`LimitError::Cancelled`] when the caller asks the work to stop.
    pub fn advance(&self, n: u64) -> Result<(), LimitError> {
        match (self.progress)(n) {
            true => Ok(()),
            false => Err(LimitError::Cancelled),
        }
    }
}

impl std::fmt::Debug for Work<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Work")
            .field("allow_long_run", &self.allow_long_run)
            .finish_non_exhaustive()
    }
}

/// Refuse `work` units of `what` beyond `limit` unless `allowed` (a long run asked for).
pub fn check_work(what: &str, work: f64, limit: f64, allowed: bool) -> Result<(), LimitError> {
    if work.is_finite() && (allowed || work <= limit) {
        return Ok(());
    }
    Err(LimitError::LongRun {
        what: what.to_string(),
        work,
        limit,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_work_beyond_the_limits_are_refused_with_the_limit() {
        assert_eq!(check_size("--points", 1000.0), Ok(1000));
        let e = check_size("--points", 1e12).unwrap_err().to_string();
        assert!(e.contains("--points") && e.contains("5e7"), "{e}");
        assert!(check_size("--points", f64::NAN).is_err());
        assert!(check_work("emulate", 1e6, 2e7, false).is_ok());
        let e = check_work("emulate", 1e15, 2e7, false)
            .unwrap_err()
            .to_string();
        assert!(e.contains("allow a long run") && e.contains("2e7"), "{e}");
        assert!(check_work("emulate", 1e15, 2e7, true).is_ok());
        assert!(check_work("emulate", f64::INFINITY, 2e7, true).is_err());
        assert_eq!(check_table("--points-per-decade", 1e6, 3), Ok(1_000_000));
        let e = check_table("--points-per-decade", 4.8e7, 3)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("× 3 values each") && e.contains("limit of 5e7"),
            "{e}"
        );
        assert!(check_table("x", f64::NAN, 3).is_err());
        assert_eq!(check_samples(4.0, 100.0), Ok(401));
        assert!(check_samples(51.0, 1e6).is_err());
        let e = check_samples(49.0, 1e6).unwrap_err().to_string();
        assert!(e.contains("5e6"), "{e}");
        assert_eq!(check_samples(4.0, 1e6), Ok(4_000_001));
        let e = check_samples(-1.0, 100.0).unwrap_err().to_string();
        assert_eq!(e, "duration_s = -1: must be > 0");
        assert!(check_samples(1.0, f64::NAN).is_err());
        // a long run lifts the work limit of an emulation, never its memory limit
        assert_eq!(check_emulation(6.0, 100.0, false), Ok(601));
        for allowed in [false, true] {
            let e = check_emulation(1e9, 100.0, allowed)
                .unwrap_err()
                .to_string();
            assert!(e.contains("limit of 5e6"), "{e}");
        }
        let e = check_emulation(6.0, 1e300, true).unwrap_err().to_string();
        assert!(e.contains("limit of 5e6"), "{e}");
    }

    /// The integrator's work of a run whose steps cost `cost(k)` evaluations each, checked
    /// after every step: the step at which it is refused, or `None`.
    fn refused_at(total: u64, allowed: bool, cost: impl Fn(u64) -> u64) -> Option<(u64, String)> {
        let mut watch = EmulatorWork::new(total, 0.01, allowed);
        let mut work = 0;
        for k in 0..total {
            work += cost(k);
            if let Err(e) = watch.check(k + 1, work) {
                return Some((k + 1, e.to_string()));
            }
        }
        None
    }

    #[test]
    fn an_emulation_is_stopped_by_its_integrators_work_not_its_steps_alone() {
        let calm = CALM_STEP_WORK as u64;
        // 10⁷ calm steps, the most the steps' limit allows: never stopped
        assert_eq!(refused_at(10_000_000, false, |_| calm), None);
        // 4.9·10⁶ steps (49 000 s at 100 Hz) at 20 000 evaluations a step, as a dual-pump
        // loop saturating on a ±150 mm, 0.5 Hz wave: stopped by the projection once a
        // thousandth of the limit is done (250 steps), at the next power of two
        let (at, e) = refused_at(4_900_000, false, |_| 20_000).unwrap();
        assert_eq!(at, 256);
        assert!(
            e.contains("projected from its rate over t = 1.28-2.56 s")
                && e.contains("20000 a controller step")
                && e.contains("about 9.8e10")
                && e.contains("more than the 5e9"),
            "{e}"
        );
        // twice the limit at a steady rate: not projected beyond ten times it, stopped when
        // the work done reaches the limit
        let (at, e) = refused_at(1_000_000, false, |_| 10_000).unwrap();
        assert_eq!(at, 500_001);
        assert!(e.contains("at t = 5000.01 s of 10000.00 s"), "{e}");
        // a saturated start of 200 steps (2 s) then calm: projected only once the calm steps
        // have brought the work to a thousandth of the limit, from a calm second half; it
        // fits and runs
        assert_eq!(
            refused_at(4_000_000, false, |k| if k < 200 { 20_000 } else { calm }),
            None
        );
        // allowed: nothing stops it
        assert_eq!(refused_at(300_000, true, |_| 20_000), None);
    }
}
