//! Prediction: the exact update reduces to the papers' closed forms, for any sampling.

use driftloop::data::{Dataset, SPINDLE, TimeUnit};
use driftloop::model::{DriftModel, EffectSpec, PredictError, Schedule};

fn model() -> DriftModel {
    DriftModel::from_modes(
        "z_um",
        vec![1000.0, 3000.0],
        &[(12.0, vec![1.0, 4.0]), (90.0, vec![3.0, 11.0])],
        0.5,
    )
}

fn dataset(times: &[f64], rpm: &[f64]) -> Dataset {
    let mut ds = Dataset::new("test", TimeUnit::Min, times.to_vec());
    ds.push_column(SPINDLE, rpm.to_vec());
    ds
}

#[test]
fn constant_speed_from_cold_is_the_sum_of_heating_terms() {
    // Irregular times: the update is exact, so the step sizes do not matter.
    let t = [0.0, 0.3, 5.0, 5.5, 17.0, 60.0, 61.0, 200.0, 480.0];
    let ds = dataset(&t, &[3000.0; 9]);
    let y = model().predict(&ds).unwrap();
    for (ti, yi) in t.iter().zip(&y) {
        let paper = 0.5 + 4.0 * (1.0 - (-ti / 12.0).exp()) + 11.0 * (1.0 - (-ti / 90.0).exp());
        assert!((yi - paper).abs() < 1e-12, "t = {ti}: {yi} vs {paper}");
    }
}

#[test]
fn a_stop_gives_the_decaying_terms_and_interpolates_between_speeds() {
    // 2000 rpm (halfway between the nodes: gains 2.5 and 7) for 100 min, then stopped.
    let t = [0.0, 100.0, 130.0, 250.0];
    let ds = dataset(&t, &[2000.0, 0.0, 0.0, 0.0]);
    let y = model().predict(&ds).unwrap();
    let heat = |a: f64, tau: f64| a * (1.0 - (-100.0 / tau).exp());
    let (x1, x2) = (heat(2.5, 12.0), heat(7.0, 90.0));
    for (i, &ti) in t.iter().enumerate().skip(1) {
        let s = ti - 100.0;
        let expected = 0.5 + x1 * (-s / 12.0).exp() + x2 * (-s / 90.0).exp();
        assert!((y[i] - expected).abs() < 1e-12, "t = {ti}");
    }
}

#[test]
fn each_run_starts_from_rest() {
    let mut ds = dataset(&[0.0, 50.0, 0.0, 50.0], &[3000.0, 3000.0, 3000.0, 3000.0]);
    ds.run_starts = vec![0, 2];
    let y = model().predict(&ds).unwrap();
    assert_eq!(y[0], 0.5);
    assert_eq!(y[2], 0.5);
    assert_eq!(y[1], y[3]);
}

#[test]
fn schedule_prediction_matches_the_same_dataset_at_any_step() {
    let schedule: Schedule = "3000:60,0:30,1500:45".parse().unwrap();
    let coarse = model().predict(&schedule.to_dataset(15.0)).unwrap();
    let fine_ds = schedule.to_dataset(0.25);
    let fine = model().predict(&fine_ds).unwrap();
    // Both include the segment boundaries and the end; the values there agree to rounding.
    let end = *fine.last().unwrap();
    assert!((coarse.last().unwrap() - end).abs() < 1e-9);
    let at_60 = fine_ds.time_min.iter().position(|&t| t == 60.0).unwrap();
    assert!((coarse[4] - fine[at_60]).abs() < 1e-9);
}

#[test]
fn refuses_missing_inputs_and_unknown_effects() {
    let ds = Dataset::new("log.csv", TimeUnit::Min, vec![0.0, 1.0]);
    let err = model().predict(&ds).unwrap_err();
    assert!(matches!(err, PredictError::MissingInput { .. }));
    assert_eq!(
        err.to_string(),
        "log.csv: no `spindle_rpm` column, but the model of z_um takes it as an input"
    );
    let mut m = model();
    m.effects.push(EffectSpec {
        kind: "periodic".into(),
        signal: None,
        position: None,
        params: Default::default(),
    });
    let err = m.predict(&dataset(&[0.0], &[0.0])).unwrap_err();
    assert!(err.to_string().contains("`periodic` effect"), "{err}");
}
