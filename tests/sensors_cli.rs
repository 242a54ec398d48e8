//! `driftloop sensors` through the binary: report, JSON shape, exit codes, and the model file it writes
//! reproducing the regression under `driftloop predict`.

mod common;

mod shared_data;

use std::path::{Path, PathBuf};

use driftloop::sensors::synth::{TRUTH, dataset};

/// The synthetic data set (one run, 900 min, seed 7) written as CSV into `dir`.
fn synthetic_csv(dir: &Path) -> PathBuf {
    let path = dir.join("sensors.csv");
    let file = std::fs::File::create(&path).unwrap();
    dataset(7, 1, 900, TRUTH).write_csv(file).unwrap();
    path
}

#[test]
fn human_report_on_synthetic_data() {
    let dir = tempfile::tempdir().unwrap();
    let csv = synthetic_csv(dir.path());
    let out = common::stdout(&common::run(&[
        "sensors",
        csv.to_str().unwrap(),
        "--channel",
        "e_um",
    ]));
    insta::assert_snapshot!(out);
}

#[test]
fn json_has_the_factors_clusters_coefficients_and_both_scores() {
    let dir = tempfile::tempdir().unwrap();
    let csv = synthetic_csv(dir.path());
    let out = common::stdout(&common::run(&[
        "sensors",
        csv.to_str().unwrap(),
        "--channel",
        "e_um",
        "--format",
        "json",
        "--holdout-from",
        "600",
    ]));
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["channel"], "e_um");
    assert_eq!(v["factors"].as_array().unwrap().len(), 8);
    assert_eq!(v["correlation"].as_array().unwrap().len(), 8);
    assert_eq!(v["chosen"], serde_json::json!(["a1_c", "b1_c"]));
    assert_eq!(v["clusters"].as_array().unwrap().len(), 4);
    assert_eq!(v["coefficients"][0]["term"], "offset");
    assert_eq!(v["validation"]["scheme"], "time-holdout");
    assert_eq!(v["validation"]["holdout_from_min"], 600.0);
    assert_eq!(v["validation"]["default_holdout"], false);
    assert_eq!(v["training_samples"], 600);
    assert_eq!(v["validation"]["score"]["samples"], 300);
    for part in [&v["fit"], &v["validation"]["score"]] {
        let rate = part["compensation_rate"].as_f64().unwrap();
        assert!(rate > 0.9 && rate < 1.0, "{part}");
    }
}

#[test]
fn usage_and_input_errors_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let csv = synthetic_csv(dir.path());
    let csv = csv.to_str().unwrap();
    let no_sensors = dir.path().join("bare.csv");
    std::fs::write(&no_sensors, "time_min,e_um\n0,1\n1,2\n2,3\n3,5\n").unwrap();
    let cases: [&[&str]; 5] = [
        &["sensors", csv, "--channel", "zz_um"],
        &["sensors", "/nonexistent/data.csv", "--channel", "e_um"],
        &["sensors", csv, "--channel", "e_um", "--threshold", "1.5"],
        &[
            "sensors",
            csv,
            "--channel",
            "e_um",
            "--holdout-from",
            "5000",
        ],
        &["sensors", no_sensors.to_str().unwrap(), "--channel", "e_um"],
    ];
    for args in cases {
        let out = common::run(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!out.stderr.is_empty(), "{args:?}");
    }
}

/// Column `name` of a CSV text.
fn csv_column(text: &str, name: &str) -> Vec<f64> {
    let mut lines = text.lines();
    let k = lines
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name}"));
    lines
        .map(|l| l.split(',').nth(k).unwrap().parse().unwrap())
        .collect()
}

#[test]
fn the_model_file_reproduces_the_regression_under_predict() {
    let dir = tempfile::tempdir().unwrap();
    let csv = synthetic_csv(dir.path());
    let model = dir.path().join("model.toml");
    let (csv, model) = (csv.to_str().unwrap(), model.to_str().unwrap());
    let report = common::stdout(&common::run(&[
        "sensors",
        csv,
        "--channel",
        "e_um",
        "--format",
        "json",
        "-o",
        model,
    ]));
    let v: serde_json::Value = serde_json::from_str(&report).unwrap();
    let predicted = common::stdout(&common::run(&["predict", model, "--data", csv]));
    let (t, p, e) = (
        csv_column(&predicted, "time_min"),
        csv_column(&predicted, "predicted_um"),
        csv_column(&predicted, "e_um"),
    );
    // The regression as documented, evaluated here from the reported coefficients.
    let ds = dataset(7, 1, 900, TRUTH);
    let coef = v["coefficients"].as_array().unwrap();
    for i in 0..t.len() {
        let mut expected = coef[0]["value"].as_f64().unwrap();
        for c in &coef[1..] {
            let s = ds.values(c["term"].as_str().unwrap()).unwrap();
            expected += c["value"].as_f64().unwrap() * (s[i] - s[0]);
        }
        assert!(
            (p[i] - expected).abs() < 1e-9,
            "row {i}: {} vs {expected}",
            p[i]
        );
    }
    // diagnose reads the model too (exit 0 or 1 — findings — never 2).
    let diagnosed = common::run(&["diagnose", model, csv, "--channel", "e_um"]);
    assert!(
        matches!(diagnosed.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&diagnosed.stderr)
    );
    // And predict's residual on the holdout is the one the report scored.
    let from = v["validation"]["holdout_from_min"].as_f64().unwrap();
    let resid: Vec<f64> = (0..t.len())
        .filter(|&i| t[i] >= from)
        .map(|i| e[i] - p[i])
        .collect();
    let rms = (resid.iter().map(|r| r * r).sum::<f64>() / resid.len() as f64).sqrt();
    let reported = v["validation"]["score"]["residual_rms_um"]
        .as_f64()
        .unwrap();
    assert!((rms - reported).abs() < 1e-6, "{rms} vs {reported}");
}

#[test]
fn real_data_end_to_end_example() {
    let Some(data) = shared_data::path("data/fl_thermal_first24h.csv") else {
        return;
    };
    let data = data.to_str().unwrap();
    let human = common::stdout(&common::run(&[
        "sensors",
        data,
        "--channel",
        "ch3_um",
        "--holdout-from",
        "960",
    ]));
    eprintln!("{human}");
    let json = common::stdout(&common::run(&[
        "sensors",
        data,
        "--channel",
        "ch3_um",
        "--holdout-from",
        "960",
        "--format",
        "json",
    ]));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    // The file is in seconds: 960 min = 57 600 s splits its 5760 rows (15 s apart) at row 3840.
    assert_eq!(v["training_samples"], 3840);
    assert_eq!(v["validation"]["score"]["samples"], 1920);
    assert_eq!(v["factors"].as_array().unwrap().len(), 16);
    let chosen = v["chosen"].as_array().unwrap();
    assert!(!chosen.is_empty() && chosen.len() < 16);
    let clusters = v["clusters"].as_array().unwrap();
    let members: usize = clusters
        .iter()
        .map(|c| c["sensors"].as_array().unwrap().len())
        .sum();
    assert_eq!(members, 16, "every sensor is in exactly one cluster");
}

#[test]
fn position_column_report_and_its_model_file() {
    use driftloop::sensors::synth::{POSITION_TRUTH, position_dataset};
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("positions.csv");
    position_dataset(4, 60, POSITION_TRUTH)
        .write_csv(std::fs::File::create(&csv).unwrap())
        .unwrap();
    let csv = csv.to_str().unwrap();
    let args = [
        "sensors",
        csv,
        "--channel",
        "e_um",
        "--position-column",
        "x_mm",
    ];
    insta::assert_snapshot!(common::stdout(&common::run(&args)));
    let json = common::stdout(&common::run(&[&args[..], &["--format", "json"]].concat()));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["position"], "x_mm");
    assert_eq!(v["geometric"].as_array().unwrap().len(), 3);
    assert_eq!(v["slope"][1]["term"], "a1_c");
    assert_eq!(v["intercept"][2]["term"], "b1_c");
    let model = dir.path().join("m.toml");
    let written = common::run(&[&args[..], &["-o", model.to_str().unwrap()]].concat());
    assert_eq!(written.status.code(), Some(0));
    let model = driftloop::model::DriftModel::read(&model).unwrap();
    let kinds: Vec<&str> = model.effects.iter().map(|e| e.kind.as_str()).collect();
    assert_eq!(
        kinds,
        [
            "geometric",
            "input_slope",
            "input_slope",
            "static_input",
            "static_input"
        ]
    );
    // The geometric constant and I's intercept are the model's offset.
    let offset = v["geometric"][0].as_f64().unwrap() + v["intercept"][0]["value"].as_f64().unwrap();
    assert!((model.offset_um - offset).abs() < 1e-12);
}
