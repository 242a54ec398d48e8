//! Spindle speed → mode target. Each mode has a steady-state gain at every characterised speed (the grid
//! nodes); 0 rpm is an implicit node with gain 0, so a stopped spindle means cooling.
//!
//! Between nodes the gain is interpolated **piecewise linearly**. Why not PCHIP (Fritsch–Carlson): the
//! interpolated gain must stay *linear in the node gains* so that fitting remains a separable least-squares
//! problem (gains solved exactly, only time constants iterated) and the fit sees the same interpolation the
//! prediction uses. Piecewise-linear interpolation is also monotone between nodes (it never overshoots the
//! node values), which is all PCHIP would add, and needs no slope assumptions the data cannot check.
//!
//! Above the top characterised speed the last segment is continued linearly (with one node: the line
//! through the origin). Heat input grows with speed, so holding the top gain would understate the drift;
//! the continuation is an extrapolation and the CLI warns whenever a schedule uses it.
//! The sign of the speed (M3/M4) is ignored: the heat does not depend on the direction.

/// The characterised speeds, ascending, all above zero.
#[derive(Debug, Clone, PartialEq)]
pub struct SpeedGrid {
    nodes: Vec<f64>,
}

/// Interpolation weights of one speed: gain = `w[0]·gain[idx[0]] + w[1]·gain[idx[1]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    pub idx: [usize; 2],
    pub w: [f64; 2],
}

impl Weights {
    const ZERO: Weights = Weights {
        idx: [0, 0],
        w: [0.0, 0.0],
    };

    /// The interpolated value for node values `gains`.
    #[inline]
    pub fn apply(&self, gains: &[f64]) -> f64 {
        self.w[0] * gains[self.idx[0]] + self.w[1] * gains[self.idx[1]]
    }
}

impl SpeedGrid {
    /// A grid from node speeds; `None` unless they are finite, positive and strictly ascending.
    pub fn new(nodes: Vec<f64>) -> Option<SpeedGrid> {
        let ok = nodes.iter().all(|n| n.is_finite() && *n > 0.0)
            && nodes.windows(2).all(|w| w[0] < w[1]);
        ok.then_some(SpeedGrid { nodes })
    }

    /// The node speeds found in logged speeds: distinct non-zero |speeds|, where values within 1 % of
    /// each other (a logged actual speed wobbling around its set value) form one node at their mean.
    pub fn from_speeds(speeds: &[f64]) -> SpeedGrid {
        let mut s: Vec<f64> = speeds
            .iter()
            .map(|v| v.abs())
            .filter(|v| *v > 0.0)
            .collect();
        s.sort_by(f64::total_cmp);
        s.dedup();
        let mut nodes = Vec::new();
        let mut cluster: Vec<f64> = Vec::new();
        for v in s {
            if let Some(&first) = cluster.first()
                && v > first * 1.01
            {
                nodes.push(cluster.iter().sum::<f64>() / cluster.len() as f64);
                cluster.clear();
            }
            cluster.push(v);
        }
        if !cluster.is_empty() {
            nodes.push(cluster.iter().sum::<f64>() / cluster.len() as f64);
        }
        SpeedGrid { nodes }
    }

    pub fn nodes(&self) -> &[f64] {
        &self.nodes
    }

    /// The highest characterised speed (0 for an empty grid).
    pub fn top(&self) -> f64 {
        self.nodes.last().copied().unwrap_or(0.0)
    }

    /// Weights of the node gains at `rpm` (see the module documentation for the rules).
    #[inline]
    pub fn weights(&self, rpm: f64) -> Weights {
        let s = rpm.abs();
        let n = &self.nodes;
        if s == 0.0 || n.is_empty() {
            return Weights::ZERO;
        }
        if s <= n[0] || n.len() == 1 {
            return Weights {
                idx: [0, 0],
                w: [s / n[0], 0.0],
            };
        }
        // First node at or above s; the last segment when s is above the top (extrapolation).
        let hi = n.partition_point(|&x| x < s).min(n.len() - 1);
        let lo = hi - 1;
        let f = (s - n[lo]) / (n[hi] - n[lo]);
        Weights {
            idx: [lo, hi],
            w: [1.0 - f, f],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> SpeedGrid {
        SpeedGrid::new(vec![1000.0, 2000.0, 4000.0]).unwrap()
    }

    #[test]
    fn interpolates_linearly_and_hits_nodes() {
        let g = [2.0, 6.0, 10.0];
        let grid = grid();
        assert_eq!(grid.weights(0.0).apply(&g), 0.0);
        assert_eq!(grid.weights(500.0).apply(&g), 1.0);
        assert_eq!(grid.weights(1000.0).apply(&g), 2.0);
        assert_eq!(grid.weights(2000.0).apply(&g), 6.0);
        assert_eq!(grid.weights(3000.0).apply(&g), 8.0);
        assert_eq!(grid.weights(-3000.0).apply(&g), 8.0);
        assert_eq!(grid.weights(4000.0).apply(&g), 10.0);
    }

    #[test]
    fn extrapolates_the_last_segment() {
        let grid = grid();
        assert_eq!(grid.weights(5000.0).apply(&[2.0, 6.0, 10.0]), 12.0);
        let single = SpeedGrid::new(vec![2000.0]).unwrap();
        assert_eq!(single.weights(3000.0).apply(&[4.0]), 6.0);
    }

    #[test]
    fn monotone_between_monotone_nodes() {
        let g = [1.0, 1.5, 7.0];
        let grid = grid();
        let mut prev = 0.0;
        for s in (0..=4000).step_by(50) {
            let v = grid.weights(s as f64).apply(&g);
            assert!(v >= prev, "{s} rpm: {v} < {prev}");
            prev = v;
        }
    }

    #[test]
    fn clusters_wobbling_speeds() {
        let grid = SpeedGrid::from_speeds(&[0.0, 2998.0, 3002.0, 3000.0, 1250.0, -1250.0, 0.0]);
        assert_eq!(grid.nodes(), &[1250.0, 3000.0]);
        assert!(SpeedGrid::new(vec![2.0, 1.0]).is_none());
    }
}
