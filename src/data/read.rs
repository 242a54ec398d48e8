//! The measurement CSV reader. `csv` tokenises; this module checks every rule of design.md §3 and reports
//! violations with file, line and column, so a bad log never turns into a panic or a silent NaN.

use std::io::Read;
use std::path::Path;

use sha2::{Digest, Sha256};

use super::{ColumnKind, Dataset, TimeUnit};

/// Why a measurement file was refused. Lines and columns are 1-based; line 1 is the header.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}: empty file: a header line naming the columns is required")]
    Empty { file: String },
    #[error("{file}: {why}")]
    NotText { file: String, why: String },
    #[error("{file}:1: no time column: exactly one of time_s, time_min, time_h is required")]
    NoTime { file: String },
    #[error(
        "{file}:1:{column}: several time columns (`{first}` and `{second}`): keep exactly one of time_s, time_min, time_h"
    )]
    SeveralTimes {
        file: String,
        column: usize,
        first: String,
        second: String,
    },
    #[error("{file}:1:{column}: column `{name}` appears twice (names are case-insensitive)")]
    DuplicateColumn {
        file: String,
        column: usize,
        name: String,
    },
    #[error("{file}:1:{column}: empty column name")]
    EmptyName { file: String, column: usize },
    #[error("{file}: no displacement channel: no column name ends in `_um`")]
    NoChannel { file: String },
    #[error("{file}: no data rows after the header")]
    NoRows { file: String },
    #[error(
        "{file}:{line}: {found} fields, but the header has {expected}: every row needs one value per column (an empty cell where there is none)"
    )]
    FieldCount {
        file: String,
        line: u64,
        found: usize,
        expected: usize,
    },
    #[error("{file}:{line}:{column}: column `{name}` is empty")]
    EmptyCell {
        file: String,
        line: u64,
        column: usize,
        name: String,
    },
    #[error("{file}:{line}:{column}: column `{name}`: `{text}` is not a number")]
    NotNumber {
        file: String,
        line: u64,
        column: usize,
        name: String,
        text: String,
    },
    #[error("{file}:{line}:{column}: column `{name}`: `{text}` is not a finite number")]
    NotFinite {
        file: String,
        line: u64,
        column: usize,
        name: String,
        text: String,
    },
    #[error(
        "{file}:{line}:{column}: column `{name}`: {text} is beyond ±{largest}{unit}, more than any machine measures"
    )]
    OutOfRange {
        file: String,
        line: u64,
        column: usize,
        name: String,
        text: String,
        largest: f64,
        unit: &'static str,
    },
    #[error(
        "{file}:{line}:{column}: time goes backwards within run {run}: {time} after {previous}"
    )]
    TimeBackwards {
        file: String,
        line: u64,
        column: usize,
        run: String,
        time: f64,
        previous: f64,
    },
    #[error(
        "{file}:{line}:{column}: run `{run}` appears again after other runs; keep each run's rows together"
    )]
    RunSplit {
        file: String,
        line: u64,
        column: usize,
        run: String,
    },
    #[error("{file}:{line}: {message}")]
    Csv {
        file: String,
        line: u64,
        message: String,
    },
}

/// What a caller needs from the file beyond a time axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Require {
    /// A measurement file: at least one `*_um` channel (fit, diagnose).
    Displacement,
    /// Inputs only, e.g. a logged spindle schedule to predict for.
    InputsOnly,
}

/// Reads a measurement CSV from a file, or from stdin when `path` is `-`.
pub fn read_path(path: &Path, require: Require) -> Result<Dataset, DataError> {
    let (name, bytes) = if path.as_os_str() == "-" {
        let mut buf = Vec::new();
        std::io::stdin()
            .read_to_end(&mut buf)
            .map(|_| ("<stdin>".to_string(), buf))
    } else {
        std::fs::read(path).map(|b| (path.display().to_string(), b))
    }
    .map_err(|source| DataError::Io {
        file: path.display().to_string(),
        source,
    })?;
    read_bytes(&name, &bytes, require)
}

/// Reads a measurement CSV held in memory; `file` names it in errors.
pub fn read_bytes(file: &str, bytes: &[u8], require: Require) -> Result<Dataset, DataError> {
    let sha256 = hex(&Sha256::digest(bytes));
    let body = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let file_s = file.to_string();
    if body.iter().all(u8::is_ascii_whitespace) {
        return Err(DataError::Empty { file: file_s });
    }
    if let Some(why) = crate::text::not_text(body, crate::text::CSV) {
        return Err(DataError::NotText { file: file_s, why });
    }
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(body);
    let csv_err = |e: csv::Error| DataError::Csv {
        file: file_s.clone(),
        line: e.position().map_or(0, |p| p.line()),
        message: crate::text::csv_problem(&e),
    };
    let header: Vec<String> = reader
        .headers()
        .map_err(csv_err)?
        .iter()
        .map(str::to_ascii_lowercase)
        .collect();
    let layout = Layout::new(file, &header, require)?;

    let mut ds = Dataset::new(file, layout.time_unit, Vec::new());
    ds.sha256 = Some(sha256);
    let mut values: Vec<Vec<f64>> = vec![Vec::new(); layout.numeric.len()];
    let mut labels: Vec<String> = Vec::new();
    // Lines of each numeric column's missing input cells.
    let mut gaps: Vec<Vec<u64>> = vec![Vec::new(); layout.numeric.len()];
    let mut text_columns = std::collections::BTreeSet::new();
    let mut record = csv::StringRecord::new();
    while reader.read_record(&mut record).map_err(csv_err)? {
        let line = record.position().map_or(0, |p| p.line());
        if record.len() == 1 && record[0].is_empty() {
            continue; // a blank line
        }
        // A log the control appends to repeats the header at every program start (the NC program
        // cannot test whether the file exists): without a run column, the header starts the next run.
        if record.len() == header.len()
            && record
                .iter()
                .zip(&header)
                .all(|(a, b)| a.eq_ignore_ascii_case(b))
        {
            if layout.run.is_none() && ds.time_min.len() > *ds.run_starts.last().unwrap_or(&0) {
                ds.run_starts.push(ds.time_min.len());
            }
            continue;
        }
        if record.len() != header.len() {
            return Err(DataError::FieldCount {
                file: file_s,
                line,
                found: record.len(),
                expected: header.len(),
            });
        }
        let cell = |col: usize| Cell {
            file,
            line,
            column: col + 1,
            name: &header[col],
            text: &record[col],
        };
        let time = cell(layout.time).number()? * layout.time_unit.minutes();
        if let Some(rc) = layout.run {
            let label = cell(rc).text()?;
            if labels.last().map(String::as_str) != Some(label) {
                if labels.iter().any(|l| l == label) {
                    return Err(DataError::RunSplit {
                        file: file_s,
                        line,
                        column: rc + 1,
                        run: label.to_string(),
                    });
                }
                if !labels.is_empty() {
                    ds.run_starts.push(ds.time_min.len());
                }
                labels.push(label.to_string());
            }
        }
        let run_start = *ds.run_starts.last().unwrap_or(&0);
        if let Some(&previous) = ds.time_min.last().filter(|_| ds.time_min.len() > run_start)
            && time < previous
        {
            let unit = layout.time_unit.minutes();
            return Err(DataError::TimeBackwards {
                file: file_s,
                line,
                column: layout.time + 1,
                run: labels
                    .last()
                    .cloned()
                    .unwrap_or_else(|| ds.run_starts.len().to_string()),
                time: time / unit,
                previous: previous / unit,
            });
        }
        // A column of text among the signals (a date, an operator, a part name) is left out, decided on
        // the first row; named as a speed, drift, temperature or position it must be numbers.
        if ds.time_min.is_empty() {
            for (k, &col) in layout.numeric.iter().enumerate() {
                let c = cell(col);
                if ColumnKind::of(c.name) == ColumnKind::Signal
                    && !c.missing()
                    && c.text.parse::<f64>().is_err()
                {
                    text_columns.insert(k);
                    ds.notes.push(format!(
                        "{file}: column `{}` holds text (`{}` at line {line}), not numbers: left out",
                        c.name, c.text
                    ));
                }
            }
        }
        ds.time_min.push(time);
        for (k, ((v, &col), gaps)) in values
            .iter_mut()
            .zip(&layout.numeric)
            .zip(&mut gaps)
            .enumerate()
        {
            if text_columns.contains(&k) {
                continue;
            }
            let c = cell(col);
            // A missing cell (empty, or a logger's NaN): a displacement channel was not measured there (a
            // log row at every gate, a measurement only at some); an input is filled in below.
            v.push(if c.missing() {
                if ColumnKind::of(c.name) != ColumnKind::Displacement {
                    gaps.push(line);
                }
                f64::NAN
            } else {
                c.number()?
            });
        }
    }
    if ds.time_min.is_empty() {
        return Err(DataError::NoRows { file: file_s });
    }
    for (k, ((v, &col), lines)) in values
        .iter_mut()
        .zip(&layout.numeric)
        .zip(&gaps)
        .enumerate()
    {
        if text_columns.contains(&k) {
            continue;
        }
        if let Some(note) = fill_gaps(file, &header[col], col, v, lines)? {
            ds.notes.push(note);
        }
    }
    if layout.run.is_some() {
        ds.run_labels = Some(labels);
    }
    // Names are known unique (checked with the header): pushed as they are, not looked up one by one,
    // which a file of 100 000 columns would pay for with 5·10⁹ comparisons.
    for (k, (values, &col)) in values.into_iter().zip(&layout.numeric).enumerate() {
        if text_columns.contains(&k) {
            continue;
        }
        let name = header[col].clone();
        let kind = ColumnKind::of(&name);
        ds.columns.push(super::Column { name, kind, values });
    }
    Ok(ds)
}

/// An input (a temperature, the spindle speed …) whose logger missed a sample holds its last value until
/// the next one, as the models treat every input between two rows; before its first value it takes that
/// value. The note says how many were filled and where the first was; a column with no value at all is
/// refused.
fn fill_gaps(
    file: &str,
    name: &str,
    col: usize,
    values: &mut [f64],
    lines: &[u64],
) -> Result<Option<String>, DataError> {
    let Some(&first_line) = lines.first() else {
        return Ok(None);
    };
    let Some(first) = values.iter().copied().find(|v| !v.is_nan()) else {
        return Err(DataError::EmptyCell {
            file: file.to_string(),
            line: first_line,
            column: col + 1,
            name: name.to_string(),
        });
    };
    let mut last = first;
    for v in values.iter_mut() {
        if v.is_nan() {
            *v = last;
        } else {
            last = *v;
        }
    }
    let count = lines.len();
    Ok(Some(format!(
        "{file}: column `{name}`: {count} missing value{} (the first at line {first_line}) filled with the value before {}",
        if count == 1 { "" } else { "s" },
        if count == 1 { "it" } else { "each" },
    )))
}

/// Where the time, run and numeric columns are.
struct Layout {
    time: usize,
    time_unit: TimeUnit,
    run: Option<usize>,
    numeric: Vec<usize>,
}

impl Layout {
    fn new(file: &str, header: &[String], require: Require) -> Result<Layout, DataError> {
        let file_s = || file.to_string();
        let mut time: Option<(usize, TimeUnit)> = None;
        let mut run = None;
        let mut numeric = Vec::new();
        // Names seen so far: a header of many thousand columns is checked in linear time.
        let mut seen = std::collections::HashSet::with_capacity(header.len());
        for (i, name) in header.iter().enumerate() {
            if name.is_empty() {
                return Err(DataError::EmptyName {
                    file: file_s(),
                    column: i + 1,
                });
            }
            if !seen.insert(name) {
                return Err(DataError::DuplicateColumn {
                    file: file_s(),
                    column: i + 1,
                    name: name.clone(),
                });
            }
            if let Some(unit) = TimeUnit::from_column_name(name) {
                if let Some((first, _)) = time {
                    return Err(DataError::SeveralTimes {
                        file: file_s(),
                        column: i + 1,
                        first: header[first].clone(),
                        second: name.clone(),
                    });
                }
                time = Some((i, unit));
            } else if name == "run" {
                run = Some(i);
            } else {
                numeric.push(i);
            }
        }
        let (time, time_unit) = time.ok_or(DataError::NoTime { file: file_s() })?;
        let has_channel = numeric
            .iter()
            .any(|&i| ColumnKind::of(&header[i]) == ColumnKind::Displacement);
        if require == Require::Displacement && !has_channel {
            return Err(DataError::NoChannel { file: file_s() });
        }
        Ok(Layout {
            time,
            time_unit,
            run,
            numeric,
        })
    }
}

struct Cell<'a> {
    file: &'a str,
    line: u64,
    column: usize,
    name: &'a str,
    text: &'a str,
}

impl<'a> Cell<'a> {
    /// An empty cell, or the text loggers and spreadsheets write for a missing sample.
    fn missing(&self) -> bool {
        self.text.is_empty()
            || ["nan", "na", "n/a", "null"]
                .iter()
                .any(|m| self.text.eq_ignore_ascii_case(m))
    }

    fn text(&self) -> Result<&'a str, DataError> {
        if self.text.is_empty() {
            return Err(DataError::EmptyCell {
                file: self.file.to_string(),
                line: self.line,
                column: self.column,
                name: self.name.to_string(),
            });
        }
        Ok(self.text)
    }

    fn number(&self) -> Result<f64, DataError> {
        let text = self.text()?;
        let v: f64 = text.parse().map_err(|_| DataError::NotNumber {
            file: self.file.to_string(),
            line: self.line,
            column: self.column,
            name: self.name.to_string(),
            text: text.to_string(),
        })?;
        if !v.is_finite() {
            return Err(DataError::NotFinite {
                file: self.file.to_string(),
                line: self.line,
                column: self.column,
                name: self.name.to_string(),
                text: text.to_string(),
            });
        }
        let (largest, unit) = largest(self.name);
        if v.abs() > largest {
            return Err(DataError::OutOfRange {
                file: self.file.to_string(),
                line: self.line,
                column: self.column,
                name: self.name.to_string(),
                text: text.to_string(),
                largest,
                unit,
            });
        }
        Ok(v)
    }
}

/// The largest magnitude a column of this name may hold, and its unit: a speed or a drift beyond it is a
/// unit or typing error, and would only make the fits ill-conditioned (an SVD of 1e200 rpm does not end).
fn largest(name: &str) -> (f64, &'static str) {
    match ColumnKind::of(name) {
        ColumnKind::Spindle => (super::FASTEST_RPM, " rpm"),
        ColumnKind::Displacement => (super::LARGEST_UM, " µm"),
        _ => (1e9, ""),
    }
}

/// Lower-case hex of a digest.
pub(crate) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
