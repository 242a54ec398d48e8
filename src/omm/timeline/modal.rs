//! The modal state the timeline follows through the program: what a gate must give back after it moved
//! the machine (tool, spindle, feed, plane, offset, frames …), and what makes a place unfit for a gate.

use std::sync::Arc;

/// The modal state a gate must restore after it moved the machine, and what makes a place unfit for a gate.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Modal {
    /// The tool in the spindle as written after `T=` or `T` (`"DRILL 8.5"` with quotes, or `12`).
    pub tool: Option<Arc<str>>,
    /// The tool the last `T` selected: the preselection a later bare `M6` loads (equal to `tool` after a
    /// change).
    pub selected: Option<Arc<str>>,
    pub d: Option<u32>,
    /// Programmed spindle speed and direction (3, 4, 5 = stopped, or [`POSITIONED`]).
    pub s: f64,
    pub direction: u32,
    pub feed: Option<f64>,
    /// Modal motion G code (0, 1, 2, 3, or a thread or tapping move: see [`is_thread`]).
    pub motion: u32,
    pub absolute: bool,
    pub z: Option<f64>,
    /// G93 / G94 / G95 (G96 / G97 keep G95), when the program set it.
    pub feed_mode: Option<u32>,
    /// G17 / G18 / G19, when the program set it.
    pub plane: Option<u32>,
    /// Exact stop or continuous path: G60, G64, G641 … G645, when the program set it.
    pub path_mode: Option<u32>,
    /// M7 / M8 (on), 78 for both (M7 and M8 add up), or M9 (off), when the program set it.
    pub coolant: Option<u32>,
    /// The profile's machine coolant pairs that are on (bit k: `[coolant] codes[k]`).
    pub machine_coolant: u8,
    /// Cutter radius compensation: 40, 41 or 42.
    pub comp: u32,
    /// The work offset selected (54 … 57, 505 … 599, or 500 for none), when the program selected one.
    pub offset: Option<u32>,
    /// How X is programmed: in radius (DIAMOF), in diameters (DIAMON), or in diameters for absolute values
    /// and radius for incremental ones (DIAM90).
    pub diameter: Diameter,
    /// G70 / G71 / G700 / G710 (inch or metric dimensions), when the program set it.
    pub units: Option<u32>,
    /// Under constant cutting speed (G96, `s` in m/min): the spindle speed estimated where S was set,
    /// n = 1000·v / (π·D) at the diameter the tool stood at, capped by LIMS.
    pub css_rpm: Option<f64>,
    /// Frames and transformations active ([`frame`] bits).
    pub frames: u8,
    /// Fields the program set by an expression the timeline cannot evaluate, and states a gate cannot give
    /// back or move under ([`unknown`] bits).
    pub unknown: u16,
    /// A modal call (`MCALL NAME`) is active: it runs after every block that moves, a gate's too.
    pub modal_call: bool,
}

/// How X values are read on a lathe (the commands of G group 29).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Diameter {
    /// DIAMOF: radius.
    #[default]
    Off,
    /// DIAMON: diameters, absolute and incremental.
    On,
    /// DIAM90: diameters for absolute values (G90, AC), radius for incremental ones (G91, IC).
    Absolute,
}

impl Diameter {
    /// X values are diameters, at least the absolute ones.
    pub fn on(self) -> bool {
        self != Diameter::Off
    }

    /// The command that selects it.
    pub fn command(self) -> &'static str {
        match self {
            Diameter::Off => "DIAMOF",
            Diameter::On => "DIAMON",
            Diameter::Absolute => "DIAM90",
        }
    }
}

/// The coolant after `m` (7, 8, 9, or 78 for both) in state `before`: M7 (mist) and M8 (flood) add to each
/// other, M9 turns both off.
pub fn coolant_after(before: Option<u32>, m: u32) -> Option<u32> {
    Some(match (before, m) {
        (Some(8 | 78), 7) | (Some(7 | 78), 8) | (_, 78) => 78,
        (_, m) => m,
    })
}

/// Bits of [`Modal::frames`].
pub mod frame {
    /// A programmable translation (TRANS, ATRANS, CTRANS with values).
    pub const TRANSLATION: u8 = 1;
    /// A programmable rotation, scale or mirror (ROT, AROT, SCALE, MIRROR, … with values).
    pub const ROTATION: u8 = 2;
    /// A kinematic transformation: TRAORI, TRANSMIT, TRACYL, TRAANG.
    pub const TRANSFORMATION: u8 = 4;
    /// A swivelled plane: CYCLE800 with an angle.
    pub const SWIVEL: u8 = 8;
    /// Rotary axes A, B, C positioned away from 0 (bits 16, 32, 64): the part may be tilted or turned.
    pub const ROTARY: u8 = 0b0111_0000;
    /// Where the rotary bits start: axis A.
    pub const ROTARY_SHIFT: u32 = 4;
    /// An orientable toolholder selected (`TCARR=n`, n ≠ 0): its orientation may tilt the tool.
    pub const TOOL_CARRIER: u8 = 128;
}

/// [`Modal::direction`] of a spindle positioned by `SPOS`, `SPOSA` or `M19`: stopped, in position control
/// at an angle the program means (an oriented boring bar's edge, a tool changer's key).
pub const POSITIONED: u32 = 19;

/// Whether motion code `g` cuts a thread or taps: `G33` (thread cutting, constant lead), `G34`/`G35` (lead
/// increasing or decreasing), `G331`/`G332` (rigid tapping in and out, the spindle in position control
/// turning with the axis) and `G63` (tapping with a compensating chuck). These are G group 1 (motion) moves
/// that cut, and while one is the modal motion the tool may stand in the thread: between a tapping-in and
/// its tapping-out, between passes a thread chain links without a retract.
pub fn is_thread(g: u32) -> bool {
    matches!(g, 33..=35 | 63 | 331 | 332)
}

/// Bits of [`Modal::unknown`].
pub mod unknown {
    pub const TOOL: u16 = 1;
    pub const D: u16 = 2;
    pub const S: u16 = 4;
    pub const FEED: u16 = 8;
    /// A sum offset (`DL=` other than 0) is active: a gate that changes tools does not give it back.
    pub const SUM_OFFSET: u16 = 16;
    /// The program addressed a spindle other than the first (`S4=`, `M4=3`, `SETMS(4)`, `SPOS[2]=`): a gate
    /// stops and gives back the master spindle only, which may not be the one that turns.
    pub const OTHER_SPINDLE: u16 = 32;
    /// A programmed tool offset (`TOFFL`, `TOFFR`, `TOFF[axis]`, the online offset `TOFFON(axis)` until
    /// `TOFFOF(axis)`) is in force. The control keeps it through a
    /// tool change, so a spindle probe carries it, and a tool setter reads it with the tool: a reading
    /// taken with another offset in force than the zero's shows its difference as drift.
    pub const TOOL_OFFSET: u16 = 64;
    /// Modal rounding (`RNDM=` other than 0) is on: the control rounds the corner between every two moves
    /// in the plane, a gate's included.
    pub const ROUNDING: u16 = 128;
    /// Working-area limits the program set (`G25`/`G26` with axis values) are monitored (`WALIMON`, the
    /// control's default, until `WALIMOF`): a gate's route (the rise, the travel to the probe point or
    /// the setter) may leave the area and stop in the control's working-area alarm.
    pub const WORK_AREA: u16 = 256;
    /// Polar coordinates in use (`AP=`, `RP=`, a pole by `G110`/`G111`/`G112`) since the program last
    /// changed the plane: the control keeps the polar angle and radius only until the plane changes.
    pub const POLAR: u16 = 512;
    /// A modal synchronized action (`ID=`/`IDS=` … `WHENEVER … DO …`) is active until `CANCEL`: it acts on
    /// a gate's moves and the probe cycle's as on the program's (an override, an output, an offset).
    pub const SYNC_ACTION: u16 = 1024;
    /// A spline or polynomial (`ASPLINE`, `BSPLINE`, `CSPLINE`, `POLY`) is the modal motion: the control
    /// joins the blocks under it into one curve, which a gate's `STOPRE`, frame write and moves would
    /// break, and a gate gives back only G0 … G3 (red team 5).
    pub const SPLINE: u16 = 2048;
    /// Travel to fixed stop is selected on an axis (`FXS[axis]=1` until `FXS[axis]=0`): the axis stands
    /// clamped against a stop at reduced torque, and moving it raises alarm 20092 (red team 5).
    pub const FIXED_STOP: u16 = 4096;
    /// `GEOAX(…)` assigned other channel axes to the geometry axes: a gate's X, Y, Z and its frame write
    /// would act on them. The switch also deletes every frame: after `GEOAX()` the state counts as lost
    /// until the program selects a work offset again (red team 5).
    pub const GEOMETRY_AXES: u16 = 8192;
}

/// The states of [`Modal::unknown`] a gate that moves cannot run its route under, with why, in the order
/// they are told (see [`Modal::route_unfit`]).
const ROUTE_STATES: &[(u16, &str)] = &[
    (
        unknown::ROUNDING,
        "modal rounding (RNDM) is on: the control would round the corners of a gate's route and of the probe cycle's moves",
    ),
    (
        unknown::WORK_AREA,
        "the program limits the working area (G25/G26 with WALIMON): a gate's rise and its travel to the probe point or the tool setter may leave it and stop in the control's working-area alarm (WALIMOF before the gate lifts it)",
    ),
    (
        unknown::FIXED_STOP,
        "travel to fixed stop (FXS) is selected: the axis stands clamped against its stop, a gate's moves would raise alarm 20092 or pull it off (FXS[axis]=0 ends it)",
    ),
    (
        unknown::SYNC_ACTION,
        "a modal synchronized action (ID=/IDS= … DO …) is active: it would act on a gate's moves and on the probe cycle's (CANCEL ends it)",
    ),
];

/// The states of [`Modal::unknown`] no gate may run in (see [`Modal::unfit`]), with why.
const UNFIT_STATES: &[(u16, &str)] = &[
    (
        unknown::GEOMETRY_AXES,
        "geometry axes are reassigned (GEOAX) or their frames deleted by the switch: a gate's X, Y, Z and its frame write would act on other axes or frames than the program's (GEOAX() and a work offset selected after it end this)",
    ),
    (
        unknown::SPLINE,
        "a spline or polynomial (ASPLINE, BSPLINE, CSPLINE, POLY) is the modal motion: a gate's STOPRE and moves would break the curve the next blocks continue, and it would give back a straight motion",
    ),
];

/// Why of the first of `states` set in `unknown`.
fn first_state(unknown: u16, states: &[(u16, &'static str)]) -> Option<&'static str> {
    states
        .iter()
        .find(|(bit, _)| unknown & bit != 0)
        .map(|(_, why)| *why)
}

impl Modal {
    /// Lengths are programmed in inch (G70, G700): driftloop's blocks, whose lengths are mm, switch to G710
    /// and back.
    pub fn inch(&self) -> bool {
        matches!(self.units, Some(70 | 700))
    }

    /// Why a gate's moves would not run as written here (a gauge, which moves nothing, is not concerned).
    /// Modal rounding (`RNDM=2`) rounds the corners of its route (the rise, the travel across, the
    /// descent to the probe point or the saved height) and the probe cycle's moves; working-area limits
    /// the program set stop a route that leaves them; a modal synchronized action acts on its moves; and
    /// a gate that `switches_plane` (G17 for its moves
    /// under G18/G19, the program's plane after them) makes the control forget the polar angle and
    /// radius the program's next polar block may rely on.
    pub fn route_unfit(&self, switches_plane: bool) -> Option<&'static str> {
        let drops_polar = self.unknown & unknown::POLAR != 0
            && switches_plane
            && matches!(self.plane, Some(18 | 19));
        first_state(self.unknown, ROUTE_STATES).or_else(|| {
            drops_polar.then_some(
                "polar coordinates (AP, RP, G110 … G112) are in use under G18/G19: a gate's moves run in G17 and the plane change back makes the control forget the polar angle and radius the program's next polar block may rely on",
            )
        })
    }

    /// Moves blend into each other at their ends: G64 … G645, or no G60 written (MD20150 may make G64
    /// the default), so a STOPRE between two feed moves stops the path on the contour.
    pub fn continuous_path(&self) -> bool {
        self.path_mode != Some(60)
    }

    /// Speed the spindle turns at (rpm, 0 when stopped).
    pub fn rpm(&self) -> f64 {
        if matches!(self.direction, 3 | 4) {
            self.css_rpm.unwrap_or(self.s).abs()
        } else {
            0.0
        }
    }

    /// Why no inserted block may run here (a STOPRE, a work-offset write or a move would spoil the
    /// contour or move along a tilted axis); `None` when the place is fit.
    pub fn unfit(&self) -> Option<&'static str> {
        if is_thread(self.motion) {
            Some(
                "thread cutting or tapping (G33, G34, G35, G331, G332, G63) is the modal motion: the tool may stand in the thread (between a tapping-in and its tapping-out, inside a chained thread), and a gate would retract it or stop the spindle there",
            )
        } else if matches!(self.comp, 41 | 42) {
            Some("cutter radius compensation (G41/G42) is active")
        } else if self.frames & frame::SWIVEL != 0 {
            Some("a swivelled plane (CYCLE800) is active")
        } else if self.frames & frame::TRANSFORMATION != 0 {
            Some("a transformation (TRAORI, TRANSMIT, TRACYL) is active")
        } else if self.frames & frame::ROTATION != 0 {
            Some("a rotated, scaled or mirrored frame is active")
        } else if self.frames & frame::TOOL_CARRIER != 0 {
            Some("an orientable toolholder (TCARR) is active")
        } else {
            first_state(self.unknown, UNFIT_STATES)
        }
    }

    /// Whether field `f`, one of [`field::SET_ONLY`], is unset: the program set none, so a gate writes none.
    pub(super) fn is_unset(&self, f: usize) -> bool {
        match f {
            field::FEED => self.feed.is_none(),
            field::PLANE => self.plane.is_none(),
            field::FEED_MODE => self.feed_mode.is_none(),
            field::PATH_MODE => self.path_mode.is_none(),
            _ => false,
        }
    }

    /// Leaves field `f`, one of [`field::SET_ONLY`], unset.
    pub(super) fn unset(&mut self, f: usize) {
        match f {
            field::FEED => self.feed = None,
            field::PLANE => self.plane = None,
            field::FEED_MODE => self.feed_mode = None,
            field::PATH_MODE => self.path_mode = None,
            _ => {}
        }
    }

    /// Why a gate here cannot measure and give the state back, beyond [`Modal::unfit`]; `None` when it can.
    pub fn not_restorable(&self) -> Option<&'static str> {
        if let Some(why) = self.unfit() {
            Some(why)
        } else if matches!(self.motion, 2 | 3) {
            Some("a circle (G2/G3) is the modal motion")
        } else if self.direction == POSITIONED {
            Some(
                "the spindle is positioned (SPOS, M19): a gate's tool change would not give its angle back",
            )
        } else if self.unknown & unknown::TOOL != 0 {
            Some("the tool is set by an expression")
        } else if self.d == Some(0) {
            Some("D0 is active: heights are the spindle's, not the tool tip's")
        } else if self.unknown & unknown::D != 0 {
            Some("the D number is set by an expression")
        } else if self.unknown & unknown::S != 0 && matches!(self.direction, 3 | 4) {
            Some("the spindle speed is set by an expression")
        } else if self.unknown & unknown::FEED != 0 {
            Some("the feed is set by an expression")
        } else if self.modal_call {
            Some(
                "a modal call (MCALL) is active: every move of a gate would run its cycle or subprogram (a drilling cycle at the probe point)",
            )
        } else if self.unknown & unknown::OTHER_SPINDLE != 0 {
            Some(
                "the program addresses a spindle other than spindle 1 (S4=, M4=3, SETMS(4), SPOS[2]): a gate's M5 and the speed it gives back act on the master spindle only",
            )
        } else {
            None
        }
    }
}

/// The fields of [`Modal`] by number, for the fold's record of the block where each last changed.
pub(super) mod field {
    use super::Modal;

    pub const COUNT: usize = 20;
    pub const TOOL: usize = 0;
    pub const D: usize = 1;
    pub const S: usize = 2;
    pub const DIRECTION: usize = 3;
    pub const FEED: usize = 4;
    pub const MOTION: usize = 5;
    pub const ABSOLUTE: usize = 6;
    pub const Z: usize = 7;
    pub const SELECTED: usize = 8;
    pub const FEED_MODE: usize = 9;
    pub const PLANE: usize = 10;
    pub const PATH_MODE: usize = 11;
    pub const COOLANT: usize = 12;
    pub const COMP: usize = 13;
    pub const FRAMES: usize = 14;
    pub const UNKNOWN: usize = 15;
    pub const OFFSET: usize = 16;
    pub const DIAMETER: usize = 17;
    pub const UNITS: usize = 18;
    pub const MACHINE_COOLANT: usize = 19;

    /// What field `f` is, as the program writes it (for messages).
    pub fn word(f: usize) -> &'static str {
        [
            "the tool (M6)",
            "the cutting edge (D)",
            "the spindle speed (S)",
            "the spindle direction (M3/M4/M5)",
            "the feed (F)",
            "the motion (G0/G1/G2/G3)",
            "G90/G91",
            "the height (Z)",
            "the tool selected (T)",
            "the feed type (G93/G94/G95)",
            "the plane (G17/G18/G19)",
            "the path mode (G60/G64 …)",
            "the coolant (M7/M8/M9)",
            "the radius compensation (G40/G41/G42)",
            "the frames (TRANS, ROT, TRAORI, CYCLE800 …)",
            "values set by expressions",
            "the work offset (G54 …)",
            "DIAMON/DIAMOF",
            "the unit (G70/G71/G700/G710)",
            "a machine coolant of the profile's [coolant]",
        ][f]
    }

    /// The fields a gate writes back only where the program set them (feed, plane, feed type, path mode):
    /// where it set none, a gate writes none and the control's value stays (see [`Modal::is_unset`]).
    pub const SET_ONLY: [usize; 4] = [FEED, PLANE, FEED_MODE, PATH_MODE];

    /// The fields `fields`, as a set.
    pub fn only(fields: &[usize]) -> [bool; COUNT] {
        let mut set = [false; COUNT];
        for &f in fields {
            set[f] = true;
        }
        set
    }

    /// Of `fields`, those not set at a block past `since` (`last`: the block, one past, where each was last
    /// set).
    pub fn not_set_since(
        fields: &[bool; COUNT],
        since: usize,
        last: &[usize; COUNT],
    ) -> [bool; COUNT] {
        std::array::from_fn(|f| fields[f] && last[f] <= since)
    }

    /// Where each field was last set by the program, as a place after block `t` whose ways differ sees
    /// it: the later of where its value last changed and where the program's words last wrote it whole,
    /// where that write runs on every way through `t`. A write that repeats the value the fold holds
    /// changes nothing, yet makes the value certain on every way (`/S3000 M3`, later `S3000 M3`); one in
    /// an IF, a loop, a skippable block or a stretch a jump passes over, begun after `t`, may not run
    /// (`written_in`: one past the block that began the innermost of them at the write, 0 for none).
    pub fn set_as_seen_from(
        t: usize,
        changed: &[usize; COUNT],
        written: &[usize; COUNT],
        written_in: &[usize; COUNT],
    ) -> [usize; COUNT] {
        std::array::from_fn(|f| {
            let write = if written_in[f] <= t { written[f] } else { 0 };
            changed[f].max(write)
        })
    }

    /// The motion and feed fields, as a plain move or a run of them sets them.
    pub fn motion_feed(motion: bool, feed: bool) -> [bool; COUNT] {
        let mut set = [false; COUNT];
        set[MOTION] = motion;
        set[FEED] = feed;
        set
    }

    /// The fields in which two states differ, by number.
    pub fn differ(a: &Modal, b: &Modal) -> [bool; COUNT] {
        [
            a.tool != b.tool,
            a.d != b.d,
            a.s != b.s || a.css_rpm != b.css_rpm,
            a.direction != b.direction,
            a.feed != b.feed,
            a.motion != b.motion,
            a.absolute != b.absolute,
            a.z != b.z,
            a.selected != b.selected,
            a.feed_mode != b.feed_mode,
            a.plane != b.plane,
            a.path_mode != b.path_mode,
            a.coolant != b.coolant,
            a.comp != b.comp,
            a.frames != b.frames,
            a.unknown != b.unknown,
            a.offset != b.offset,
            a.diameter != b.diameter,
            a.units != b.units,
            a.machine_coolant != b.machine_coolant,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::{Diameter, Modal, field};

    /// The named field numbers are the places `differ` reports those fields at.
    #[test]
    fn field_numbers_name_their_fields() {
        let base = Modal::default();
        let only = |changed: Modal| -> Vec<usize> {
            let d = field::differ(&base, &changed);
            (0..field::COUNT).filter(|&f| d[f]).collect()
        };
        let feed = Modal {
            feed: Some(100.0),
            ..Modal::default()
        };
        let motion = Modal {
            motion: 1,
            ..Modal::default()
        };
        let z = Modal {
            z: Some(5.0),
            ..Modal::default()
        };
        assert_eq!(only(feed), [field::FEED]);
        assert_eq!(only(motion), [field::MOTION]);
        assert_eq!(only(z), [field::Z]);
        let one = |m: Modal, f: usize| assert_eq!(only(m), [f]);
        let d = Modal::default;
        one(
            Modal {
                tool: Some("1".into()),
                ..d()
            },
            field::TOOL,
        );
        one(Modal { d: Some(1), ..d() }, field::D);
        one(Modal { s: 1.0, ..d() }, field::S);
        one(
            Modal {
                direction: 3,
                ..d()
            },
            field::DIRECTION,
        );
        one(
            Modal {
                absolute: true,
                ..d()
            },
            field::ABSOLUTE,
        );
        one(
            Modal {
                selected: Some("1".into()),
                ..d()
            },
            field::SELECTED,
        );
        one(
            Modal {
                feed_mode: Some(95),
                ..d()
            },
            field::FEED_MODE,
        );
        one(
            Modal {
                plane: Some(18),
                ..d()
            },
            field::PLANE,
        );
        one(
            Modal {
                path_mode: Some(64),
                ..d()
            },
            field::PATH_MODE,
        );
        one(
            Modal {
                coolant: Some(8),
                ..d()
            },
            field::COOLANT,
        );
        one(Modal { comp: 41, ..d() }, field::COMP);
        one(Modal { frames: 1, ..d() }, field::FRAMES);
        one(Modal { unknown: 1, ..d() }, field::UNKNOWN);
        one(
            Modal {
                offset: Some(54),
                ..d()
            },
            field::OFFSET,
        );
        one(
            Modal {
                diameter: Diameter::On,
                ..d()
            },
            field::DIAMETER,
        );
        one(
            Modal {
                units: Some(70),
                ..d()
            },
            field::UNITS,
        );
        one(
            Modal {
                machine_coolant: 1,
                ..d()
            },
            field::MACHINE_COOLANT,
        );
        let all = Modal {
            tool: Some("1".into()),
            selected: Some("2".into()),
            d: Some(1),
            s: 1.0,
            direction: 3,
            feed: Some(1.0),
            motion: 1,
            absolute: true,
            z: Some(1.0),
            feed_mode: Some(94),
            plane: Some(17),
            path_mode: Some(64),
            coolant: Some(8),
            machine_coolant: 1,
            comp: 41,
            offset: Some(54),
            diameter: Diameter::On,
            units: Some(700),
            css_rpm: None,
            frames: 1,
            unknown: 1,
            modal_call: true,
        };
        assert_eq!(only(all).len(), field::COUNT);
    }
}
