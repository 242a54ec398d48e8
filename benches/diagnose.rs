//! Diagnosis speed: a 15 s production log of 11 000 samples with 16 candidate columns (ambient, coolant,
//! an axis position and 13 further temperatures), one undeclared input lag in it. Target: under 5 s.

use criterion::{Criterion, criterion_group, criterion_main};
use driftloop::diagnose::scenario::{CHANNEL, Scenario, simulate};
use driftloop::diagnose::{Options, diagnose};
use driftloop::model::effects::Kind;
use driftloop::model::synth::Rng;
use driftloop::model::{FitOptions, fit};

fn bench(c: &mut Criterion) {
    let mut sc = Scenario::new(7, Some(Kind::InputLag));
    sc.step_min = 0.25;
    sc.log_min = 0.25 * 10_999.0;
    sc.holdout_from_min = 2000.0;
    let sim = simulate(&sc).unwrap();
    let mut log = sim.production;
    let mut rng = Rng::new(99);
    for k in 1..=13 {
        let (period, phase) = (
            200.0 + 600.0 * rng.uniform(),
            std::f64::consts::TAU * rng.uniform(),
        );
        let v = log
            .time_min
            .iter()
            .map(|t| {
                21.0 + (std::f64::consts::TAU * t / period + phase).sin() + 0.05 * rng.normal()
            })
            .collect();
        log.push_column(&format!("t{k}_c"), v);
    }
    assert_eq!(log.len(), 11_000);
    let declared = fit(&sim.characterisation, &FitOptions::new(CHANNEL)).unwrap();
    let opts = Options::new(CHANNEL).holdout_from(sc.holdout_from_min);
    let mut group = c.benchmark_group("diagnose");
    group.sample_size(10);
    group.bench_function("11000 samples, 16 candidate columns", |b| {
        b.iter(|| diagnose(&declared, &log, &opts).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
