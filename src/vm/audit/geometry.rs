//! Where a move goes relative to the probe point and the tool axis.

use std::f64::consts::TAU;

use crate::vm::interp::Movement;

/// Positions closer than this are the same (mm).
pub(super) const EPS: f64 = 1e-6;

/// Arcs are checked as chords of at most this angle (rad; 2.5°: a chord strays 0.1 % of the radius).
const ARC_STEP: f64 = TAU / 144.0;

/// The two axes (of X, Y, Z) across the measured one.
pub(super) fn plane_of(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

/// Whether a move goes straight up the tool axis `axis` (0, 1, 2 for X, Y, Z) and nowhere else.
pub(super) fn straight_up(m: &Movement, axis: usize) -> bool {
    !moves_across(m, axis) && m.to[axis] > m.from[axis] + EPS
}

/// Whether a move changes no geometry axis.
pub(super) fn stands_still(m: &Movement) -> bool {
    (0..3).all(|k| (m.to[k] - m.from[k]).abs() <= EPS)
}

/// Whether a move changes a geometry axis other than `axis`.
pub(super) fn moves_across(m: &Movement, axis: usize) -> bool {
    (0..3).any(|k| k != axis && (m.to[k] - m.from[k]).abs() > EPS)
}

/// Whether a move passes within `margin` (across the measured axis `axis`) of `point` while at or below
/// the point on the measured axis.
pub(super) fn touches(m: &Movement, point: [f64; 3], axis: usize, margin: f64) -> bool {
    let arc = match (m.motion, m.centre, m.plane) {
        (2 | 3, Some(c), [Some(p), Some(q), Some(r)]) => Some((c, [p, q, r])),
        _ => None,
    };
    let Some((centre, [p, q, r])) = arc else {
        // Lines, splines (the polygon of their points) and arcs under a rotation: the chord.
        return segment_touches(m.from, m.to, point, axis, margin);
    };
    let radius = (m.from[p] - centre[p]).hypot(m.from[q] - centre[q]);
    let rise = m.to[r] - m.from[r];
    let (i, j) = plane_of(axis);
    // Every point of the arc lies within radius + rise of the centre.
    if (point[i] - centre[i]).hypot(point[j] - centre[j]) > radius + rise.abs() + margin {
        return false;
    }
    let a0 = (m.from[q] - centre[q]).atan2(m.from[p] - centre[p]);
    let a1 = (m.to[q] - centre[q]).atan2(m.to[p] - centre[p]);
    let clockwise = m.motion == 2;
    let mut sweep = if clockwise { a0 - a1 } else { a1 - a0 }.rem_euclid(TAU);
    if sweep < 1e-12 {
        sweep = TAU;
    }
    let pieces = (sweep / ARC_STEP).ceil().max(1.0) as usize;
    let at = |k: usize| {
        let f = k as f64 / pieces as f64;
        let angle = if clockwise {
            a0 - f * sweep
        } else {
            a0 + f * sweep
        };
        let mut v = [0.0; 3];
        v[p] = centre[p] + radius * angle.cos();
        v[q] = centre[q] + radius * angle.sin();
        v[r] = m.from[r] + f * rise;
        v
    };
    (0..pieces).any(|k| segment_touches(at(k), at(k + 1), point, axis, margin))
}

/// A box in work coordinates (X, Y, Z) a cycle machines, with what it leaves standing: a box within it
/// across the tool axis, from the bottom to the top.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Machined {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// The tool axis (0, 1, 2) and the standing box's `lo`, `hi` across it.
    pub island: Option<(usize, [f64; 3], [f64; 3])>,
}

/// Whether the box reaches `point` or below it on `axis` within `margin` of it across that axis, and the
/// point does not stand on the island (deeper inside it than `margin`).
pub(super) fn box_touches(b: &Machined, point: [f64; 3], axis: usize, margin: f64) -> bool {
    if b.lo[axis] > point[axis] + EPS {
        return false;
    }
    let (i, j) = plane_of(axis);
    let outside = |k: usize| (b.lo[k] - point[k]).max(point[k] - b.hi[k]).max(0.0);
    if outside(i).hypot(outside(j)) > margin + EPS {
        return false;
    }
    match b.island {
        Some((tool_axis, lo, hi)) if tool_axis == axis => ![i, j]
            .iter()
            .all(|&k| point[k] > lo[k] + margin && point[k] < hi[k] - margin),
        _ => true,
    }
}

/// The segment's part at or below `point` on `axis`, within `margin` of it across that axis.
fn segment_touches(a: [f64; 3], b: [f64; 3], point: [f64; 3], axis: usize, margin: f64) -> bool {
    let level = point[axis] + EPS;
    let (ka, kb) = (a[axis], b[axis]);
    let (t0, t1) = match (ka <= level, kb <= level) {
        (true, true) => (0.0, 1.0),
        (false, false) => return false,
        (true, false) => (0.0, (level - ka) / (kb - ka)),
        (false, true) => ((level - ka) / (kb - ka), 1.0),
    };
    let (i, j) = plane_of(axis);
    let d = [b[i] - a[i], b[j] - a[j]];
    let to_point = [point[i] - a[i], point[j] - a[j]];
    let length2 = d[0] * d[0] + d[1] * d[1];
    let t = if length2 == 0.0 {
        t0
    } else {
        ((to_point[0] * d[0] + to_point[1] * d[1]) / length2).clamp(t0, t1)
    };
    (to_point[0] - t * d[0]).hypot(to_point[1] - t * d[1]) <= margin + EPS
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(motion: u32, from: [f64; 3], to: [f64; 3]) -> Movement {
        Movement {
            motion,
            from,
            to,
            centre: None,
            plane: [Some(0), Some(1), Some(2)],
        }
    }

    #[test]
    fn a_cut_below_the_nominal_near_the_point_touches_it() {
        let p = [0.0, 0.0, 0.0];
        assert!(touches(
            &line(1, [-10.0, 3.0, -1.0], [10.0, 3.0, -1.0]),
            p,
            2,
            5.0
        ));
        assert!(!touches(
            &line(1, [-10.0, 6.0, -1.0], [10.0, 6.0, -1.0]),
            p,
            2,
            5.0
        ));
        assert!(
            !touches(&line(1, [-10.0, 0.0, 1.0], [10.0, 0.0, 1.0]), p, 2, 5.0),
            "above the nominal"
        );
        // A ramp reaches the nominal only past X = 5: the part below it stays 5 mm or more away.
        assert!(!touches(
            &line(1, [-20.0, 0.0, 10.0], [20.0, 0.0, -10.0]),
            [-6.0, 0.0, 0.0],
            2,
            5.0
        ));
        assert!(touches(
            &line(1, [-20.0, 0.0, 10.0], [20.0, 0.0, -10.0]),
            [-4.0, 0.0, 0.0],
            2,
            5.0
        ));
    }

    #[test]
    fn arcs_are_followed_along_their_sweep() {
        // A half circle of radius 20 around the origin through Y = 20 (counter-clockwise from X20 to X-20).
        let half = Movement {
            motion: 3,
            from: [20.0, 0.0, -1.0],
            to: [-20.0, 0.0, -1.0],
            centre: Some([0.0, 0.0, -1.0]),
            plane: [Some(0), Some(1), Some(2)],
        };
        assert!(touches(&half, [0.0, 18.0, 0.0], 2, 5.0));
        assert!(
            !touches(&half, [0.0, -18.0, 0.0], 2, 5.0),
            "the other half is not cut"
        );
        assert!(
            !touches(&half, [0.0, 0.0, 0.0], 2, 5.0),
            "the centre stays 20 mm away"
        );
        let clockwise = Movement { motion: 2, ..half };
        assert!(touches(&clockwise, [0.0, -18.0, 0.0], 2, 5.0));
    }

    #[test]
    fn a_machined_box_touches_the_point_unless_it_stands_on_its_island() {
        let face = Machined {
            lo: [-10.0, -10.0, 0.0],
            hi: [130.0, 90.0, 1.0],
            island: None,
        };
        assert!(box_touches(&face, [0.0, 0.0, 0.0], 2, 5.0));
        assert!(
            !box_touches(&face, [0.0, 0.0, -0.5], 2, 5.0),
            "below the cut"
        );
        assert!(box_touches(&face, [-14.0, 0.0, 0.0], 2, 5.0));
        assert!(
            !box_touches(&face, [-14.0, -14.0, 0.0], 2, 5.0),
            "5.7 mm off the corner"
        );
        let spigot = Machined {
            island: Some((2, [20.0, 20.0, 0.0], [60.0, 60.0, 0.0])),
            ..face
        };
        assert!(
            !box_touches(&spigot, [40.0, 40.0, 0.0], 2, 5.0),
            "on the spigot"
        );
        assert!(
            box_touches(&spigot, [23.0, 40.0, 0.0], 2, 5.0),
            "at its edge"
        );
        assert!(
            box_touches(&spigot, [40.0, 40.0, 0.0], 0, 5.0),
            "measured across: the island is no help"
        );
    }

    #[test]
    fn only_a_pure_rise_along_the_tool_axis_is_straight_up() {
        assert!(straight_up(
            &line(0, [0.0, 0.0, 10.0], [0.0, 0.0, 100.0]),
            2
        ));
        assert!(!straight_up(
            &line(0, [0.0, 0.0, 10.0], [5.0, 0.0, 100.0]),
            2
        ));
        assert!(!straight_up(&line(0, [0.0, 0.0, 10.0], [0.0, 0.0, 5.0]), 2));
        // A lathe retracts along X.
        assert!(straight_up(
            &line(0, [20.0, 0.0, 10.0], [60.0, 0.0, 10.0]),
            0
        ));
        // A move to where the tool stands is neither.
        let nowhere = line(0, [1.0, 2.0, 3.0], [1.0, 2.0, 3.0]);
        assert!(stands_still(&nowhere) && !straight_up(&nowhere, 2));
        assert!(!stands_still(&line(0, [1.0, 2.0, 3.0], [1.0, 2.0, 3.1])));
    }
}
