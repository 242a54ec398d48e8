//! Natural cubic spline through measured means: the correction at any position between the targets.

/// Interpolating cubic spline with zero second derivative at both end nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct NaturalSpline {
    x: Vec<f64>,
    y: Vec<f64>,
    /// Second derivatives at the nodes.
    m: Vec<f64>,
}

impl NaturalSpline {
    /// `x` strictly increasing, at least two nodes (two nodes give the straight line through them).
    pub fn new(x: &[f64], y: &[f64]) -> Self {
        assert!(
            x.len() >= 2 && x.len() == y.len(),
            "a spline needs two or more (x, y) nodes"
        );
        assert!(
            x.windows(2).all(|w| w[1] > w[0]),
            "spline nodes must be strictly increasing"
        );
        let n = x.len();
        let mut m = vec![0.0; n];
        if n > 2 {
            // Tridiagonal system for the interior second derivatives, solved by the Thomas algorithm.
            let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
            let interior = n - 2;
            let mut diag = vec![0.0; interior];
            let mut rhs = vec![0.0; interior];
            for i in 0..interior {
                diag[i] = 2.0 * (h[i] + h[i + 1]);
                rhs[i] = 6.0 * ((y[i + 2] - y[i + 1]) / h[i + 1] - (y[i + 1] - y[i]) / h[i]);
            }
            for i in 1..interior {
                let factor = h[i] / diag[i - 1];
                diag[i] -= factor * h[i];
                rhs[i] -= factor * rhs[i - 1];
            }
            m[interior] = rhs[interior - 1] / diag[interior - 1];
            for i in (0..interior - 1).rev() {
                m[i + 1] = (rhs[i] - h[i + 1] * m[i + 2]) / diag[i];
            }
        }
        NaturalSpline {
            x: x.to_vec(),
            y: y.to_vec(),
            m,
        }
    }

    /// Value at `t`; outside the nodes the end value is held, as the control holds its first and last
    /// compensation values beyond the table.
    pub fn eval(&self, t: f64) -> f64 {
        let n = self.x.len();
        if t <= self.x[0] {
            return self.y[0];
        }
        if t >= self.x[n - 1] {
            return self.y[n - 1];
        }
        let i = self.segment(t);
        let h = self.x[i + 1] - self.x[i];
        let a = (self.x[i + 1] - t) / h;
        let b = (t - self.x[i]) / h;
        a * self.y[i]
            + b * self.y[i + 1]
            + ((a * a * a - a) * self.m[i] + (b * b * b - b) * self.m[i + 1]) * h * h / 6.0
    }

    /// Second derivative at `t` inside the node range (linear between the node values).
    pub fn second_derivative(&self, t: f64) -> f64 {
        let i = self.segment(t.clamp(self.x[0], self.x[self.x.len() - 1]));
        let h = self.x[i + 1] - self.x[i];
        let b = ((t - self.x[i]) / h).clamp(0.0, 1.0);
        (1.0 - b) * self.m[i] + b * self.m[i + 1]
    }

    fn segment(&self, t: f64) -> usize {
        let upper = self.x.partition_point(|&x| x <= t);
        upper.saturating_sub(1).min(self.x.len() - 2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const X: [f64; 6] = [0.0, 30.0, 50.0, 120.0, 200.0, 210.0];
    const Y: [f64; 6] = [1.0, -4.0, 9.0, 2.5, -7.0, 0.0];

    #[test]
    fn passes_through_every_node() {
        let s = NaturalSpline::new(&X, &Y);
        for (x, y) in X.iter().zip(Y) {
            assert!((s.eval(*x) - y).abs() < 1e-12, "at {x}");
        }
    }

    #[test]
    fn natural_end_conditions_and_continuity() {
        let s = NaturalSpline::new(&X, &Y);
        assert_eq!(s.second_derivative(X[0]), 0.0);
        assert!(s.second_derivative(X[5]).abs() < 1e-15);
        // First derivative continuous at interior nodes (finite differences from both sides).
        for &x in &X[1..5] {
            let d = 1e-6;
            let left = (s.eval(x) - s.eval(x - d)) / d;
            let right = (s.eval(x + d) - s.eval(x)) / d;
            assert!(
                (left - right).abs() < 1e-4,
                "kink at {x}: {left} vs {right}"
            );
        }
        assert!(
            s.second_derivative(50.0).abs() > 1e-3,
            "interior curvature must not vanish"
        );
    }

    #[test]
    fn matches_the_closed_form_for_three_equal_steps() {
        // Nodes 0, 1, 2 with values 0, 1, 0: m1 = 6·(−1 − 1)/(2·2) = −3, so s(0.5) = 0.5 + (0.5 − 0.125)·3/6.
        let s = NaturalSpline::new(&[0.0, 1.0, 2.0], &[0.0, 1.0, 0.0]);
        assert!((s.eval(0.5) - 0.6875).abs() < 1e-12);
        assert!((s.second_derivative(1.0) + 3.0).abs() < 1e-12);
    }

    #[test]
    fn reproduces_straight_lines_and_holds_ends() {
        let y: Vec<f64> = X.iter().map(|x| 0.25 * x - 3.0).collect();
        let s = NaturalSpline::new(&X, &y);
        for t in [7.0, 44.4, 133.0, 205.0] {
            assert!((s.eval(t) - (0.25 * t - 3.0)).abs() < 1e-9);
        }
        assert_eq!(s.eval(-10.0), y[0]);
        assert_eq!(s.eval(500.0), y[5]);
        let two = NaturalSpline::new(&[0.0, 10.0], &[1.0, 3.0]);
        assert!((two.eval(2.5) - 1.5).abs() < 1e-12);
    }

    proptest::proptest! {
        #[test]
        fn any_nodes_are_interpolated_with_natural_ends(
            gaps in proptest::collection::vec(0.5f64..80.0, 1..15),
            values in proptest::collection::vec(-50.0f64..50.0, 16),
        ) {
            let x: Vec<f64> = std::iter::once(0.0).chain(gaps.iter().scan(0.0, |at, gap| { *at += gap; Some(*at) })).collect();
            let y = &values[..x.len()];
            let s = NaturalSpline::new(&x, y);
            for (xi, yi) in x.iter().zip(y) {
                proptest::prop_assert!((s.eval(*xi) - yi).abs() < 1e-9);
            }
            proptest::prop_assert_eq!(s.second_derivative(x[0]), 0.0);
            proptest::prop_assert!(s.second_derivative(x[x.len() - 1]).abs() < 1e-12);
        }
    }
}
