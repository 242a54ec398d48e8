//! Correlation and least squares for the sensor regression.

use nalgebra::{DMatrix, DVector};

/// Pearson correlation of two equally long series; 0 when either is constant (it explains nothing).
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    if a.is_empty() {
        return 0.0;
    }
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// Root mean square; 0 for an empty slice.
pub fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    }
}

/// Ordinary least squares y ≈ X·β: coefficients and their standard errors σ·√diag((XᵀX)⁻¹).
#[derive(Debug, Clone, PartialEq)]
pub struct LeastSquares {
    pub beta: Vec<f64>,
    pub se: Vec<f64>,
    /// Residual standard deviation with the coefficients' degrees of freedom removed.
    pub sigma: f64,
}

/// Solves by Householder QR, so a badly scaled design loses no more digits than it must. `None` when the
/// columns are linearly dependent or there are no more rows than columns.
pub fn least_squares(x: &DMatrix<f64>, y: &[f64]) -> Option<LeastSquares> {
    let (n, p) = x.shape();
    if n <= p || p == 0 {
        return None;
    }
    let qr = x.clone().qr();
    let r = qr.r();
    let scale = r.diagonal().amax();
    if r.diagonal().iter().any(|d| d.abs() <= scale * 1e-10) {
        return None;
    }
    let qty = qr.q().transpose() * DVector::from_column_slice(y);
    let beta = r.solve_upper_triangular(&qty)?;
    let resid = DVector::from_column_slice(y) - x * &beta;
    let sigma = (resid.norm_squared() / (n - p) as f64).sqrt();
    let r_inv = r.solve_upper_triangular(&DMatrix::identity(p, p))?;
    // (XᵀX)⁻¹ = R⁻¹R⁻ᵀ, whose diagonal is the squared row norms of R⁻¹.
    let se = (0..p).map(|i| sigma * r_inv.row(i).norm()).collect();
    Some(LeastSquares {
        beta: beta.iter().copied().collect(),
        se,
        sigma,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_of_a_line_and_its_mirror() {
        let a = [1.0, 2.0, 3.0, 4.0];
        let b = [8.0, 6.0, 4.0, 2.0];
        assert!((pearson(&a, &b) + 1.0).abs() < 1e-12);
        assert_eq!(pearson(&a, &[5.0; 4]), 0.0);
    }

    #[test]
    fn least_squares_recovers_an_exact_plane_and_its_standard_errors_shrink_with_noise() {
        let rows: Vec<[f64; 3]> = (0..20)
            .map(|i| [1.0, i as f64, ((i * 7) % 5) as f64])
            .collect();
        let x = DMatrix::from_fn(20, 3, |i, j| rows[i][j]);
        let y: Vec<f64> = rows.iter().map(|r| 2.0 + 0.5 * r[1] - 3.0 * r[2]).collect();
        let fit = least_squares(&x, &y).unwrap();
        for (b, t) in fit.beta.iter().zip([2.0, 0.5, -3.0]) {
            assert!((b - t).abs() < 1e-9, "{b} vs {t}");
        }
        assert!(fit.se.iter().all(|s| *s < 1e-9));
        let dependent = DMatrix::from_fn(20, 2, |i, _| rows[i][1]);
        assert!(least_squares(&dependent, &y).is_none());
    }
}
