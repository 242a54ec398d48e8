//! The HTML reports people look at: one self-contained file each (no scripts, nothing fetched), axes with
//! their units, and no line joining two runs of a data set (each run starts at its own time zero).

mod common;

use std::fmt::Write as _;
use std::path::Path;

fn code(o: &std::process::Output) -> i32 {
    o.status.code().expect("exit code")
}

/// The SVG charts of a report, in order.
fn charts(html: &str) -> Vec<&str> {
    html.split("<svg")
        .skip(1)
        .map(|s| s.split("</svg>").next().unwrap())
        .collect()
}

/// The `d` of every drawn path with a stroke of the given dash (data lines; legends are `<line>`s).
fn paths(svg: &str, dashed: bool) -> Vec<&str> {
    svg.lines()
        .filter(|l| l.starts_with("<path d=\"M") && l.contains("fill=\"none\""))
        .filter(|l| l.contains("stroke-dasharray") == dashed)
        .collect()
}

fn assert_offline(html: &str) {
    assert!(html.starts_with("<!DOCTYPE html>"), "one HTML file");
    for remote in [
        "<script",
        "src=\"http",
        "href=\"http",
        "@import",
        "url(http",
    ] {
        assert!(!html.contains(remote), "{remote} in a report");
    }
}

fn run(args: &[&str]) -> String {
    let o = common::run(args);
    assert_eq!(code(&o), 0, "{args:?}: {}", common::stderr(&o));
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn diagnose_draws_each_run_apart_with_units_on_the_axes() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let data = "fixtures/data/characterisation.csv";
    run(&["fit", data, "--channel", "drift_z_um", "-o", &p("m.toml")]);
    run(&[
        "diagnose",
        &p("m.toml"),
        data,
        "--channel",
        "drift_z_um",
        "--holdout-from",
        "none",
        "--report",
        &p("r.html"),
    ]);
    let html = std::fs::read_to_string(p("r.html")).unwrap();
    assert_offline(&html);
    let runs = 5; // 1000 … 5000 rpm, each from rest at its own time zero
    let first = charts(&html)[0];
    let before = paths(first, true);
    assert_eq!(
        before.len(),
        runs,
        "one line per run, none joining two runs"
    );
    let start = |d: &str| d.split(' ').next().unwrap().to_string();
    assert!(
        before.iter().all(|d| start(d) == start(before[0])),
        "every run's line starts at time zero: {:?}",
        before.iter().map(|d| start(d)).collect::<Vec<_>>()
    );
    assert!(first.contains("time since the run&#39;s start in min"));
    assert!(first.contains("drift in µm"), "{first}");
    for svg in charts(&html) {
        assert!(svg.contains(" in µm"), "a µm axis: {svg}");
        assert!(svg.contains(" in min"), "a min axis: {svg}");
    }
}

/// Three runs of a channel that follows `t1_c` (2 µm/°C) and a sensor `t2_c` that moves with it.
fn sensor_runs(path: &Path) {
    let mut csv = String::from("time_min,run,t1_c,t2_c,t3_c,z_um\n");
    for run in 0..3 {
        for i in 0..40 {
            let t = f64::from(i) * 5.0;
            let warm = (1.0 + f64::from(run)) * (1.0 - (-t / 60.0).exp());
            let wobble = 0.3 * ((t + f64::from(run) * 17.0) / 23.0).sin();
            let noise = 0.05 * ((f64::from(i) * 7.3 + f64::from(run)).sin());
            let _ = writeln!(
                csv,
                "{t},{run},{:.4},{:.4},{:.4},{:.4}",
                20.0 + warm,
                21.0 + 0.98 * warm + 0.01 * wobble,
                19.0 + wobble,
                2.0 * warm + noise
            );
        }
    }
    std::fs::write(path, csv).unwrap();
}

#[test]
fn sensors_writes_a_report_with_runs_apart_and_units() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("runs.csv");
    sensor_runs(&data);
    let report = dir.path().join("sensors.html");
    let text = run(&[
        "sensors",
        &data.display().to_string(),
        "--channel",
        "z_um",
        "--report",
        &report.display().to_string(),
    ]);
    let html = std::fs::read_to_string(&report).unwrap();
    assert_offline(&html);
    assert!(html.contains("leave-one-run-out"), "the validation named");
    let kept = text
        .lines()
        .filter_map(|l| l.split("keep ").nth(1))
        .map(str::trim)
        .collect::<Vec<_>>();
    assert!(!kept.is_empty(), "{text}");
    for sensor in &kept {
        assert!(html.contains(&format!("keep {sensor}")), "{sensor}");
    }
    let charts = charts(&html);
    assert_eq!(charts.len(), 3, "measured/predicted, residual, sensors");
    assert_eq!(
        paths(charts[0], false).len(),
        3,
        "the regression: one line per run"
    );
    assert!(charts[0].contains("z_um in µm") && charts[0].contains(" in min"));
    assert!(charts[1].contains("residual in µm"));
    assert!(charts[2].contains("change since the run&#39;s start in °C"));
    assert_eq!(
        paths(charts[2], false).len(),
        3 * kept.len(),
        "each kept sensor, one line per run"
    );
}

#[test]
fn sensors_report_of_a_single_run_marks_the_holdout() {
    let dir = tempfile::tempdir().unwrap();
    run(&[
        "simulate-data",
        &dir.path().display().to_string(),
        "--effect",
        "none",
        "--seed",
        "3",
    ]);
    let report = dir.path().join("r.html");
    run(&[
        "sensors",
        &dir.path().join("production.csv").display().to_string(),
        "--channel",
        "z_um",
        "--min-correlation",
        "0",
        "--report",
        &report.display().to_string(),
    ]);
    let html = std::fs::read_to_string(&report).unwrap();
    assert_offline(&html);
    let charts = charts(&html);
    assert_eq!(charts.len(), 3);
    assert!(
        charts[0].contains(">holdout<"),
        "the holdout's start is marked"
    );
    assert!(charts[0].contains("time in min"));
}
