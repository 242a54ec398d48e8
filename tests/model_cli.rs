//! `driftloop fit` and `driftloop predict` through the binary: outputs, and exit code 2 on bad input.

mod common;

use std::path::{Path, PathBuf};

const FIXTURE: &str = "fixtures/data/characterisation.csv";

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// `driftloop fit FIXTURE --channel drift_z_um --format json EXTRA…`, which must succeed; its JSON.
fn fit_json(extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "fit",
        FIXTURE,
        "--channel",
        "drift_z_um",
        "--format",
        "json",
    ];
    args.extend_from_slice(extra);
    let out = common::run(&args);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

fn fit_to(dir: &Path) -> PathBuf {
    let model = dir.join("model.toml");
    let out = common::run(&[
        "fit",
        FIXTURE,
        "--channel",
        "drift_z_um",
        "-o",
        model.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    model
}

#[test]
fn fit_prints_a_summary_and_writes_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model.toml");
    let out = common::run(&[
        "fit",
        FIXTURE,
        "--channel",
        "DRIFT_Z_UM",
        "-o",
        model.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    insta::assert_snapshot!("fit_summary", text(&out.stdout));
    let written = std::fs::read_to_string(&model).unwrap();
    assert!(written.starts_with("schema = 1\n"));
}

#[test]
fn fit_json_is_one_object_with_the_model() {
    let v = fit_json(&["--modes", "1"]);
    assert_eq!(v["schema"], 1);
    assert_eq!(v["spindle"]["modes"].as_array().unwrap().len(), 1);
    assert_eq!(v["fit"]["selection"], "fixed");
    // The runs get faster in file order: the law above 5000 rpm is chosen on the folds that predict a
    // faster run, and the grid carries it.
    assert_eq!(v["spindle"]["extrapolation"], "power-law");
    assert_eq!(v["spindle"]["characterised_top_rpm"], 5000.0);
    let p = v["fit"]["speed_law"]["exponent"].as_f64().unwrap();
    assert_eq!(v["spindle"]["modes"][0]["power_law_exponent"], p);
    assert_eq!(v["fit"]["speed_law"]["trials"].as_array().unwrap().len(), 9);
}

#[test]
fn fit_until_takes_a_unit_and_a_bare_number_is_minutes() {
    let v = fit_json(&["--until", "200"]);
    assert_eq!(v["fit"]["until"], 200.0);
    let samples = v["fit"]["samples"].as_u64().unwrap();
    assert!(samples < 206);
    // The same time in seconds and in hours; the model file keeps it in the data's unit (minutes here).
    for until in ["12000s", "200min"] {
        let v = fit_json(&["--until", until]);
        assert_eq!(v["fit"]["samples"].as_u64().unwrap(), samples, "{until}");
    }
    let out = common::run(&[
        "fit",
        FIXTURE,
        "--channel",
        "drift_z_um",
        "--until",
        "2 days",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("unknown time unit `days`"));
}

#[test]
fn predict_a_schedule_and_a_data_file() {
    let dir = tempfile::tempdir().unwrap();
    let model = fit_to(dir.path());
    let m = model.to_str().unwrap();
    let out = common::run(&[
        "predict",
        m,
        "--schedule",
        "3000:60,0:30,6000:10",
        "--step",
        "30",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let csv = text(&out.stdout);
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "time_min,spindle_rpm,predicted_um");
    let times: Vec<&str> = lines[1..]
        .iter()
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(times, ["0", "30", "60", "90", "100"]);
    let warning = text(&out.stderr);
    assert!(
        warning.contains("6000 rpm is above the top characterised speed 5000 rpm")
            && warning.contains("the power law")
            && warning.contains("chosen by forward validation"),
        "{warning}"
    );

    let pred = dir.path().join("pred.csv");
    let out = common::run(&[
        "predict",
        m,
        "--data",
        FIXTURE,
        "-o",
        pred.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let csv = std::fs::read_to_string(&pred).unwrap();
    assert!(csv.starts_with("time_min,run,spindle_rpm,drift_z_um,predicted_um,residual_um\n"));
    assert_eq!(csv.lines().count(), 207);
}

#[test]
fn bad_input_exits_2_with_the_location() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "time_s,spindle_rpm,z_um\n0,0,0\n15,3000,x\n").unwrap();
    let out = common::run(&["fit", bad.to_str().unwrap(), "--channel", "z_um"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("bad.csv:3:3: column `z_um`: `x` is not a number"),
        "{}",
        text(&out.stderr)
    );

    let out = common::run(&["fit", "no/such/file.csv", "--channel", "z_um"]);
    assert_eq!(out.status.code(), Some(2));
    let out = common::run(&["fit", FIXTURE, "--channel", "ch9_um"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("no channel `ch9_um`; displacement channels: drift_z_um"));

    let model = fit_to(dir.path());
    let newer = dir.path().join("newer.toml");
    let t = std::fs::read_to_string(&model)
        .unwrap()
        .replacen("schema = 1", "schema = 7", 1);
    std::fs::write(&newer, t).unwrap();
    let out = common::run(&["predict", newer.to_str().unwrap(), "--schedule", "1000:10"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("schema 7 is not supported"));
    let out = common::run(&["predict", model.to_str().unwrap(), "--schedule", "1000"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_degenerate_fixed_order_falls_back_and_says_why() {
    let v = fit_json(&["--modes", "3"]);
    assert_eq!(v["spindle"]["modes"].as_array().unwrap().len(), 2);
    let orders = v["fit"]["orders"].as_array().unwrap();
    assert_eq!(orders[0]["modes"], 3);
    assert!(
        orders[0]["note"]
            .as_str()
            .unwrap()
            .starts_with("rejected: "),
        "{}",
        orders[0]
    );
    assert_eq!(orders[1]["note"], "chosen");
}

#[test]
fn fit_reads_stdin_and_writes_the_model_to_stdout() {
    let data = std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join(FIXTURE)).unwrap();
    let out = common::driftloop(
        Path::new(env!("CARGO_MANIFEST_DIR")),
        &[
            "fit",
            "-",
            "--channel",
            "drift_z_um",
            "--modes",
            "2",
            "-o",
            "-",
        ],
        &data,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let model = driftloop::model::DriftModel::from_toml(&text(&out.stdout), "stdout").unwrap();
    assert_eq!(model.data.unwrap().file, "<stdin>");
    assert!(text(&out.stderr).starts_with("drift_z_um: 2 spindle modes"));
}
