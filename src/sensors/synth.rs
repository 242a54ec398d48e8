//! Synthetic sensor data with a known structure, for tests and examples: two groups of three redundant
//! sensors, two irrelevant sensors, and an error that depends on one sensor of each group.

use crate::data::{Dataset, TimeUnit};
use crate::model::synth::Rng;

/// The truth behind [`dataset`]: E(i) = offset + gain_a·(a₁(i) − a₁(s)) + gain_b·(b₁(i) − b₁(s)) + noise,
/// s the first row of i's run.
#[derive(Debug, Clone, Copy)]
pub struct Truth {
    pub offset_um: f64,
    pub gain_a: f64,
    pub gain_b: f64,
    pub noise_um: f64,
}

pub const TRUTH: Truth = Truth {
    offset_um: 1.5,
    gain_a: 4.0,
    gain_b: -2.5,
    noise_um: 0.3,
};

/// The eight sensors at local times `local` (minutes since their run's start, runs `span` long):
/// `a1_c a2_c a3_c` (a warm-up), `b1_c b2_c b3_c` (a slow oscillation), `n1_c n2_c` (noise around a
/// constant). The first of each group carries the least noise.
fn sensors(rng: &mut Rng, local: &[f64], span: f64) -> Vec<(&'static str, Vec<f64>)> {
    let a: Vec<f64> = local
        .iter()
        .map(|&t| 20.0 + 3.0 * (1.0 - (-t / (0.2 * span)).exp()))
        .collect();
    let b: Vec<f64> = local
        .iter()
        .map(|&t| 22.0 + 1.5 * (2.0 * std::f64::consts::PI * t / (0.45 * span)).sin())
        .collect();
    let flat = |v: f64| vec![v; local.len()];
    let mut noisy = |base: &[f64], sd: f64| -> Vec<f64> {
        base.iter().map(|v| v + sd * rng.normal()).collect()
    };
    vec![
        ("a1_c", noisy(&a, 0.01)),
        ("a2_c", noisy(&a, 0.15)),
        ("a3_c", noisy(&a, 0.25)),
        ("b1_c", noisy(&b, 0.01)),
        ("b2_c", noisy(&b, 0.12)),
        ("b3_c", noisy(&b, 0.2)),
        ("n1_c", noisy(&flat(21.0), 0.3)),
        ("n2_c", noisy(&flat(23.0), 0.3)),
    ]
}

/// `runs` runs of `n` rows one minute apart, channel `e_um` and the eight sensors. Every run starts from
/// rest; with more than one run the runs are labelled `r1`, `r2`, ….
pub fn dataset(seed: u64, runs: usize, n: usize, truth: Truth) -> Dataset {
    let mut rng = Rng::new(seed);
    let local: Vec<f64> = (0..runs * n).map(|i| (i % n) as f64).collect();
    let sensors = sensors(&mut rng, &local, n as f64);
    let t = (0..runs * n).map(|i| i as f64).collect();
    let mut ds = Dataset::new("synthetic", TimeUnit::Min, t);
    ds.run_starts = (0..runs).map(|k| k * n).collect();
    if runs > 1 {
        ds.run_labels = Some((1..=runs).map(|k| format!("r{k}")).collect());
    }
    let (a1, b1) = (&sensors[0].1, &sensors[3].1);
    let e: Vec<f64> = (0..runs * n)
        .map(|i| {
            let start = i - i % n;
            let change = |s: &[f64]| s[i] - s[start];
            truth.offset_um
                + truth.gain_a * change(a1)
                + truth.gain_b * change(b1)
                + truth.noise_um * rng.normal()
        })
        .collect();
    ds.push_column("e_um", e);
    for (name, v) in sensors {
        ds.push_column(name, v);
    }
    ds
}

/// The truth behind [`position_dataset`]: E = E_G(p) + S·p + I with E_G = g₀ + g₁p + g₂p²,
/// S = slope_a·(a₁ − a₁ at the first step) µm/mm and I = intercept_b·(b₁ − b₁ at the first step) µm.
#[derive(Debug, Clone, Copy)]
pub struct PositionTruth {
    pub geometric: [f64; 3],
    pub slope_a: f64,
    pub intercept_b: f64,
    pub noise_um: f64,
}

pub const POSITION_TRUTH: PositionTruth = PositionTruth {
    geometric: [2.0, 0.01, -2e-5],
    slope_a: 0.02,
    intercept_b: -2.5,
    noise_um: 0.3,
};

/// `steps` thermal states 10 min apart, each measured at x_mm = 0, 50, …, 300 (rows sharing the step's
/// time, one sensor reading per state), one run.
pub fn position_dataset(seed: u64, steps: usize, truth: PositionTruth) -> Dataset {
    const POSITIONS: usize = 7;
    let mut rng = Rng::new(seed);
    let local: Vec<f64> = (0..steps).map(|k| 10.0 * k as f64).collect();
    let per_step = sensors(&mut rng, &local, 10.0 * steps as f64);
    let row_step = |i: usize| i / POSITIONS;
    let n = steps * POSITIONS;
    let mut ds = Dataset::new(
        "synthetic",
        TimeUnit::Min,
        (0..n).map(|i| local[row_step(i)]).collect(),
    );
    let x: Vec<f64> = (0..n).map(|i| 50.0 * (i % POSITIONS) as f64).collect();
    let (a1, b1) = (&per_step[0].1, &per_step[3].1);
    let g = truth.geometric;
    let e = (0..n)
        .map(|i| {
            let (k, p) = (row_step(i), x[i]);
            g[0] + g[1] * p
                + g[2] * p * p
                + truth.slope_a * (a1[k] - a1[0]) * p
                + truth.intercept_b * (b1[k] - b1[0])
                + truth.noise_um * rng.normal()
        })
        .collect();
    ds.push_column("e_um", e);
    ds.push_column("x_mm", x);
    for (name, v) in per_step {
        ds.push_column(name, (0..n).map(|i| v[row_step(i)]).collect());
    }
    ds
}
