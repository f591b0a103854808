//! Measured or emulated records (SPEC §9): CSV with a header row, columns by name, extra
//! columns ignored. `time_s`, `x_ref_mm`, `x_mm` are required; `p1_bar`, `p2_bar` (gauge),
//! `w1_rpm`, `w2_rpm` are optional. Time is strictly increasing, uniform or not.

use std::path::Path;

/// Errors reading a record; every one names the file, and the line and column where there is one.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read: {message}")]
    Io {
        /// The file.
        file: String,
        /// The cause.
        message: String,
    },
    /// CSV structure: ragged row, invalid UTF-8, ...
    #[error("{file}: line {line}: {message}")]
    Csv {
        /// The file.
        file: String,
        /// 1-based line.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// A required column is absent or a column appears twice.
    #[error("{file}: line 1 (header): {message}")]
    Header {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// A field that is not a finite number.
    #[error("{file}: line {line}, column `{column}`: {message}")]
    Value {
        /// The file.
        file: String,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: String,
        /// What is wrong.
        message: String,
    },
    /// Too few samples.
    #[error("{file}: {message}")]
    Empty {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
}

/// A record in user units (s, mm, bar gauge, rpm), as in the file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Record {
    /// Where it came from, for messages.
    pub file: String,
    /// Sample times (s), strictly increasing.
    pub time_s: Vec<f64>,
    /// Position reference (mm).
    pub x_ref_mm: Vec<f64>,
    /// Measured position (mm).
    pub x_mm: Vec<f64>,
    /// Chamber 1 pressure (bar gauge), if recorded.
    pub p1_bar: Option<Vec<f64>>,
    /// Chamber 2 pressure (bar gauge), if recorded.
    pub p2_bar: Option<Vec<f64>>,
    /// Motor 1 speed (rpm), if recorded.
    pub w1_rpm: Option<Vec<f64>>,
    /// Motor 2 speed (rpm), if recorded.
    pub w2_rpm: Option<Vec<f64>>,
}

const REQUIRED: [&str; 3] = ["time_s", "x_ref_mm", "x_mm"];
const OPTIONAL: [&str; 4] = ["p1_bar", "p2_bar", "w1_rpm", "w2_rpm"];

impl Record {
    /// Read and check a record file.
    pub fn read(path: &Path) -> Result<Record, RecordError> {
        let (bytes, file) = read_bytes(path)?;
        Self::parse(&bytes, &file)
    }

    /// Parse record text; `file` names it in messages.
    pub fn parse(bytes: &[u8], file: &str) -> Result<Record, RecordError> {
        let mut t = Table::parse(bytes, file, &REQUIRED, &OPTIONAL)?;
        Ok(Record {
            file: file.to_string(),
            time_s: t.take("time_s").unwrap_or_default(),
            x_ref_mm: t.take("x_ref_mm").unwrap_or_default(),
            x_mm: t.take("x_mm").unwrap_or_default(),
            p1_bar: t.take("p1_bar"),
            p2_bar: t.take("p2_bar"),
            w1_rpm: t.take("w1_rpm"),
            w2_rpm: t.take("w2_rpm"),
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether the record holds no sample (never true for a parsed record).
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    /// Index of the first sample whose reference differs from the first one (`len()` if the
    /// reference never changes).
    pub fn first_change(&self) -> usize {
        let r0 = self.x_ref_mm[0];
        self.x_ref_mm
            .iter()
            .position(|&r| r != r0)
            .unwrap_or(self.len())
    }

    /// The initial steady state of a signal (SPEC §9): the mean of the samples before the
    /// reference first changes, or the first sample if it changes at once.
    pub fn initial_mean(&self, signal: &[f64]) -> f64 {
        let k = self.first_change().max(1);
        signal[..k].iter().sum::<f64>() / k as f64
    }
}

/// Named numeric columns read from a CSV file with a header row: the first required column is
/// time, which must strictly increase; every field must be a finite number.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// The columns found, required first, by name.
    columns: Vec<(String, Vec<f64>)>,
}

impl Table {
    /// Read a file with the `required` columns (the first is time) and any `optional` ones.
    pub fn read(path: &Path, required: &[&str], optional: &[&str]) -> Result<Table, RecordError> {
        let (bytes, file) = read_bytes(path)?;
        Self::parse(&bytes, &file, required, optional)
    }

    /// Parse CSV text; `file` names it in messages.
    pub fn parse(
        bytes: &[u8],
        file: &str,
        required: &[&str],
        optional: &[&str],
    ) -> Result<Table, RecordError> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(bytes);
        let csv_err = |e: csv::Error| RecordError::Csv {
            file: file.to_string(),
            line: e.position().map_or(1, |p| p.line()),
            message: e.to_string(),
        };
        let headers = reader.headers().map_err(csv_err)?.clone();
        let index = column_index(&headers, file, required, optional)?;
        let mut columns: Vec<Vec<f64>> = vec![Vec::new(); index.len()];
        let mut prev_time: Option<f64> = None;
        for row in reader.records() {
            let row = row.map_err(csv_err)?;
            let line = row.position().map_or(0, |p| p.line());
            for (c, (name, i)) in index.iter().enumerate() {
                columns[c].push(parse_field(row.get(*i).unwrap_or(""), file, line, name)?);
            }
            let t = columns[0][columns[0].len() - 1];
            if let Some(p) = prev_time.filter(|&p| t <= p) {
                return Err(RecordError::Value {
                    file: file.to_string(),
                    line,
                    column: index[0].0.clone(),
                    message: format!("time must strictly increase: {t} follows {p}"),
                });
            }
            prev_time = Some(t);
        }
        if columns[0].len() < 2 {
            return Err(RecordError::Empty {
                file: file.to_string(),
                message: format!("needs at least 2 samples, found {}", columns[0].len()),
            });
        }
        Ok(Table {
            columns: index.into_iter().map(|(n, _)| n).zip(columns).collect(),
        })
    }

    /// Take a column out of the table by name (`None` if absent).
    pub fn take(&mut self, name: &str) -> Option<Vec<f64>> {
        self.columns
            .iter_mut()
            .find(|(n, _)| n == name)
            .map(|(_, v)| std::mem::take(v))
    }
}

/// The bytes of a file and its name for messages.
fn read_bytes(path: &Path) -> Result<(Vec<u8>, String), RecordError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| RecordError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    Ok((bytes, file))
}

/// Positions of the required and present optional columns, required first.
fn column_index(
    headers: &csv::StringRecord,
    file: &str,
    required: &[&str],
    optional: &[&str],
) -> Result<Vec<(String, usize)>, RecordError> {
    let header_err = |message: String| RecordError::Header {
        file: file.to_string(),
        message,
    };
    for (i, h) in headers.iter().enumerate() {
        if headers.iter().skip(i + 1).any(|other| other == h) && !h.is_empty() {
            return Err(header_err(format!("column `{h}` appears twice")));
        }
    }
    let find = |name: &str| headers.iter().position(|h| h == name);
    let mut index = Vec::new();
    for name in required {
        let i = find(name).ok_or_else(|| {
            let found: Vec<&str> = headers.iter().collect();
            header_err(format!(
                "missing required column `{name}` (need {}; found: {})",
                required.join(", "),
                found.join(", ")
            ))
        })?;
        index.push((name.to_string(), i));
    }
    for name in optional {
        if let Some(i) = find(name) {
            index.push((name.to_string(), i));
        }
    }
    Ok(index)
}

/// A finite number, or an error naming line and column.
fn parse_field(text: &str, file: &str, line: u64, column: &str) -> Result<f64, RecordError> {
    let err = |message: String| RecordError::Value {
        file: file.to_string(),
        line,
        column: column.to_string(),
        message,
    };
    let v: f64 = text
        .parse()
        .map_err(|_| err(format!("`{text}` is not a number")))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(err(format!("`{text}` is not a finite number")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Record, RecordError> {
        Record::parse(text.as_bytes(), "r.csv")
    }

    #[test]
    fn reads_required_optional_and_extra_columns_in_any_order() {
        let r = parse("extra,x_mm,time_s,p1_bar,x_ref_mm\n1,340,0,4,340\n2,340.5,0.01,4.1,345\n")
            .unwrap();
        assert_eq!(r.time_s, vec![0.0, 0.01]);
        assert_eq!(r.x_mm, vec![340.0, 340.5]);
        assert_eq!(r.p1_bar, Some(vec![4.0, 4.1]));
        assert_eq!(r.p2_bar, None);
        assert_eq!(r.first_change(), 1);
        assert_eq!(r.initial_mean(&r.x_mm), 340.0);
    }

    #[test]
    fn initial_state_is_the_mean_before_the_reference_changes() {
        let r =
            parse("time_s,x_ref_mm,x_mm\n0,340,339.9\n0.01,340,340.1\n0.02,345,340.2\n").unwrap();
        assert_eq!(r.first_change(), 2);
        assert!((r.initial_mean(&r.x_mm) - 340.0).abs() < 1e-12);
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse("time_s,x_mm\n0,1\n").unwrap_err().to_string();
        assert!(e.contains("r.csv") && e.contains("x_ref_mm"), "{e}");
        let e = parse("time_s,x_ref_mm,x_mm\n0,1,1\n0.01,NaN,1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("x_ref_mm"), "{e}");
        let e = parse("time_s,x_ref_mm,x_mm\n0,1,1\n0,1,1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 3") && e.contains("time_s") && e.contains("increase"),
            "{e}"
        );
        let e = parse("time_s,x_ref_mm,x_mm\n0,1,1\n0.01,1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3"), "{e}");
        let e = parse("time_s,x_ref_mm,x_mm\n0,abc,1\n0.01,1,1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("x_ref_mm") && e.contains("abc"),
            "{e}"
        );
        let e = parse("time_s,x_ref_mm,x_mm\n").unwrap_err().to_string();
        assert!(e.contains("at least 2"), "{e}");
        let e = parse("time_s,x_ref_mm,x_mm,x_mm\n0,1,1,1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("twice"), "{e}");
        let e = parse("").unwrap_err().to_string();
        assert!(e.contains("r.csv"), "{e}");
    }
}
