//! Drift model speed: fitting 11 000 samples with 3 modes (target < 1 s), the distributed-lag model over 16
//! sensors on the same 11 000 samples (target: seconds), and predicting 1 M steps (target < 50 ms). Run with
//! `cargo bench --bench model`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use driftloop::data::Dataset;
use driftloop::model::dlag::{DlagOptions, fit_dlag};
use driftloop::model::synth::{self, Rng};
use driftloop::model::{DriftModel, FitOptions, ModesChoice, Schedule, fit};

fn truth() -> DriftModel {
    let grid = vec![1250.0, 2500.0, 3750.0, 5000.0];
    let law = |amp: f64| {
        grid.iter()
            .map(|s| amp * (s / 5000.0f64).powf(1.4))
            .collect::<Vec<_>>()
    };
    DriftModel::from_modes(
        "z_um",
        grid.clone(),
        &[(8.0, law(6.0)), (45.0, law(15.0)), (240.0, law(12.0))],
        0.0,
    )
}

/// A 46 h test like the real one: 4 h at each speed, 4 h stopped between, 15 s sampling (11 041 rows).
fn eleven_thousand_samples() -> Dataset {
    let schedule: Schedule = "0:15,1250:240,0:240,2500:240,0:240,3750:240,0:240,5000:240,0:1305"
        .parse()
        .unwrap();
    let mut ds = schedule.to_dataset(0.25);
    synth::measure(&truth(), &mut ds, 0.3, &mut Rng::new(1)).unwrap();
    ds
}

/// 16 temperatures like the real test's: slow hall waves of different periods, some following the spindle.
fn with_sensors(mut ds: Dataset) -> Dataset {
    let rpm = ds.values("spindle_rpm").unwrap().to_vec();
    for k in 0..16 {
        let period = 300.0 + 97.0 * k as f64;
        let heated = 0.4 * (k % 4) as f64;
        let mut x = 0.0;
        let col: Vec<f64> = ds
            .time_min
            .iter()
            .zip(&rpm)
            .map(|(t, r)| {
                x += (heated * r / 1000.0 - x) * 0.25 / 40.0;
                25.0 + (std::f64::consts::TAU * t / period).sin() + x
            })
            .collect();
        ds.push_column(&format!("t{}_c", k + 1), col);
    }
    ds
}

fn bench(c: &mut Criterion) {
    let ds = eleven_thousand_samples();
    assert!(ds.len() > 11_000);
    let mut opts = FitOptions::new("z_um");
    opts.modes = ModesChoice::Fixed(3);
    let mut group = c.benchmark_group("fit");
    group.sample_size(10);
    group.bench_function("11k_samples_3_modes", |b| {
        b.iter(|| fit(black_box(&ds), &opts).unwrap())
    });
    opts.modes = ModesChoice::Auto;
    group.bench_function("11k_samples_auto_order", |b| {
        b.iter(|| fit(black_box(&ds), &opts).unwrap())
    });
    let sensed = with_sensors(ds.clone());
    let dlag = DlagOptions::new("z_um");
    group.bench_function("11k_samples_16_sensors_dlag", |b| {
        b.iter(|| fit_dlag(black_box(&sensed), &dlag).unwrap())
    });
    group.finish();

    let schedule: Schedule = "3000:60000,0:60000,5000:60000,1500:70000".parse().unwrap();
    let big = schedule.to_dataset(0.25);
    assert!(big.len() >= 1_000_000);
    let model = truth();
    let mut out = vec![0.0; big.len()];
    c.bench_function("predict_1m_steps_3_modes", |b| {
        b.iter(|| model.predict_into(black_box(&big), &mut out).unwrap())
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
