//! Deterministic synthetic measurement data: inputs laid out like a characterisation test, drift from a
//! known (truth) model, Gaussian noise from a seeded generator. Same seed, same bytes, on every machine
//! that computes `exp` the same way.

use crate::data::{Dataset, SPINDLE, TimeUnit};

use super::{DriftModel, PredictError};

/// The crate's one pseudo-random generator, SplitMix64: tiny, seedable, the same numbers on every machine.
/// Noise of synthetic data, simulated inputs and probes, generated benchmark programs.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// When samples are taken within a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sampling {
    /// A constant step (minutes), e.g. 0.25 for a 15 s log.
    Every(f64),
    /// The papers' manual practice: `dense` minutes apart during the first hour, then a random step drawn
    /// uniformly from `later` minutes.
    Sparse { dense: f64, later: (f64, f64) },
}

impl Sampling {
    /// Sample times in [0, `minutes`], always including both ends.
    pub fn times(&self, minutes: f64, rng: &mut Rng) -> Vec<f64> {
        let mut t = vec![0.0];
        loop {
            let last = *t.last().unwrap_or(&0.0);
            let step = match *self {
                Sampling::Every(s) => s,
                Sampling::Sparse { dense, .. } if last < 60.0 => dense,
                Sampling::Sparse { later: (a, b), .. } => a + (b - a) * rng.uniform(),
            };
            // Rounded to the second, as a logged time would be.
            let next = ((last + step) * 60.0).round() / 60.0;
            if next >= minutes - 1e-9 {
                break;
            }
            t.push(next);
        }
        t.push(minutes);
        t
    }
}

/// Characterisation runs: one run per speed, heating at that speed from cold for `heat_min`, then (if
/// `cool_min` > 0) stopped for `cool_min`; time restarts at zero in every run.
pub fn characterisation(
    speeds: &[f64],
    heat_min: f64,
    cool_min: f64,
    sampling: Sampling,
    rng: &mut Rng,
) -> Dataset {
    let mut ds = Dataset::new("synthetic", TimeUnit::Min, Vec::new());
    ds.run_starts.clear();
    let mut rpm = Vec::new();
    let mut labels = Vec::new();
    for &speed in speeds {
        ds.run_starts.push(ds.time_min.len());
        labels.push(format!("{speed}rpm"));
        for t in sampling.times(heat_min + cool_min, rng) {
            ds.time_min.push(t);
            rpm.push(if t < heat_min { speed } else { 0.0 });
        }
    }
    if ds.run_starts.is_empty() {
        ds.run_starts.push(0);
    }
    ds.run_labels = Some(labels);
    ds.push_column(SPINDLE, rpm);
    ds
}

/// Adds the truth model's drift plus N(0, `noise_um`²) noise as the model's channel, rounded to
/// 0.001 µm like a logged value.
pub fn measure(
    truth: &DriftModel,
    inputs: &mut Dataset,
    noise_um: f64,
    rng: &mut Rng,
) -> Result<(), PredictError> {
    let mut y = truth.predict(inputs)?;
    for v in &mut y {
        *v = ((*v + noise_um * rng.normal()) * 1000.0).round() / 1000.0;
    }
    inputs.push_column(&truth.channel, y);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_data() {
        let make = |seed| {
            let mut rng = Rng::new(seed);
            let sampling = Sampling::Sparse {
                dense: 5.0,
                later: (10.0, 20.0),
            };
            let mut ds = characterisation(&[1000.0, 2000.0], 240.0, 60.0, sampling, &mut rng);
            let truth = DriftModel::from_modes(
                "z_um",
                vec![1000.0, 2000.0],
                &[(30.0, vec![2.0, 5.0])],
                0.0,
            );
            measure(&truth, &mut ds, 0.3, &mut rng).unwrap();
            ds
        };
        assert_eq!(make(7), make(7));
        assert_ne!(make(7), make(8));
        let ds = make(7);
        assert_eq!(ds.run_starts.len(), 2);
        for r in ds.runs() {
            let t = &ds.time_min[r];
            assert_eq!((t[0], *t.last().unwrap()), (0.0, 300.0));
            assert!(t.windows(2).all(|w| w[1] > w[0]));
        }
    }

    #[test]
    fn normal_has_unit_variance() {
        let mut rng = Rng::new(1);
        let x: Vec<f64> = (0..20000).map(|_| rng.normal()).collect();
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / x.len() as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
    }
}
