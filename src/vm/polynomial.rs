//! Polynomial interpolation (POLY): each axis follows f(p) = a0 + a1·p + a2·p² + … + a5·p⁵ over the
//! parameter interval 0 ≤ p ≤ PL (PL=1 unless the block says otherwise). a0 is where the axis stands, the
//! block programs the end point f(PL) and a2 … a5 (`PO[X]=(end, a2, a3)` or `X=PO(end, a2, a3)`), and a1
//! follows from the end point; an axis named with its end point alone goes there linearly (Programming
//! Manual 03/2006, 5.5 "Polynomial interpolation (POLY, POLYPATH)").
//!
//! The dry run ends the block at the programmed end points, as the control does, and times it by the
//! length of the curve, taken as a polygon of [`SAMPLES`] points along p: the feed is the path feed along
//! the curve. The programmable frame's rotation, scale and mirror are left out of that length, and a
//! common denominator polynomial (`PO[]=(…)`, rational curves) is not supported.

/// The motion mode of POLY (modal like G1; G0 … G3 and the splines end it).
pub const POLY: u32 = 1001;

/// Points the curve's length is summed over: a cubic over one block is within 0.1 % of its length.
const SAMPLES: usize = 64;

/// One axis of a polynomial block: start and end point (mm) and the coefficients a2 … a5 (0 where not
/// programmed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisCurve {
    pub start: f64,
    pub end: f64,
    pub coefficients: [f64; 4],
}

impl AxisCurve {
    /// The axis position at parameter `p` of the interval `0 ..= pl`.
    pub fn at(&self, p: f64, pl: f64) -> f64 {
        let higher = |p: f64| {
            self.coefficients
                .iter()
                .enumerate()
                .map(|(k, a)| a * p.powi(k as i32 + 2))
                .sum::<f64>()
        };
        let a1 = (self.end - self.start - higher(pl)) / pl;
        self.start + a1 * p + higher(p)
    }
}

/// The length of the path the axes make together over `0 ..= pl`.
pub fn length(axes: &[AxisCurve], pl: f64) -> f64 {
    let point = |i: usize| {
        let p = pl * i as f64 / SAMPLES as f64;
        axes.iter().map(move |a| a.at(p, pl))
    };
    (1..=SAMPLES)
        .map(|i| {
            point(i - 1)
                .zip(point(i))
                .map(|(a, b)| (b - a).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(start: f64, end: f64, coefficients: &[f64]) -> AxisCurve {
        let mut c = [0.0; 4];
        c[..coefficients.len()].copy_from_slice(coefficients);
        AxisCurve {
            start,
            end,
            coefficients: c,
        }
    }

    #[test]
    fn the_curve_starts_where_the_axis_stands_and_ends_at_the_programmed_point() {
        let x = curve(2.0, 12.5, &[0.8, -0.2, 0.05, 0.01]);
        for pl in [1.0, 1.5, 3.0] {
            assert!((x.at(0.0, pl) - 2.0).abs() < 1e-12);
            assert!((x.at(pl, pl) - 12.5).abs() < 1e-12, "PL={pl}");
        }
    }

    #[test]
    fn a_straight_polynomial_is_as_long_as_the_line_and_a_bent_one_longer() {
        let line = [curve(0.0, 30.0, &[]), curve(0.0, 40.0, &[])];
        assert!((length(&line, 1.0) - 50.0).abs() < 1e-9);
        assert!(
            (length(&line, 2.5) - 50.0).abs() < 1e-9,
            "PL does not stretch the path"
        );
        // X goes 0 → 10 along 10·p², Y leaves 0 and comes back along 4·p² − 4·p³.
        let bent = [curve(0.0, 10.0, &[10.0]), curve(0.0, 0.0, &[4.0, -4.0])];
        let l = length(&bent, 1.0);
        // Y rises to 16/27 at p = 2/3: longer than the chord, shorter than going up and down beside it.
        assert!(l > 10.05 && l < 10.0 + 2.0 * 16.0 / 27.0, "{l}");
    }

    #[test]
    fn a_quadrant_of_a_parabola_matches_its_closed_length() {
        // y = x² for x in 0..1 as x = p, y = p²: length = (2√5 + asinh 2) / 4.
        let parabola = [curve(0.0, 1.0, &[]), curve(0.0, 1.0, &[1.0])];
        let exact = (2.0 * 5f64.sqrt() + 2f64.asinh()) / 4.0;
        assert!((length(&parabola, 1.0) - exact).abs() < 1e-3 * exact);
    }
}
