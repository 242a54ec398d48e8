//! The measurement CSV reader: accepted layouts and every refusal, with file, line and column.

use driftloop::data::{ColumnKind, DataError, Require, TimeUnit, read_bytes};

fn read(text: &str) -> Result<driftloop::data::Dataset, DataError> {
    read_bytes("log.csv", text.as_bytes(), Require::Displacement)
}

fn error(text: &str) -> String {
    read(text).unwrap_err().to_string()
}

#[test]
fn reads_any_column_order_and_case_with_runs_and_units() {
    let ds = read("Run,Ambient_C,TIME_H,Spindle_RPM,x_mm,Z_um,flow\nA,20,0,1000,1,0.5,3\nA,20.5,0.5,0,1,0.7,3\nB,21,0,2000,2,0.1,3\n")
        .unwrap();
    assert_eq!(ds.time_unit, TimeUnit::H);
    assert_eq!(ds.time_min, vec![0.0, 30.0, 0.0]);
    assert_eq!(ds.run_starts, vec![0, 2]);
    assert_eq!(ds.run_labels, Some(vec!["A".to_string(), "B".to_string()]));
    let kinds: Vec<_> = ds
        .columns
        .iter()
        .map(|c| (c.name.as_str(), c.kind))
        .collect();
    assert_eq!(
        kinds,
        vec![
            ("ambient_c", ColumnKind::Temperature),
            ("spindle_rpm", ColumnKind::Spindle),
            ("x_mm", ColumnKind::Position),
            ("z_um", ColumnKind::Displacement),
            ("flow", ColumnKind::Signal),
        ]
    );
    assert_eq!(ds.values("Z_UM").unwrap(), &[0.5, 0.7, 0.1]);
    let declared = vec!["spindle_rpm".to_string()];
    let candidates: Vec<_> = ds
        .candidate_signals(&declared)
        .map(|c| c.name.as_str())
        .collect();
    assert_eq!(candidates, vec!["ambient_c", "x_mm", "flow"]);
    assert_eq!(ds.sha256.as_deref().map(str::len), Some(64));
}

#[test]
fn irregular_sampling_bom_crlf_and_round_trip() {
    let text =
        "\u{feff}time_s,spindle_rpm,z_um\r\n0,0,0\r\n7,3000,0.25\r\n607,3000,1.5\r\n1807.5,0,2\r\n";
    let ds = read(text).unwrap();
    assert_eq!(
        ds.time_min,
        vec![0.0, 7.0 / 60.0, 607.0 / 60.0, 1807.5 / 60.0]
    );
    assert_eq!(ds.min_step_min(), Some(7.0 / 60.0));
    let mut out = Vec::new();
    ds.write_csv(&mut out).unwrap();
    assert_eq!(
        String::from_utf8(out.clone()).unwrap(),
        "time_s,spindle_rpm,z_um\n0,0,0\n7,3000,0.25\n607,3000,1.5\n1807.5,0,2\n"
    );
    let again = read_bytes("again.csv", &out, Require::Displacement).unwrap();
    assert_eq!(again.columns, ds.columns);
}

#[test]
fn refuses_missing_or_several_time_columns() {
    assert_eq!(
        error("t,z_um\n0,1\n"),
        "log.csv:1: no time column: exactly one of time_s, time_min, time_h is required"
    );
    assert_eq!(
        error("time_s,z_um,time_min\n0,1,0\n"),
        "log.csv:1:3: several time columns (`time_s` and `time_min`): keep exactly one of time_s, time_min, time_h"
    );
}

#[test]
fn refuses_bad_cells_naming_line_and_column() {
    assert_eq!(
        error("time_s,spindle_rpm,z_um\n0,0,0\n15,3000,abc\n"),
        "log.csv:3:3: column `z_um`: `abc` is not a number"
    );
    assert_eq!(
        error("time_s,spindle_rpm,z_um\n0,,0\n15,,1\n"),
        "log.csv:2:2: column `spindle_rpm` is empty"
    );
    assert_eq!(
        error("time_s,spindle_rpm,z_um\nNaN,0,0\n"),
        "log.csv:2:1: column `time_s`: `NaN` is not a finite number"
    );
    assert_eq!(
        error("time_s,spindle_rpm,z_um\n0,0,inf\n"),
        "log.csv:2:3: column `z_um`: `inf` is not a finite number"
    );
    assert_eq!(
        error("time_s,spindle_rpm,z_um\n0,0,0\n15,0\n"),
        "log.csv:3: 2 fields, but the header has 3: every row needs one value per column (an empty cell where there is none)"
    );
}

#[test]
fn refuses_time_going_backwards_within_a_run_but_not_across_runs() {
    assert_eq!(
        error("time_min,z_um\n0,0\n10,1\n5,2\n"),
        "log.csv:4:1: time goes backwards within run 1: 5 after 10"
    );
    assert_eq!(
        error("run,time_min,z_um\na,0,0\na,10,1\nb,0,0\nb,5,1\nb,4,1\n"),
        "log.csv:6:2: time goes backwards within run b: 4 after 5"
    );
    assert_eq!(
        error("run,time_min,z_um\na,0,0\nb,0,0\na,5,1\n"),
        "log.csv:4:1: run `a` appears again after other runs; keep each run's rows together"
    );
    assert!(read("run,time_min,z_um\na,0,0\na,10,1\nb,0,0\n").is_ok());
}

#[test]
fn refuses_empty_files_and_files_without_channels() {
    assert_eq!(
        error(""),
        "log.csv: empty file: a header line naming the columns is required"
    );
    assert_eq!(
        error("\n\n"),
        "log.csv: empty file: a header line naming the columns is required"
    );
    assert_eq!(
        error("time_s,z_um\n"),
        "log.csv: no data rows after the header"
    );
    assert_eq!(
        error("time_s,spindle_rpm,t1_c\n0,0,20\n"),
        "log.csv: no displacement channel: no column name ends in `_um`"
    );
    assert!(read_bytes("s.csv", b"time_s,spindle_rpm\n0,0\n", Require::InputsOnly).is_ok());
    assert_eq!(
        error("time_s,Z_um,z_UM\n0,1,1\n"),
        "log.csv:1:3: column `z_um` appears twice (names are case-insensitive)"
    );
}

#[test]
fn fit_window_keeps_whole_runs_before_the_cut() {
    let ds = read("run,time_min,z_um\na,0,0\na,10,1\na,20,2\nb,0,0\nb,30,1\n").unwrap();
    let w = ds.until(15.0);
    assert_eq!(w.time_min, vec![0.0, 10.0, 0.0]);
    assert_eq!(w.run_starts, vec![0, 2]);
    assert_eq!(w.values("z_um").unwrap(), &[0.0, 1.0, 0.0]);
    assert_eq!(w.sha256, ds.sha256);
}

#[test]
fn a_repeated_header_is_skipped_and_starts_a_run_when_there_is_no_run_column() {
    // The log a transformed program appends to: its header again at every program start.
    let ds = read("time_min,spindle_rpm,z_um\n0,0,0\n50,3000,4\nTIME_MIN, spindle_rpm ,z_um\n0,0,1\n20,3000,3\n")
        .unwrap();
    assert_eq!(ds.time_min, [0.0, 50.0, 0.0, 20.0]);
    assert_eq!(ds.runs().collect::<Vec<_>>(), [0..2, 2..4]);
    assert_eq!(
        error("time_min,z_um\n0,0\n10,1\ntime_min,z_um\n5,2\n4,2\n"),
        "log.csv:6:1: time goes backwards within run 2: 4 after 5"
    );
    // With a run column the labels decide; the repeated header is only skipped.
    let ds =
        read("time_min,z_um,pass,run\n0,0,0,17\n9,1,1,17\ntime_min,z_um,pass,run\n0,0,0,431\n")
            .unwrap();
    assert_eq!(ds.runs().collect::<Vec<_>>(), [0..2, 2..3]);
    assert_eq!(
        ds.run_labels.as_deref(),
        Some(&["17".to_string(), "431".to_string()][..])
    );
    // A header line at the very start of the data (an empty first run) starts nothing.
    assert_eq!(
        read("time_min,z_um\ntime_min,z_um\n0,0\n")
            .unwrap()
            .runs()
            .count(),
        1
    );
}
