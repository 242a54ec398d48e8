//! A temperature-sensor model through the whole chain with the binary: synthetic sensor data →
//! `driftloop sensors … -o m.toml` → `driftloop transform` with a profile that maps the sensors to analog
//! inputs → an NC program that reads `$A_INA[n]` at the zero and at every gate, parses without errors and is
//! kept as a golden file; and a dry run of such a term against a machine whose drift follows the sensor.

mod common;

use std::path::Path;

use driftloop::omm::DEFAULT_PROFILE;
use driftloop::sensors::synth::{POSITION_TRUTH, TRUTH, dataset, position_dataset};

const PROGRAM: &str = "fixtures/omm/handwritten.mpf";

/// Runs `driftloop` in `dir` (relative paths there; the model file then names its data `sensors.csv`).
fn run_in(dir: &Path, args: &[&str]) -> String {
    common::stdout(&common::driftloop(dir, args, b""))
}

/// Writes the profile (probing at X `x_mm`) mapping `a1_c` and `b1_c` to `$A_INA[1]` and `$A_INA[2]`, then
/// the model with `sensors_args`, and transforms the handwritten fixture; returns the transformed program.
fn transform_with(dir: &Path, x_mm: f64, sensors_args: &[&str]) -> String {
    let at = DEFAULT_PROFILE.replacen("\nx = 0.0\n", &format!("\nx = {x_mm:?}\n"), 1);
    let profile = format!("{at}\n[log]\ninputs = {{ a1_c = 1, b1_c = 2 }}\n");
    std::fs::write(dir.join("p.toml"), profile).unwrap();
    let base = [
        "sensors",
        "sensors.csv",
        "--channel",
        "e_um",
        "-o",
        "m.toml",
    ];
    run_in(dir, &[&base[..], sensors_args].concat());
    let program = Path::new(env!("CARGO_MANIFEST_DIR")).join(PROGRAM);
    run_in(
        dir,
        &[
            "transform",
            program.to_str().unwrap(),
            "--model",
            "m.toml",
            "--profile",
            "p.toml",
        ],
    )
}

/// The inserted lines (ending in the marker), which is what the sensor terms change.
fn inserted(program: &str) -> String {
    program
        .lines()
        .filter(|l| l.ends_with(";DL"))
        .map(|l| format!("{l}\n"))
        .collect()
}

fn assert_parses(program: &str) {
    let parsed = driftloop::parse(program.as_bytes());
    assert!(
        parsed.diagnostics().is_empty(),
        "{:?}",
        parsed.diagnostics()
    );
}

#[test]
fn a_sensor_model_is_transformed_into_analog_input_reads() {
    let dir = tempfile::tempdir().unwrap();
    let csv = std::fs::File::create(dir.path().join("sensors.csv")).unwrap();
    dataset(7, 1, 900, TRUTH).write_csv(csv).unwrap();
    let out = transform_with(dir.path(), 0.0, &[]);
    assert_parses(&out);
    // The zero reads both inputs; every gate reads them again, without lag.
    assert!(out.contains("=$A_INA[1] ; a1_c"), "{out}");
    assert!(out.contains("=$A_INA[2] ; b1_c"), "{out}");
    let gate_reads = out.lines().filter(|l| l.contains("*($A_INA[1]-R")).count();
    assert!(gate_reads >= 2, "{gate_reads} gates read a1_c");
    assert!(
        !out.contains("EXP(-"),
        "a static model has no lag to update"
    );
    insta::assert_snapshot!(inserted(&out));
}

#[test]
fn a_position_model_is_evaluated_at_the_measuring_position() {
    let dir = tempfile::tempdir().unwrap();
    let csv = std::fs::File::create(dir.path().join("sensors.csv")).unwrap();
    position_dataset(4, 60, POSITION_TRUTH)
        .write_csv(csv)
        .unwrap();
    let out = transform_with(dir.path(), 200.0, &["--position-column", "x_mm"]);
    assert_parses(&out);
    assert!(out.contains("=$A_INA[1] ; a1_c") && out.contains("=$A_INA[2] ; b1_c"));
    // At X 200 the slope S = 0.02 µm/mm per °C of a1 (the synthetic truth) is ≈ 4 µm/°C = 0.004 mm/°C.
    // The terms of one lag share a block: the gain is the number before `*($A_INA[1]-R…)`.
    let gain: f64 = out
        .lines()
        .filter(|l| l.contains("a1_c") && l.ends_with(";DL"))
        .find_map(|l| {
            let at = l.find("*($A_INA[1]-R")?;
            let before = &l[..at];
            let start = before.rfind(['=', '+', ')']).map_or(0, |i| i + 1);
            Some(&before[start..])
        })
        .expect("a gate reads a1_c")
        .parse()
        .unwrap();
    assert!((gain - 0.004).abs() < 0.0005, "{gain}");
    insta::assert_snapshot!(inserted(&out));
    // A position column that names no axis cannot be evaluated on the machine: refused, exit 2.
    let text = std::fs::read_to_string(dir.path().join("m.toml")).unwrap();
    std::fs::write(
        dir.path().join("m.toml"),
        text.replace("\"x_mm\"", "\"pos_mm\""),
    )
    .unwrap();
    let program = Path::new(env!("CARGO_MANIFEST_DIR")).join(PROGRAM);
    let refused = common::driftloop(
        dir.path(),
        &[
            "transform",
            program.to_str().unwrap(),
            "--model",
            "m.toml",
            "--profile",
            "p.toml",
        ],
        b"",
    );
    assert_eq!(refused.status.code(), Some(2));
    assert!(common::stderr(&refused).contains("x_mm, y_mm or z_mm"));
}

/// Ambient on `$A_INA[1]`: 20 °C rising by 1 °C per 10 min.
fn ambient(t_min: f64) -> f64 {
    20.0 + t_min / 10.0
}

/// The machine's Z drift follows the ambient without lag, −1.2 µm/°C: what a `static_input` term models.
fn static_truth(axis: &str, t: f64, _: &driftloop::vm::SpindleHistory) -> f64 {
    if axis == "Z" {
        -1.2 * (ambient(t) - ambient(0.0))
    } else {
        0.0
    }
}

/// The demo program transformed with `model`, dry-run against [`static_truth`]: the largest machined error.
fn dry_run_max_error(model: &driftloop::model::DriftModel) -> f64 {
    use driftloop::omm::Profile;
    use driftloop::vm::{Config, End, SimpleMachine, run_source};
    let text = format!("{DEFAULT_PROFILE}\n[log]\ninputs = {{ ambient_c = 1 }}\n");
    let profile = Profile::from_toml(&text, "ambient.toml").unwrap();
    let bytes = driftloop::demo::transform_program(model, &profile).unwrap();
    assert_parses(std::str::from_utf8(&bytes).unwrap());
    let points = (0..=60)
        .map(|k| (10.0 * k as f64, ambient(10.0 * k as f64)))
        .collect();
    let mut machine = SimpleMachine::with_drift(static_truth).analog(1, points);
    let config = Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        probe_surface_mm: -100.0,
        ..Config::default()
    };
    let run = run_source("demo.mpf", &bytes, None, &config, &mut machine).unwrap();
    assert_eq!(run.end, End::ProgramEnd { code: "M30".into() });
    eprintln!(
        "max error {:.3} µm, max drift {:.3} µm, {} measurements",
        run.totals.max_abs_error_um,
        run.passes
            .iter()
            .map(|p| p.drift_um.abs())
            .fold(0.0, f64::max),
        run.measurements.len()
    );
    run.totals.max_abs_error_um
}

#[test]
fn dry_run_a_static_sensor_term_predicts_the_drift_between_measurements() {
    use driftloop::model::DriftModel;
    use driftloop::model::effects::{Effect, Kind};
    let blind = DriftModel::from_modes("drift_z_um", vec![], &[], 0.0);
    let mut sensor = blind.clone();
    sensor.effects.push(
        Effect {
            kind: Kind::StaticInput,
            signal: Some("ambient_c".into()),
            position: None,
            theta: vec![],
            amplitudes: vec![-1.2],
        }
        .to_spec(),
    );
    let with = dry_run_max_error(&sensor);
    let without = dry_run_max_error(&blind);
    eprintln!("with the sensor term {with:.3} µm, without {without:.3} µm");
    // Without the term nothing predicts the drift, so no measurement is triggered and the whole drift
    // reaches the part; with it the prediction follows the sensor read at every gate. A tenth of the
    // profile's 20 µm tolerance is the bound (as for the lagged inputs in transform_log).
    assert!(with < 2.0, "with the sensor term: {with} µm");
    assert!(without > 5.0 * with, "with {with}, without {without}");
}
