//! One series from several files: characterisation CSVs and the DRIFTLOG files transformed programs write
//! (`driftloop log merge`, `diagnose MODEL A.csv DRIFTLOG …`). Every file is read on its own (its time unit,
//! its runs, its repeated headers); the merged data keep each file's runs in file order, each from rest at
//! its own time zero, so time bases need no shifting: a run is an experiment from rest wherever it was
//! logged. Columns are matched by name (case-insensitive) after the renames; an input one file lacks is an
//! error (its rows could not be predicted), a displacement channel one file lacks is "not measured there".

use std::path::Path;

use super::{ColumnKind, Dataset};

/// Bookkeeping columns of a DRIFTLOG that are not signals: left out of the merged data.
const BOOKKEEPING: [&str; 1] = ["pass"];

/// Why files could not be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error(
        "{file}: no column `{column}`, which {other} has; every file must carry the inputs: log it, or map a column of {file} to it with --rename OLD={column}"
    )]
    MissingInput {
        file: String,
        column: String,
        other: String,
    },
    #[error("--rename {from}={to}: no file has a column `{from}`")]
    UnknownRename { from: String, to: String },
    #[error("{file}: --rename {from}={to} meets a column `{to}` the file already has")]
    RenameClash {
        file: String,
        from: String,
        to: String,
    },
    #[error("nothing to merge")]
    Empty,
}

/// The merged series and what a user should know about it.
#[derive(Debug, Clone)]
pub struct Merged {
    pub data: Dataset,
    /// Channels some files do not measure, bookkeeping columns left out.
    pub notes: Vec<String>,
}

/// A `--rename OLD=NEW` pair.
pub fn parse_rename(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        Some((a, b)) if !a.trim().is_empty() && !b.trim().is_empty() => {
            Ok((a.trim().to_ascii_lowercase(), b.trim().to_ascii_lowercase()))
        }
        _ => Err(format!("`{s}`: expected OLD=NEW, e.g. drift_z_um=ch3_um")),
    }
}

fn short(source: &str) -> String {
    Path::new(source)
        .file_name()
        .map_or_else(|| source.to_string(), |n| n.to_string_lossy().into_owned())
}

/// Merges `parts` in order; `renames` map a file's column names to the merged ones.
pub fn merge(mut parts: Vec<Dataset>, renames: &[(String, String)]) -> Result<Merged, MergeError> {
    if parts.is_empty() {
        return Err(MergeError::Empty);
    }
    for (from, to) in renames {
        if !parts.iter().any(|p| p.column(from).is_some()) {
            return Err(MergeError::UnknownRename {
                from: from.clone(),
                to: to.clone(),
            });
        }
    }
    let mut notes = Vec::new();
    for p in &mut parts {
        for (from, to) in renames {
            if p.column(from).is_none() {
                continue;
            }
            if p.column(to).is_some() {
                return Err(MergeError::RenameClash {
                    file: p.source.clone(),
                    from: from.clone(),
                    to: to.clone(),
                });
            }
            let values = p.values(from).map(<[f64]>::to_vec).unwrap_or_default();
            p.columns.retain(|c| &c.name != from);
            p.push_column(to, values);
        }
        let before = p.columns.len();
        p.columns
            .retain(|c| !BOOKKEEPING.contains(&c.name.as_str()));
        if p.columns.len() < before {
            notes.push(format!(
                "{}: the bookkeeping column `pass` is left out",
                p.source
            ));
        }
    }
    let mut names: Vec<(String, ColumnKind)> = Vec::new();
    for p in &parts {
        for c in &p.columns {
            if !names.iter().any(|(n, _)| n == &c.name) {
                names.push((c.name.clone(), c.kind));
            }
        }
    }
    for p in &parts {
        for (name, kind) in &names {
            if p.column(name).is_some() {
                continue;
            }
            if *kind == ColumnKind::Displacement {
                notes.push(format!(
                    "{}: no `{name}`: its rows count as not measured there",
                    p.source
                ));
                continue;
            }
            let other = parts
                .iter()
                .find(|q| q.column(name).is_some())
                .map_or_else(String::new, |q| q.source.clone());
            return Err(MergeError::MissingInput {
                file: p.source.clone(),
                column: name.clone(),
                other,
            });
        }
    }
    let several = parts.len() > 1;
    let source = parts
        .iter()
        .map(|p| p.source.as_str())
        .collect::<Vec<_>>()
        .join(" + ");
    let mut out = Dataset::new(source, parts[0].time_unit, Vec::new());
    out.run_starts.clear();
    let mut labels = Vec::new();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let shorts: Vec<String> = parts.iter().map(|p| short(&p.source)).collect();
    for (k, p) in parts.iter().enumerate() {
        // Two files of the same name (job1/DRIFTLOG, job2/DRIFTLOG) keep their runs apart by their paths.
        let file = if shorts.iter().filter(|s| **s == shorts[k]).count() > 1 {
            p.source.clone()
        } else {
            shorts[k].clone()
        };
        for (r, range) in p.runs().enumerate() {
            out.run_starts.push(out.time_min.len());
            labels.push(if several {
                format!("{file}:{}", p.run_label(r))
            } else {
                p.run_label(r)
            });
            out.time_min.extend_from_slice(&p.time_min[range.clone()]);
            for (col, (name, _)) in columns.iter_mut().zip(&names) {
                match p.values(name) {
                    Some(v) => col.extend_from_slice(&v[range.clone()]),
                    None => col.extend(std::iter::repeat_n(f64::NAN, range.len())),
                }
            }
        }
    }
    if out.run_starts.is_empty() {
        out.run_starts.push(0);
    }
    let labelled = several || parts.iter().any(|p| p.run_labels.is_some());
    out.run_labels = labelled.then_some(labels);
    for (values, (name, _)) in columns.into_iter().zip(&names) {
        out.push_column(name, values);
    }
    Ok(Merged { data: out, notes })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::{Require, read_bytes};

    fn read(name: &str, text: &str) -> Dataset {
        read_bytes(name, text.as_bytes(), Require::InputsOnly).unwrap()
    }

    #[test]
    fn logs_of_the_same_name_in_two_folders_keep_their_runs_apart() {
        let job = "time_min,spindle_rpm,drift_z_um,pass,run\n0,3000,0,1,0\n5,3000,1.5,1,0\n";
        let m = merge(
            vec![read("job1/DRIFTLOG", job), read("job2/DRIFTLOG", job)],
            &[],
        )
        .unwrap();
        let labels = m.data.run_labels.clone().unwrap();
        assert_eq!(labels, ["job1/DRIFTLOG:0", "job2/DRIFTLOG:0"]);
        // Written and read back, the two jobs are still two runs (not one going back in time).
        let mut bytes = Vec::new();
        m.data.write_csv(&mut bytes).unwrap();
        let back = read_bytes("merged.csv", &bytes, Require::InputsOnly).unwrap();
        assert_eq!(back.run_starts, vec![0, 2]);
    }

    #[test]
    fn a_characterisation_and_a_drift_log_become_one_series() {
        let charac = read(
            "char.csv",
            "time_s,spindle_rpm,ch3_um,t1_c\n0,0,0,20\n60,3000,1.5,20.5\n120,3000,2.5,21\n",
        );
        // Two jobs appended to one log, each with its header (a run per start timer value).
        let log = read(
            "DRIFTLOG",
            "time_min,spindle_rpm,drift_z_um,pass,run,t1_c\n0,3000,0,1,17,22\n5,3000,,2,17,22.5\n\
             time_min,spindle_rpm,drift_z_um,pass,run,t1_c\n0,0,0,1,99,23\n",
        );
        let renames = [parse_rename("drift_z_um=ch3_um").unwrap()];
        let m = merge(vec![charac, log], &renames).unwrap();
        let d = &m.data;
        assert_eq!(d.time_min, vec![0.0, 1.0, 2.0, 0.0, 5.0, 0.0]);
        assert_eq!(d.run_starts, vec![0, 3, 5]);
        assert_eq!(
            d.run_labels.as_deref().unwrap(),
            ["char.csv:1", "DRIFTLOG:17", "DRIFTLOG:99"]
        );
        let ch = d.values("ch3_um").unwrap();
        assert_eq!(&ch[..4], &[0.0, 1.5, 2.5, 0.0]);
        assert!(ch[4].is_nan() && ch[5] == 0.0);
        assert_eq!(
            d.values("t1_c").unwrap(),
            &[20.0, 20.5, 21.0, 22.0, 22.5, 23.0]
        );
        assert!(d.column("pass").is_none() && d.column("drift_z_um").is_none());
        assert!(m.notes.iter().any(|n| n.contains("pass")));
        // Written and read back, the merged series is the same.
        let mut bytes = Vec::new();
        d.write_csv(&mut bytes).unwrap();
        let back = read_bytes("merged.csv", &bytes, Require::Displacement).unwrap();
        assert_eq!(back.run_starts, d.run_starts);
        assert_eq!(back.time_min, d.time_min);
    }

    #[test]
    fn mismatches_are_named() {
        let a = read("a.csv", "time_min,spindle_rpm,z_um,t1_c\n0,0,0,20\n");
        let b = read("b.csv", "time_min,spindle_rpm,z_um\n0,0,0\n");
        let e = merge(vec![a.clone(), b.clone()], &[])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("b.csv: no column `t1_c`, which a.csv has") && e.contains("--rename"),
            "{e}"
        );
        let e = merge(vec![a.clone()], &[parse_rename("x_c=y_c").unwrap()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("no file has a column `x_c`"), "{e}");
        let e = merge(vec![a], &[parse_rename("t1_c=z_um").unwrap()])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a.csv: --rename t1_c=z_um meets a column `z_um`"),
            "{e}"
        );
        assert!(parse_rename("x").is_err() && parse_rename("=y").is_err());
    }
}
