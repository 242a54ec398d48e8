//! The regions the Siemens milling cycles of the original machine, in the work coordinates the probe point
//! is checked in: the dry run skips the cycles, so the probe-point check sees no moves of theirs.

use super::geometry::Machined;
use crate::MM_PER_INCH;
use crate::vm::cycle_extent::{Extent, Region, extent, pattern_extent};
use crate::vm::interp::SkippedCall;
use crate::vm::motion::{IDENTITY, State};

/// The regions of a skipped call (one, or a hole pattern's holes) in the coordinates of the settable work
/// offset (those of a `Movement`), or why they cannot be known; `None` for a call that is no milling cycle
/// (or a hole pattern that only positions).
pub(super) fn machined(call: &SkippedCall, st: &State) -> Option<Result<Vec<Machined>, String>> {
    let at = st.modal.plane.map(|a| a.map_or(0.0, |a| st.local[a]));
    let at = [at[0], at[1]];
    let region = pattern_extent(&call.name, &call.args, at, call.under.as_ref())
        .or_else(|| extent(&call.name, &call.args, call.modally, at))?;
    Some(match region {
        Extent::Known(region) => in_work_coordinates(&region, st).map(|b| vec![b]),
        Extent::Holes(holes) => holes.iter().map(|h| in_work_coordinates(h, st)).collect(),
        Extent::Unknown(why) => Err(why),
    })
}

/// The cycle's box (working plane, tool axis) through the programmable frame: the box holding its corners,
/// and what it leaves standing where the frame only translates (under a rotation the box of a standing
/// box would claim more than stands).
fn in_work_coordinates(r: &Region, st: &State) -> Result<Machined, String> {
    let frames = &st.frames;
    let geo = st
        .modal
        .plane
        .map(|a| a.and_then(|a| frames.geo.iter().position(|g| *g == Some(a))));
    let [Some(first), Some(second), Some(tool)] = geo else {
        return Err("its working plane is not one of X, Y, Z".into());
    };
    let unit = if st.modal.inch { MM_PER_INCH } else { 1.0 };
    let mut ranges = [[0.0; 2]; 3];
    ranges[first] = r.plane[0].map(|v| v * unit);
    ranges[second] = r.plane[1].map(|v| v * unit);
    ranges[tool] = r.depth.map(|v| v * unit);
    let shift: [f64; 3] = std::array::from_fn(|k| frames.geo[k].map_or(0.0, |a| frames.trans[a]));
    let linear = frames.linear.unwrap_or(IDENTITY);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for corner in 0..8 {
        let p: [f64; 3] = std::array::from_fn(|k| ranges[k][(corner >> k) & 1]);
        for k in 0..3 {
            let v = shift[k] + (0..3).map(|j| linear[k][j] * p[j]).sum::<f64>();
            lo[k] = lo[k].min(v);
            hi[k] = hi[k].max(v);
        }
    }
    let island = r.island.filter(|_| frames.linear.is_none()).map(|[a, b]| {
        let (mut ilo, mut ihi) = (lo, hi);
        for (k, range) in [(first, a), (second, b)] {
            ilo[k] = shift[k] + range[0] * unit;
            ihi[k] = shift[k] + range[1] * unit;
        }
        (tool, ilo, ihi)
    });
    Ok(Machined { lo, hi, island })
}
