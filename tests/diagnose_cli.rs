//! `driftloop simulate-data` → `fit` → `diagnose` through the binary: the JSON object's shape, the exit
//! codes, the refined model that `predict` reproduces the "after" prediction with, the HTML report.

mod common;

use std::path::Path;
use std::process::Output;

use driftloop::data::{Require, read_path};
use driftloop::diagnose::{Options, diagnose};
use driftloop::model::DriftModel;

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Simulated data with `effect` in `dir`, and the declared model fitted on the characterisation.
fn prepare(dir: &Path, effect: &str, seed: &str) {
    let d = dir.to_str().unwrap();
    let out = common::run(&["simulate-data", d, "--effect", effect, "--seed", seed]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    for f in [
        "characterisation.csv",
        "production.csv",
        "truth.toml",
        "scenario.json",
    ] {
        assert!(dir.join(f).exists(), "{f}");
    }
    let model = dir.join("model.toml");
    let out = common::run(&[
        "fit",
        dir.join("characterisation.csv").to_str().unwrap(),
        "--channel",
        "z_um",
        "-o",
        model.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

/// `driftloop diagnose DIR/model.toml DIR/production.csv --channel z_um EXTRA…`.
fn diagnose_in(dir: &Path, extra: &[&str]) -> Output {
    let model = dir.join("model.toml");
    let data = dir.join("production.csv");
    let mut args = vec![
        "diagnose",
        model.to_str().unwrap(),
        data.to_str().unwrap(),
        "--channel",
        "z_um",
    ];
    args.extend_from_slice(extra);
    common::run(&args)
}

#[test]
fn json_refined_model_and_report() {
    let dir = tempfile::tempdir().unwrap();
    prepare(dir.path(), "step", "3");
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let out = diagnose_in(
        dir.path(),
        &[
            "--holdout-from",
            "1080",
            "--format",
            "json",
            "-o",
            &p("refined.toml"),
            "--report",
            &p("report.html"),
        ],
    );
    assert_eq!(
        out.status.code(),
        Some(1),
        "effects found → exit 1; {}",
        text(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    assert_eq!(
        keys,
        [
            "after",
            "before",
            "channel",
            "effects_added",
            "holdout_guard",
            "probing",
            "residual_white",
            "uncompensated"
        ]
    );
    // A probe every 60 min by default: alone, with the model before, with the model after.
    assert_eq!(v["probing"]["every_min"], 60.0);
    for k in ["probe_only", "before", "after"] {
        assert!(v["probing"][k]["rms_um"].is_f64(), "{k}");
    }
    assert_eq!(v["channel"], "z_um");
    for w in ["uncompensated", "before", "after"] {
        for k in ["rms_um", "max_um", "p95_um"] {
            assert!(
                v[w]["fit"][k].is_f64() && v[w]["holdout"][k].is_f64(),
                "{w} {k}"
            );
        }
    }
    let e = &v["effects_added"][0];
    assert_eq!(e["kind"], "step");
    assert!(e["signal"].is_null());
    assert!(e["params"]["at_min"].is_f64() && e["explained_rms_um"].as_f64().unwrap() > 0.0);

    // The refined model predicts, through the library and through `predict`, the "after" numbers.
    let refined = DriftModel::read(Path::new(&p("refined.toml"))).unwrap();
    assert_eq!(refined.effects[0].kind, "step");
    let ds = read_path(Path::new(&p("production.csv")), Require::Displacement).unwrap();
    let again = diagnose(&refined, &ds, &Options::new("z_um").holdout_from(1080.0)).unwrap();
    let after_rms = v["after"]["holdout"]["rms_um"].as_f64().unwrap();
    assert!((again.before.holdout.unwrap().rms_um - after_rms).abs() < 1e-3);
    let out = common::run(&[
        "predict",
        &p("refined.toml"),
        "--data",
        &p("production.csv"),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let csv = text(&out.stdout);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "residual_um").unwrap();
    let hold: Vec<f64> = csv
        .lines()
        .skip(1)
        .filter(|l| l.split(',').next().unwrap().parse::<f64>().unwrap() >= 1080.0)
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect();
    let rms = (hold.iter().map(|r| r * r).sum::<f64>() / hold.len() as f64).sqrt();
    assert!((rms - after_rms).abs() < 1e-3, "{rms} vs {after_rms}");

    let html = std::fs::read_to_string(p("report.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("How to read") && html.contains("step"));
    // Self-contained: no scripts, nothing loaded from anywhere.
    assert!(
        !html.contains("<script") && !html.contains("src=\"http") && !html.contains("href=\"http")
    );
}

#[test]
fn human_output_holds_out_the_last_third_by_default_and_bad_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    prepare(dir.path(), "none", "2");
    let p = |f: &str| dir.path().join(f).to_str().unwrap().to_string();
    let out = diagnose_in(dir.path(), &["--holdout-from", "none"]);
    let s = text(&out.stdout);
    assert!(s.contains("in-sample only"), "{s}");
    assert!(matches!(out.status.code(), Some(0 | 1)));
    // Without --holdout-from the last third of the 24 h log is held out: from the first row at or after
    // minute 960 on (the log is sampled every few minutes).
    let out = diagnose_in(dir.path(), &[]);
    let s = text(&out.stdout);
    let from: f64 = s
        .split("rows from minute ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("{s}"));
    assert!((960.0..970.0).contains(&from), "{s}");
    assert!(s.contains("with a probe re-zeroing the correction every 60 min (on the holdout)"));
    // The channel defaults to the model's; a time takes its unit.
    let model = p("model.toml");
    let data = p("production.csv");
    let out = common::run(&["diagnose", &model, &data, "--holdout-from", "20h"]);
    assert!(text(&out.stdout).contains("rows before minute 1200"));
    let out = common::run(&["diagnose", &model, &data, "--holdout-from", "16 hours"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("unknown time unit `hours`"));
    let out = common::run(&[
        "diagnose",
        &p("model.toml"),
        &p("production.csv"),
        "--channel",
        "q_um",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("not `q_um`"),
        "{}",
        text(&out.stderr)
    );
    let out = common::run(&["simulate-data", &p("x"), "--effect", "gremlin"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn golden_human_and_json_output() {
    use driftloop::diagnose::scenario::{CHANNEL, Scenario, simulate};
    use driftloop::model::effects::Kind;
    use driftloop::model::{FitOptions, fit};
    let sc = Scenario::new(5, Some(Kind::InputLag));
    let sim = simulate(&sc).unwrap();
    let declared = fit(&sim.characterisation, &FitOptions::new(CHANNEL)).unwrap();
    let opts = Options::new(CHANNEL).holdout_from(sc.holdout_from_min);
    let d = diagnose(&declared, &sim.production, &opts).unwrap();
    insta::assert_snapshot!("diagnose_human", d.human());
    // The report shows the column the effect reads beside its contribution.
    let html = d.html();
    assert!(html.contains("The column coolant_c") && html.matches("<svg").count() == 4);
    insta::assert_snapshot!(
        "diagnose_json",
        serde_json::to_string_pretty(&d.json()).unwrap()
    );
}
