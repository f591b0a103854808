//! Commands as requests (docs/architecture.md#requests): each command the command line and the
//! Python package share is a request type, its options as fields named as both front ends name
//! them (`step_mm` is `--step-mm` and `step_mm=`), and one call, [`Request::run`], that returns
//! its outcome: the document both front ends show ([`Document`]: the JSON `--json` prints and
//! Python returns, the text the terminal shows, the warnings). The front ends only parse their
//! arguments into a request and show its outcome, so both give the same keys, and checks of an
//! option are written once.
//!
//! - [`advise`] — `advise`;
//! - [`analysis`] — `margins`, `poles`, `bode`, `model`;
//! - [`bulk`] — `bulk-modulus`;
//! - [`chatter`] — `chatter`;
//! - [`design`] — `design`, nominal and robust;
//! - [`emulate`] — `emulate`;
//! - [`frf`] — `frf` of a record;
//! - [`identify`] — `identify` (from an experiment file or from records on a rig), `identify-merge`;
//! - [`select`] — `select`;
//! - [`standstill`] — `leakage`, `identify-drive`;
//! - [`time`] — `step`, `track`, `simulate` (a record replayed).

pub mod advise;
pub mod analysis;
pub mod bulk;
pub mod chatter;
pub mod cycle;
pub mod design;
pub mod emulate;
pub mod frf;
pub mod identify;
pub mod select;
pub mod standstill;
pub mod time;

use pumpcyl::rig::Rig;
use serde_json::Value;

/// The rig a request runs on, as the front end read it.
#[derive(Debug, Clone)]
pub struct RigInput {
    /// The rig, with every override applied.
    pub rig: Rig,
    /// The rig as the front end names it in documents (`default rig`, `my.toml, mass_kg=900`,
    /// `Rig(mass_kg=900.0)`).
    pub name: String,
    /// The keys its rig file left out (docs/formats.md#rig-toml); `None` for a rig not read
    /// from a file.
    pub defaulted: Option<Vec<&'static str>>,
}

impl RigInput {
    /// The embedded default rig (the article's), named `name`.
    pub fn default_named(name: &str) -> RigInput {
        RigInput {
            rig: Rig::default(),
            name: name.to_string(),
            defaulted: None,
        }
    }

    /// The result document `doc` with the keys this rig's file left out
    /// ([`crate::documents::with_rig_defaulted_keys`]).
    pub fn document(&self, doc: Value) -> Value {
        crate::documents::with_rig_defaulted_keys(doc, self.defaulted.as_deref())
    }
}

/// What a long request reports and how it is stopped: `tick(n)` is called as `n` more units of
/// work are done (candidates, cases) and returns `false` once the caller wants it to stop.
#[derive(Clone, Copy)]
pub struct Hooks<'a> {
    /// Progress and cancellation, as the core's cancellable searches take them.
    pub tick: &'a (dyn Fn(u64) -> bool + Sync),
}

impl Hooks<'static> {
    /// No progress shown, never cancelled.
    pub fn none() -> Hooks<'static> {
        Hooks { tick: &|_| true }
    }
}

/// A command's request: its inputs (the rig, records, an application) and its options, checked
/// and run by [`Request::run`].
pub trait Request {
    /// What the request returns.
    type Outcome: Document;

    /// The work it will report through [`Hooks::tick`]: the units in all and their name
    /// (`conditions`, `candidates`); `None` for a request too quick to report progress.
    fn work(&self) -> Option<(u64, &'static str)> {
        None
    }

    /// Run the request.
    ///
    /// # Errors
    /// An option out of range (a [`FieldError`] naming it), a rig the command cannot run on, a
    /// computation that fails or a cancellation.
    fn run(&self, hooks: Hooks<'_>) -> anyhow::Result<Self::Outcome>;
}

/// The outcome of a request as the front ends show it.
pub trait Document {
    /// The JSON document (`--json`; Python's `Result`).
    ///
    /// # Errors
    /// A number of the document cannot be computed.
    fn json(&self) -> anyhow::Result<Value>;

    /// The text the command line prints without `--json`.
    ///
    /// # Errors
    /// A number of the text cannot be computed.
    fn text(&self) -> anyhow::Result<String>;

    /// What the front end warns of (the command line on standard error, Python as a
    /// `UserWarning`); the JSON document lists the same lines as its `warnings`.
    fn warnings(&self) -> &[String] {
        &[]
    }
}

/// An option of a request out of its range: the front end names it as its user wrote it
/// (`--step-mm 0: ...` on the command line, `step(step_mm=0.0): ...` in Python), with every
/// option a rule ties together.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: {problem}", self.named(|f| format!("{} = {}", f.name, f.given.on_command_line())))]
pub struct FieldError {
    /// The options at fault and the values given.
    pub fields: Vec<Field>,
    /// What is wrong with them.
    pub problem: String,
    /// The switch that would let it run anyway (`allow_long_run` for work beyond its limit).
    pub unless: Option<&'static str>,
}

/// An option of a request and the value given for it.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// The request's field: the Python keyword, and the command line's option with `-` for `_`
    /// unless `flag` says otherwise.
    pub name: &'static str,
    /// The command line's option where it is not the field's name (`force-n` for the
    /// repeated option of `forces_n`).
    pub flag: Option<&'static str>,
    /// The value given.
    pub given: Given,
}

/// A value given for an option.
#[derive(Debug, Clone, PartialEq)]
pub enum Given {
    /// A number.
    Number(f64),
    /// Text, as written (quoted in Python).
    Text(String),
    /// A value as the core wrote it, shown as it is by both front ends.
    Shown(String),
    /// A wave: frequency (Hz) and amplitude (mm); `80:5` on the command line, `(80.0, 5.0)` in
    /// Python.
    Wave(f64, f64),
    /// A shard `I/N` of a search: `1/2` on the command line, `(1, 2)` in Python.
    Shard(usize, usize),
    /// Item `index` of a list option (from 0), given as `value`: on the command line the
    /// repeated option's value (`--wave 80:5` of `waves`), in Python `waves[1]=(80.0, 5.0)`.
    Item(usize, Box<Given>),
}

impl Given {
    /// As the command line's user wrote it (`0.5`, `NaN`).
    fn on_command_line(&self) -> String {
        match self {
            Given::Number(v) => format!("{v}"),
            Given::Text(t) | Given::Shown(t) => t.clone(),
            Given::Wave(f, a) => format!("{f}:{a}"),
            Given::Shard(i, n) => format!("{i}/{n}"),
            Given::Item(_, v) => v.on_command_line(),
        }
    }

    /// As Python shows it (`0.5`, `2.0`, `nan`, `'text'`).
    fn in_python(&self) -> String {
        match self {
            Given::Number(v) if v.is_nan() => "nan".into(),
            Given::Number(v) if v.is_infinite() => if *v > 0.0 { "inf" } else { "-inf" }.into(),
            Given::Number(v) if v.fract() == 0.0 && v.abs() < 1e16 => format!("{v:.1}"),
            Given::Number(v) => format!("{v}"),
            Given::Text(t) => format!("{t:?}").replace('"', "'"),
            Given::Shown(t) => t.clone(),
            Given::Wave(f, a) => {
                let (f, a) = (Given::Number(*f).in_python(), Given::Number(*a).in_python());
                format!("({f}, {a})")
            }
            Given::Shard(i, n) => format!("({i}, {n})"),
            Given::Item(_, v) => v.in_python(),
        }
    }
}

impl Field {
    /// The option as the command line spells it: `--step-mm`; an item of a list option as the
    /// repeated option (`--wave` of `waves`).
    fn flag(&self) -> String {
        let name = match (self.flag, &self.given) {
            (Some(flag), _) => flag,
            (None, Given::Item(..)) => self.name.strip_suffix('s').unwrap_or(self.name),
            (None, _) => self.name,
        };
        format!("--{}", name.replace('_', "-"))
    }

    /// The option as Python spells it: `step_mm`, an item `waves[1]`.
    fn keyword(&self) -> String {
        match &self.given {
            Given::Item(i, _) => format!("{}[{i}]", self.name),
            _ => self.name.to_string(),
        }
    }
}

impl FieldError {
    /// `field` = `value` is wrong: `problem`.
    pub fn new(field: &'static str, value: Given, problem: impl Into<String>) -> FieldError {
        FieldError {
            fields: Vec::new(),
            problem: problem.into(),
            unless: None,
        }
        .and(field, value)
    }

    /// The same error, tied to `field` = `value` too.
    #[must_use]
    pub fn and(mut self, field: &'static str, value: Given) -> FieldError {
        self.fields.push(Field {
            name: field,
            flag: None,
            given: value,
        });
        self
    }

    /// The core's complaint about a field (`forces_n = 2e9: as an external_force_n, ...`), its
    /// value shown as the core wrote it, the field the request's `name`; `flag` the command
    /// line's option where it is not the field's name.
    pub fn of_core(
        e: pumpcyl::source_files::FieldError,
        name: &'static str,
        flag: Option<&'static str>,
    ) -> FieldError {
        let stated = (e.message.strip_prefix(e.field))
            .and_then(|rest| rest.strip_prefix(" = "))
            .and_then(|rest| rest.split_once(": "));
        let (given, problem) = match stated {
            Some((value, problem)) => (Given::Shown(value.into()), problem.to_string()),
            None => {
                let problem = (e.message.strip_prefix(e.field))
                    .and_then(|rest| rest.strip_prefix(": "))
                    .unwrap_or(&e.message);
                (Given::Shown("…".into()), problem.to_string())
            }
        };
        let field = Field { name, flag, given };
        FieldError {
            fields: vec![field],
            problem,
            unless: None,
        }
    }

    /// The same error, which the switch `switch` would let run anyway.
    #[must_use]
    pub fn unless(mut self, switch: &'static str) -> FieldError {
        self.unless = Some(switch);
        self
    }

    fn named(&self, each: impl Fn(&Field) -> String) -> String {
        let parts: Vec<String> = self.fields.iter().map(each).collect();
        parts.join(", ")
    }

    /// The error as the command line says it: `--periods 2.5: must be ...`.
    pub fn on_command_line(&self) -> String {
        let named = self.named(|f| match f.given.on_command_line().as_str() {
            "…" => f.flag(),
            value => format!("{} {value}", f.flag()),
        });
        let unless =
            (self.unless).map_or(String::new(), |u| format!(" (--{})", u.replace('_', "-")));
        format!("{named}: {}{unless}", self.problem)
    }

    /// The error as Python says it of the call `call`: `track(periods=2.5): must be ...`.
    pub fn in_python(&self, call: &str) -> String {
        let named = self.named(|f| format!("{}={}", f.keyword(), f.given.in_python()));
        let unless = (self.unless).map_or(String::new(), |u| format!(" ({u}=True)"));
        format!("{call}({named}): {}{unless}", self.problem)
    }
}

/// The confidence level `confidence` checked in (0, 1).
///
/// # Errors
/// A [`FieldError`] naming `confidence`.
pub fn check_confidence(confidence: f64) -> anyhow::Result<()> {
    let ok = pumpcyl::ident::check_confidence(confidence).is_ok();
    check_field(
        "confidence",
        confidence,
        ok,
        "must lie strictly between 0 and 1",
    )
}

/// `Ok` if `ok`, else the [`FieldError`] of `field` = `value` saying `problem`.
///
/// # Errors
/// `ok` is false.
pub fn check_field(field: &'static str, value: f64, ok: bool, problem: &str) -> anyhow::Result<()> {
    if ok {
        return Ok(());
    }
    Err(FieldError::new(field, Given::Number(value), problem).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_field_error_names_its_options_as_each_front_end_spells_them() {
        let e = FieldError::new("duration_s", Given::Number(4.0), "too long")
            .and("rate_hz", Given::Number(f64::NAN));
        assert_eq!(
            e.on_command_line(),
            "--duration-s 4, --rate-hz NaN: too long"
        );
        assert_eq!(
            e.in_python("step"),
            "step(duration_s=4.0, rate_hz=nan): too long"
        );
        assert_eq!(e.to_string(), "duration_s = 4, rate_hz = NaN: too long");
        let text = FieldError::new("compare", Given::Text("beta_bar=-1".into()), "must be > 0");
        assert_eq!(
            text.in_python("step"),
            "step(compare='beta_bar=-1'): must be > 0"
        );
        let half = FieldError::new("periods", Given::Number(2.5), "whole");
        assert_eq!(half.in_python("track"), "track(periods=2.5): whole");
        assert_eq!(half.on_command_line(), "--periods 2.5: whole");
        let wave = Given::Item(1, Box::new(Given::Wave(80.0, 5.0)));
        let wave = FieldError::new("waves", wave, "above Nyquist");
        assert_eq!(wave.on_command_line(), "--wave 80:5: above Nyquist");
        assert_eq!(
            wave.in_python("design"),
            "design(waves[1]=(80.0, 5.0)): above Nyquist"
        );
        let inf = FieldError::new("x", Given::Number(f64::NEG_INFINITY), "finite");
        assert_eq!(inf.in_python("f"), "f(x=-inf): finite");
    }

    #[test]
    fn check_field_passes_or_names_the_field() {
        assert!(check_field("step_mm", 5.0, true, "non-zero").is_ok());
        let e = check_field("step_mm", 0.0, false, "non-zero").unwrap_err();
        let field = e.downcast_ref::<FieldError>().expect("a FieldError");
        assert_eq!(field.on_command_line(), "--step-mm 0: non-zero");
    }
}
