//! Synthetic sensor data with a known structure, for tests and examples: two groups of three redundant
//! sensors, two irrelevant sensors, and an error that depends on one sensor of each group.

use crate::data::{Dataset, TimeUnit};
use crate::model::synth::Rng;

/// The truth behind [`dataset`]: E(i) = offset + gain_a·(a₁(i−1) − a₁(s)) + gain_b·(b₁(i−1) − b₁(s)) + noise,
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

/// `runs` runs of `n` rows one minute apart, channel `e_um`, sensors `a1_c a2_c a3_c` (a warm-up),
/// `b1_c b2_c b3_c` (a slow oscillation) and `n1_c n2_c` (noise around a constant). Every run starts
/// from rest; with more than one run the runs are labelled `r1`, `r2`, ….
pub fn dataset(seed: u64, runs: usize, n: usize, truth: Truth) -> Dataset {
    let mut rng = Rng::new(seed);
    let span = n as f64;
    let local: Vec<f64> = (0..runs * n).map(|i| (i % n) as f64).collect();
    let a: Vec<f64> = local
        .iter()
        .map(|&t| 20.0 + 3.0 * (1.0 - (-t / (0.2 * span)).exp()))
        .collect();
    let b: Vec<f64> = local
        .iter()
        .map(|&t| 22.0 + 1.5 * (2.0 * std::f64::consts::PI * t / (0.45 * span)).sin())
        .collect();
    let t = (0..runs * n).map(|i| i as f64).collect();
    let mut ds = Dataset::new("synthetic", TimeUnit::Min, t);
    ds.run_starts = (0..runs).map(|k| k * n).collect();
    if runs > 1 {
        ds.run_labels = Some((1..=runs).map(|k| format!("r{k}")).collect());
    }
    let n = runs * n;
    let mut noisy = |base: &[f64], sd: f64| -> Vec<f64> {
        base.iter().map(|v| v + sd * rng.normal()).collect()
    };
    let sensors = [
        ("a1_c", noisy(&a, 0.01)),
        ("a2_c", noisy(&a, 0.15)),
        ("a3_c", noisy(&a, 0.25)),
        ("b1_c", noisy(&b, 0.01)),
        ("b2_c", noisy(&b, 0.12)),
        ("b3_c", noisy(&b, 0.2)),
        ("n1_c", noisy(&[21.0; 1].repeat(n), 0.3)),
        ("n2_c", noisy(&[23.0; 1].repeat(n), 0.3)),
    ];
    let (a1, b1) = (&sensors[0].1, &sensors[3].1);
    let e: Vec<f64> = (0..n)
        .map(|i| {
            let start = i - i % span as usize;
            let lagged = |s: &[f64]| if i == start { 0.0 } else { s[i - 1] - s[start] };
            truth.offset_um
                + truth.gain_a * lagged(a1)
                + truth.gain_b * lagged(b1)
                + truth.noise_um * rng.normal()
        })
        .collect();
    ds.push_column("e_um", e);
    for (name, v) in sensors {
        ds.push_column(name, v);
    }
    ds
}
