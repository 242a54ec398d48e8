//! The first-order lag every model term is made of: dx/dt = (g − x)/τ. With the target g constant over
//! an interval of length Δt the update x ← g + (x − g)·e^(−Δt/τ) is exact, whatever Δt is.
//!
//! Convention: a row's inputs hold from that row's time until the next row's time (design.md §3, "held
//! from that row on"), so the state at row i is the state at row i−1 advanced by Δt = tᵢ − tᵢ₋₁ towards
//! the target of row i−1. Each run starts at rest: every state is zero at the run's first row.

/// e^(−Δt/τ), recomputed only when Δt changes: a constant sampling step costs one `exp` per series.
#[derive(Debug, Clone, Copy)]
pub struct Decay {
    tau: f64,
    dt: f64,
    e: f64,
}

impl Decay {
    pub fn new(tau: f64) -> Decay {
        Decay {
            tau,
            dt: 0.0,
            e: 1.0,
        }
    }

    #[inline]
    pub fn tau(&self) -> f64 {
        self.tau
    }

    /// e^(−Δt/τ).
    #[inline]
    pub fn at(&mut self, dt: f64) -> f64 {
        if dt != self.dt {
            self.dt = dt;
            self.e = (-dt / self.tau).exp();
        }
        self.e
    }
}

/// One exact step of the lag towards `target` with decay factor `e`.
#[inline]
pub fn step(x: f64, target: f64, e: f64) -> f64 {
    target + (x - target) * e
}

/// A time constant as summaries print it (`2.47 min`, `20.8 min`).
pub fn fmt_tau(tau_min: f64) -> String {
    if tau_min < 10.0 {
        format!("{tau_min:.2} min")
    } else {
        format!("{tau_min:.1} min")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_compose_exactly() {
        // Two half steps give the same state as one whole step: the update is exact, not an integrator.
        let mut d = Decay::new(30.0);
        let whole = step(1.0, 5.0, d.at(20.0));
        let e = d.at(10.0);
        let halves = step(step(1.0, 5.0, e), 5.0, e);
        assert!((whole - halves).abs() < 1e-12);
        assert!((whole - (5.0 - 4.0 * (-20.0f64 / 30.0).exp())).abs() < 1e-12);
    }
}
