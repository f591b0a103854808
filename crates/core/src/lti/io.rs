//! The JSON form of a state-space model: `{"A": [[..]], "B": [[..]], "C": [[..]], "D": [[..]],
//! "states": [{"name": .., "unit": ..}]}`, row-major nested arrays, SI units. Written by
//! `pumpcyl model --json`, read by `--ss FILE`.

use super::{LtiError, StateSpace};
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Name and SI unit of a state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StateInfo {
    /// State name, e.g. `p1`.
    pub name: String,
    /// SI unit, e.g. `Pa`.
    pub unit: String,
}

/// The serialised model. `states` is optional on input.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelJson {
    /// State matrix rows.
    #[serde(rename = "A")]
    pub a: Vec<Vec<f64>>,
    /// Input matrix rows.
    #[serde(rename = "B")]
    pub b: Vec<Vec<f64>>,
    /// Output matrix rows.
    #[serde(rename = "C")]
    pub c: Vec<Vec<f64>>,
    /// Feedthrough matrix rows.
    #[serde(rename = "D")]
    pub d: Vec<Vec<f64>>,
    /// State names and units.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub states: Vec<StateInfo>,
}

impl ModelJson {
    /// Parse and check JSON text: the model and its state names, or one line naming the line,
    /// column and key of the problem (a leading byte-order mark is allowed).
    pub fn parse(
        text: &str,
    ) -> Result<(StateSpace, Vec<StateInfo>), crate::source_files::InputError> {
        use crate::source_files::InputError::Invalid;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        if text.trim().is_empty() {
            return Err(Invalid(
                "line 1: empty file: expected a JSON object {\"A\", \"B\", \"C\", \"D\"}".into(),
            ));
        }
        let json: ModelJson = serde_json::from_str(text).map_err(|e| {
            let message = e.to_string();
            let suffix = format!(" at line {} column {}", e.line(), e.column());
            let mut message = crate::source_files::serde_message(
                message.strip_suffix(&suffix).unwrap_or(&message),
            );
            let rest = text.lines().nth(e.line().max(1) - 1).unwrap_or("");
            let rest = rest.get(e.column().max(1) - 1..).unwrap_or("");
            if ["NaN", "Infinity", "-Infinity", "inf", "-inf"]
                .iter()
                .any(|w| rest.starts_with(w))
            {
                message += ": JSON has no NaN or Infinity; every entry must be a finite number";
            }
            Invalid(format!(
                "line {}, column {}: {message}",
                e.line(),
                e.column()
            ))
        })?;
        let located = |e: LtiError| {
            let first_word = match &e {
                LtiError::Dimension(m) => m.split_whitespace().next().unwrap_or(""),
                LtiError::IllPosedFeedback => "D",
                LtiError::Magnitude { matrix, .. } => matrix,
                _ => "B",
            };
            let key = match first_word.trim_matches('`') {
                k @ ("B" | "C" | "D" | "states") => k,
                _ => "A",
            };
            Invalid(format!(
                "line {}, key `{key}`: {e}",
                json_key_line(text, key)
            ))
        };
        let sys = json.to_model().map_err(located)?;
        for (name, m) in [("A", &sys.a), ("B", &sys.b), ("C", &sys.c), ("D", &sys.d)] {
            super::check_magnitudes(name, m).map_err(located)?;
        }
        sys.unity_feedback().map_err(located)?;
        let states = if json.states.is_empty() {
            (1..=sys.order())
                .map(|i| StateInfo {
                    name: format!("x{i}"),
                    unit: String::new(),
                })
                .collect()
        } else {
            json.states
        };
        Ok((sys, states))
    }

    /// Serialise a model with its state names.
    pub fn from_model(sys: &StateSpace, states: Vec<StateInfo>) -> Self {
        let rows = |m: &DMatrix<f64>| -> Vec<Vec<f64>> {
            m.row_iter().map(|r| r.iter().copied().collect()).collect()
        };
        ModelJson {
            a: rows(&sys.a),
            b: rows(&sys.b),
            c: rows(&sys.c),
            d: rows(&sys.d),
            states,
        }
    }

    /// Build the state-space model, checking ragged rows, sizes (at most [`MAX_STATES`] states)
    /// and finiteness.
    pub fn to_model(&self) -> Result<StateSpace, LtiError> {
        let n = self.a.len();
        if n == 0 {
            return Err(LtiError::Dimension(
                "A is empty: the model has no states".into(),
            ));
        }
        if n > MAX_STATES {
            return Err(LtiError::Dimension(format!(
                "A has {n} states, more than the limit of {MAX_STATES} (the eigenvalues and the \
                 frequency response cost n³ and n² per frequency)"
            )));
        }
        let m = self.b.first().map_or(0, Vec::len);
        let p = self.c.len();
        let a = matrix("A", &self.a, n)?;
        let b = matrix("B", &self.b, m)?;
        let c = matrix("C", &self.c, n)?;
        let d = matrix("D", &self.d, m)?;
        if !self.states.is_empty() && self.states.len() != n {
            return Err(LtiError::Dimension(format!(
                "`states` lists {} states, A has {n}",
                self.states.len()
            )));
        }
        let sys = StateSpace::new(a, b, c, d)?;
        debug_assert_eq!(sys.c.nrows(), p);
        Ok(sys)
    }
}

/// The line where `"key":` is written (1 when it is not).
/// The most states a state-space model read from JSON may have: fifty times the article's rig,
/// an analysis of seconds.
pub const MAX_STATES: usize = 500;

fn json_key_line(text: &str, key: &str) -> usize {
    let quoted = format!("\"{key}\"");
    text.match_indices(&quoted)
        .find(|(i, _)| text[i + quoted.len()..].trim_start().starts_with(':'))
        .map_or(1, |(i, _)| {
            crate::source_files::line_col(&text.as_bytes()[..i]).0
        })
}

/// A matrix from rows that must all have `cols` entries.
fn matrix(name: &str, rows: &[Vec<f64>], cols: usize) -> Result<DMatrix<f64>, LtiError> {
    for (i, r) in rows.iter().enumerate() {
        if r.len() != cols {
            return Err(LtiError::Dimension(format!(
                "{name} row {} has {} entries, expected {cols}",
                i + 1,
                r.len()
            )));
        }
    }
    Ok(DMatrix::from_fn(rows.len(), cols, |i, j| rows[i][j]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors() {
        let text = r#"{"A": [[0, 1], [-2, -3]], "B": [[0], [1]], "C": [[1, 0]], "D": [[0]]}"#;
        let j: ModelJson = serde_json::from_str(text).unwrap();
        let sys = j.to_model().unwrap();
        assert_eq!(sys.a[(1, 0)], -2.0);
        let back = ModelJson::from_model(&sys, vec![]);
        assert_eq!(back.to_model().unwrap(), sys);
        let ragged = r#"{"A": [[0, 1], [-2]], "B": [[0], [1]], "C": [[1, 0]], "D": [[0]]}"#;
        let e = serde_json::from_str::<ModelJson>(ragged)
            .unwrap()
            .to_model()
            .unwrap_err();
        assert!(e.to_string().contains("A row 2"), "{e}");
        let mismatch =
            r#"{"A": [[0, 1], [-2, -3]], "B": [[0], [1], [2]], "C": [[1, 0]], "D": [[0]]}"#;
        assert!(serde_json::from_str::<ModelJson>(mismatch)
            .unwrap()
            .to_model()
            .is_err());
    }
}
