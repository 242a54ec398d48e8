//! The model files `driftloop::sensors` writes: `predict` reproduces the regression's own prediction, the
//! files survive a byte-exact round trip, and `diagnose` refits them.

use driftloop::diagnose::{Options as DiagnoseOptions, diagnose};
use driftloop::model::DriftModel;
use driftloop::sensors::position::analyse_position;
use driftloop::sensors::synth::{POSITION_TRUTH, TRUTH, dataset, position_dataset};
use driftloop::sensors::{Options, analyse};

fn assert_same(a: &[f64], b: &[f64]) {
    assert_eq!(a.len(), b.len());
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() < 1e-9, "row {i}: {x} vs {y}");
    }
}

fn kinds(m: &DriftModel) -> Vec<(&str, Option<&str>, Option<&str>)> {
    m.effects
        .iter()
        .map(|e| (e.kind.as_str(), e.signal.as_deref(), e.position.as_deref()))
        .collect()
}

#[test]
fn predict_reproduces_the_plain_regression_with_and_without_runs() {
    for (runs, n) in [(1, 900), (3, 300)] {
        let ds = dataset(11, runs, n, TRUTH);
        let a = analyse(&ds, &Options::new("e_um")).unwrap();
        let model = a.to_model();
        assert!(model.inputs.is_empty() && model.spindle.modes.is_empty());
        assert_eq!(
            kinds(&model),
            [
                ("static_input", Some("a1_c"), None),
                ("static_input", Some("b1_c"), None)
            ]
        );
        assert_eq!(model.offset_um, a.coefficients[0].value);
        let text = model.to_toml();
        let back = DriftModel::from_toml(&text, "m.toml").unwrap();
        assert_eq!(back.to_toml(), text);
        assert_same(&back.predict(&ds).unwrap(), a.prediction());
        // The regression is the truth's form: its prediction leaves the noise.
        let e = ds.values("e_um").unwrap();
        let rms = (e
            .iter()
            .zip(a.prediction())
            .map(|(y, p)| (y - p).powi(2))
            .sum::<f64>()
            / e.len() as f64)
            .sqrt();
        assert!((rms - TRUTH.noise_um).abs() < 0.1 * TRUTH.noise_um, "{rms}");
    }
}

#[test]
fn predict_reproduces_the_position_regression() {
    let ds = position_dataset(4, 60, POSITION_TRUTH);
    let a = analyse_position(&ds, "x_mm", &Options::new("e_um")).unwrap();
    let model = a.to_model();
    assert_eq!(
        kinds(&model),
        [
            ("geometric", None, Some("x_mm")),
            ("input_slope", Some("a1_c"), Some("x_mm")),
            ("input_slope", Some("b1_c"), Some("x_mm")),
            ("static_input", Some("a1_c"), None),
            ("static_input", Some("b1_c"), None),
        ]
    );
    let text = model.to_toml();
    let back = DriftModel::from_toml(&text, "m.toml").unwrap();
    assert_eq!(back.to_toml(), text);
    let predicted = back.predict(&ds).unwrap();
    assert_same(&predicted, a.prediction());
    // The slope term carries the true S: 0.02 µm/mm per °C of a1.
    let slope_a1 = &back.effects[1].params["um_per_mm_per_unit"];
    assert!(
        (slope_a1 - POSITION_TRUTH.slope_a).abs() < 3.0 * a.slope[1].se,
        "{slope_a1}"
    );
    // Without the position column the model cannot predict: refused, not predicted without it.
    let mut bare = ds.clone();
    bare.columns.retain(|c| c.name != "x_mm");
    assert!(back.predict(&bare).is_err());
}

#[test]
fn diagnose_refits_the_regression_terms() {
    let ds = dataset(5, 1, 900, TRUTH);
    let a = analyse(&ds, &Options::new("e_um")).unwrap();
    let d = diagnose(&a.to_model(), &ds, &DiagnoseOptions::new("e_um")).unwrap();
    // The refit keeps the terms and solves their gains on all rows: the truth within a few standard errors.
    let refined = &d.refined;
    assert_eq!(kinds(refined)[..2], kinds(&a.to_model())[..]);
    for (spec, truth, c) in [
        (&refined.effects[0], TRUTH.gain_a, &a.coefficients[1]),
        (&refined.effects[1], TRUTH.gain_b, &a.coefficients[2]),
    ] {
        let gain = spec.params["gain_um_per_unit"];
        assert!((gain - truth).abs() < 4.0 * c.se, "{gain} vs {truth}");
    }
    assert!(d.after.fit.rms_um <= d.before.fit.rms_um + 1e-9);

    let ds = position_dataset(4, 60, POSITION_TRUTH);
    let a = analyse_position(&ds, "x_mm", &Options::new("e_um")).unwrap();
    let d = diagnose(&a.to_model(), &ds, &DiagnoseOptions::new("e_um")).unwrap();
    assert_eq!(kinds(&d.refined)[..5], kinds(&a.to_model())[..]);
    assert!(d.after.fit.rms_um <= d.before.fit.rms_um + 1e-9);
}

#[test]
fn model_files_of_the_earlier_static_form_still_predict_one_row_late() {
    // What `sensors -o` wrote before the static terms existed: an input with τ far below the step.
    let text = "schema = 1\nchannel = \"e_um\"\noffset_um = 1.5\n\n[spindle]\ngrid_rpm = []\n\
        interpolation = \"piecewise-linear\"\nextrapolation = \"linear-last-segment\"\nmodes = []\n\n\
        [[inputs]]\nsignal = \"a1_c\"\ntau_min = 1e-9\ngain_um_per_unit = 4.0\n";
    let model = DriftModel::from_toml(text, "old.toml").unwrap();
    let ds = dataset(2, 2, 50, TRUTH);
    let a1 = ds.values("a1_c").unwrap();
    let expected: Vec<f64> = (0..ds.len())
        .map(|i| {
            let start = i - i % 50;
            1.5 + if i == start {
                0.0
            } else {
                4.0 * (a1[i - 1] - a1[start])
            }
        })
        .collect();
    assert_same(&model.predict(&ds).unwrap(), &expected);
}
