//! Issue I.8: undeclared effects harder than the library's random draw. A spindle-driven mode far slower
//! than the characterisation showed (τ 20–40 h against 4 h heating runs) and modes that cool several times
//! slower or faster than they heat; the diagnosis must bring the holdout error to at most twice the noise.

use driftloop::diagnose::scenario::{CHANNEL, Scenario, simulate};
use driftloop::diagnose::{Diagnosis, Options, diagnose};
use driftloop::model::effects::Kind;
use driftloop::model::{FitOptions, fit};

fn run(seed: u64, kind: Kind, size: f64, step_min: f64, theta: f64) -> (Scenario, Diagnosis) {
    let mut sc = Scenario::new(seed, Some(kind));
    sc.effect_size = size;
    sc.step_min = step_min;
    sc.theta = Some(theta);
    let sim = simulate(&sc).unwrap();
    let declared = fit(&sim.characterisation, &FitOptions::new(CHANNEL)).unwrap();
    let opts = Options::new(CHANNEL).holdout_from(sc.holdout_from_min);
    let d = diagnose(&declared, &sim.production, &opts).unwrap();
    eprintln!(
        "{kind:?} seed {seed} size {size} step {step_min} θ {theta}: holdout {:.3} = {:.2}× noise\n{}",
        d.after.holdout.unwrap().rms_um,
        d.after.holdout.unwrap().rms_um / sc.noise_um,
        d.human()
    );
    (sc, d)
}

#[test]
fn a_mode_far_slower_than_the_characterisation() {
    for (seed, size, step, tau) in [
        (81, 4.0, 3.0, 1200.0),
        (82, 6.0, 5.0, 1800.0),
        (83, 5.0, 4.0, 2400.0),
    ] {
        let (sc, d) = run(seed, Kind::ExtraMode, size, step, tau);
        let hold = d.after.holdout.unwrap().rms_um;
        assert!(
            hold <= 2.0 * sc.noise_um,
            "seed {seed}: holdout RMS after {hold}"
        );
    }
}

#[test]
fn modes_that_cool_much_slower_or_faster_than_they_heat() {
    for (seed, step, ratio) in [(91, 3.0, 4.0), (92, 5.0, 0.25), (93, 4.0, 3.5)] {
        let (sc, d) = run(seed, Kind::CoolingAsymmetry, 0.0, step, ratio);
        let hold = d.after.holdout.unwrap().rms_um;
        assert!(
            hold <= 2.0 * sc.noise_um,
            "seed {seed}: holdout RMS after {hold}"
        );
    }
}

/// Ten seeds per case at 4× the noise, sampling 1, 3 or 5 min; prints the holdout RMS after diagnosis in
/// multiples of the noise (docs/forward.md quotes it). Release-speed: `cargo test --release --test
/// diagnose_hard -- --ignored --nocapture`.
#[test]
#[ignore = "release-speed sweep; run explicitly"]
fn sweep() {
    let cases = [
        (Kind::CoolingAsymmetry, 3.0),
        (Kind::CoolingAsymmetry, 5.0),
        (Kind::CoolingAsymmetry, 0.2),
        (Kind::ExtraMode, 1500.0),
        (Kind::ExtraMode, 3000.0),
    ];
    for (kind, theta) in cases {
        let mut ratios = Vec::new();
        for seed in 100..110u64 {
            let mut sc = Scenario::new(seed, Some(kind));
            sc.effect_size = 4.0;
            sc.step_min = [1.0, 3.0, 5.0][(seed % 3) as usize];
            sc.theta = Some(theta);
            let sim = simulate(&sc).unwrap();
            let declared = fit(&sim.characterisation, &FitOptions::new(CHANNEL)).unwrap();
            let opts = Options::new(CHANNEL).holdout_from(sc.holdout_from_min);
            let d = diagnose(&declared, &sim.production, &opts).unwrap();
            ratios.push(d.after.holdout.unwrap().rms_um / sc.noise_um);
        }
        let within = ratios.iter().filter(|r| **r <= 2.0).count();
        let text: Vec<String> = ratios.iter().map(|r| format!("{r:.2}")).collect();
        eprintln!(
            "{kind:?} θ {theta}: {within}/10 within 2× the noise: {}",
            text.join(" ")
        );
    }
}
