//! One test per effect of the candidate library and a control: the declared model is fitted on simulated
//! characterisation runs, a simulated production log carrying one undeclared effect (or none) is
//! diagnosed with a holdout, and the diagnosis must (a) name the injected kind (and signal), (b) bring the
//! holdout RMS to at most twice the injected noise, (c) in the control, blame no column.
//! Seeds, effect sizes (3–8× the noise) and sampling steps vary across cases.

use driftloop::diagnose::scenario::{CHANNEL, Scenario, simulate};
use driftloop::diagnose::{Diagnosis, Options, diagnose};
use driftloop::model::effects::Kind;
use driftloop::model::{FitOptions, fit};

fn run(seed: u64, kind: Option<Kind>, size: f64, step_min: f64) -> (Scenario, Diagnosis) {
    let mut sc = Scenario::new(seed, kind);
    sc.effect_size = size;
    sc.step_min = step_min;
    let sim = simulate(&sc).unwrap();
    let declared = fit(&sim.characterisation, &FitOptions::new(CHANNEL)).unwrap();
    let opts = Options::new(CHANNEL).holdout_from(sc.holdout_from_min);
    let d = diagnose(&declared, &sim.production, &opts).unwrap();
    eprintln!(
        "{:?} seed {seed} size {size} step {step_min}\n{}",
        kind,
        d.human()
    );
    (sc, d)
}

fn check(kind: Kind, signal: Option<&str>, cases: &[(u64, f64, f64)]) {
    for &(seed, size, step) in cases {
        let (sc, d) = run(seed, Some(kind), size, step);
        let first = d
            .effects_added
            .first()
            .unwrap_or_else(|| panic!("seed {seed}: nothing found"));
        assert_eq!(first.effect.kind, kind, "seed {seed}");
        if let Some(sig) = signal {
            assert_eq!(first.effect.signal.as_deref(), Some(sig), "seed {seed}");
        }
        let hold = d.after.holdout.unwrap().rms_um;
        assert!(
            hold <= 2.0 * sc.noise_um,
            "seed {seed}: holdout RMS after {hold}"
        );
    }
}

#[test]
fn control_blames_no_column() {
    for (seed, step) in [(1, 3.0), (2, 5.0), (3, 4.0), (4, 0.5)] {
        let (sc, d) = run(seed, None, 0.0, step);
        assert!(
            d.effects_added.iter().all(|a| a.effect.signal.is_none()),
            "seed {seed}: {:?}",
            d.effects_added
        );
        assert!(d.after.holdout.unwrap().rms_um <= 2.0 * sc.noise_um);
    }
}

#[test]
fn input_lag_of_an_undeclared_temperature() {
    // The scenario picks ambient_c or coolant_c from the seed; the one it picked must be found.
    for (seed, size, step) in [(11, 3.0, 3.0), (12, 6.0, 5.0), (13, 4.0, 4.0)] {
        let mut sc = Scenario::new(seed, Some(Kind::InputLag));
        sc.effect_size = size;
        sc.step_min = step;
        let injected = simulate(&sc).unwrap().truth.effects[0].signal.clone();
        let (_, d) = run(seed, Some(Kind::InputLag), size, step);
        assert_eq!(d.effects_added[0].effect.kind, Kind::InputLag);
        assert_eq!(d.effects_added[0].effect.signal, injected);
        assert!(d.after.holdout.unwrap().rms_um <= 0.6);
    }
}

#[test]
fn extra_mode_slower_than_the_characterisation_showed() {
    check(Kind::ExtraMode, None, &[(21, 4.0, 3.0), (22, 8.0, 5.0)]);
}

#[test]
fn cooling_asymmetry() {
    check(
        Kind::CoolingAsymmetry,
        None,
        &[(31, 0.0, 3.0), (32, 0.0, 4.0)],
    );
}

#[test]
fn position_slope_with_an_axis_position() {
    check(
        Kind::PositionSlope,
        Some("x_mm"),
        &[(41, 3.0, 3.0), (42, 6.0, 5.0)],
    );
}

#[test]
fn time_trend() {
    check(Kind::TimeTrend, None, &[(51, 3.0, 3.0), (52, 6.0, 5.0)]);
}

#[test]
fn periodic_daily_cycle() {
    check(Kind::Periodic, None, &[(61, 4.0, 3.0), (62, 8.0, 5.0)]);
}

#[test]
fn step_offset() {
    check(Kind::Step, None, &[(71, 3.0, 3.0), (72, 6.0, 5.0)]);
}
