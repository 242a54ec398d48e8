//! Reading positioning measurements from CSV (long format, one approach per row).
//!
//! Columns (header required, names case-insensitive, order free, other columns ignored):
//! `axis`, `target_mm`, `direction` (`+`/`-`, also `up`/`down`, `pos`/`neg`, `↑`/`↓`), `deviation_um`
//! (measured minus target, µm) and optionally `run` (an integer; a run may appear only once per axis, target and
//! direction).

use std::io::Read;

use thiserror::Error;

/// Approach direction at a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Plus,
    Minus,
}

/// The repeated deviations measured at one target, per direction, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetSamples {
    pub target_mm: f64,
    pub plus_um: Vec<f64>,
    pub minus_um: Vec<f64>,
}

/// All targets of one axis, sorted by position.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSamples {
    pub axis: String,
    pub targets: Vec<TargetSamples>,
}

/// A problem in the input, located by file, line and (where it is about one field) column.
#[derive(Debug, Error)]
#[error("{file}:{line}{}: {message}", column.as_ref().map(|(n, name)| format!(":{n} ({name})")).unwrap_or_default())]
pub struct InputError {
    pub file: String,
    pub line: u64,
    /// 1-based column number and the column's header name.
    pub column: Option<(usize, String)>,
    pub message: String,
}

const REQUIRED: [&str; 4] = ["axis", "target_mm", "direction", "deviation_um"];

struct Columns {
    axis: usize,
    target: usize,
    direction: usize,
    deviation: usize,
    run: Option<usize>,
}

/// One parsed row, kept with its line for later group-level errors.
struct Row {
    line: u64,
    axis: String,
    target_mm: f64,
    direction: Direction,
    run: Option<i64>,
    deviation_um: f64,
}

/// Reads and validates the whole file; every direction of every target must have at least `min_runs` values.
pub fn read_samples<R: Read>(
    reader: R,
    file: &str,
    min_runs: usize,
) -> Result<Vec<AxisSamples>, InputError> {
    let mut csv = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(false)
        .trim(csv::Trim::All)
        .from_reader(reader);
    let error = |line: u64, column: Option<(usize, String)>, message: String| InputError {
        file: file.to_string(),
        line,
        column,
        message,
    };
    let headers = csv
        .headers()
        .map_err(|e| {
            let why = crate::text::csv_problem(&e);
            error(1, None, format!("cannot read the header: {why}"))
        })?
        .clone();
    if headers.is_empty() || headers.iter().all(str::is_empty) {
        return Err(error(
            1,
            None,
            "empty file: expected a header with axis,target_mm,direction,deviation_um".into(),
        ));
    }
    let names: Vec<String> = headers
        .iter()
        .map(|h| h.trim_start_matches('\u{feff}').to_ascii_lowercase())
        .collect();
    for (i, name) in names.iter().enumerate() {
        if let Some(j) = names[..i].iter().position(|other| other == name) {
            return Err(error(
                1,
                Some((i + 1, name.clone())),
                format!("column `{name}` repeats column {}", j + 1),
            ));
        }
    }
    let find = |name: &str| names.iter().position(|n| n == name);
    let missing: Vec<&str> = REQUIRED
        .iter()
        .copied()
        .filter(|name| find(name).is_none())
        .collect();
    if !missing.is_empty() {
        return Err(error(
            1,
            None,
            format!(
                "missing column(s) {}; the header needs axis,target_mm,direction,deviation_um (run optional)",
                missing.join(", ")
            ),
        ));
    }
    let columns = Columns {
        axis: find("axis").unwrap_or_default(),
        target: find("target_mm").unwrap_or_default(),
        direction: find("direction").unwrap_or_default(),
        deviation: find("deviation_um").unwrap_or_default(),
        run: find("run"),
    };

    let mut rows = Vec::new();
    for record in csv.records() {
        let record = record.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            error(line, None, crate::text::csv_problem(&e))
        })?;
        let line = record.position().map_or(0, |p| p.line());
        if record.iter().all(str::is_empty) {
            continue;
        }
        let field = |index: usize| {
            (
                record.get(index).unwrap_or(""),
                Some((index + 1, names[index].clone())),
            )
        };
        // A figure beyond a metre (a million mm or µm) is a unit or typing error: refused, not tabulated.
        let number = |index: usize, what: &str| -> Result<f64, InputError> {
            let (text, column) = field(index);
            match text.parse::<f64>() {
                Ok(value) if value.abs() <= 1e6 => Ok(value),
                Ok(value) if value.is_finite() => Err(error(
                    line,
                    column,
                    format!("expected {what} within ±1e6, found `{text}`"),
                )),
                _ => Err(error(
                    line,
                    column,
                    format!("expected {what}, found `{text}`"),
                )),
            }
        };
        let (axis, axis_column) = field(columns.axis);
        if axis.is_empty() {
            return Err(error(line, axis_column, "the axis name is empty".into()));
        }
        let (direction_text, direction_column) = field(columns.direction);
        let direction = parse_direction(direction_text).ok_or_else(|| {
            error(
                line,
                direction_column,
                format!("expected a direction `+` or `-`, found `{direction_text}`"),
            )
        })?;
        let run = match columns.run {
            None => None,
            Some(index) => {
                let (text, column) = field(index);
                Some(text.parse::<i64>().map_err(|_| {
                    error(
                        line,
                        column,
                        format!("expected a run number, found `{text}`"),
                    )
                })?)
            }
        };
        rows.push(Row {
            line,
            axis: axis.to_string(),
            target_mm: number(columns.target, "a target position in mm")?,
            direction,
            run,
            deviation_um: number(columns.deviation, "a deviation in µm")?,
        });
    }
    if rows.is_empty() {
        return Err(error(1, None, "no measurements below the header".into()));
    }
    group(rows, file, min_runs)
}

fn parse_direction(text: &str) -> Option<Direction> {
    match text.to_ascii_lowercase().as_str() {
        "+" | "up" | "pos" | "plus" | "positive" | "↑" => Some(Direction::Plus),
        "-" | "−" | "down" | "neg" | "minus" | "negative" | "↓" => Some(Direction::Minus),
        _ => None,
    }
}

/// Two targets closer than this (mm) are the same target written with different rounding.
const SAME_TARGET_MM: f64 = 1e-9;

fn group(rows: Vec<Row>, file: &str, min_runs: usize) -> Result<Vec<AxisSamples>, InputError> {
    struct Group {
        first_line: u64,
        target_mm: f64,
        plus: Vec<(Option<i64>, f64, u64)>,
        minus: Vec<(Option<i64>, f64, u64)>,
    }
    let mut axes: Vec<(String, Vec<Group>)> = Vec::new();
    for row in rows {
        let axis_index = match axes.iter().position(|(name, _)| *name == row.axis) {
            Some(i) => i,
            None => {
                axes.push((row.axis.clone(), Vec::new()));
                axes.len() - 1
            }
        };
        let groups = &mut axes[axis_index].1;
        let group_index = match groups
            .iter()
            .position(|g| (g.target_mm - row.target_mm).abs() < SAME_TARGET_MM)
        {
            Some(i) => i,
            None => {
                groups.push(Group {
                    first_line: row.line,
                    target_mm: row.target_mm,
                    plus: Vec::new(),
                    minus: Vec::new(),
                });
                groups.len() - 1
            }
        };
        let group = &mut groups[group_index];
        let samples = match row.direction {
            Direction::Plus => &mut group.plus,
            Direction::Minus => &mut group.minus,
        };
        if let Some(run) = row.run
            && let Some(&(_, _, earlier)) = samples.iter().find(|(r, _, _)| *r == Some(run))
        {
            return Err(InputError {
                file: file.to_string(),
                line: row.line,
                column: None,
                message: format!(
                    "axis {} target {} mm direction {}: run {run} already given on line {earlier}",
                    row.axis,
                    row.target_mm,
                    direction_sign(row.direction)
                ),
            });
        }
        samples.push((row.run, row.deviation_um, row.line));
    }

    let mut result = Vec::new();
    for (axis, mut groups) in axes {
        groups.sort_by(|a, b| a.target_mm.total_cmp(&b.target_mm));
        for group in &groups {
            for (direction, samples) in [
                (Direction::Plus, &group.plus),
                (Direction::Minus, &group.minus),
            ] {
                if samples.len() < min_runs {
                    return Err(InputError {
                        file: file.to_string(),
                        line: group.first_line,
                        column: None,
                        message: format!(
                            "axis {axis} target {} mm direction {}: {} value(s), at least {min_runs} approaches per direction are needed",
                            group.target_mm,
                            direction_sign(direction),
                            samples.len()
                        ),
                    });
                }
            }
        }
        if groups.len() < 2 {
            return Err(InputError {
                file: file.to_string(),
                line: groups[0].first_line,
                column: None,
                message: format!(
                    "axis {axis}: only one target position; at least two are needed for a correction curve"
                ),
            });
        }
        let targets = groups
            .into_iter()
            .map(|g| TargetSamples {
                target_mm: g.target_mm,
                plus_um: g.plus.into_iter().map(|(_, v, _)| v).collect(),
                minus_um: g.minus.into_iter().map(|(_, v, _)| v).collect(),
            })
            .collect();
        result.push(AxisSamples { axis, targets });
    }
    Ok(result)
}

fn direction_sign(direction: Direction) -> char {
    match direction {
        Direction::Plus => '+',
        Direction::Minus => '-',
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Vec<AxisSamples>, InputError> {
        read_samples(text.as_bytes(), "t.csv", 5)
    }

    fn rows(axis: &str, target: f64, dir: &str, values: &[f64]) -> String {
        values
            .iter()
            .enumerate()
            .map(|(i, v)| format!("{axis},{target},{dir},{},{v}\n", i + 1))
            .collect()
    }

    fn two_targets() -> String {
        let mut text = String::from("Axis,Target_mm,Direction,Run,Deviation_um\n");
        for target in [0.0, 50.0] {
            text += &rows("X", target, "+", &[4.0, 11.0, 11.0, 12.0, 7.0]);
            text += &rows("X", target, "-", &[-9.0, -10.0, -11.0, -7.0, -7.0]);
        }
        text
    }

    #[test]
    fn reads_long_format_with_any_header_case() {
        let axes = read(&two_targets()).unwrap();
        assert_eq!(axes.len(), 1);
        assert_eq!(axes[0].axis, "X");
        assert_eq!(axes[0].targets.len(), 2);
        assert_eq!(axes[0].targets[1].target_mm, 50.0);
        assert_eq!(axes[0].targets[1].plus_um, vec![4.0, 11.0, 11.0, 12.0, 7.0]);
        assert_eq!(
            axes[0].targets[1].minus_um,
            vec![-9.0, -10.0, -11.0, -7.0, -7.0]
        );
    }

    #[test]
    fn text_in_a_number_names_line_and_column() {
        let text = two_targets().replacen("X,0,+,3,11", "X,0,+,3,eleven", 1);
        let err = read(&text).unwrap_err().to_string();
        assert_eq!(
            err,
            "t.csv:4:5 (deviation_um): expected a deviation in µm, found `eleven`"
        );
    }

    #[test]
    fn nan_is_not_a_measurement() {
        let text = two_targets().replacen("X,0,+,3,11", "X,0,+,3,NaN", 1);
        assert!(
            read(&text)
                .unwrap_err()
                .to_string()
                .starts_with("t.csv:4:5 (deviation_um)")
        );
    }

    #[test]
    fn unknown_direction_is_an_error() {
        let text = two_targets().replacen("X,0,+,1,", "X,0,left,1,", 1);
        let err = read(&text).unwrap_err().to_string();
        assert_eq!(
            err,
            "t.csv:2:3 (direction): expected a direction `+` or `-`, found `left`"
        );
    }

    #[test]
    fn fewer_than_five_approaches_is_a_clear_error() {
        let text: String = two_targets()
            .lines()
            .filter(|l| !l.starts_with("X,50,-,5,"))
            .map(|l| format!("{l}\n"))
            .collect();
        let err = read(&text).unwrap_err().to_string();
        assert!(
            err.contains("axis X target 50 mm direction -: 4 value(s), at least 5"),
            "{err}"
        );
    }

    #[test]
    fn missing_columns_and_empty_files_are_errors() {
        let err = read("axis,target_mm,deviation_um\nX,0,1\n")
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing column(s) direction"), "{err}");
        assert!(read("").unwrap_err().to_string().contains("empty file"));
        assert!(
            read("axis,target_mm,direction,deviation_um\n")
                .unwrap_err()
                .to_string()
                .contains("no measurements")
        );
    }

    #[test]
    fn a_row_with_a_missing_field_names_its_line() {
        let text = two_targets().replacen("X,0,+,4,12\n", "X,0,+,4\n", 1);
        let err = read(&text).unwrap_err().to_string();
        assert!(
            err.starts_with("t.csv:5: 4 fields, but the rows before have 5"),
            "{err}"
        );
    }

    #[test]
    fn repeated_run_is_an_error() {
        let text = two_targets().replacen("X,0,+,2,", "X,0,+,1,", 1);
        let err = read(&text).unwrap_err().to_string();
        assert_eq!(
            err,
            "t.csv:3: axis X target 0 mm direction +: run 1 already given on line 2"
        );
    }

    #[test]
    fn a_single_target_is_not_enough_for_a_curve() {
        let mut text = String::from("axis,target_mm,direction,deviation_um\n");
        for dir in ["up", "down"] {
            text += &format!("Y,10,{dir},1\n").repeat(5);
        }
        let err = read(&text).unwrap_err().to_string();
        assert_eq!(
            err,
            "t.csv:2: axis Y: only one target position; at least two are needed for a correction curve"
        );
    }
}
