//! The drift model's fit (driftloop's own variable projection with Levenberg–Marquardt, `model::varpro`)
//! against the `varpro` crate's solver on the same separable least-squares problem: spindle modes on the
//! speed grid, each the first-order lag design.md §1 describes, plus an offset.
//!
//! The basis here is written anew from the model's definition (a mode's unit response to each grid node's
//! gain, exact for speeds held between rows, from equilibrium at each run's start) with its derivatives by
//! ln τ; only the speed grid's interpolation weights come from driftloop. driftloop fits as `fit` does
//! (a scan of starts, BIC for the order); the `varpro` crate fits the same order from a plain start.
//!
//! Tolerances, from what the solvers promise rather than from one data set:
//! - residual sum of squares within 1e-6 (relative): both stop once a step gains less than ~1e-8 of it;
//! - each τ within 1 % of the other's, and within a tenth of driftloop's standard error of τ where that
//!   is below 10 % of τ: with N readings, a τ off by z standard errors raises the RSS by about z²/N of
//!   itself, so 1e-6 of the RSS allows z ≈ 0.08 at N ≈ 6000;
//! - the fitted curves within 0.1 % of the data's range at every reading.
//!
//! Measured (`cargo test --test model_varpro_check -- --nocapture`): RSS agree to 1e-11 … 1e-14, τ to
//! 1e-5 of itself, on the synthetic case and all five real channels.

mod shared_data;

use driftloop::data::{Dataset, Require, SPINDLE, read_path};
use driftloop::model::synth::{self, Rng, Sampling};
use driftloop::model::{DriftModel, FitOptions, ModesChoice, SpeedGrid, fit};
use nalgebra_varpro::{DMatrix, DVector, Dyn, OMatrix, OVector};
use varpro::model::SeparableNonlinearModel;
use varpro::problem::SeparableProblemBuilder;
use varpro::solvers::levmar::LevMarSolver;

/// Spindle modes with time constants exp(θₖ) and an offset, on the rows of one data set.
struct SpindleModes {
    /// tᵢ − tᵢ₋₁ within a run (0 at a run's first row).
    dt: Vec<f64>,
    run_starts: Vec<usize>,
    /// The speed grid's interpolation weights of each row's speed: (node, weight) pairs.
    weights: Vec<[(usize, f64); 2]>,
    /// Grid nodes.
    m: usize,
    /// Rows with a reading, ascending.
    observed: Vec<usize>,
    theta: Vec<f64>,
}

impl SpindleModes {
    fn new(ds: &Dataset, channel: &str, theta: Vec<f64>) -> SpindleModes {
        let rpm = ds.values(SPINDLE).unwrap();
        let grid = SpeedGrid::from_speeds(rpm);
        let starts: Vec<usize> = ds.runs().map(|r| r.start).collect();
        let dt = (0..ds.len())
            .map(|i| {
                if starts.contains(&i) {
                    0.0
                } else {
                    ds.time_min[i] - ds.time_min[i - 1]
                }
            })
            .collect();
        let weights = rpm
            .iter()
            .map(|&s| {
                let w = grid.weights(s);
                [(w.idx[0], w.w[0]), (w.idx[1], w.w[1])]
            })
            .collect();
        let y = ds.values(channel).unwrap();
        SpindleModes {
            dt,
            run_starts: starts,
            weights,
            m: grid.nodes().len(),
            observed: (0..ds.len()).filter(|&i| !y[i].is_nan()).collect(),
            theta,
        }
    }

    fn target(&self, row: usize, node: usize) -> f64 {
        self.weights[row]
            .iter()
            .filter(|(j, _)| *j == node)
            .map(|(_, w)| w)
            .sum()
    }

    /// The unit response of a lag with time constant τ to node `node`'s gain at every row, and its
    /// derivative by ln τ.
    fn response(&self, tau: f64, node: usize) -> (Vec<f64>, Vec<f64>) {
        let rows = self.dt.len();
        let (mut x, mut dx) = (vec![0.0; rows], vec![0.0; rows]);
        for i in 1..rows {
            if self.run_starts.contains(&i) {
                continue;
            }
            // x(t + Δt) = g + (x − g)·e^(−Δt/τ), g the target the previous row's speed sets.
            let g = self.target(i - 1, node);
            let e = (-self.dt[i] / tau).exp();
            x[i] = g + (x[i - 1] - g) * e;
            // d/dln τ: e' = e·Δt/τ.
            dx[i] = dx[i - 1] * e + (x[i - 1] - g) * e * self.dt[i] / tau;
        }
        (x, dx)
    }

    fn columns(&self) -> usize {
        self.theta.len() * self.m + 1
    }

    /// The basis (`derivative`: None) or its derivative by θₖ, on the observed rows.
    fn matrix(&self, derivative: Option<usize>) -> OMatrix<f64, Dyn, Dyn> {
        let mut out = DMatrix::zeros(self.observed.len(), self.columns());
        for (k, &theta) in self.theta.iter().enumerate() {
            if derivative.is_some_and(|d| d != k) {
                continue;
            }
            for node in 0..self.m {
                let (x, dx) = self.response(theta.exp(), node);
                let col = if derivative.is_some() { &dx } else { &x };
                for (r, &row) in self.observed.iter().enumerate() {
                    out[(r, k * self.m + node)] = col[row];
                }
            }
        }
        if derivative.is_none() {
            out.column_mut(self.columns() - 1).fill(1.0);
        }
        out
    }
}

impl SeparableNonlinearModel for SpindleModes {
    type ScalarType = f64;
    type Error = std::convert::Infallible;

    fn parameter_count(&self) -> usize {
        self.theta.len()
    }

    fn base_function_count(&self) -> usize {
        self.columns()
    }

    fn output_len(&self) -> usize {
        self.observed.len()
    }

    fn set_params(&mut self, parameters: OVector<f64, Dyn>) -> Result<(), Self::Error> {
        self.theta = parameters.iter().copied().collect();
        Ok(())
    }

    fn params(&self) -> OVector<f64, Dyn> {
        DVector::from_vec(self.theta.clone())
    }

    fn eval(&self) -> Result<OMatrix<f64, Dyn, Dyn>, Self::Error> {
        Ok(self.matrix(None))
    }

    fn eval_partial_deriv(&self, k: usize) -> Result<OMatrix<f64, Dyn, Dyn>, Self::Error> {
        Ok(self.matrix(Some(k)))
    }
}

/// What the `varpro` crate found: time constants (ascending), RSS and the fitted curve on the observed
/// rows.
struct CrateFit {
    tau: Vec<f64>,
    rss: f64,
    curve: Vec<f64>,
}

fn crate_fit(ds: &Dataset, channel: &str, tau_start: &[f64]) -> CrateFit {
    let theta = tau_start.iter().map(|t| t.ln()).collect();
    let model = SpindleModes::new(ds, channel, theta);
    let y = ds.values(channel).unwrap();
    let observed: Vec<f64> = model.observed.iter().map(|&i| y[i]).collect();
    let problem = SeparableProblemBuilder::new(model)
        .observations(DVector::from_vec(observed.clone()))
        .build()
        .unwrap();
    let result = LevMarSolver::default()
        .fit(problem)
        .unwrap_or_else(|r| panic!("varpro did not converge: {:?}", r.minimization_report));
    let curve: Vec<f64> = result.best_fit().unwrap().iter().copied().collect();
    let rss = observed
        .iter()
        .zip(&curve)
        .map(|(a, b)| (a - b).powi(2))
        .sum();
    let mut tau: Vec<f64> = result
        .nonlinear_parameters()
        .iter()
        .map(|t| t.exp())
        .collect();
    tau.sort_by(f64::total_cmp);
    CrateFit { tau, rss, curve }
}

/// A plain start for `k` time constants, spread evenly on a log scale over 10 min … 1000 min.
fn plain_start(k: usize) -> Vec<f64> {
    (0..k)
        .map(|j| 10.0 * 100f64.powf((j as f64 + 0.5) / k as f64))
        .collect()
}

/// Fits the channel with driftloop (order `modes`), then the same order with the `varpro` crate from a
/// plain start, and checks the stated tolerances; returns driftloop's model.
fn cross_check(ds: &Dataset, channel: &str, modes: ModesChoice) -> DriftModel {
    let mut opts = FitOptions::new(channel);
    opts.modes = modes;
    let model = fit(ds, &opts).unwrap();
    let modes = model.spindle.modes.len();
    let theirs = crate_fit(ds, channel, &plain_start(modes));
    let y = ds.values(channel).unwrap();
    let ours: Vec<f64> = model.predict(ds).unwrap();
    let observed: Vec<usize> = (0..ds.len()).filter(|&i| !y[i].is_nan()).collect();
    let rss: f64 = observed.iter().map(|&i| (y[i] - ours[i]).powi(2)).sum();
    let summary = model.fit.as_ref().unwrap();
    let n = summary.samples as f64;
    assert!(
        (rss / n).sqrt() - summary.rms_um < 1e-9 * summary.rms_um.max(1.0),
        "{channel}: the model's prediction is its fit"
    );
    eprintln!(
        "{channel}, {modes} modes: τ driftloop {:?} varpro {:?}; RSS {rss:.6} vs {:.6} ({:+.2e})",
        model
            .spindle
            .modes
            .iter()
            .map(|m| m.tau_min)
            .collect::<Vec<_>>(),
        theirs.tau,
        theirs.rss,
        rss / theirs.rss - 1.0
    );
    assert!(
        (rss - theirs.rss).abs() <= 1e-6 * theirs.rss,
        "{channel}: RSS {rss} against varpro's {}",
        theirs.rss
    );
    for (m, &tau) in model.spindle.modes.iter().zip(&theirs.tau) {
        let diff = (m.tau_min - tau).abs();
        assert!(
            diff <= 0.01 * tau,
            "{channel}: τ {} against varpro's {tau}",
            m.tau_min
        );
        if let Some(se) = m.tau_se_min.filter(|se| *se < 0.1 * m.tau_min) {
            assert!(
                diff <= 0.1 * se,
                "{channel}: τ {} against varpro's {tau}, standard error {se}",
                m.tau_min
            );
        }
    }
    let (lo, hi) = observed.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &i| {
        (lo.min(y[i]), hi.max(y[i]))
    });
    let worst = observed
        .iter()
        .zip(&theirs.curve)
        .map(|(&i, v)| (ours[i] - v).abs())
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-3 * (hi - lo),
        "{channel}: curves differ by {worst} µm"
    );
    model
}

/// A known two-mode truth, characterised as the papers do (one run per speed, heating then cooling),
/// with 0.3 µm noise: both solvers find the same minimum, near the truth.
#[test]
fn synthetic_characterisation_agrees_with_varpro() {
    let speeds = [1000.0, 2000.0, 3000.0, 4000.0, 5000.0];
    let truth = DriftModel::from_modes(
        "drift_z_um",
        speeds.to_vec(),
        &[
            (12.0, speeds.iter().map(|s| 4.0 * s / 5000.0).collect()),
            (
                90.0,
                speeds
                    .iter()
                    .map(|s| 20.0 * (s / 5000.0_f64).powf(1.4))
                    .collect(),
            ),
        ],
        0.5,
    );
    let mut rng = Rng::new(17);
    let mut ds = synth::characterisation(&speeds, 240.0, 240.0, Sampling::Every(2.0), &mut rng);
    synth::measure(&truth, &mut ds, 0.3, &mut rng).unwrap();
    let model = cross_check(&ds, "drift_z_um", ModesChoice::Fixed(2));
    assert_eq!(model.spindle.modes.len(), 2);
    for (m, t) in model.spindle.modes.iter().zip(&truth.spindle.modes) {
        let se = m.tau_se_min.unwrap();
        assert!(
            (m.tau_min - t.tau_min).abs() < 4.0 * se,
            "τ {} of truth {}",
            m.tau_min,
            t.tau_min
        );
    }
}

/// The real 24 h spindle test: every channel, in the order driftloop's BIC chooses.
#[test]
fn real_thermal_data_agrees_with_varpro() {
    let Some(path) = shared_data::path("data/fl_thermal_first24h.csv") else {
        return;
    };
    let ds = read_path(&path, Require::Displacement).unwrap();
    for channel in ["ch1_um", "ch2_um", "ch3_um", "ch4_um", "ch5_um"] {
        cross_check(&ds, channel, ModesChoice::Auto);
    }
}
