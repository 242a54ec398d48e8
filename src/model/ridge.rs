//! Ridge regression on standardised columns, built for forward validation: the sufficient statistics
//! (sums, cross products) of a stretch of rows are added up once, so fitting on every row before an origin
//! and scoring on every row after it costs a k × k eigen-decomposition per fold, and every penalty after
//! that a few k × k products — the rows are never visited again.
//!
//! The intercept is not penalised. Each column is scaled by its standard deviation on the training rows,
//! so one penalty treats a temperature in °C and a spindle response in µm alike; a column that does not
//! vary over the training rows gets a zero coefficient (nothing can be learnt about it there).

use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// Sums over a set of rows of a design with k columns and a response y.
#[derive(Debug, Clone, PartialEq)]
pub struct Moments {
    pub n: f64,
    pub sx: DVector<f64>,
    pub sy: f64,
    pub sxx: DMatrix<f64>,
    pub sxy: DVector<f64>,
    pub syy: f64,
}

impl Moments {
    pub fn zero(k: usize) -> Moments {
        Moments {
            n: 0.0,
            sx: DVector::zeros(k),
            sy: 0.0,
            sxx: DMatrix::zeros(k, k),
            sxy: DVector::zeros(k),
            syy: 0.0,
        }
    }

    /// Moments of the rows `rows` of the column-major design `cols` (k columns of the data's length).
    pub fn of_rows(cols: &[Vec<f64>], y: &[f64], rows: &[usize]) -> Moments {
        let k = cols.len();
        let mut m = Moments::zero(k);
        m.n = rows.len() as f64;
        let mut x = vec![0.0; k];
        for &i in rows {
            for (xj, c) in x.iter_mut().zip(cols) {
                *xj = c[i];
            }
            let yi = y[i];
            m.sy += yi;
            m.syy += yi * yi;
            for a in 0..k {
                m.sx[a] += x[a];
                m.sxy[a] += x[a] * yi;
                for b in a..k {
                    m.sxx[(a, b)] += x[a] * x[b];
                }
            }
        }
        m.sxx.fill_lower_triangle_with_upper_triangle();
        m
    }

    /// The moments of the same rows with the columns `extra` appended after the columns `cols` these moments
    /// were computed from (each a column of the data's length).
    pub fn extended(
        &self,
        cols: &[Vec<f64>],
        extra: &[&[f64]],
        y: &[f64],
        rows: &[usize],
    ) -> Moments {
        let (k, e) = (cols.len(), extra.len());
        let mut m = Moments::zero(k + e);
        m.n = self.n;
        m.sy = self.sy;
        m.syy = self.syy;
        m.sx.rows_mut(0, k).copy_from(&self.sx);
        m.sxy.rows_mut(0, k).copy_from(&self.sxy);
        m.sxx.view_mut((0, 0), (k, k)).copy_from(&self.sxx);
        for &i in rows {
            for (a, ca) in extra.iter().enumerate() {
                let xa = ca[i];
                let ka = k + a;
                m.sx[ka] += xa;
                m.sxy[ka] += xa * y[i];
                for (b, cb) in cols.iter().enumerate() {
                    m.sxx[(b, ka)] += cb[i] * xa;
                }
                for (b, cb) in extra.iter().enumerate().skip(a) {
                    m.sxx[(ka, k + b)] += cb[i] * xa;
                }
            }
        }
        // The new entries went to the upper triangle; mirror them.
        for a in k..k + e {
            for b in 0..a {
                m.sxx[(a, b)] = m.sxx[(b, a)];
            }
        }
        m
    }

    /// The moments of both sets of rows together.
    pub fn plus(&self, other: &Moments) -> Moments {
        Moments {
            n: self.n + other.n,
            sx: &self.sx + &other.sx,
            sy: self.sy + other.sy,
            sxx: &self.sxx + &other.sxx,
            sxy: &self.sxy + &other.sxy,
            syy: self.syy + other.syy,
        }
    }

    /// The moments of the columns `idx` (in that order) of the same rows.
    pub fn select(&self, idx: &[usize]) -> Moments {
        Moments {
            n: self.n,
            sx: self.sx.select_rows(idx),
            sy: self.sy,
            sxx: self.sxx.select_rows(idx).select_columns(idx),
            sxy: self.sxy.select_rows(idx),
            syy: self.syy,
        }
    }

    /// Sum of squared errors of `fit` on these rows.
    pub fn sse(&self, fit: &Coefficients) -> f64 {
        let (a, b) = (fit.intercept, &fit.beta);
        let v = self.syy - 2.0 * a * self.sy - 2.0 * b.dot(&self.sxy)
            + self.n * a * a
            + 2.0 * a * b.dot(&self.sx)
            + (&self.sxx * b).dot(b);
        v.max(0.0)
    }
}

/// A fitted linear predictor: y ≈ intercept + Σ beta_j·x_j.
#[derive(Debug, Clone, PartialEq)]
pub struct Coefficients {
    pub intercept: f64,
    pub beta: DVector<f64>,
    /// Effective degrees of freedom of the penalised columns, Σ d/(d + λ) over the eigenvalues d.
    pub dof: f64,
}

/// The training moments decomposed once, ready to be solved for any penalty.
pub struct Ridge {
    mean_x: DVector<f64>,
    mean_y: f64,
    /// 1/standard deviation of each column on the training rows (0 for a constant column).
    inv_sd: DVector<f64>,
    eigen: SymmetricEigen<f64, nalgebra::Dyn>,
    /// Eigenvectors' projection of the standardised cross products.
    projected: DVector<f64>,
}

/// Columns with less relative spread than this over the training rows count as constant there.
const CONSTANT: f64 = 1e-12;

impl Ridge {
    /// `None` with fewer than two training rows.
    pub fn new(train: &Moments) -> Option<Ridge> {
        if train.n < 2.0 {
            return None;
        }
        let n = train.n;
        let mean_x = &train.sx / n;
        let mean_y = train.sy / n;
        let centred = &train.sxx - (&mean_x * mean_x.transpose()) * n;
        let cross = &train.sxy - &mean_x * (mean_y * n);
        let k = mean_x.len();
        let inv_sd = DVector::from_fn(k, |j, _| {
            let var = centred[(j, j)] / n;
            let scale = train.sxx[(j, j)] / n;
            if var > CONSTANT * scale.max(f64::MIN_POSITIVE) && var > 0.0 {
                1.0 / var.sqrt()
            } else {
                0.0
            }
        });
        let standard = DMatrix::from_fn(k, k, |a, b| centred[(a, b)] * inv_sd[a] * inv_sd[b] / n);
        let rhs = cross.component_mul(&inv_sd) / n;
        let eigen = SymmetricEigen::new(standard);
        let projected = eigen.eigenvectors.transpose() * rhs;
        Some(Ridge {
            mean_x,
            mean_y,
            inv_sd,
            eigen,
            projected,
        })
    }

    /// Coefficients for penalty `lambda` (on the standardised columns, per training row).
    pub fn solve(&self, lambda: f64) -> Coefficients {
        let d = &self.eigen.eigenvalues;
        let shrunk = DVector::from_fn(d.len(), |i, _| {
            let di = d[i].max(0.0);
            if di + lambda > 0.0 {
                self.projected[i] / (di + lambda)
            } else {
                0.0
            }
        });
        let gamma = &self.eigen.eigenvectors * shrunk;
        let beta = gamma.component_mul(&self.inv_sd);
        let dof = d
            .iter()
            .map(|&di| {
                let di = di.max(0.0);
                if di + lambda > 0.0 {
                    di / (di + lambda)
                } else {
                    0.0
                }
            })
            .sum();
        Coefficients {
            intercept: self.mean_y - self.mean_x.dot(&beta),
            beta,
            dof,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design() -> (Vec<Vec<f64>>, Vec<f64>) {
        let n = 200;
        let x1: Vec<f64> = (0..n).map(|i| (i as f64 * 0.1).sin()).collect();
        let x2: Vec<f64> = (0..n).map(|i| (i as f64 * 0.037).cos() * 5.0).collect();
        let x3 = vec![2.0; n];
        let y = (0..n)
            .map(|i| 1.5 + 2.0 * x1[i] - 0.3 * x2[i] + 0.01 * ((i * 7919 % 13) as f64 - 6.0))
            .collect();
        (vec![x1, x2, x3], y)
    }

    #[test]
    fn without_penalty_it_is_least_squares_and_constant_columns_get_nothing() {
        let (cols, y) = design();
        let rows: Vec<usize> = (0..y.len()).collect();
        let m = Moments::of_rows(&cols, &y, &rows);
        let c = Ridge::new(&m).unwrap().solve(0.0);
        assert!((c.beta[0] - 2.0).abs() < 0.01, "{}", c.beta[0]);
        assert!((c.beta[1] + 0.3).abs() < 0.01, "{}", c.beta[1]);
        assert_eq!(c.beta[2], 0.0);
        assert!((c.intercept - 1.5).abs() < 0.05);
        assert!((c.dof - 2.0).abs() < 1e-9);
        // The SSE from the moments equals the SSE over the rows.
        let direct: f64 = rows
            .iter()
            .map(|&i| {
                let p = c.intercept + c.beta[0] * cols[0][i] + c.beta[1] * cols[1][i];
                (y[i] - p).powi(2)
            })
            .sum();
        assert!((m.sse(&c) - direct).abs() < 1e-9 * (1.0 + direct));
    }

    #[test]
    fn the_penalty_shrinks_and_moments_add_up() {
        let (cols, y) = design();
        let (a, b): (Vec<usize>, Vec<usize>) = (0..y.len()).partition(|i| i % 3 == 0);
        let all: Vec<usize> = (0..y.len()).collect();
        let whole = Moments::of_rows(&cols, &y, &all);
        let parts = Moments::of_rows(&cols, &y, &a).plus(&Moments::of_rows(&cols, &y, &b));
        assert!((&whole.sxx - &parts.sxx).norm() < 1e-9);
        // Columns appended to a part's moments give the moments of the wider design.
        let first = Moments::of_rows(&cols[..1], &y, &a);
        let extra: Vec<&[f64]> = cols[1..].iter().map(Vec::as_slice).collect();
        let wide = first.extended(&cols[..1], &extra, &y, &a);
        assert_eq!(wide, Moments::of_rows(&cols, &y, &a));
        let r = Ridge::new(&whole).unwrap();
        let loose = r.solve(0.0);
        let tight = r.solve(10.0);
        assert!(tight.beta.norm() < 0.5 * loose.beta.norm());
        assert!(tight.dof < 1.0);
    }
}
