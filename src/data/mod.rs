//! Measurement data (design.md §3): a time axis normalised to minutes, run boundaries, and named numeric
//! columns classified by their suffix. Read from CSV by [`read_path`] / [`read_bytes`], written back by
//! [`Dataset::write_csv`].

mod duration;
pub mod merge;
mod read;
mod write;

pub use duration::Minutes;
pub use read::{DataError, Require, read_bytes, read_path};

use std::ops::Range;

/// The unit the time column of a data file was given in; kept so outputs use the same unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeUnit {
    S,
    Min,
    H,
}

impl TimeUnit {
    /// Minutes per one unit.
    pub fn minutes(self) -> f64 {
        match self {
            TimeUnit::S => 1.0 / 60.0,
            TimeUnit::Min => 1.0,
            TimeUnit::H => 60.0,
        }
    }

    /// The column name that carries this unit (`time_s`, `time_min`, `time_h`).
    pub fn column_name(self) -> &'static str {
        match self {
            TimeUnit::S => "time_s",
            TimeUnit::Min => "time_min",
            TimeUnit::H => "time_h",
        }
    }

    fn from_column_name(name: &str) -> Option<TimeUnit> {
        [TimeUnit::S, TimeUnit::Min, TimeUnit::H]
            .into_iter()
            .find(|u| u.column_name() == name)
    }

    /// Converts minutes to this unit.
    pub fn from_minutes(self, minutes: f64) -> f64 {
        minutes / self.minutes()
    }
}

/// What a column holds, from its name (design.md §3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnKind {
    /// `spindle_rpm`: speed held from its row on.
    Spindle,
    /// `*_um`: a displacement channel. NaN (an empty cell in the file) marks a row where the channel was not
    /// measured: the row still carries its time and inputs, which hold from it until the next row.
    Displacement,
    /// `*_c`: a temperature.
    Temperature,
    /// `*_mm`: an axis position.
    Position,
    /// Any other numeric column: a candidate signal for diagnosis.
    Signal,
}

impl ColumnKind {
    fn of(name: &str) -> ColumnKind {
        if name == SPINDLE {
            ColumnKind::Spindle
        } else if name.ends_with("_um") {
            ColumnKind::Displacement
        } else if name.ends_with("_c") {
            ColumnKind::Temperature
        } else if name.ends_with("_mm") {
            ColumnKind::Position
        } else {
            ColumnKind::Signal
        }
    }
}

/// Which rows of a displacement channel carry a reading (NaN, an empty cell in the file: not measured).
pub fn measured(values: &[f64]) -> Vec<bool> {
    values.iter().map(|v| !v.is_nan()).collect()
}

/// Most rows driftloop makes for one series (a schedule sampled by `predict --step`, a simulated log):
/// ten million, some 80 MB a column. Asking for more is refused with this limit named, rather than
/// allocating without bound.
pub const MOST_ROWS: f64 = 1e7;

/// Fastest spindle speed a log or a model may carry (rpm).
pub const FASTEST_RPM: f64 = 1e6;
/// Largest drift figure (reading, gain, offset, amplitude) a log, model or profile may carry (µm): one metre.
pub const LARGEST_UM: f64 = 1e6;

/// Refuses a series of `rows` rows beyond [`MOST_ROWS`]; `how` says what asked for it and how to ask for
/// fewer.
pub fn check_rows(rows: f64, how: &str) -> Result<(), String> {
    if rows.is_finite() && rows <= MOST_ROWS {
        Ok(())
    } else {
        Err(format!(
            "{how} makes {rows:.3e} rows, more than the {MOST_ROWS:.0} driftloop makes for one series"
        ))
    }
}

/// Name of the spindle speed column.
pub const SPINDLE: &str = "spindle_rpm";

/// One numeric column, name lower-cased.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    pub name: String,
    pub kind: ColumnKind,
    pub values: Vec<f64>,
}

/// A measurement series: rows sorted in time within each run.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Where the data came from (file name), for messages.
    pub source: String,
    /// Unit of the time column in the source; `time_min` holds the values in minutes.
    pub time_unit: TimeUnit,
    /// Time of every row in minutes, from the file (not shifted to zero per run).
    pub time_min: Vec<f64>,
    /// Label of each run (the `run` column's text), one per run; `None` when the file has no `run` column.
    pub run_labels: Option<Vec<String>>,
    /// First row of each run, ascending, starting with 0; a file without `run` is one run.
    pub run_starts: Vec<usize>,
    /// Every numeric column other than time and run, in file order.
    pub columns: Vec<Column>,
    /// SHA-256 (hex) of the file the data were read from; `None` for generated data.
    pub sha256: Option<String>,
    /// What the reader did that the user should know (missing input samples filled in).
    pub notes: Vec<String>,
}

impl Dataset {
    /// A dataset with a time axis only; add columns with [`Dataset::push_column`].
    pub fn new(source: impl Into<String>, time_unit: TimeUnit, time_min: Vec<f64>) -> Dataset {
        Dataset {
            source: source.into(),
            time_unit,
            time_min,
            run_labels: None,
            run_starts: vec![0],
            columns: Vec::new(),
            sha256: None,
            notes: Vec::new(),
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.time_min.len()
    }

    pub fn is_empty(&self) -> bool {
        self.time_min.is_empty()
    }

    /// Adds (or replaces) a column; its kind follows from the (lower-cased) name.
    ///
    /// # Panics
    /// If `values` does not have one value per row (a programming error, not a data error).
    pub fn push_column(&mut self, name: &str, values: Vec<f64>) {
        assert_eq!(values.len(), self.len(), "column `{name}` length");
        let name = name.to_ascii_lowercase();
        let kind = ColumnKind::of(&name);
        match self.columns.iter_mut().find(|c| c.name == name) {
            Some(c) => c.values = values,
            None => self.columns.push(Column { name, kind, values }),
        }
    }

    /// The column of that name (case-insensitive).
    pub fn column(&self, name: &str) -> Option<&Column> {
        let name = name.to_ascii_lowercase();
        self.columns.iter().find(|c| c.name == name)
    }

    /// Values of a column (case-insensitive name).
    pub fn values(&self, name: &str) -> Option<&[f64]> {
        self.column(name).map(|c| c.values.as_slice())
    }

    /// The displacement channels (`*_um`).
    pub fn channels(&self) -> impl Iterator<Item = &Column> {
        self.columns
            .iter()
            .filter(|c| c.kind == ColumnKind::Displacement)
    }

    /// Columns a model declaring `declared` inputs does not use: candidate signals for diagnosis
    /// (temperatures, positions, other numeric columns; never displacement channels).
    pub fn candidate_signals<'a>(
        &'a self,
        declared: &'a [String],
    ) -> impl Iterator<Item = &'a Column> {
        self.columns.iter().filter(move |c| {
            c.kind != ColumnKind::Displacement
                && !declared.iter().any(|d| d.eq_ignore_ascii_case(&c.name))
        })
    }

    /// Row ranges of the runs.
    pub fn runs(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        let n = self.len();
        self.run_starts
            .iter()
            .enumerate()
            .map(move |(i, &s)| s..self.run_starts.get(i + 1).copied().unwrap_or(n))
    }

    /// Label of run `i` for reports: the `run` column's text, or its 1-based number.
    pub fn run_label(&self, i: usize) -> String {
        match &self.run_labels {
            Some(l) => l[i].clone(),
            None => (i + 1).to_string(),
        }
    }

    /// Smallest positive time step within any run, in minutes.
    pub fn min_step_min(&self) -> Option<f64> {
        self.runs()
            .flat_map(|r| {
                self.time_min[r]
                    .windows(2)
                    .map(|w| w[1] - w[0])
                    .collect::<Vec<_>>()
            })
            .filter(|d| *d > 0.0)
            .min_by(f64::total_cmp)
    }

    /// Longest run duration in minutes.
    pub fn longest_run_min(&self) -> f64 {
        self.runs()
            .filter(|r| !r.is_empty())
            .map(|r| self.time_min[r.end - 1] - self.time_min[r.start])
            .fold(0.0, f64::max)
    }

    /// The rows whose time (in minutes) is before `until_min`; runs that start later are dropped.
    pub fn until(&self, until_min: f64) -> Dataset {
        self.rows_where(|i| self.time_min[i] < until_min)
    }

    /// [`Dataset::until`] when a time is given, the whole data set (not copied) otherwise.
    pub fn until_opt(&self, until_min: Option<f64>) -> std::borrow::Cow<'_, Dataset> {
        match until_min {
            Some(u) => std::borrow::Cow::Owned(self.until(u)),
            None => std::borrow::Cow::Borrowed(self),
        }
    }

    /// The rows `keep` accepts (by index), in their runs; runs left without a row are dropped.
    pub fn rows_where(&self, keep: impl Fn(usize) -> bool) -> Dataset {
        let mut out = Dataset::new(self.source.clone(), self.time_unit, Vec::new());
        out.run_starts.clear();
        let mut labels = Vec::new();
        let mut cols: Vec<Vec<f64>> = vec![Vec::new(); self.columns.len()];
        for (ri, range) in self.runs().enumerate() {
            let mut started = false;
            for i in range {
                if !keep(i) {
                    continue;
                }
                if !started {
                    out.run_starts.push(out.time_min.len());
                    labels.push(self.run_label(ri));
                    started = true;
                }
                out.time_min.push(self.time_min[i]);
                for (c, col) in cols.iter_mut().zip(&self.columns) {
                    c.push(col.values[i]);
                }
            }
        }
        if out.run_starts.is_empty() {
            out.run_starts.push(0);
        }
        out.run_labels = self.run_labels.as_ref().map(|_| labels);
        out.sha256 = self.sha256.clone();
        out.columns = self
            .columns
            .iter()
            .zip(cols)
            .map(|(c, values)| Column {
                name: c.name.clone(),
                kind: c.kind,
                values,
            })
            .collect();
        out
    }
}
