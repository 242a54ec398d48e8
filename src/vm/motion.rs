//! Axis positions, frames and move geometry.
//!
//! Positions are kept twice per axis: the last programmed position in the work coordinate system ("local") and
//! the commanded machine position. Machine = local + active settable frame (`$P_UIFR[n]` selected by G54…)
//! plus programmable translation (TRANS / ATRANS). An axis that is not programmed does not move when a frame
//! changes; its next incremental move traverses the change (MD42440 FRAME_OFFSET_INCR_PROG = 1, the default).
//! A write to `$P_UIFR` changes the stored frame only: it acts once the work offset is selected again, as on
//! the control. Rotation, scaling and mirroring (ROT, SCALE, MIRROR and their additive forms) make the
//! programmable frame a linear map of the geometry axes X, Y, Z; while one is active a move of any geometry
//! axis places all three.

use std::fmt;
use std::rc::Rc;

/// Number of settable frames, `$P_UIFR[0]` (G500) … `$P_UIFR[99]`.
pub const FRAMES: usize = 100;

/// The motion mode of BSPLINE / ASPLINE / CSPLINE (modal like G1). The dry run times a spline by the polygon
/// through its programmed points, an approximation: the curve is shorter (B spline) or close to it.
pub const SPLINE: u32 = 1000;

/// Thread cutting (G33, G34, G35), rigid tapping in and out (G331, G332) and tapping with a compensating
/// chuck (G63): G group 1 moves that cut, the axis following the spindle (G63: at the feed F).
pub fn is_thread(motion: u32) -> bool {
    matches!(motion, 33..=35 | 63 | 331 | 332)
}

/// How an axis value in a block is meant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dim {
    Modal,
    Absolute,
    Incremental,
    /// Absolute in machine coordinates: the axis was named by its machine axis name.
    Machine,
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
    /// The program's own value of the selected frame at its selection (its `initial`): what a correction
    /// is measured against.
    pub base: Vec<f64>,
    /// Copy of the selected frame made at selection.
    pub active: Vec<f64>,
    /// Programmable translation, coarse plus fine: TRANS and G58 write the coarse part, ATRANS and G59
    /// the fine one.
    pub trans: Vec<f64>,
    /// The fine (additive) part of `trans`: the sum of ATRANS translations, or what G59 put in its place.
    pub trans_fine: Vec<f64>,
    /// Rotation, scale and mirror of the programmable frame over the geometry axes (`None`: identity).
    pub linear: Option<Matrix>,
    /// Indices of the geometry axes X, Y, Z in the axis list.
    pub geo: [Option<usize>; 3],
    /// Count the programmable translation as a correction too (for programs corrected through ATRANS).
    pub trans_is_correction: bool,
}

/// A 3 × 3 matrix over the geometry axes, rows and columns in the order X, Y, Z.
pub type Matrix = [[f64; 3]; 3];

pub const IDENTITY: Matrix = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

pub fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    let mut m = [[0.0; 3]; 3];
    for (r, row) in m.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[r][k] * b[k][c]).sum();
        }
    }
    m
}

/// Rotation by `degrees` about geometry axis `k` (0 = X, 1 = Y, 2 = Z), counter-clockwise looking from the
/// positive end of the axis.
pub fn rotation(k: usize, degrees: f64) -> Matrix {
    let (s, c) = degrees.to_radians().sin_cos();
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    let mut m = IDENTITY;
    m[i][i] = c;
    m[i][j] = -s;
    m[j][i] = s;
    m[j][j] = c;
    m
}

impl Frames {
    pub fn new(axes: usize) -> Self {
        Frames {
            table: vec![vec![0.0; axes]; FRAMES],
            fine: vec![vec![0.0; axes]; FRAMES],
            initial: vec![vec![0.0; axes]; FRAMES],
            base: vec![0.0; axes],
            selected: 0,
            active: vec![0.0; axes],
            trans: vec![0.0; axes],
            trans_fine: vec![0.0; axes],
            linear: None,
            geo: [None; 3],
            trans_is_correction: false,
        }
    }

    /// Deletes the programmable frame (what TRANS, ROT, SCALE, MIRROR do before they set their part).
    pub fn reset_programmable(&mut self) {
        self.trans.iter_mut().for_each(|t| *t = 0.0);
        self.trans_fine.iter_mut().for_each(|t| *t = 0.0);
        self.linear = None;
    }

    /// Adds a translation along `axis`, in the coordinate system the programmable frame has made so far
    /// (ATRANS after ROT translates along the rotated axis, after SCALE by the scaled amount); an `additive`
    /// one (ATRANS) goes into the fine part too.
    pub fn translate(&mut self, axis: usize, v: f64, additive: bool) {
        let k = self.geo.iter().position(|g| *g == Some(axis));
        let steps: Vec<(usize, f64)> = match (k, &self.linear) {
            (Some(k), Some(m)) => m
                .iter()
                .zip(self.geo)
                .filter_map(|(row, g)| g.map(|a| (a, row[k] * v)))
                .collect(),
            _ => vec![(axis, v)],
        };
        for (a, d) in steps {
            self.trans[a] += d;
            if additive {
                self.trans_fine[a] += d;
            }
        }
    }

    /// G58 (`fine` false) / G59: replaces the coarse / fine part of the programmable translation of `axis`
    /// with `v` and keeps the other part (Programming Manual 12/2019, "Programmable work offset (G58,
    /// G59)"). The parts are kept in the frame's own coordinates, as TRANS writes them: under a rotation
    /// the value is not turned.
    pub fn replace_translation(&mut self, axis: usize, v: f64, fine: bool) {
        if fine {
            self.trans[axis] += v - self.trans_fine[axis];
            self.trans_fine[axis] = v;
        } else {
            self.trans[axis] = v + self.trans_fine[axis];
        }
    }

    /// Chains a rotation, scale or mirror onto the programmable frame.
    pub fn compose(&mut self, m: &Matrix) {
        let product = multiply(self.linear.as_ref().unwrap_or(&IDENTITY), m);
        self.linear = (product != IDENTITY).then_some(product);
    }

    /// Whether a rotation, scale or mirror is active.
    pub fn is_linear(&self) -> bool {
        self.linear.is_some()
    }

    pub fn select(&mut self, n: usize) {
        self.selected = n;
        self.active = self.total(n);
        self.base = self.initial[n].clone();
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
        self.base = self.initial[self.selected].clone();
    }

    /// Frame `n` written whole by the program (`$P_UIFR[n]=CTRANS(…)`, which driftloop never writes): its
    /// new value is the program's own, no correction; it acts from the next selection.
    pub fn set_whole(&mut self, n: usize, coarse: Vec<f64>) {
        self.fine[n] = vec![0.0; self.fine[n].len()];
        self.table[n] = coarse;
        self.initial[n] = self.total(n);
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
        self.active[axis] - self.base[axis] + programmable
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
    pub feed_mode: FeedMode,
    /// G70 / G700: lengths in inch (G700 also the feed).
    pub inch: bool,
    pub inch_feed: bool,
    /// G group 10: 60 (exact stop), 64, 641 … 645 (continuous path).
    pub path: u32,
    /// G group 12: exact stop window 601, 602, 603.
    pub exact_stop: u32,
    /// Cutter radius compensation: 40, 41, 42.
    pub compensation: u32,
    /// Constant cutting speed (G96): S is m/min, the spindle turns 1000·S / (π·D), at most `lims`.
    pub css: bool,
    pub lims: Option<f64>,
    /// Settings that shape the path in real time but move no programmed point (corner behaviour,
    /// compressor, …): one entry per group of [`SETTING_GROUPS`], the index of its active command.
    pub settings: [u8; SETTING_GROUPS.len()],
    /// `OFFN=`: the contour's offset under cutter compensation (mm).
    pub offn: f64,
    /// POLYPATH: whether the path axes follow their polynomials under POLY (else they go linearly).
    pub poly_axes: bool,
}

/// Modal groups the dry run keeps as state without modelling what they do to the path: the group, then
/// its commands, the control's default first.
pub const SETTING_GROUPS: [(&str, &[&str]); 9] = [
    (
        "approach and retraction under radius compensation (G group 17)",
        &["NORM", "KONT", "KONTT", "KONTC"],
    ),
    ("corner behaviour (G group 18)", &["G450", "G451"]),
    (
        "tool compensation type (G group 22)",
        &[
            "CUT2D", "CUT2DF", "CUT3DC", "CUT3DFS", "CUT3DFF", "CUT3DF", "CUT3DCC", "CUT3DCCD",
        ],
    ),
    ("orientation reference (G group 25)", &["ORIWKS", "ORIMKS"]),
    (
        "working area limitation (G group 28)",
        &["WALIMON", "WALIMOF"],
    ),
    (
        "toolholder orientation (G group 42)",
        &["TCOABS", "TCOFR", "TCOFRZ", "TCOFRY", "TCOFRX"],
    ),
    ("path reference (G group 45)", &["SPATH", "UPATH"]),
    (
        "orientation interpolation (G group 51)",
        crate::views::ORIENTATION_INTERPOLATIONS,
    ),
    (
        "compressor (G group 59)",
        &["COMPOF", "COMPON", "COMPCURV", "COMPCAD", "COMPSURF"],
    ),
];

/// The group of [`SETTING_GROUPS`] a command belongs to, and its index there.
pub fn setting(name: &str) -> Option<(usize, u8)> {
    SETTING_GROUPS
        .iter()
        .enumerate()
        .find_map(|(k, (_, names))| names.iter().position(|n| *n == name).map(|i| (k, i as u8)))
}

/// Feed type (G group 15).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FeedMode {
    /// G93: F is the reciprocal of the block's time in minutes.
    InverseTime,
    /// G94: mm/min.
    PerMinute,
    /// G95: mm per spindle revolution.
    PerRevolution,
}

impl FeedMode {
    pub fn g(self) -> u32 {
        match self {
            FeedMode::InverseTime => 93,
            FeedMode::PerMinute => 94,
            FeedMode::PerRevolution => 95,
        }
    }
}

/// A tool as the program names it: `T="NAME"` by name, `T12` / `T=12` by number.
#[derive(Debug, Clone, PartialEq)]
pub enum Tool {
    Number(f64),
    Name(Rc<str>),
}

impl Tool {
    /// `$P_TOOLNO`: the number; a named tool's is the internal one the dry run gives its first duplo.
    pub fn number(&self) -> f64 {
        match self {
            Tool::Number(n) => *n,
            Tool::Name(name) => super::tool_numbers::internal_number(name, 1),
        }
    }
}

/// `T=` of a value: a number or a name.
impl From<&super::value::Value> for Tool {
    fn from(v: &super::value::Value) -> Tool {
        match v {
            super::value::Value::Num(n) => Tool::Number(*n),
            super::value::Value::Str(name) => Tool::Name(name.as_str().into()),
        }
    }
}

impl fmt::Display for Tool {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tool::Number(n) => write!(f, "T{}", super::value::format_number(*n)),
            Tool::Name(name) => write!(f, "T=\"{name}\""),
        }
    }
}

/// A kinematic transformation (TRAORI, TRANSMIT, TRACYL) or a swivelled plane (CYCLE800): states the dry
/// run records without modelling their geometry.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Kinematics {
    /// The active transformation's command, until TRAFOOF.
    pub transformation: Option<&'static str>,
    /// The angles A, B, C of the last CYCLE800 with any non-zero angle, until CYCLE800() or zero angles.
    pub swivel: Option<[f64; 3]>,
    /// `TCARR=n`: the orientable toolholder selected, until `TCARR=0`. Its angles come from tool data or
    /// rotary axes the dry run does not evaluate, so any selected one counts as tilting the tool.
    pub tool_carrier: Option<f64>,
    /// The tool orientation programmed under TRAORI, until the transformation ends.
    pub orientation: super::orientation::Orientation,
}

/// What `PROC … SAVE` restores on return: modal G codes and frames.
#[derive(Debug, Clone)]
pub struct Saved {
    modal: Modal,
    selected: usize,
    active: Vec<f64>,
    trans: Vec<f64>,
    trans_fine: Vec<f64>,
    linear: Option<Matrix>,
}

/// Positions, modal state, spindle and tool of the virtual machine.
#[derive(Debug, Clone)]
pub struct State {
    pub local: Vec<f64>,
    pub machine: Vec<f64>,
    /// Bit i set once axis i has been programmed.
    pub moved: u64,
    /// Bit i set while axis i stands where a move in machine coordinates (G53, SUPA) put it.
    pub suppressed: u64,
    pub modal: Modal,
    pub frames: Frames,
    /// Programmed S (rpm) and rotation (3 = M3, 4 = M4, 0 = stopped).
    pub s: f64,
    pub rotation: u32,
    /// The tool in the spindle and the one preselected by `T` (loaded by the next M6; it stays preselected
    /// after the change, so a later bare M6 loads it again).
    pub tool: Option<Tool>,
    pub preselected: Option<Tool>,
    pub d: f64,
    /// `DL=`: the sum offset added to the cutting edge's length (0: none), until `DL=0` or another D.
    pub dl: f64,
    /// M7 (mist) and M8 (flood) coolant, both off after M9.
    pub mist: bool,
    pub flood: bool,
    /// The machine coolant pairs on (bit k: `Config::machine_coolant` pair k).
    pub machine_coolant: u8,
    pub kinematics: Kinematics,
    /// DIAMON / DIAM90: the axis (X) whose programmed values are diameters; the machine moves half.
    pub diameter_axis: Option<usize>,
    /// DIAM90: only absolute values of that axis are diameters, incremental ones (G91, IC) are radius.
    pub diam90: bool,
    /// SD43900 `$SA_TEMP_COMP_ABS_VALUE` per axis (mm): persistent setting data, like the settable frames.
    pub temp_comp: Vec<f64>,
    /// The master spindle stands in position control at this angle (`SPOS`, `SPOSA`, `M19`) until M3, M4,
    /// M5 or a tool change.
    pub spindle_position: Option<f64>,
    /// G25 / G26: the programmed lower and upper limit of the master spindle's speed (rpm).
    pub speed_limits: [Option<f64>; 2],
    /// Spindles 2 … [`SPINDLES`]: neither timed nor part of the drift, kept to be compared.
    pub others: [Spindle; SPINDLES - 1],
    /// The master spindle (SETMS): 1, or one of `others`.
    pub master: usize,
    /// Modal and static synchronized actions (`ID=n`, `IDS=n` … `DO`) recorded, not run: (id, static, line).
    pub sync_actions: Vec<(u32, bool, usize)>,
}

/// Spindles the dry run follows: the master spindle 1 and the others up to this number.
pub const SPINDLES: usize = 4;

/// A spindle other than the master: speed, direction (3, 4, 0 stopped) and the angle it is positioned at.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Spindle {
    pub s: f64,
    pub rotation: u32,
    pub position: Option<f64>,
}

impl State {
    pub fn new(axes: usize) -> Self {
        State {
            local: vec![0.0; axes],
            machine: vec![0.0; axes],
            moved: 0,
            suppressed: 0,
            modal: Modal {
                motion: 0,
                absolute: true,
                plane: [Some(0), Some(1), Some(2)],
                feed: None,
                feed_mode: FeedMode::PerMinute,
                inch: false,
                inch_feed: false,
                path: 60,
                exact_stop: 601,
                compensation: 40,
                css: false,
                lims: None,
                settings: [0; SETTING_GROUPS.len()],
                offn: 0.0,
                poly_axes: true,
            },
            frames: Frames::new(axes),
            s: 0.0,
            rotation: 0,
            tool: None,
            preselected: None,
            d: 0.0,
            dl: 0.0,
            mist: false,
            machine_coolant: 0,
            flood: false,
            kinematics: Kinematics::default(),
            diameter_axis: None,
            diam90: false,
            temp_comp: vec![0.0; axes],
            spindle_position: None,
            speed_limits: [None; 2],
            others: [Spindle::default(); SPINDLES - 1],
            master: 1,
            sync_actions: Vec::new(),
        }
    }

    /// The work position of `axis` (`$AA_IW`): the machine position less the active offsets; the programmed
    /// one while a rotation, scale or mirror is active.
    pub fn work_position(&self, axis: usize) -> f64 {
        if self.frames.is_linear() {
            self.local[axis]
        } else if self.diameter_axis == Some(axis) {
            2.0 * (self.machine[axis] - self.frames.offset(axis))
        } else {
            self.machine[axis] - self.frames.offset(axis)
        }
    }

    /// The master spindle's speed, within the programmed limits G25 / G26.
    pub fn spindle_rpm(&self) -> f64 {
        if self.rotation == 0 {
            return 0.0;
        }
        let n = self.rpm_for(self.s);
        match self.speed_limits {
            [None, None] => n,
            [low, high] => n.max(low.unwrap_or(0.0)).min(high.unwrap_or(f64::INFINITY)),
        }
    }

    /// The speed a programmed `s` gives: itself, or under constant cutting speed (G96, `s` in m/min) the
    /// speed at the diameter the tool stands at, capped by LIMS.
    fn rpm_for(&self, s: f64) -> f64 {
        if self.modal.css {
            // The diameter the tool stands at: twice its distance from the turning axis.
            let d = self.frames.geo[0].map_or(0.0, |x| 2.0 * self.machine[x].abs());
            let n = if d > 1.0 {
                1000.0 * s.abs() / (std::f64::consts::PI * d)
            } else {
                self.modal.lims.unwrap_or(s)
            };
            self.modal.lims.map_or(n, |l| n.min(l))
        } else {
            s
        }
    }

    /// The master spindle's speed (SETMS): what a feed per revolution, a dwell in revolutions and a
    /// thread run by. Spindle 1's within its G25 / G26 limits; another's as programmed.
    pub fn master_rpm(&self) -> f64 {
        match self.master {
            0 | 1 => self.spindle_rpm(),
            n => {
                let s = &self.others[n - 2];
                if s.rotation == 0 {
                    0.0
                } else {
                    self.rpm_for(s.s)
                }
            }
        }
    }

    /// Places the geometry axes X, Y, Z through the programmable frame's rotation, scale and mirror.
    pub fn place_geometry(&mut self) {
        let Some(m) = self.frames.linear else {
            return;
        };
        let geo = self.frames.geo;
        let local = geo.map(|g| g.map_or(0.0, |a| self.local[a]));
        for (row, g) in m.iter().zip(geo) {
            if let Some(a) = g {
                self.machine[a] =
                    self.frames.offset(a) + (0..3).map(|k| row[k] * local[k]).sum::<f64>();
            }
        }
    }

    /// The programmed position on X, Y, Z in the coordinates of the settable work offset: through the
    /// programmable frame (translation, rotation, scale, mirror); an axis last moved in machine coordinates
    /// (G53, SUPA) where that put it, less the offset. Axes the machine lacks read 0.
    pub fn work_geometry(&self) -> [f64; 3] {
        let f = &self.frames;
        let local = f.geo.map(|g| g.map_or(0.0, |a| self.local[a]));
        let linear = f.linear.unwrap_or(IDENTITY);
        let mut out = [0.0; 3];
        for (k, g) in f.geo.iter().enumerate() {
            out[k] = match *g {
                None => 0.0,
                Some(a) if self.suppressed & (1 << a) != 0 => self.machine[a] - f.active[a],
                Some(a) => f.trans[a] + (0..3).map(|j| linear[k][j] * local[j]).sum::<f64>(),
            };
        }
        out
    }

    /// The centre of an arc from `start` to `end` (programmed coordinates of the plane axes `plane`) in the
    /// coordinates of [`State::work_geometry`]; `None` under a rotation, scale or mirror.
    pub fn work_centre(
        &self,
        arc: &ArcSpec,
        start: [f64; 2],
        end: [f64; 2],
        plane: [usize; 2],
        start_local: &[f64],
    ) -> Option<[f64; 3]> {
        if self.frames.is_linear() {
            return None;
        }
        let centre = arc_centre(arc, start, end)?;
        let geo = self.frames.geo;
        let mut out = [0.0; 3];
        for (k, g) in geo.iter().enumerate() {
            let Some(a) = *g else { continue };
            out[k] = self.frames.trans[a]
                + match plane.iter().position(|p| *p == a) {
                    Some(j) => centre[j],
                    None => start_local[a],
                };
        }
        Some(out)
    }

    /// Snapshot for `PROC … SAVE`.
    pub fn save(&self) -> Saved {
        Saved {
            modal: self.modal.clone(),
            selected: self.frames.selected,
            active: self.frames.active.clone(),
            trans: self.frames.trans.clone(),
            trans_fine: self.frames.trans_fine.clone(),
            linear: self.frames.linear,
        }
    }

    pub fn restore(&mut self, saved: Saved) {
        self.modal = saved.modal;
        self.frames.selected = saved.selected;
        self.frames.active = saved.active;
        self.frames.trans = saved.trans;
        self.frames.trans_fine = saved.trans_fine;
        self.frames.linear = saved.linear;
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
    /// `TURN=`: full turns before the end point (a helix), each adding a circle to the path.
    pub turns: f64,
}

/// The centre of an arc in the plane, from I/J (relative or absolute) or from CR= (positive: the arc of at
/// most 180°, the centre to the right of the chord for G2, to the left for G3).
pub fn arc_centre(arc: &ArcSpec, start: [f64; 2], end: [f64; 2]) -> Option<[f64; 2]> {
    match (arc.centre, arc.radius) {
        (Some(c), _) if arc.centre_absolute => Some(c),
        (Some(c), _) => Some([start[0] + c[0], start[1] + c[1]]),
        (None, Some(cr)) => {
            let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
            let chord = dx.hypot(dy);
            if chord == 0.0 {
                return None;
            }
            let h = (cr * cr - chord * chord / 4.0).max(0.0).sqrt();
            // Right of the direction of travel for a short clockwise arc; each of G3 and CR < 0 flips it.
            let side = if arc.clockwise == (cr >= 0.0) {
                1.0
            } else {
                -1.0
            };
            let (nx, ny) = (dy / chord * side, -dx / chord * side);
            Some([
                (start[0] + end[0]) / 2.0 + nx * h,
                (start[1] + end[1]) / 2.0 + ny * h,
            ])
        }
        (None, None) => None,
    }
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
    Ok(((sweep + arc.turns * std::f64::consts::TAU) * r).hypot(rise))
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
            turns: 0.0,
        }
    }

    #[test]
    fn each_turn_of_a_helix_adds_a_circle() {
        let one = arc_length(
            &arc(false, Some([-10.0, 0.0]), None),
            [10.0, 0.0],
            [10.0, 0.0],
            0.0,
        );
        let mut three = arc(false, Some([-10.0, 0.0]), None);
        three.turns = 2.0;
        let three = arc_length(&three, [10.0, 0.0], [10.0, 0.0], 6.0).unwrap();
        let circle = std::f64::consts::TAU * 10.0;
        assert!((one.unwrap() - circle).abs() < 1e-9);
        assert!((three - (3.0 * circle).hypot(6.0)).abs() < 1e-9);
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
    fn arc_centres_from_cr_lie_on_the_side_the_direction_and_sign_say() {
        let arc = |clockwise, cr| ArcSpec {
            clockwise,
            centre: None,
            centre_absolute: false,
            radius: Some(cr),
            turns: 0.0,
        };
        let near = |c: Option<[f64; 2]>, x: f64, y: f64| {
            let c = c.unwrap();
            (c[0] - x).abs() < 1e-9 && (c[1] - y).abs() < 1e-9
        };
        // From (0,0) to (2,0) with radius √2: centre 1 below (clockwise, short) or above.
        let r = 2f64.sqrt();
        assert!(near(
            arc_centre(&arc(true, r), [0.0, 0.0], [2.0, 0.0]),
            1.0,
            -1.0
        ));
        assert!(near(
            arc_centre(&arc(true, -r), [0.0, 0.0], [2.0, 0.0]),
            1.0,
            1.0
        ));
        assert!(near(
            arc_centre(&arc(false, r), [0.0, 0.0], [2.0, 0.0]),
            1.0,
            1.0
        ));
        assert!(near(
            arc_centre(&arc(false, -r), [0.0, 0.0], [2.0, 0.0]),
            1.0,
            -1.0
        ));
        let ij = ArcSpec {
            clockwise: true,
            centre: Some([5.0, 1.0]),
            centre_absolute: false,
            radius: None,
            turns: 0.0,
        };
        assert!(near(arc_centre(&ij, [1.0, 1.0], [0.0, 0.0]), 6.0, 2.0));
    }

    #[test]
    fn rotations_turn_counter_clockwise_and_compose() {
        let rz = rotation(2, 90.0);
        let x = [1.0, 0.0, 0.0];
        let turned: Vec<f64> = (0..3)
            .map(|r| (0..3).map(|k| rz[r][k] * x[k]).sum())
            .collect();
        assert!((turned[0]).abs() < 1e-12 && (turned[1] - 1.0).abs() < 1e-12);
        let mut f = Frames::new(3);
        f.geo = [Some(0), Some(1), Some(2)];
        f.compose(&rz);
        f.translate(0, 10.0, true);
        assert!(
            f.trans[0].abs() < 1e-12 && (f.trans[1] - 10.0).abs() < 1e-12,
            "ATRANS along the turned X"
        );
        f.compose(&rotation(2, -90.0));
        assert!(!f.is_linear(), "back to the identity");
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

    /// fixtures/shop5/20 sets up its offsets with `$P_UIFR[n]=CTRANS(…)`: the machined error of a dry run
    /// counted the 611 mm of its own Z offset as a correction.
    #[test]
    fn a_frame_the_program_writes_whole_is_no_correction() {
        let mut f = Frames::new(3);
        f.table[1][2] = -100.0;
        f.mark_initial();
        f.select(1);
        f.table[1][2] = -100.02;
        f.select(1);
        assert!((f.correction(2) + 0.02).abs() < 1e-12);
        f.set_whole(1, vec![-412.35, 0.0, -611.48]);
        assert!(
            (f.correction(2) + 0.02).abs() < 1e-12,
            "it acts at the next selection"
        );
        f.select(1);
        assert_eq!(f.correction(2), 0.0);
        assert_eq!(f.offset(0), -412.35);
        f.table[1][2] = -611.5;
        f.select(1);
        assert!(
            (f.correction(2) + 0.02).abs() < 1e-9,
            "a write after it is a correction of it"
        );
    }
}
