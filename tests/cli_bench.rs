//! `driftloop bench` stays runnable: a 1 MB program, one run, JSON report. Timing is not checked here (that
//! is what the benchmark itself is for); the report's shape and the round trip are.

mod common;

use common::{driftloop, stderr};

#[test]
fn small_bench_reports_a_byte_identical_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let output = driftloop(
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
        b"",
    );
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
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
    let plain = driftloop(dir.path(), &args, b"");
    let report: serde_json::Value = serde_json::from_slice(&plain.stdout).unwrap();
    assert!(report["transform"].is_null(), "only with --transform");
    let mut with = args.to_vec();
    with.extend(["--transform", "--save", "cam.mpf"]);
    let output = driftloop(dir.path(), &with, b"");
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let t = &report["transform"];
    assert!(t["ratio_to_parse_print"].as_f64().unwrap() > 0.0);
    let model = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    let command = driftloop(
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
        b"",
    );
    assert_eq!(command.status.code(), Some(0), "{}", stderr(&command));
    let files: serde_json::Value = serde_json::from_slice(&command.stdout).unwrap();
    let inserted = &files[0]["summary"]["blocks_inserted"];
    assert!(inserted.as_u64().unwrap() > 0);
    assert_eq!(&t["blocks_inserted"], inserted);
}
