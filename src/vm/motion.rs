//! Axis positions, frames and move geometry.
//!
//! Positions are kept twice per axis: the last programmed position in the work coordinate system ("local") and
//! the commanded machine position. Machine = local + active settable frame (`$P_UIFR[n]` selected by G54…)
//! plus programmable translation (TRANS / ATRANS). An axis that is not programmed does not move when a frame
//! changes; its next incremental move traverses the change (MD42440 FRAME_OFFSET_INCR_PROG = 1, the default).
//! A write to `$P_UIFR` changes the stored frame only: it acts once the work offset is selected again, as on
//! the control.

/// Number of settable frames, `$P_UIFR[0]` (G500) … `$P_UIFR[99]`.
pub const FRAMES: usize = 100;

/// The motion mode of BSPLINE / ASPLINE / CSPLINE (modal like G1). The dry run times a spline by the polygon
/// through its programmed points, an approximation: the curve is shorter (B spline) or close to it.
pub const SPLINE: u32 = 1000;

/// How an axis value in a block is meant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dim {
    Modal,
    Absolute,
    Incremental,
}

#[derive(Debug, Clone)]
pub struct Frames {
    /// `$P_UIFR[n, axis, TR]`.
    pub table: Vec<Vec<f64>>,
    /// `$P_UIFR[n, axis, FI]`: the fine offset, added to the coarse one.
    pub fine: Vec<Vec<f64>>,
    /// Coarse plus fine offset of each frame at program start (corrections are measured against it).
    pub initial: Vec<Vec<f64>>,
    /// Selected frame number (0 = G500).
    pub selected: usize,
    /// Copy of the selected frame made at selection.
    pub active: Vec<f64>,
    /// Programmable translation (TRANS / ATRANS).
    pub trans: Vec<f64>,
    /// Count the programmable translation as a correction too (for programs corrected through ATRANS).
    pub trans_is_correction: bool,
}

impl Frames {
    pub fn new(axes: usize) -> Self {
        Frames {
            table: vec![vec![0.0; axes]; FRAMES],
            fine: vec![vec![0.0; axes]; FRAMES],
            initial: vec![vec![0.0; axes]; FRAMES],
            selected: 0,
            active: vec![0.0; axes],
            trans: vec![0.0; axes],
            trans_is_correction: false,
        }
    }

    pub fn select(&mut self, n: usize) {
        self.selected = n;
        self.active = self.total(n);
    }

    /// Coarse plus fine offset of frame `n`.
    pub fn total(&self, n: usize) -> Vec<f64> {
        self.table[n]
            .iter()
            .zip(&self.fine[n])
            .map(|(c, f)| c + f)
            .collect()
    }

    /// Remembers the current table as the start state.
    pub fn mark_initial(&mut self) {
        self.initial = (0..FRAMES).map(|n| self.total(n)).collect();
    }

    /// Total offset of `axis` (local → machine).
    pub fn offset(&self, axis: usize) -> f64 {
        self.active[axis] + self.trans[axis]
    }

    /// How far the active settable frame has been corrected since program start, along `axis` (mm).
    pub fn correction(&self, axis: usize) -> f64 {
        let programmable = if self.trans_is_correction {
            self.trans[axis]
        } else {
            0.0
        };
        self.active[axis] - self.initial[self.selected][axis] + programmable
    }
}

/// Modal G-code state.
#[derive(Debug, Clone)]
pub struct Modal {
    pub motion: u32,
    pub absolute: bool,
    /// Plane axes (first, second, infeed) as indices into the axis list; G17 = X Y Z.
    pub plane: [Option<usize>; 3],
    pub feed: Option<f64>,
    pub feed_per_rev: bool,
    /// G70 / G700: lengths in inch (G700 also the feed).
    pub inch: bool,
    pub inch_feed: bool,
}

/// What `PROC … SAVE` restores on return: modal G codes and frames.
#[derive(Debug, Clone)]
pub struct Saved {
    modal: Modal,
    selected: usize,
    active: Vec<f64>,
    trans: Vec<f64>,
}

/// Positions, modal state, spindle and tool of the virtual machine.
#[derive(Debug, Clone)]
pub struct State {
    pub local: Vec<f64>,
    pub machine: Vec<f64>,
    /// Bit i set once axis i has been programmed.
    pub moved: u64,
    pub modal: Modal,
    pub frames: Frames,
    /// Programmed S (rpm) and rotation (3 = M3, 4 = M4, 0 = stopped).
    pub s: f64,
    pub rotation: u32,
    pub tool_number: f64,
    pub pending_tool: Option<f64>,
    pub d: f64,
}

impl State {
    pub fn new(axes: usize) -> Self {
        State {
            local: vec![0.0; axes],
            machine: vec![0.0; axes],
            moved: 0,
            modal: Modal {
                motion: 0,
                absolute: true,
                plane: [Some(0), Some(1), Some(2)],
                feed: None,
                feed_per_rev: false,
                inch: false,
                inch_feed: false,
            },
            frames: Frames::new(axes),
            s: 0.0,
            rotation: 0,
            tool_number: 0.0,
            pending_tool: None,
            d: 0.0,
        }
    }

    pub fn spindle_rpm(&self) -> f64 {
        if self.rotation == 0 { 0.0 } else { self.s }
    }

    /// Snapshot for `PROC … SAVE`.
    pub fn save(&self) -> Saved {
        Saved {
            modal: self.modal.clone(),
            selected: self.frames.selected,
            active: self.frames.active.clone(),
            trans: self.frames.trans.clone(),
        }
    }

    pub fn restore(&mut self, saved: Saved) {
        self.modal = saved.modal;
        self.frames.selected = saved.selected;
        self.frames.active = saved.active;
        self.frames.trans = saved.trans;
    }
}

/// Length of an arc move (helix when the infeed axis moves too).
#[derive(Debug, Clone, Copy)]
pub struct ArcSpec {
    pub clockwise: bool,
    /// Centre offsets (I, J, K along the plane's first, second axis), relative to the start point unless
    /// `centre_absolute`.
    pub centre: Option<[f64; 2]>,
    pub centre_absolute: bool,
    pub radius: Option<f64>,
}

/// Arc length from `start` to `end` in the plane (2-D points), with `rise` along the infeed axis.
pub fn arc_length(arc: &ArcSpec, start: [f64; 2], end: [f64; 2], rise: f64) -> Result<f64, String> {
    let sweep_and_radius = match (arc.centre, arc.radius) {
        (Some(c), _) => {
            let centre = if arc.centre_absolute {
                c
            } else {
                [start[0] + c[0], start[1] + c[1]]
            };
            let r0 = (start[0] - centre[0]).hypot(start[1] - centre[1]);
            let r1 = (end[0] - centre[0]).hypot(end[1] - centre[1]);
            if r0 < 1e-9 {
                return Err("arc radius is zero".into());
            }
            // The control's tolerance for the end point (MD21000 CIRCLE_ERROR_CONST, default 0.01 mm).
            if (r0 - r1).abs() > 0.01 + 0.001 * r0 {
                return Err(format!(
                    "end point is not on the circle: radius {r0:.3} at the start, {r1:.3} at the end (alarm 14040)"
                ));
            }
            let a0 = (start[1] - centre[1]).atan2(start[0] - centre[0]);
            let a1 = (end[1] - centre[1]).atan2(end[0] - centre[0]);
            let mut sweep = if arc.clockwise { a0 - a1 } else { a1 - a0 };
            sweep = sweep.rem_euclid(std::f64::consts::TAU);
            if sweep < 1e-12 {
                sweep = std::f64::consts::TAU;
            }
            (sweep, r0)
        }
        (None, Some(cr)) => {
            let chord = (end[0] - start[0]).hypot(end[1] - start[1]);
            let r = cr.abs();
            if chord > 2.0 * r + 1e-6 {
                return Err(format!(
                    "CR={cr} is smaller than half the distance {chord:.3} between start and end"
                ));
            }
            let half = (chord / (2.0 * r)).min(1.0).asin();
            let sweep = if cr >= 0.0 {
                2.0 * half
            } else {
                std::f64::consts::TAU - 2.0 * half
            };
            (sweep, r)
        }
        (None, None) => return Err("circle without centre (I, J, K) or radius (CR=)".into()),
    };
    let (sweep, r) = sweep_and_radius;
    Ok((sweep * r).hypot(rise))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arc(clockwise: bool, centre: Option<[f64; 2]>, radius: Option<f64>) -> ArcSpec {
        ArcSpec {
            clockwise,
            centre,
            centre_absolute: false,
            radius,
        }
    }

    #[test]
    fn half_circle_by_centre_in_both_directions() {
        let pi = std::f64::consts::PI;
        let l = arc_length(
            &arc(true, Some([50.0, 0.0]), None),
            [0.0, 0.0],
            [100.0, 0.0],
            0.0,
        );
        assert!((l.unwrap() - 50.0 * pi).abs() < 1e-9);
        let l = arc_length(
            &arc(false, Some([50.0, 0.0]), None),
            [0.0, 0.0],
            [100.0, 0.0],
            0.0,
        );
        assert!((l.unwrap() - 50.0 * pi).abs() < 1e-9);
    }

    #[test]
    fn quarter_circle_direction_matters() {
        let pi = std::f64::consts::PI;
        // From (10,0) to (0,10) around the origin: counter-clockwise a quarter, clockwise three quarters.
        let ccw = arc_length(
            &arc(false, Some([-10.0, 0.0]), None),
            [10.0, 0.0],
            [0.0, 10.0],
            0.0,
        );
        let cw = arc_length(
            &arc(true, Some([-10.0, 0.0]), None),
            [10.0, 0.0],
            [0.0, 10.0],
            0.0,
        );
        assert!((ccw.unwrap() - 5.0 * pi).abs() < 1e-9);
        assert!((cw.unwrap() - 15.0 * pi).abs() < 1e-9);
    }

    #[test]
    fn full_circle_and_helix() {
        let pi = std::f64::consts::PI;
        let l = arc_length(
            &arc(true, Some([5.0, 0.0]), None),
            [0.0, 0.0],
            [0.0, 0.0],
            0.0,
        );
        assert!((l.unwrap() - 10.0 * pi).abs() < 1e-9);
        let l = arc_length(
            &arc(true, Some([5.0, 0.0]), None),
            [0.0, 0.0],
            [0.0, 0.0],
            3.0,
        );
        assert!((l.unwrap() - (10.0 * pi).hypot(3.0)).abs() < 1e-9);
    }

    #[test]
    fn radius_form_picks_short_or_long_arc() {
        let pi = std::f64::consts::PI;
        let short = arc_length(&arc(true, None, Some(10.0)), [0.0, 0.0], [20.0, 0.0], 0.0);
        assert!((short.unwrap() - 10.0 * pi).abs() < 1e-9);
        let chord = 10.0 * 2f64.sqrt();
        let long = arc_length(&arc(true, None, Some(-10.0)), [0.0, 0.0], [chord, 0.0], 0.0);
        assert!((long.unwrap() - 15.0 * pi).abs() < 1e-6);
        assert!(arc_length(&arc(true, None, Some(5.0)), [0.0, 0.0], [20.0, 0.0], 0.0).is_err());
    }

    #[test]
    fn end_point_off_the_circle_is_an_error() {
        let e = arc_length(
            &arc(true, Some([50.0, 0.0]), None),
            [0.0, 0.0],
            [90.0, 0.0],
            0.0,
        );
        assert!(e.unwrap_err().contains("14040"));
        assert!(arc_length(&arc(true, None, None), [0.0; 2], [1.0, 0.0], 0.0).is_err());
    }

    #[test]
    fn correction_is_measured_against_the_start_table() {
        let mut f = Frames::new(3);
        f.table[1][2] = -100.0;
        f.mark_initial();
        f.select(1);
        f.table[1][2] = -100.02;
        assert_eq!(
            f.correction(2),
            0.0,
            "a write acts only when the frame is selected again"
        );
        f.select(1);
        assert!((f.correction(2) + 0.02).abs() < 1e-12);
        f.trans[2] = 1.0;
        assert!((f.offset(2) + 99.02).abs() < 1e-12);
        assert!(
            (f.correction(2) + 0.02).abs() < 1e-12,
            "TRANS is programmed geometry"
        );
        f.trans_is_correction = true;
        assert!((f.correction(2) - 0.98).abs() < 1e-12);
        f.fine[1][2] = 0.005;
        f.select(1);
        assert!(
            (f.correction(2) - 0.985).abs() < 1e-12,
            "the fine offset adds to the coarse one"
        );
    }
}
