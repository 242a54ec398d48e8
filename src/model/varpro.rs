//! Separable nonlinear least squares (variable projection) for the drift model.
//!
//! The prediction is linear in the amplitudes (mode gains at each grid speed, input gains, offset) once the
//! time constants are fixed, so for given θ = ln τ the amplitudes come from a linear least-squares solve
//! and only θ is iterated, by Levenberg–Marquardt on the projected residual with Kaufman's Jacobian
//! J = −(I − Φ Φ⁺)·∂(Φc)/∂θ. The sensitivities ∂(Φc)/∂θ are propagated exactly through the lag recursion.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};

use super::lag::Decay;
use super::speed_grid::Weights;

/// The data of one fit laid out for the recursions. The recursions run over every row (a row's inputs hold
/// until the next row, measured there or not); the least squares sees only the rows with a reading.
pub(crate) struct Problem {
    /// The readings, one per entry of `obs`.
    pub y: Vec<f64>,
    /// Row of each reading, ascending.
    pub obs: Vec<usize>,
    /// tᵢ − tᵢ₋₁ within a run (the value at a run's first row is unused).
    pub dt: Vec<f64>,
    pub runs: Vec<Range<usize>>,
    /// Interpolation weights of each row's spindle speed.
    pub w: Vec<Weights>,
    /// Grid nodes (amplitudes per spindle mode).
    pub m: usize,
    /// Each declared extra input minus its value at the run's start.
    pub u: Vec<Vec<f64>>,
}

/// Layout of θ and the amplitude vector c for K spindle modes and L inputs:
/// θ = [ln τ of modes…, ln τ of inputs…]; c = [gains of mode 1 (m)…, gains of mode K, input gains (L), offset].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    pub k: usize,
    pub l: usize,
    pub m: usize,
}

impl Layout {
    pub fn n_linear(&self) -> usize {
        self.k * self.m + self.l + 1
    }
    pub fn n_nonlinear(&self) -> usize {
        self.k + self.l
    }
}

impl Problem {
    /// Number of readings.
    pub fn n(&self) -> usize {
        self.y.len()
    }

    /// Number of rows the recursions run over.
    fn rows(&self) -> usize {
        self.dt.len()
    }

    /// The reading indices (into `y`) of each run.
    pub fn observed_runs(&self) -> Vec<Range<usize>> {
        self.runs
            .iter()
            .map(|r| {
                self.obs.partition_point(|&i| i < r.start)..self.obs.partition_point(|&i| i < r.end)
            })
            .collect()
    }

    /// Fills an N × P matrix with `fill` (which writes every row), keeping only the rows with a reading.
    pub fn observed(&self, p: usize, out: &mut DMatrix<f64>, fill: impl Fn(&mut [&mut [f64]])) {
        let rows = self.rows();
        let run_fill = |m: &mut DMatrix<f64>| {
            let mut cols: Vec<&mut [f64]> = m.as_mut_slice().chunks_mut(rows).collect();
            fill(&mut cols);
        };
        if self.n() == rows {
            if out.shape() != (rows, p) {
                *out = DMatrix::zeros(rows, p);
            }
            run_fill(out);
        } else {
            let mut full = DMatrix::zeros(rows, p);
            run_fill(&mut full);
            *out = DMatrix::from_fn(self.n(), p, |i, j| full[(self.obs[i], j)]);
        }
    }

    pub fn layout(&self, k: usize) -> Layout {
        Layout {
            k,
            l: self.u.len(),
            m: self.m,
        }
    }

    /// Unit responses of a spindle mode with time constant `tau` to each grid node's gain, into `cols`.
    pub fn spindle_columns(&self, tau: f64, cols: &mut [&mut [f64]]) {
        let mut decay = Decay::new(tau);
        let mut x = vec![0.0; self.m];
        for run in &self.runs {
            x.fill(0.0);
            for c in cols.iter_mut() {
                c[run.start] = 0.0;
            }
            for i in run.start + 1..run.end {
                let e = decay.at(self.dt[i]);
                let w = self.w[i - 1];
                for xj in x.iter_mut() {
                    *xj *= e;
                }
                x[w.idx[0]] += (1.0 - e) * w.w[0];
                x[w.idx[1]] += (1.0 - e) * w.w[1];
                for (c, xj) in cols.iter_mut().zip(&x) {
                    c[i] = *xj;
                }
            }
        }
    }

    /// Unit response of input `j` through a lag with time constant `tau`, into `col`.
    pub fn input_column(&self, j: usize, tau: f64, col: &mut [f64]) {
        let u = &self.u[j];
        let mut decay = Decay::new(tau);
        for run in &self.runs {
            let mut x = 0.0;
            col[run.start] = 0.0;
            for i in run.start + 1..run.end {
                let e = decay.at(self.dt[i]);
                x = u[i - 1] + (x - u[i - 1]) * e;
                col[i] = x;
            }
        }
    }

    /// ∂/∂ln τ of a lag's response whose target at row i is `target(i)`.
    fn sensitivity(&self, tau: f64, target: impl Fn(usize) -> f64, out: &mut [f64]) {
        let mut decay = Decay::new(tau);
        for run in &self.runs {
            let (mut x, mut d) = (0.0, 0.0);
            out[run.start] = 0.0;
            for (off, o) in out[run.start + 1..run.end].iter_mut().enumerate() {
                let i = run.start + 1 + off;
                let dt = self.dt[i];
                let e = decay.at(dt);
                let g = target(i - 1);
                d = d * e + (x - g) * e * dt / tau;
                x = g + (x - g) * e;
                *o = d;
            }
        }
    }

    /// The basis Φ (N readings × P) for time constants `theta` (ln τ).
    pub fn basis(&self, lay: Layout, theta: &[f64], phi: &mut DMatrix<f64>) {
        let p = lay.n_linear();
        self.observed(p, phi, |cols| {
            for k in 0..lay.k {
                self.spindle_columns(theta[k].exp(), &mut cols[k * lay.m..(k + 1) * lay.m]);
            }
            for j in 0..lay.l {
                self.input_column(j, theta[lay.k + j].exp(), cols[lay.k * lay.m + j]);
            }
            cols[p - 1].fill(1.0);
        });
    }

    /// ∂(Φc)/∂θ (N readings × q).
    pub fn sensitivities(&self, lay: Layout, theta: &[f64], c: &DVector<f64>) -> DMatrix<f64> {
        let mut v = DMatrix::zeros(0, 0);
        self.observed(lay.n_nonlinear(), &mut v, |cols| {
            for k in 0..lay.k {
                let gains = &c.as_slice()[k * lay.m..(k + 1) * lay.m];
                self.sensitivity(theta[k].exp(), |i| self.w[i].apply(gains), cols[k]);
            }
            for j in 0..lay.l {
                let gain = c[lay.k * lay.m + j];
                let u = &self.u[j];
                self.sensitivity(theta[lay.k + j].exp(), |i| gain * u[i], cols[lay.k + j]);
            }
        });
        v
    }
}

/// Solves the normal equations G x = b after scaling G to unit diagonal (Cholesky; SVD when G is
/// numerically singular). `None` only if the system has no usable solution.
pub(crate) fn solve_normal(gram: &DMatrix<f64>, b: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let p = gram.nrows();
    let s: Vec<f64> = (0..p)
        .map(|i| {
            let d = gram[(i, i)];
            if d > 0.0 { 1.0 / d.sqrt() } else { 1.0 }
        })
        .collect();
    let scaled = DMatrix::from_fn(p, p, |i, j| gram[(i, j)] * s[i] * s[j]);
    let sb = DMatrix::from_fn(b.nrows(), b.ncols(), |i, j| b[(i, j)] * s[i]);
    let x = match scaled.clone().cholesky() {
        Some(ch) => ch.solve(&sb),
        None => scaled.svd(true, true).solve(&sb, 1e-12).ok()?,
    };
    let x = DMatrix::from_fn(x.nrows(), x.ncols(), |i, j| x[(i, j)] * s[i]);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Amplitudes, residual and RSS at one θ.
pub(crate) struct Point {
    pub theta: Vec<f64>,
    pub c: DVector<f64>,
    pub resid: DVector<f64>,
    pub rss: f64,
}

/// Evaluates the projected problem at θ; `phi` is reused as workspace and holds Φ(θ) afterwards.
pub(crate) fn evaluate(
    p: &Problem,
    lay: Layout,
    theta: &[f64],
    phi: &mut DMatrix<f64>,
) -> Option<Point> {
    p.basis(lay, theta, phi);
    let y = DMatrix::from_column_slice(p.n(), 1, &p.y);
    let c = solve_normal(&cross(phi, phi), &cross(phi, &y))?;
    let mut resid = p.y.clone();
    subtract_combination(&mut resid, phi, c.as_slice());
    let rss = dot(&resid, &resid);
    let c = DVector::from_column_slice(c.as_slice());
    let resid = DVector::from_vec(resid);
    Some(Point {
        theta: theta.to_vec(),
        c,
        resid,
        rss,
    })
}

/// Levenberg–Marquardt on θ within `[lo, hi]` (each ln τ), from `theta0`. A parameter at a bound whose
/// step points outward is held there for that step (a simple active set).
pub(crate) fn minimise(
    p: &Problem,
    lay: Layout,
    theta0: &[f64],
    lo: f64,
    hi: f64,
) -> Option<Point> {
    let mut phi = DMatrix::zeros(0, 0);
    let mut best = evaluate(p, lay, theta0, &mut phi)?;
    let q = lay.n_nonlinear();
    if q == 0 {
        return Some(best);
    }
    let mut trial_phi = DMatrix::zeros(0, 0);
    let mut lambda = 1e-3;
    for _ in 0..60 {
        // Kaufman's Jacobian: W = (I − P_Φ) V, with V = ∂(Φc)/∂θ; the Gauss–Newton step solves WᵀW δ = Wᵀr.
        let mut w = p.sensitivities(lay, &best.theta, &best.c);
        let a = solve_normal(&cross(&phi, &phi), &cross(&phi, &w))?;
        let n = p.n();
        for (j, col) in w.as_mut_slice().chunks_mut(n).enumerate() {
            subtract_combination(col, &phi, a.column(j).as_slice());
        }
        let jtj = cross(&w, &w);
        let jtr = DVector::from_column_slice(
            cross(&w, &DMatrix::from_column_slice(n, 1, best.resid.as_slice())).as_slice(),
        );
        let mut free = vec![true; q];
        let mut accepted = None;
        for _ in 0..12 {
            let Some(delta) = damped_step(&jtj, &jtr, lambda, &free) else {
                lambda *= 10.0;
                continue;
            };
            let mut blocked = false;
            for i in 0..q {
                let t = best.theta[i] + delta[i];
                if free[i]
                    && (t < lo || t > hi)
                    && (best.theta[i] - lo).abs().min((best.theta[i] - hi).abs()) < 1e-9
                {
                    free[i] = false;
                    blocked = true;
                }
            }
            if blocked {
                continue;
            }
            let trial: Vec<f64> = (0..q)
                .map(|i| (best.theta[i] + delta[i]).clamp(lo, hi))
                .collect();
            match evaluate(p, lay, &trial, &mut trial_phi) {
                Some(pt) if pt.rss < best.rss => {
                    accepted = Some((best.rss - pt.rss) / best.rss.max(f64::MIN_POSITIVE));
                    best = pt;
                    std::mem::swap(&mut phi, &mut trial_phi);
                    lambda = (lambda * 0.25).max(1e-9);
                    break;
                }
                _ => lambda *= 4.0,
            }
        }
        match accepted {
            Some(gain) if gain > 1e-9 => {}
            _ => break,
        }
    }
    Some(best)
}

/// (JᵀJ + λ·diag JᵀJ) δ = Jᵀr over the free parameters; held ones get δ = 0.
fn damped_step(
    jtj: &DMatrix<f64>,
    jtr: &DVector<f64>,
    lambda: f64,
    free: &[bool],
) -> Option<Vec<f64>> {
    let idx: Vec<usize> = (0..free.len()).filter(|&i| free[i]).collect();
    let mut delta = vec![0.0; free.len()];
    if idx.is_empty() {
        return Some(delta);
    }
    let f = idx.len();
    let mut damped = DMatrix::from_fn(f, f, |i, j| jtj[(idx[i], idx[j])]);
    for i in 0..f {
        damped[(i, i)] += lambda * jtj[(idx[i], idx[i])].max(1e-12);
    }
    let rhs = DMatrix::from_fn(f, 1, |i, _| jtr[idx[i]]);
    let x = solve_normal(&damped, &rhs)?;
    for (k, &i) in idx.iter().enumerate() {
        delta[i] = x[k];
    }
    Some(delta)
}

// Plain-slice kernels for the products the fit needs. nalgebra's general products are fast in release
// but slow in unoptimised (test) builds; these loops are fast enough in both and keep `cargo test` short.

/// Dot product.
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut s = 0.0;
    for (x, y) in a.iter().zip(b) {
        s += x * y;
    }
    s
}

/// AᵀB for column-major A (n × p) and B (n × q).
pub(crate) fn cross(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    let n = a.nrows();
    let same = std::ptr::eq(a, b);
    let mut out = DMatrix::zeros(a.ncols(), b.ncols());
    for (i, ca) in a.as_slice().chunks(n).enumerate() {
        for (j, cb) in b.as_slice().chunks(n).enumerate() {
            if same && j < i {
                out[(i, j)] = out[(j, i)];
            } else {
                out[(i, j)] = dot(ca, cb);
            }
        }
    }
    out
}

/// y ← y − Φc.
fn subtract_combination(y: &mut [f64], phi: &DMatrix<f64>, c: &[f64]) {
    for (col, &cj) in phi.as_slice().chunks(y.len()).zip(c) {
        for (yi, v) in y.iter_mut().zip(col) {
            *yi -= cj * v;
        }
    }
}
