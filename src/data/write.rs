//! Writes a [`Dataset`] back as a measurement CSV that [`super::read_bytes`] reads to the same values.

use std::io::Write;

use super::Dataset;

impl Dataset {
    /// Writes the header (time in the dataset's own unit, `run` when the data have runs, then every column)
    /// and one line per row. Numbers use the shortest text that reads back to the same `f64`.
    pub fn write_csv<W: Write>(&self, out: W) -> std::io::Result<()> {
        let mut w = csv::Writer::from_writer(out);
        let mut header = vec![self.time_unit.column_name().to_string()];
        if self.run_labels.is_some() {
            header.push("run".into());
        }
        header.extend(self.columns.iter().map(|c| c.name.clone()));
        w.write_record(&header)?;
        let mut row: Vec<String> = Vec::with_capacity(header.len());
        for (run, range) in self.runs().enumerate() {
            for i in range {
                row.clear();
                // Minutes → unit can leave a last-bit error (7 s → 0.1166… min → 7.000000000000001 s).
                let t = self.time_unit.from_minutes(self.time_min[i]);
                row.push(format_number((t * 1e9).round() / 1e9));
                if self.run_labels.is_some() {
                    row.push(self.run_label(run));
                }
                row.extend(self.columns.iter().map(|c| format_number(c.values[i])));
                w.write_record(&row)?;
            }
        }
        w.flush()
    }
}

/// Shortest round-trip text of a number; whole numbers without a trailing `.0`; NaN (a displacement not
/// measured at that row) as the empty cell the reader takes it from.
pub(crate) fn format_number(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else if v == v.trunc() && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}
