//! `driftloop bench` stays runnable: a 1 MB program, one run, JSON report. Timing is not checked here (that
//! is what the benchmark itself is for); the report's shape and the round trip are.

mod common;

use std::path::Path;

use common::{driftloop, stderr};

/// Runs driftloop in `dir`, requires it to succeed, and returns what it printed as JSON.
fn json(dir: &Path, args: &[&str]) -> serde_json::Value {
    let output = driftloop(dir, args, b"");
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    serde_json::from_slice(&output.stdout).unwrap()
}

#[test]
fn small_bench_reports_a_byte_identical_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let report = json(
        dir.path(),
        &[
            "bench",
            "--size-mb",
            "1",
            "--runs",
            "1",
            "--format",
            "json",
            "--save",
            "cam.mpf",
        ],
    );
    let saved = std::fs::read(dir.path().join("cam.mpf")).unwrap();
    assert_eq!(report["file_bytes"], saved.len());
    assert!(saved.len() >= 1_000_000);
    assert_eq!(
        report["lines"],
        saved.iter().filter(|&&b| b == b'\n').count()
    );
    let d = &report["driftloop"];
    assert_eq!(d["round_trip_identical"], true);
    assert_eq!(
        d["diagnostics"], 0,
        "the generated program is valid Sinumerik"
    );
    assert!(d["parse_print_mb_per_s"].as_f64().unwrap() > 0.0);
    if cfg!(target_os = "linux") {
        let per_byte = d["peak_rss_per_file_byte"].as_f64().unwrap();
        assert!(
            per_byte > 1.0,
            "the source alone is one file size: {per_byte}"
        );
    }
}

/// `--transform` times what `driftloop transform` does to the same program: the blocks it reports inserted
/// are the ones the command inserts with the same model and the default profile.
#[test]
fn bench_transform_matches_the_command() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["bench", "--size-mb", "1", "--runs", "1", "--format", "json"];
    let report = json(dir.path(), &args);
    assert!(report["transform"].is_null(), "only with --transform");
    let mut with = args.to_vec();
    with.extend(["--transform", "--save", "cam.mpf"]);
    let report = json(dir.path(), &with);
    let t = &report["transform"];
    assert!(t["ratio_to_parse_print"].as_f64().unwrap() > 0.0);
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    let files = json(
        dir.path(),
        &[
            "transform",
            "cam.mpf",
            "--model",
            model,
            "--format",
            "json",
            "-o",
            "out.mpf",
        ],
    );
    let inserted = &files[0]["summary"]["blocks_inserted"];
    assert!(inserted.as_u64().unwrap() > 0);
    assert_eq!(&t["blocks_inserted"], inserted);
}
