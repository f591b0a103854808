//! Measured or emulated records (docs/formats.md#record-csv): CSV with a header row, columns by name, extra
//! columns ignored. `time_s`, `x_ref_mm`, `x_mm` are required; `p1_bar`, `p2_bar` (gauge),
//! `w1_rpm`, `w2_rpm` are optional. Time is strictly increasing, uniform or not.

use crate::source_files::{Disk, Files};
use std::io::{BufRead, BufReader, Read};
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
    /// A MAT-file that is not a usable record (the message names the variable).
    #[error("{file}: {message}")]
    Mat {
        /// The file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// Positions in another unit than the column's mm.
    #[error("{file}: column `{column}` {message}")]
    Unit {
        /// The file.
        file: String,
        /// Column name.
        column: String,
        /// What is wrong, with the likely unit.
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

/// The smallest and largest value of a column (∞, −∞ when empty).
pub(crate) fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        })
}

/// The largest MAT-file record read, in bytes (2 GiB: 5·10⁷ samples of five columns in
/// doubles, the sample limit, fit with room to spare).
pub const MAX_MAT_BYTES: u64 = 2 << 30;

const REQUIRED: [&str; 3] = ["time_s", "x_ref_mm", "x_mm"];

/// The finest motion (mm) a cylinder position sensor resolves: 1 µm, the finest step of
/// magnetostrictive and optical linear encoders. A reference moving less is no experiment
/// in mm.
pub const POSITION_RESOLUTION_MM: f64 = 1e-3;
const OPTIONAL: [&str; 4] = ["p1_bar", "p2_bar", "w1_rpm", "w2_rpm"];

impl Record {
    /// The smallest and largest reference position (mm).
    pub fn reference_range_mm(&self) -> (f64, f64) {
        range(&self.x_ref_mm)
    }

    /// Refuse positions in another unit than mm, naming the column and the likely unit
    /// (docs/formats.md#record-csv), so that no command and no Python call fits a record in
    /// metres or micrometres as if it were millimetres:
    /// - a column reaching beyond −1 … 2 strokes (`stroke_mm`): 1000 times too large, micrometres;
    /// - on a cylinder longer than 10 mm, every reference and measured position within 1 mm of 0,
    ///   or a reference whose whole motion is nonzero but below what a position sensor resolves
    ///   ([`POSITION_RESOLUTION_MM`]): metres, which would fit with an error near zero.
    pub fn check_units(&self, stroke_mm: f64) -> Result<(), RecordError> {
        let refuse = |column: &str, message: String| {
            Err(RecordError::Unit {
                file: self.file.clone(),
                column: column.to_string(),
                message,
            })
        };
        for (column, values) in [("x_ref_mm", &self.x_ref_mm), ("x_mm", &self.x_mm)] {
            let (lo, hi) = range(values);
            if lo < -stroke_mm || hi > 2.0 * stroke_mm {
                let (lo_mm, hi_mm) = (lo * 1e-3, hi * 1e-3);
                let unit = if lo_mm >= -stroke_mm && hi_mm <= 2.0 * stroke_mm {
                    format!("is it in micrometres ({lo_mm} … {hi_mm} mm)?")
                } else {
                    "is it in another unit?".to_string()
                };
                return refuse(
                    column,
                    format!(
                        "spans {lo} … {hi}, far outside the 0 … {stroke_mm} mm stroke: {unit} \
                         The column must be in mm"
                    ),
                );
            }
        }
        if stroke_mm <= 10.0 {
            return Ok(());
        }
        let (lo, hi) = range(&self.x_ref_mm);
        let (xlo, xhi) = range(&self.x_mm);
        if [lo, hi, xlo, xhi].iter().all(|v| v.abs() < 1.0) {
            return refuse(
                "x_ref_mm",
                format!(
                    "spans {lo} … {hi} and x_mm {xlo} … {xhi}, all within 1 mm of 0 on a \
                     {stroke_mm} mm cylinder: is the record in metres ({} … {} mm)? The columns \
                     must be in mm",
                    lo * 1e3,
                    hi * 1e3
                ),
            );
        }
        if hi > lo && hi - lo < POSITION_RESOLUTION_MM {
            return refuse(
                "x_ref_mm",
                format!(
                    "moves by {} mm in all, below what a position sensor resolves \
                     ({POSITION_RESOLUTION_MM} mm): is the record in metres? The column must be \
                     in mm",
                    hi - lo
                ),
            );
        }
        Ok(())
    }

    /// Read and check a record file, streamed (memory holds the used columns, not the text);
    /// a `.mat` file is read as a MAT-file record ([`Table::from_mat`]).
    pub fn read(path: &Path) -> Result<Record, RecordError> {
        Self::read_in(&Disk, path)
    }

    /// [`Record::read`] from `files`.
    pub fn read_in(files: &dyn Files, path: &Path) -> Result<Record, RecordError> {
        let t = Table::read_in(files, path, &REQUIRED, &OPTIONAL)?;
        Ok(Self::from_table(t, &path.display().to_string()))
    }

    /// Parse record text; `file` names it in messages.
    pub fn parse(bytes: &[u8], file: &str) -> Result<Record, RecordError> {
        Self::from_reader(bytes, file)
    }

    /// Parse a record from a stream; `file` names it in messages.
    pub fn from_reader<R: BufRead>(reader: R, file: &str) -> Result<Record, RecordError> {
        let t = Table::from_reader(reader, file, &REQUIRED, &OPTIONAL)?;
        Ok(Self::from_table(t, file))
    }

    /// A record from MAT-file bytes (see [`Table::from_mat`]); `file` names it in messages.
    pub fn parse_mat(bytes: &[u8], file: &str) -> Result<Record, RecordError> {
        let t = Table::from_mat(bytes, file, &REQUIRED, &OPTIONAL)?;
        Ok(Self::from_table(t, file))
    }

    fn from_table(mut t: Table, file: &str) -> Record {
        Record {
            file: file.to_string(),
            time_s: t.take("time_s").unwrap_or_default(),
            x_ref_mm: t.take("x_ref_mm").unwrap_or_default(),
            x_mm: t.take("x_mm").unwrap_or_default(),
            p1_bar: t.take("p1_bar"),
            p2_bar: t.take("p2_bar"),
            w1_rpm: t.take("w1_rpm"),
            w2_rpm: t.take("w2_rpm"),
        }
    }

    /// A record from in-memory columns (s, mm), checked as a file is: at least 2 samples, equal
    /// lengths, finite values, strictly increasing time. `name` stands for the file in
    /// messages, which name the column and the 0-based sample.
    pub fn from_arrays(
        name: &str,
        time_s: &[f64],
        x_ref_mm: &[f64],
        x_mm: &[f64],
    ) -> Result<Record, RecordError> {
        let err = |message: String| RecordError::Empty {
            file: name.to_string(),
            message,
        };
        let n = time_s.len();
        if n < 2 {
            return Err(err(format!(
                "{n} samples: a record needs at least 2 samples"
            )));
        }
        for (column, values) in [("time_s", time_s), ("x_ref_mm", x_ref_mm), ("x_mm", x_mm)] {
            if values.len() != n {
                return Err(err(format!(
                    "column `{column}` has {} samples, `time_s` has {n}",
                    values.len()
                )));
            }
            if let Some(k) = values.iter().position(|v| !v.is_finite()) {
                return Err(err(format!(
                    "column `{column}`, sample {k}: {} is not a finite number",
                    values[k]
                )));
            }
        }
        if let Some(k) = (1..n).find(|&k| time_s[k] <= time_s[k - 1]) {
            return Err(err(format!(
                "column `time_s`, sample {k}: time must strictly increase: {} follows {}",
                time_s[k],
                time_s[k - 1]
            )));
        }
        Ok(Record {
            file: name.to_string(),
            time_s: time_s.to_vec(),
            x_ref_mm: x_ref_mm.to_vec(),
            x_mm: x_mm.to_vec(),
            ..Record::default()
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

    /// The mean chamber pressure (p1 + p2)/2 (bar gauge) at each sample, the pressure the
    /// gas-fraction model reads β_e at (docs/bulk-modulus.md); `None` without both pressures.
    pub fn mean_chamber_pressure_bar(&self) -> Option<Vec<f64>> {
        let (cap, rod) = (self.p1_bar.as_ref()?, self.p2_bar.as_ref()?);
        Some(cap.iter().zip(rod).map(|(a, b)| 0.5 * (a + b)).collect())
    }

    /// The initial steady state of a signal (docs/simulation.md#deviations-and-the-baseline): the mean of the samples before the
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
    /// Read a file with the `required` columns (the first is time) and any `optional` ones,
    /// streamed.
    pub fn read(path: &Path, required: &[&str], optional: &[&str]) -> Result<Table, RecordError> {
        Self::read_in(&Disk, path, required, optional)
    }

    /// [`Table::read`] from `files`; a MAT-file is read whole, at most [`MAX_MAT_BYTES`], its
    /// header and then each element's tag checked before the element is read
    /// ([`crate::matfile::read_stream`]), so a stream that never ends is refused at once.
    pub fn read_in(
        files: &dyn Files,
        path: &Path,
        required: &[&str],
        optional: &[&str],
    ) -> Result<Table, RecordError> {
        let file = path.display().to_string();
        let io = |e: std::io::Error| RecordError::Io {
            file: file.clone(),
            message: e.to_string(),
        };
        let mut stream = files.open(path).map_err(io)?;
        if is_mat(path) {
            // element by element: a file that is no MAT-file (`/dev/urandom` behind a link), or
            // a valid header before endless data, is refused at its first wrong tag
            let bytes =
                crate::matfile::read_stream(&mut stream, MAX_MAT_BYTES).map_err(|e| match e {
                    crate::matfile::StreamError::Io(e) => io(e),
                    crate::matfile::StreamError::Mat(e) => RecordError::Mat {
                        file: file.clone(),
                        message: e.0,
                    },
                })?;
            return Self::from_mat(&bytes, &file, required, optional);
        }
        let reader = BufReader::with_capacity(1 << 16, stream);
        Self::from_reader(reader, &file, required, optional)
    }

    /// Parse CSV text; `file` names it in messages.
    pub fn parse(
        bytes: &[u8],
        file: &str,
        required: &[&str],
        optional: &[&str],
    ) -> Result<Table, RecordError> {
        Self::from_reader(bytes, file, required, optional)
    }

    /// Parse CSV from a stream, one row at a time; `file` names it in messages. The dialect
    /// comes from the header line (see [`Dialect`]); a UTF-8 byte-order mark is dropped.
    pub fn from_reader<R: BufRead>(
        reader: R,
        file: &str,
        required: &[&str],
        optional: &[&str],
    ) -> Result<Table, RecordError> {
        let mut reader = std::io::BufReader::new(LineLimit {
            inner: reader,
            line_bytes: 0,
        });
        let (header_line, dialect) = Dialect::sniff(&mut reader, file)?;
        let mut csv = csv::ReaderBuilder::new()
            .delimiter(dialect.delimiter)
            .flexible(true)
            .has_headers(true)
            .from_reader(header_line.chain(reader));
        let csv_err = |e: csv::Error| RecordError::Csv {
            file: file.to_string(),
            line: e.position().map_or(1, |p| p.line()),
            message: e.to_string(),
        };
        let headers = header_names(csv.byte_headers().map_err(csv_err)?, file)?;
        let index = column_index(&headers, file, required, optional)?;
        let mut rows = Rows {
            file,
            dialect,
            headers: &headers,
            index: &index,
            columns: vec![Vec::new(); index.len()],
            line: 1,
        };
        let mut row = csv::ByteRecord::new();
        while csv.read_byte_record(&mut row).map_err(csv_err)? {
            rows.line = row.position().map_or(rows.line + 1, |p| p.line());
            if rows.columns.first().map_or(0, Vec::len) as f64 >= crate::limits::MAX_POINTS {
                return Err(RecordError::Csv {
                    file: file.to_string(),
                    line: rows.line,
                    message: format!(
                        "more than {:e} data rows, the limit for a record",
                        crate::limits::MAX_POINTS
                    ),
                });
            }
            rows.push(&row)?;
        }
        rows.finish()
    }

    /// A table from a level-5 MAT-file (MATLAB `save -v7`/`-v6`, Octave `save -mat`): one real
    /// vector per column, named as the CSV column (`time_s`, `x_ref_mm`, ...), all of one
    /// length; other variables are ignored. The same checks as for CSV apply: finite values,
    /// strictly increasing time, at least two samples.
    pub fn from_mat(
        bytes: &[u8],
        file: &str,
        required: &[&str],
        optional: &[&str],
    ) -> Result<Table, RecordError> {
        let err = |message: String| RecordError::Mat {
            file: file.to_string(),
            message,
        };
        let vars = crate::matfile::read(bytes).map_err(|e| err(e.0))?;
        let names: Vec<String> = vars.iter().map(|v| v.name.clone()).collect();
        let mut columns = Vec::new();
        for (k, name) in required.iter().chain(optional).enumerate() {
            let Some(var) = vars.iter().find(|v| v.name == *name) else {
                if k < required.len() {
                    let message =
                        missing_column(name, &names, required).replace("column", "variable");
                    return Err(err(message));
                }
                continue;
            };
            let values = var
                .vector()
                .map_err(|why| err(format!("variable `{name}` {why}")))?;
            if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(err(format!(
                    "variable `{name}`, element {}: `{v}` is not a finite number",
                    i + 1
                )));
            }
            columns.push((name.to_string(), values.to_vec()));
        }
        let n = columns[0].1.len();
        if let Some((name, v)) = columns.iter().find(|(_, v)| v.len() != n) {
            return Err(err(format!(
                "variable `{name}` has {} elements, `{}` has {n}: every column needs one value per sample",
                v.len(),
                columns[0].0
            )));
        }
        if n < 2 {
            return Err(err(format!("{n} samples: a record needs at least 2")));
        }
        if let Some(i) = columns[0].1.windows(2).position(|w| w[1] <= w[0]) {
            let t = &columns[0].1;
            return Err(err(format!(
                "variable `{}`, element {}: time must strictly increase: {} follows {}",
                columns[0].0,
                i + 2,
                t[i + 1],
                t[i]
            )));
        }
        Ok(Table { columns })
    }

    /// Take a column out of the table by name (`None` if absent).
    pub fn take(&mut self, name: &str) -> Option<Vec<f64>> {
        self.columns
            .iter_mut()
            .find(|(n, _)| n == name)
            .map(|(_, v)| std::mem::take(v))
    }
}

/// How a CSV file is written, decided from its header line: comma-separated with decimal points,
/// or, as European spreadsheets write it, semicolon- (or tab-) separated with decimal commas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dialect {
    /// Field separator.
    pub delimiter: u8,
    /// Whether `,` is the decimal mark (only with `;` or tab separators).
    pub decimal_comma: bool,
}

impl Dialect {
    /// Read the header line (dropping a byte-order mark) and decide the dialect: `;` or tab
    /// separators when the header has one of them and no comma. Returns the header line to be
    /// read again by the CSV reader.
    fn sniff<R: BufRead>(
        reader: &mut R,
        file: &str,
    ) -> Result<(std::io::Cursor<Vec<u8>>, Dialect), RecordError> {
        let mut line = Vec::new();
        reader
            .read_until(b'\n', &mut line)
            .map_err(|e| RecordError::Io {
                file: file.to_string(),
                message: e.to_string(),
            })?;
        if line.starts_with(crate::source_files::BOM) {
            line.drain(..crate::source_files::BOM.len());
        }
        if line.iter().all(u8::is_ascii_whitespace) {
            return Err(RecordError::Csv {
                file: file.to_string(),
                line: 1,
                message: "empty file: the first line must be a header row naming the columns"
                    .into(),
            });
        }
        let count = |c: u8| line.iter().filter(|&&b| b == c).count();
        let delimiter = match (count(b','), count(b';'), count(b'\t')) {
            (0, s, _) if s > 0 => b';',
            (0, 0, t) if t > 0 => b'\t',
            _ => b',',
        };
        let dialect = Dialect {
            delimiter,
            decimal_comma: delimiter != b',',
        };
        Ok((std::io::Cursor::new(line), dialect))
    }
}

/// The column builder of [`Table::from_reader`]: checks and stores one row at a time.
struct Rows<'a> {
    file: &'a str,
    dialect: Dialect,
    headers: &'a [String],
    index: &'a [(String, usize)],
    columns: Vec<Vec<f64>>,
    /// Line of the row being read (1-based).
    line: u64,
}

impl Rows<'_> {
    /// Check a row's length, parse its used fields and check that time increases.
    fn push(&mut self, row: &csv::ByteRecord) -> Result<(), RecordError> {
        let err = |message: String| RecordError::Csv {
            file: self.file.to_string(),
            line: self.line,
            message,
        };
        let n = self.headers.len();
        if row.len() < n {
            return Err(err(format!(
                "{} fields, the header has {n}: no value for `{}` and after",
                row.len(),
                self.headers[row.len()]
            )));
        }
        if row.iter().skip(n).any(|f| !f.trim_ascii().is_empty()) {
            return Err(err(format!(
                "{} fields, the header has {n}: a value past the last column `{}`",
                row.len(),
                self.headers[n - 1]
            )));
        }
        for (c, (name, i)) in self.index.iter().enumerate() {
            let v = parse_field(&row[*i], self.dialect, self.file, self.line, name)?;
            if let Some(limit) = physical_limit(name).filter(|l| v.abs() > *l) {
                return Err(err(format!(
                    "`{name}` = {}: far outside anything physical (|value| <= {limit:e} for \
                     this unit)",
                    crate::units::readable(v)
                )));
            }
            self.columns[c].push(v);
        }
        self.check_time()
    }

    /// The newest time sample must exceed the one before it.
    fn check_time(&self) -> Result<(), RecordError> {
        let t = &self.columns[0];
        match t.len() {
            0 | 1 => Ok(()),
            k if t[k - 1] > t[k - 2] => Ok(()),
            k => Err(RecordError::Value {
                file: self.file.to_string(),
                line: self.line,
                column: self.index[0].0.clone(),
                message: format!(
                    "time must strictly increase: {} follows {}{}",
                    t[k - 1],
                    t[k - 2],
                    if t[k - 1] == t[k - 2] {
                        " (a repeated sample)"
                    } else {
                        ""
                    }
                ),
            }),
        }
    }

    /// The table, if it holds at least two samples.
    fn finish(self) -> Result<Table, RecordError> {
        let samples = self.columns[0].len();
        if samples < 2 {
            let what = if samples == 0 {
                "no data rows after the header"
            } else {
                "only one data row"
            };
            return Err(RecordError::Csv {
                file: self.file.to_string(),
                line: self.line + 1,
                message: format!("{what}: a record needs at least 2 samples"),
            });
        }
        Ok(Table {
            columns: self
                .index
                .iter()
                .map(|(n, _)| n.clone())
                .zip(self.columns)
                .collect(),
        })
    }
}

/// The largest magnitude a column can hold, by its unit: positions within 100 m, pressures within
/// 10 000 bar, speeds within 10⁶ rpm, times within 30 years. `None` for other columns.
fn physical_limit(name: &str) -> Option<f64> {
    [("_mm", 1e5), ("_bar", 1e4), ("_rpm", 1e6), ("_s", 1e9)]
        .iter()
        .find(|(unit, _)| name.ends_with(unit))
        .map(|(_, limit)| *limit)
}

/// The longest line a record may have (bytes): far beyond any row of numbers.
const MAX_LINE_BYTES: usize = 1 << 20;

/// A reader that fails once a line grows past [`MAX_LINE_BYTES`], so a file without line ends
/// (a binary file, `/dev/zero`) is an error instead of filling memory.
struct LineLimit<R> {
    inner: R,
    line_bytes: usize,
}

impl<R: std::io::Read> std::io::Read for LineLimit<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            self.line_bytes = if b == b'\n' { 0 } else { self.line_bytes + 1 };
            if self.line_bytes > MAX_LINE_BYTES {
                return Err(std::io::Error::other(format!(
                    "a line longer than {} MiB: not a CSV record",
                    MAX_LINE_BYTES >> 20
                )));
            }
        }
        Ok(n)
    }
}

/// Whether a path names a MAT-file (extension `.mat`, any case).
fn is_mat(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"))
}

/// The header's column names (trimmed); a name that is not UTF-8 is an error at line 1.
fn header_names(headers: &csv::ByteRecord, file: &str) -> Result<Vec<String>, RecordError> {
    headers
        .iter()
        .enumerate()
        .map(|(i, h)| {
            std::str::from_utf8(h.trim_ascii())
                .map(str::to_string)
                .map_err(|_| RecordError::Csv {
                    file: file.to_string(),
                    line: 1,
                    message: format!(
                        "header field {} (`{}`) is not UTF-8 text; save the file as UTF-8",
                        i + 1,
                        String::from_utf8_lossy(h)
                    ),
                })
        })
        .collect()
}

/// Positions of the required and present optional columns, required first.
fn column_index(
    headers: &[String],
    file: &str,
    required: &[&str],
    optional: &[&str],
) -> Result<Vec<(String, usize)>, RecordError> {
    let header_err = |message: String| RecordError::Header {
        file: file.to_string(),
        message,
    };
    let used = required.iter().chain(optional);
    if let Some(name) = used
        .clone()
        .find(|n| headers.iter().filter(|h| h == n).count() > 1)
    {
        return Err(header_err(format!("column `{name}` appears twice")));
    }
    if let Some(h) = headers.iter().find(|h| h.chars().any(char::is_control)) {
        return Err(header_err(format!(
            "column name `{}` holds control characters: this is not a CSV text file",
            h.escape_debug()
        )));
    }
    if headers.iter().all(|h| h.parse::<f64>().is_ok()) {
        return Err(header_err(format!(
            "the first line holds numbers, not column names; add a header row naming the \
             columns ({})",
            required.join(", ")
        )));
    }
    let mut index = Vec::new();
    for name in required {
        let i = headers
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| header_err(missing_column(name, headers, required)))?;
        index.push((name.to_string(), i));
    }
    for name in optional {
        if let Some(i) = headers.iter().position(|h| h == name) {
            index.push((name.to_string(), i));
        }
    }
    Ok(index)
}

/// Why a required column is missing, with a hint when a header looks like it in another case
/// or another unit (units are never converted silently).
fn missing_column(name: &str, headers: &[String], required: &[&str]) -> String {
    let stem = |s: &str| {
        s.rsplit_once('_')
            .map_or(s.to_string(), |(a, _)| a.to_string())
    };
    let hint = if let Some(h) = headers.iter().find(|h| h.eq_ignore_ascii_case(name)) {
        format!("; `{h}` differs only in case: rename it `{name}`")
    } else if let Some(h) = headers
        .iter()
        .find(|h| stem(h) == stem(name) && h.contains('_'))
    {
        format!(
            "; `{h}` has another unit: convert its values to the unit of `{name}` and rename \
             it (pumpcyl never guesses units)"
        )
    } else {
        String::new()
    };
    format!(
        "missing required column `{name}` (need {}; found: {}){hint}",
        required.join(", "),
        headers.join(", ")
    )
}

/// A finite number, or an error naming line and column. With decimal commas, `,` is read as
/// the decimal point.
fn parse_field(
    bytes: &[u8],
    dialect: Dialect,
    file: &str,
    line: u64,
    column: &str,
) -> Result<f64, RecordError> {
    let err = |message: String| RecordError::Value {
        file: file.to_string(),
        line,
        column: column.to_string(),
        message,
    };
    let text = std::str::from_utf8(bytes.trim_ascii()).map_err(|_| {
        err(format!(
            "`{}` is not UTF-8 text; save the file as UTF-8",
            String::from_utf8_lossy(bytes)
        ))
    })?;
    if text.is_empty() {
        return Err(err("empty field: every sample needs a value".into()));
    }
    let v: f64 = if dialect.decimal_comma {
        text.replace(',', ".").parse()
    } else {
        text.parse()
    }
    .map_err(|_| err(not_a_number(text, dialect)))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(err(format!("`{text}` is not a finite number")))
    }
}

/// Why a field is not a number, with the dialect's rules when they may be the cause.
fn not_a_number(text: &str, dialect: Dialect) -> String {
    let sep = if dialect.delimiter == b';' {
        "semicolon"
    } else {
        "tab"
    };
    match (dialect.decimal_comma, text.contains(',')) {
        (false, true) => format!(
            "`{text}` is not a number: in a comma-separated file the decimal mark is `.`; a file \
             with decimal commas must separate its fields with `;`"
        ),
        (true, _) => format!(
            "`{text}` is not a number (a {sep}-separated file: `,` is read as the decimal mark \
             and thousands separators are not allowed)"
        ),
        (false, false) => format!("`{text}` is not a number"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Record, RecordError> {
        Record::parse(text.as_bytes(), "r.csv")
    }

    /// A file of endless `byte`s (as `/dev/zero` or `/dev/urandom`), which fails a read past
    /// its first mebibyte, so a reader that goes on after the header is caught.
    struct Endless(u8);

    impl Files for Endless {
        fn open(&self, _: &Path) -> std::io::Result<Box<dyn Read + Send + '_>> {
            struct Bytes(u8, usize);
            impl Read for Bytes {
                fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                    if self.1 >= 1 << 20 {
                        return Err(std::io::Error::other("read past the first MiB"));
                    }
                    buf.fill(self.0);
                    self.1 += buf.len();
                    Ok(buf.len())
                }
            }
            Ok(Box::new(Bytes(self.0, 0)))
        }
    }

    /// A record in metres or micrometres under `_mm` names is refused, naming the column and
    /// the likely unit; the same record in mm passes, and so does a record about 0 that moves.
    #[test]
    fn positions_in_another_unit_are_refused() {
        let mm = parse("time_s,x_ref_mm,x_mm\n0,340,339.9\n0.01,345,340.2\n").unwrap();
        mm.check_units(500.0).unwrap();
        let metres = parse("time_s,x_ref_mm,x_mm\n0,0.34,0.3399\n0.01,0.345,0.3402\n").unwrap();
        let e = metres.check_units(500.0).unwrap_err().to_string();
        assert!(
            e.contains("column `x_ref_mm`") && e.contains("metres"),
            "{e}"
        );
        let um = parse("time_s,x_ref_mm,x_mm\n0,20000,19900\n0.01,25000,20200\n").unwrap();
        let e = um.check_units(500.0).unwrap_err().to_string();
        assert!(
            e.contains("column `x_ref_mm`") && e.contains("micrometres"),
            "{e}"
        );
        // only the measured column in µm
        let x_um = parse("time_s,x_ref_mm,x_mm\n0,20,19900\n0.01,25,20200\n").unwrap();
        let e = x_um.check_units(500.0).unwrap_err().to_string();
        assert!(
            e.contains("column `x_mm`") && e.contains("micrometres"),
            "{e}"
        );
        // a step of 0.5 µm at 340 mm: below what a sensor resolves
        let tiny = parse("time_s,x_ref_mm,x_mm\n0,340,340\n0.01,340.0005,340\n").unwrap();
        let e = tiny.check_units(500.0).unwrap_err().to_string();
        assert!(e.contains("resolves"), "{e}");
        // about 0, moving 5 mm: mm
        let rel = parse("time_s,x_ref_mm,x_mm\n0,0,0.1\n0.01,5,0.4\n").unwrap();
        rel.check_units(500.0).unwrap();
    }

    #[test]
    fn a_mat_record_is_refused_on_its_header_before_the_rest_is_read() {
        for byte in [0u8, 0xA5] {
            let e = Table::read_in(&Endless(byte), Path::new("r.mat"), &["time_s"], &[])
                .unwrap_err()
                .to_string();
            assert!(e.contains("not a level-5 MAT-file"), "{byte:#x}: {e}");
        }
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
    fn spreadsheet_exports_are_accepted() {
        let plain = parse("time_s,x_ref_mm,x_mm\n0,340,339.5\n0.01,345,340.25\n").unwrap();
        let variants = [
            // CRLF line ends, a byte-order mark, blank lines, a trailing delimiter
            "\u{feff}time_s,x_ref_mm,x_mm\r\n0,340,339.5\r\n\r\n0.01,345,340.25,\r\n",
            // semicolons with decimal commas, as European spreadsheets write them
            "time_s;x_ref_mm;x_mm\n0;340;339,5\n0,01;345;340,25\n",
            // tabs, quoted names, spaces around fields
            "\"time_s\"\t x_ref_mm\tx_mm\n0\t340\t339,5\n0,01\t345\t 340,25\n",
        ];
        for text in variants {
            let r = parse(text).unwrap_or_else(|e| panic!("{text:?}: {e}"));
            assert_eq!(
                (&r.time_s, &r.x_ref_mm, &r.x_mm),
                (&plain.time_s, &plain.x_ref_mm, &plain.x_mm),
                "{text:?}"
            );
        }
        let e = parse("time_s,x_ref_mm,x_mm\n0,340,\"339,5\"\n0.01,345,340\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("`;`"), "{e}");
    }

    #[test]
    fn a_duplicated_unused_column_is_harmless() {
        let r = parse("time_s,x_ref_mm,x_mm,note,note\n0,1,1,a,b\n1,1,1,c,d\n").unwrap();
        assert_eq!(r.len(), 2);
    }

    #[test]
    fn initial_state_is_the_mean_before_the_reference_changes() {
        let r =
            parse("time_s,x_ref_mm,x_mm\n0,340,339.9\n0.01,340,340.1\n0.02,345,340.2\n").unwrap();
        assert_eq!(r.first_change(), 2);
        assert!((r.initial_mean(&r.x_mm) - 340.0).abs() < 1e-12);
    }

    #[test]
    fn arrays_are_checked_like_files() {
        let t = [0.0, 0.01, 0.02];
        let r = Record::from_arrays("ds", &t, &[1.0, 2.0, 2.0], &[1.0, 1.5, 2.0]).unwrap();
        let from_text = Record::parse(b"time_s,x_ref_mm,x_mm\n0,1,1\n0.01,2,1.5\n0.02,2,2\n", "ds");
        assert_eq!(r, from_text.unwrap());
        assert_eq!(r.first_change(), 1);
        let msg = |t: &[f64], r: &[f64], x: &[f64]| {
            Record::from_arrays("ds", t, r, x).unwrap_err().to_string()
        };
        assert_eq!(
            msg(&[0.0], &[1.0], &[1.0]),
            "ds: 1 samples: a record needs at least 2 samples"
        );
        assert_eq!(
            msg(&t, &[1.0, 2.0], &[1.0, 1.0, 1.0]),
            "ds: column `x_ref_mm` has 2 samples, `time_s` has 3"
        );
        assert_eq!(
            msg(&t, &[1.0, 2.0, 2.0], &[1.0, f64::NAN, 1.0]),
            "ds: column `x_mm`, sample 1: NaN is not a finite number"
        );
        assert_eq!(
            msg(&[0.0, 0.02, 0.02], &[1.0; 3], &[1.0; 3]),
            "ds: column `time_s`, sample 2: time must strictly increase: 0.02 follows 0.02"
        );
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
