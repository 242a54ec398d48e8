//! `driftloop::sensors` on synthetic data whose structure is known: two groups of three redundant sensors,
//! two irrelevant sensors, an error driven by one sensor of each group.

use driftloop::sensors::synth::{TRUTH, dataset};
use driftloop::sensors::{Options, analyse};

#[test]
fn the_two_groups_are_found_one_sensor_kept_each_and_the_noise_sensors_dropped() {
    for seed in 1..=6 {
        let ds = dataset(seed, 1, 900, TRUTH);
        let a = analyse(&ds, &Options::new("e_um")).unwrap();
        let groups: Vec<Vec<&str>> = a
            .clusters
            .iter()
            .map(|c| c.sensors.iter().map(String::as_str).collect())
            .collect();
        assert_eq!(
            groups,
            vec![
                vec!["a1_c", "a2_c", "a3_c"],
                vec!["b1_c", "b2_c", "b3_c"],
                vec!["n1_c"],
                vec!["n2_c"]
            ],
            "seed {seed}"
        );
        assert_eq!(a.chosen, ["a1_c", "b1_c"], "seed {seed}");
        assert!(a.clusters[2].dropped.is_some() && a.clusters[3].dropped.is_some());
    }
}

#[test]
fn the_regression_recovers_the_true_gains_within_three_standard_errors() {
    for seed in 1..=6 {
        let ds = dataset(seed, 1, 900, TRUTH);
        let a = analyse(&ds, &Options::new("e_um")).unwrap();
        let truth = [TRUTH.offset_um, TRUTH.gain_a, TRUTH.gain_b];
        assert_eq!(a.coefficients.len(), 3);
        for (c, t) in a.coefficients.iter().zip(truth) {
            assert!(c.se > 0.0);
            assert!(
                (c.value - t).abs() <= 3.0 * c.se,
                "seed {seed}: {} = {} ± {}, truth {t}",
                c.term,
                c.value,
                c.se
            );
        }
        // The residual is the measurement noise, on the fit and on the unseen last third alike.
        for sc in [&a.fit, &a.validation.score] {
            assert!(
                (sc.residual_rms_um - TRUTH.noise_um).abs() < 0.1 * TRUTH.noise_um,
                "{sc:?}"
            );
            assert!(sc.compensation_rate > 0.9, "{sc:?}");
        }
        assert_eq!(a.validation.scheme, "time-holdout");
        assert!(a.validation.default_holdout);
    }
}

#[test]
fn leave_one_run_out_is_used_when_the_data_has_runs_and_scores_the_noise() {
    let ds = dataset(3, 3, 300, TRUTH);
    let a = analyse(&ds, &Options::new("e_um")).unwrap();
    assert_eq!(a.validation.scheme, "leave-one-run-out");
    assert_eq!(a.chosen, ["a1_c", "b1_c"]);
    assert_eq!((a.training_samples, a.validation.score.samples), (900, 900));
    let left_out = &a.validation.score;
    assert!(
        left_out.residual_rms_um >= a.fit.residual_rms_um,
        "{left_out:?}"
    );
    assert!(
        (left_out.residual_rms_um - TRUTH.noise_um).abs() < 0.15 * TRUTH.noise_um,
        "{left_out:?}"
    );
    assert!(left_out.compensation_rate > 0.8, "{left_out:?}");
}

#[test]
fn a_missing_channel_and_data_without_sensors_are_refused() {
    let ds = dataset(1, 1, 100, TRUTH);
    assert!(analyse(&ds, &Options::new("zz_um")).is_err());
    let mut bare = driftloop::data::Dataset::new("x", ds.time_unit, ds.time_min.clone());
    bare.push_column("e_um", ds.values("e_um").unwrap().to_vec());
    assert!(analyse(&bare, &Options::new("e_um")).is_err());
}

#[test]
fn with_a_position_column_the_slope_and_intercept_sensors_and_gains_are_recovered() {
    use driftloop::sensors::position::analyse_position;
    use driftloop::sensors::synth::{POSITION_TRUTH, position_dataset};
    for seed in 1..=5 {
        let ds = position_dataset(seed, 90, POSITION_TRUTH);
        let a = analyse_position(&ds, "x_mm", &Options::new("e_um")).unwrap();
        assert_eq!(a.chosen, ["a1_c", "b1_c"], "seed {seed}");
        assert_eq!(a.clusters.len(), 4, "seed {seed}");
        // S follows a1 only, I follows b1 only.
        let within =
            |c: &driftloop::sensors::Coefficient, t: f64| (c.value - t).abs() <= 3.0 * c.se;
        let (s, i) = (&a.slope, &a.intercept);
        assert!(within(&s[1], POSITION_TRUTH.slope_a), "seed {seed}: {s:?}");
        assert!(within(&s[2], 0.0), "seed {seed}: {s:?}");
        assert!(within(&i[1], 0.0), "seed {seed}: {i:?}");
        assert!(
            within(&i[2], POSITION_TRUTH.intercept_b),
            "seed {seed}: {i:?}"
        );
        // E_G comes from the seven noisy readings of one state: compared as a curve, within a few of
        // its pointwise standard errors (≈ 0.2 µm for σ = 0.3 µm).
        let poly = |c: &[f64], p: f64| c[0] + c[1] * p + c[2] * p * p;
        for p in [0.0, 100.0, 200.0, 300.0] {
            let d = poly(&a.geometric, p) - poly(&POSITION_TRUTH.geometric, p);
            assert!(d.abs() < 1.0, "seed {seed}: E_G {:?}", a.geometric);
        }
        assert!(a.fit.compensation_rate > 0.8, "seed {seed}: {:?}", a.fit);
        assert!(
            a.validation.compensation_rate > 0.8,
            "seed {seed}: {:?}",
            a.validation
        );
    }
}

#[test]
fn the_position_variant_needs_two_positions_per_step() {
    use driftloop::sensors::position::analyse_position;
    let ds = dataset(1, 1, 100, TRUTH);
    let mut with_x = ds.clone();
    with_x.push_column("x_mm", vec![10.0; 100]);
    assert!(analyse_position(&with_x, "x_mm", &Options::new("e_um")).is_err());
    assert!(analyse_position(&ds, "x_mm", &Options::new("e_um")).is_err());
}
