//! The shipped fixture is what the generator makes; model files round-trip byte for byte; unknown schemas
//! and broken models are refused.

use std::path::PathBuf;

use driftloop::data::{Require, read_path};
use driftloop::model::file::ModelFileError;
use driftloop::model::synth::{self, Rng, Sampling};
use driftloop::model::{DriftModel, FitOptions, fit};

fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/data/characterisation.csv")
}

/// The fixture's truth: τ 20 min and 120 min, gains 10 and 25 µm at 5000 rpm following a 1.4 power of speed;
/// one run per 1000…5000 rpm, 240 min heating and 240 min cooling, sampled every 5 min for the first hour
/// and every 10–20 min after, 0.3 µm noise, seed 2026.
fn generate() -> Vec<u8> {
    let speeds = [1000.0, 2000.0, 3000.0, 4000.0, 5000.0];
    let law = |amp: f64| {
        speeds
            .iter()
            .map(|s| amp * (s / 5000.0f64).powf(1.4))
            .collect::<Vec<_>>()
    };
    let truth = DriftModel::from_modes(
        "drift_z_um",
        speeds.to_vec(),
        &[(20.0, law(10.0)), (120.0, law(25.0))],
        0.0,
    );
    let mut rng = Rng::new(2026);
    let sampling = Sampling::Sparse {
        dense: 5.0,
        later: (10.0, 20.0),
    };
    let mut ds = synth::characterisation(&speeds, 240.0, 240.0, sampling, &mut rng);
    synth::measure(&truth, &mut ds, 0.3, &mut rng).unwrap();
    let mut out = Vec::new();
    ds.write_csv(&mut out).unwrap();
    out
}

/// Set DRIFTLOOP_BLESS=1 to rewrite the fixture after a deliberate change to the generator.
#[test]
fn shipped_fixture_is_reproducible() {
    let fresh = generate();
    if std::env::var_os("DRIFTLOOP_BLESS").is_some() {
        std::fs::write(fixture(), &fresh).unwrap();
    }
    let shipped = std::fs::read(fixture()).unwrap();
    assert!(
        shipped == fresh,
        "fixtures/data/characterisation.csv differs from the generator's output"
    );
}

fn fitted() -> DriftModel {
    let ds = read_path(&fixture(), Require::Displacement).unwrap();
    fit(&ds, &FitOptions::new("drift_z_um")).unwrap()
}

#[test]
fn model_file_round_trips_byte_for_byte() {
    let model = fitted();
    let text = model.to_toml();
    assert!(text.starts_with("schema = 1\n"), "{text}");
    for key in [
        "tau_min = ",
        "gain_um = ",
        "grid_rpm = ",
        "sha256 = \"",
        "rms_um = ",
        "effects = []",
    ] {
        assert!(text.contains(key), "missing {key}");
    }
    let back = DriftModel::from_toml(&text, "m.toml").unwrap();
    assert_eq!(back, model);
    assert_eq!(back.to_toml(), text);
    let data = model.data.as_ref().unwrap();
    assert_eq!(data.sha256.len(), 64);
    assert_eq!(data.rows, model.fit.as_ref().unwrap().samples);
}

#[test]
fn refuses_unknown_schema_and_broken_models() {
    let text = fitted().to_toml();
    let newer = text.replacen("schema = 1", "schema = 2", 1);
    let err = DriftModel::from_toml(&newer, "m.toml").unwrap_err();
    assert!(matches!(err, ModelFileError::Schema { found: 2, .. }));
    assert_eq!(
        err.to_string(),
        "m.toml: model file schema 2 is not supported: this driftloop reads schema 1 only"
    );
    let none = text.replacen("schema = 1\n", "", 1);
    assert_eq!(
        DriftModel::from_toml(&none, "m.toml")
            .unwrap_err()
            .to_string(),
        "m.toml: no `schema` number: not a driftloop model file"
    );
    let bad_grid = text.replacen(
        "grid_rpm = [1000.0, 2000.0,",
        "grid_rpm = [2000.0, 1000.0,",
        1,
    );
    assert!(matches!(
        DriftModel::from_toml(&bad_grid, "m.toml").unwrap_err(),
        ModelFileError::Invalid { .. }
    ));
    let bad_interp = text.replacen("\"piecewise-linear\"", "\"cubic\"", 1);
    assert!(matches!(
        DriftModel::from_toml(&bad_interp, "m.toml").unwrap_err(),
        ModelFileError::Syntax { .. }
    ));
}

#[test]
fn effects_added_later_survive_the_file() {
    let mut model = fitted();
    let mut params = std::collections::BTreeMap::new();
    params.insert("tau_min".to_string(), 30.0);
    params.insert("gain_um_per_unit".to_string(), -1.8);
    model.effects.push(driftloop::model::EffectSpec {
        kind: "input_lag".into(),
        signal: Some("ambient_c".into()),
        position: None,
        params,
    });
    let text = model.to_toml();
    assert_eq!(DriftModel::from_toml(&text, "m.toml").unwrap(), model);
}
