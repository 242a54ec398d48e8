//! `driftloop log merge` and `diagnose MODEL A.csv DRIFTLOG`: a characterisation CSV (seconds, one run) and
//! a DRIFTLOG the transformed program appended two jobs to (minutes, a header per job, the channel under
//! another name, empty drift cells where a gate did not measure) become one series.

mod common;

use std::path::Path;

use driftloop::data::{Require, read_bytes};

const CHARACTERISATION: &str = "time_s,spindle_rpm,ch3_um,t1_c\n\
0,0,0,20\n600,3000,1.2,20.1\n1200,3000,2.0,20.3\n1800,3000,2.4,20.4\n2400,0,1.5,20.4\n3000,0,0.9,20.3\n";

const DRIFTLOG: &str = "time_min,spindle_rpm,drift_z_um,pass,run,t1_c\n\
0,3000,0,1,4711,21\n12,3000,,2,4711,21.2\n25,0,2.1,3,4711,21.3\n\
time_min,spindle_rpm,drift_z_um,pass,run,t1_c\n\
0,2000,0,1,5230,22\n30,2000,1.1,2,5230,22.4\n";

fn write(dir: &Path) {
    std::fs::write(dir.join("char.csv"), CHARACTERISATION).unwrap();
    std::fs::write(dir.join("DRIFTLOG"), DRIFTLOG).unwrap();
}

#[test]
fn a_characterisation_and_a_drift_log_merge_into_one_series() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path());
    let out = common::driftloop(
        dir.path(),
        &[
            "log",
            "merge",
            "char.csv",
            "DRIFTLOG",
            "--rename",
            "drift_z_um=ch3_um",
        ],
        b"",
    );
    assert_eq!(out.status.code(), Some(0), "{}", common::stderr(&out));
    let csv = String::from_utf8_lossy(&out.stdout).into_owned();
    insta::assert_snapshot!("merged_log", csv);
    assert!(common::stderr(&out).contains("`pass` is left out"));
    // The merged file reads back as three runs in the first file's time unit, nothing lost.
    let ds = read_bytes("merged.csv", csv.as_bytes(), Require::Displacement).unwrap();
    assert_eq!(ds.run_starts, vec![0, 6, 9]);
    assert_eq!(
        ds.values("ch3_um")
            .unwrap()
            .iter()
            .filter(|v| v.is_nan())
            .count(),
        1
    );
}

#[test]
fn mismatched_files_are_refused_with_the_column_named() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path());
    std::fs::write(
        dir.path().join("bare.log"),
        "time_min,spindle_rpm,ch3_um\n0,0,0\n",
    )
    .unwrap();
    let out = common::driftloop(dir.path(), &["log", "merge", "char.csv", "bare.log"], b"");
    assert_eq!(out.status.code(), Some(2));
    let err = common::stderr(&out);
    assert!(
        err.contains("bare.log: no column `t1_c`, which char.csv has"),
        "{err}"
    );
    let out = common::driftloop(
        dir.path(),
        &["log", "merge", "char.csv", "--rename", "drift_x_um"],
        b"",
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(common::stderr(&out).contains("expected OLD=NEW"));
}

#[test]
fn diagnose_reads_the_files_merged_and_defaults_to_the_models_channel() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path());
    let run = |args: &[&str]| common::driftloop(dir.path(), args, b"");
    let out = run(&["fit", "char.csv", "-o", "m.toml"]);
    assert_eq!(out.status.code(), Some(0), "{}", common::stderr(&out));
    let out = run(&[
        "diagnose",
        "m.toml",
        "char.csv",
        "DRIFTLOG",
        "--rename",
        "drift_z_um=ch3_um",
        "--holdout-from",
        "none",
    ]);
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{}",
        common::stderr(&out)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("diagnosis of ch3_um on char.csv + DRIFTLOG"),
        "{text}"
    );
    assert!(
        text.contains("1 rows carry the inputs but no reading"),
        "{text}"
    );
}
