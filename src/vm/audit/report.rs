//! The audit as a person reads it: one line per finding, `file:line: kind: message`, then a summary.

use std::fmt::Write;

use super::Audit;

impl Audit {
    /// `file` names the transformed program in the finding lines.
    pub fn human(&self, file: &str) -> String {
        let mut o = String::new();
        for f in &self.findings {
            let again = match f.times {
                1 => String::new(),
                n => format!(" ({n} times)"),
            };
            let original = f
                .original_line
                .map(|l| format!(" [original line {l}]"))
                .unwrap_or_default();
            let _ = writeln!(
                o,
                "{}:{}: {}: {}{original}{again}",
                f.file.as_deref().unwrap_or(file),
                f.line,
                f.kind.name(),
                f.message
            );
        }
        for note in &self.notes {
            let _ = writeln!(o, "note: {note}");
        }
        if let Some(stopped) = &self.stopped {
            let _ = writeln!(o, "note: {stopped}");
        }
        let counts: Vec<String> = self
            .counts
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        let _ = writeln!(
            o,
            "audit of {file}: {} finding(s){}; {} resume point(s) compared, {} abort path(s) followed ({} reached an \
             abort); {} original and {} transformed blocks executed",
            self.findings.len(),
            if counts.is_empty() {
                String::new()
            } else {
                format!(" ({})", counts.join(", "))
            },
            self.resume_points,
            self.abort_runs,
            self.aborts_reached,
            self.original_blocks,
            self.transformed_blocks
        );
        o
    }
}
