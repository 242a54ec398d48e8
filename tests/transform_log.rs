//! The measurement log a transformed program writes, run on the dry-run VM: with `[log]` in the profile it
//! measures at every gate and carries the analog inputs the profile names, so `diagnose` can read it as is.

use driftloop::demo::transform_program;
use driftloop::model::DriftModel;
use driftloop::omm::{DEFAULT_PROFILE, Profile};
use driftloop::vm::{Config, End, Run, SimpleMachine, SpindleHistory, run_source};

/// 30 µm at 4000 rpm through a 40 min lag (the demo truth's spindle part).
const MODEL: &str = include_str!("../fixtures/omm/spindle_40min.toml");

fn config() -> Config {
    Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        probe_surface_mm: -100.0,
        ..Config::default()
    }
}

fn truth(axis: &str, t: f64, spindle: &SpindleHistory) -> f64 {
    if axis != "Z" {
        return 0.0;
    }
    spindle.intervals(t).fold(0.0, |x, (a, b, rpm)| {
        let target = 30.0 * rpm / 4000.0;
        target + (x - target) * (-(b - a) / 40.0).exp()
    })
}

/// The run's DRIFTLOG as header + rows of fields.
fn run_log(profile: &Profile) -> (Run, Vec<String>, Vec<Vec<f64>>) {
    let model = DriftModel::from_toml(MODEL, "model.toml").unwrap();
    let bytes = transform_program(&model, profile).unwrap();
    // Ambient 20 °C rising by 1 °C per 10 min: every row must read its own value.
    let mut machine = SimpleMachine::with_drift(truth).analog(1, vec![(0.0, 20.0), (600.0, 80.0)]);
    let run = run_source("stepped.mpf", &bytes, None, &config(), &mut machine).unwrap();
    assert_eq!(run.end, End::ProgramEnd { code: "M30".into() });
    let text = run.files.get(&profile.registers.log_file).expect("a log");
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    // An empty drift cell: the gate did not measure (NaN, as the data reader takes it).
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|f| match f.trim() {
                    "" => f64::NAN,
                    v => v.parse().unwrap(),
                })
                .collect()
        })
        .collect();
    (run, header, rows)
}

#[test]
fn every_gate_is_measured_and_logged_with_the_ambient_input() {
    let text = format!(
        "{DEFAULT_PROFILE}\n[log]\nmeasure_every_gate = true\ninputs = {{ ambient_c = 1 }}\n"
    );
    let dense = Profile::from_toml(&text, "dense.toml").unwrap();
    let (run, header, rows) = run_log(&dense);
    let (_, sparse_header, sparse_rows) = run_log(&Profile::default_profile());
    assert_eq!(
        header,
        [
            "time_min",
            "spindle_rpm",
            "drift_z_um",
            "pass",
            "run",
            "ambient_c"
        ]
    );
    assert_eq!(sparse_header.len(), 5, "without [log] no input column");
    // Both log a row at every gate (production has fewer: extra gates only where it plans to measure)
    // and leave the drift empty where they did not measure.
    let measured = |rows: &[Vec<f64>]| rows.iter().filter(|r| !r[2].is_nan()).count();
    assert!(
        sparse_rows.len() >= run.passes.len()
            && rows.len() >= sparse_rows.len()
            && measured(&rows) > measured(&sparse_rows)
            && measured(&sparse_rows) < sparse_rows.len(),
        "dense {} rows, sparse {} rows ({} measured), {} passes",
        rows.len(),
        sparse_rows.len(),
        measured(&sparse_rows),
        run.passes.len()
    );
    for row in &rows {
        assert_eq!(row.len(), 6);
        // The log's time counts from the zero; the run starts minutes before it (well under one degree).
        let expected = 20.0 + row[0] / 10.0;
        assert!((row[5] - expected).abs() < 1.0, "{row:?}");
    }
    assert!(rows.last().unwrap()[5] > rows[0][5] + 1.0);
    // Measured drift follows the truth: the rows are real readings, not placeholders.
    assert!(rows.iter().any(|r| r[2] > 10.0), "{rows:?}");
    // A gate that cannot measure (the update at the spindle start) logs its row without a reading.
    assert!(rows.iter().any(|r| r[2].is_nan()), "{rows:?}");
}

#[test]
fn log_inputs_are_checked() {
    let text = format!("{DEFAULT_PROFILE}\n[log]\ninputs = {{ \"amb ient\" = 1 }}\n");
    let err = Profile::from_toml(&text, "p.toml").unwrap_err().to_string();
    assert!(err.contains("log.inputs"), "{err}");
    let text = format!("{DEFAULT_PROFILE}\n[log]\nevery = 3\n");
    let err = Profile::from_toml(&text, "p.toml").unwrap_err().to_string();
    assert!(err.contains("unknown field `every`"), "{err}");
}

/// −1.5 µm/°C of ambient change through a 30 min lag, the ambient rising by 1 °C per 10 min (as in
/// `run_log`): k·r·(t − τ(1 − e^(−t/τ))).
fn truth_with_ambient(axis: &str, t: f64, spindle: &SpindleHistory) -> f64 {
    let amb = -1.5 * 0.1 * (t - 30.0 * (1.0 - (-t / 30.0).exp()));
    truth(axis, t, spindle) + if axis == "Z" { amb } else { 0.0 }
}

fn max_error_with(model_text: &str, profile: &Profile) -> f64 {
    let model = DriftModel::from_toml(model_text, "model.toml").unwrap();
    let bytes = transform_program(&model, profile).unwrap();
    let reparsed = driftloop::parse(&bytes);
    assert!(
        reparsed.diagnostics().is_empty(),
        "{:?}",
        reparsed.diagnostics()
    );
    let points = vec![(0.0, 20.0), (600.0, 80.0)];
    let mut machine = SimpleMachine::with_drift(truth_with_ambient).analog(1, points);
    let run = run_source("stepped.mpf", &bytes, None, &config(), &mut machine).unwrap();
    assert_eq!(run.end, End::ProgramEnd { code: "M30".into() });
    run.totals.max_abs_error_um
}

#[test]
fn an_ambient_input_lag_is_predicted_in_nc() {
    let text = format!("{DEFAULT_PROFILE}\n[log]\ninputs = {{ ambient_c = 1 }}\n");
    let profile = Profile::from_toml(&text, "ambient.toml").unwrap();
    let with_input = format!(
        "{MODEL}[[inputs]]\nsignal = \"ambient_c\"\ntau_min = 30.0\ngain_um_per_unit = -1.5\n"
    );
    let spindle_only = max_error_with(MODEL, &profile);
    let full = max_error_with(&with_input, &profile);
    // Sampling the input at the gates only costs a little; a tenth of the 20 µm tolerance is the bound.
    assert!(full < 2.0, "with the input lag: {full} µm");
    assert!(
        spindle_only > 5.0 * full,
        "without it: {spindle_only} µm, with it {full} µm"
    );
    // The signal must be mapped: without `[log] inputs` the model is refused.
    let model = DriftModel::from_toml(&with_input, "model.toml").unwrap();
    let err = transform_program(&model, &Profile::default_profile())
        .unwrap_err()
        .to_string();
    assert!(err.contains("ambient_c"), "{err}");
}

/// The production program's log (no `measure_every_gate`), as the dry run's WRITE left it, reads back as a
/// dataset: a row at every gate, a reading only where the program measured, the spindle stop and the
/// ambient input at every row.
#[test]
fn the_production_log_reads_back_with_rows_without_a_reading() {
    use driftloop::data::{Require, read_bytes};
    let text = format!("{DEFAULT_PROFILE}\n[log]\ninputs = {{ ambient_c = 1 }}\n");
    let profile = Profile::from_toml(&text, "production.toml").unwrap();
    let model = DriftModel::from_toml(MODEL, "model.toml").unwrap();
    let bytes = transform_program(&model, &profile).unwrap();
    let mut machine = SimpleMachine::with_drift(truth).analog(1, vec![(0.0, 20.0), (600.0, 26.0)]);
    let run = run_source("stepped.mpf", &bytes, None, &config(), &mut machine).unwrap();
    assert_eq!(run.end, End::ProgramEnd { code: "M30".into() });
    let log = &run.files[&profile.registers.log_file];
    let ds = read_bytes("DRIFTLOG", log.as_bytes(), Require::Displacement).unwrap();
    let z = ds.values("drift_z_um").unwrap();
    let readings = z.iter().filter(|v| !v.is_nan()).count();
    // The zero and at least one gate measured, and rows without a reading between them.
    assert!(readings >= 2 && readings < ds.len(), "{log}");
    assert_eq!(z[0], 0.0, "{log}");
    assert!(z.iter().any(|v| *v > 10.0), "{log}");
    // The last row is the spindle stop, which no measurement sees.
    assert_eq!(
        ds.values("spindle_rpm").unwrap()[ds.len() - 1],
        0.0,
        "{log}"
    );
    let amb = ds.values("ambient_c").unwrap();
    assert!(amb[ds.len() - 1] > amb[0] + 1.0, "{log}");
}
