//! The units the timeline counts in: time in whole ticks, and the length of a move (straight or along an
//! arc) that a feed or rapid rate turns into time.

/// The timeline counts time in whole ticks of 10^-9 min (60 ns), each block's time rounded to a tick: sums
/// of ticks do not depend on their order, so the parser can add up a run of moves on its own and the
/// timeline still equals, bit for bit, the one reading every block gives. Rounding moves a block's time by
/// at most 30 ns; a decimal tick keeps times that are whole in it (0.65 min) the same decimals in reports.
pub(super) const TICKS_PER_MIN: f64 = 1e9;

/// `minutes` in whole ticks (negative, NaN: none; beyond `u64`: the most there are).
pub(super) fn ticks(minutes: f64) -> u64 {
    (minutes * TICKS_PER_MIN + 0.5) as u64
}

/// `minutes` rounded to the nearest tick: a time derived from the timeline's (plus a measurement's time, say)
/// reported in the timeline's own steps.
pub(crate) fn on_tick(minutes: f64) -> f64 {
    ticks(minutes) as f64 / TICKS_PER_MIN
}

/// Length of the move from `a` to `b` (an axis never programmed at 0): straight, or along the arc for
/// G2/G3 (XY plane).
pub(super) fn move_length(
    motion: u32,
    a: [f64; 3],
    b: [f64; 3],
    centre: [Option<f64>; 3],
    radius: Option<f64>,
) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let straight = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if !matches!(motion, 2 | 3) {
        return straight;
    }
    let cw = motion == 2;
    let (r, sweep) = match (centre[0], centre[1], radius) {
        (i, j, _) if i.is_some() || j.is_some() => {
            let c = [a[0] + i.unwrap_or(0.0), a[1] + j.unwrap_or(0.0)];
            let r = ((a[0] - c[0]).powi(2) + (a[1] - c[1]).powi(2)).sqrt();
            let a0 = (a[1] - c[1]).atan2(a[0] - c[0]);
            let a1 = (b[1] - c[1]).atan2(b[0] - c[0]);
            let mut sweep = if cw { a0 - a1 } else { a1 - a0 };
            if sweep <= 1e-12 {
                sweep += std::f64::consts::TAU;
            }
            (r, sweep)
        }
        (_, _, Some(cr)) => {
            let chord = (d[0] * d[0] + d[1] * d[1]).sqrt();
            let r = cr.abs().max(chord / 2.0);
            let small = 2.0 * (chord / (2.0 * r)).clamp(-1.0, 1.0).asin();
            // CR < 0 selects the arc over 180°.
            (
                r,
                if cr < 0.0 {
                    std::f64::consts::TAU - small
                } else {
                    small
                },
            )
        }
        _ => return straight,
    };
    ((r * sweep).powi(2) + d[2] * d[2]).sqrt()
}
