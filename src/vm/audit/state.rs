//! The control state of the two runs compared item by item. Each difference is one text: what, the
//! transformed run's value, the original's.

use super::AuditSettings;
use crate::omm::machine_coolant::MachineCoolant;
use crate::omm::nc::shown as num;
use crate::omm::profile::OffsetMethod;
use crate::vm::motion::{FRAMES, Frames, IDENTITY, Matrix, SETTING_GROUPS, Spindle, State, Tool};

/// Lengths closer than this are equal (mm); the correction itself is micrometres and is excluded by entry.
const MM: f64 = 1e-6;

/// NaN differs from every number (a faulty probe value written into an offset).
fn differ(a: f64, b: f64) -> bool {
    if a.is_nan() || b.is_nan() {
        return a.is_nan() != b.is_nan();
    }
    (a - b).abs() > MM * (1.0 + a.abs().max(b.abs()) * 1e-9)
}

/// One item of the control state that differs between the runs.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Difference {
    pub what: String,
    pub text: String,
}

fn item(what: &str, here: String, original: String) -> Difference {
    Difference {
        what: what.to_string(),
        text: format!("{what} {here} here, {original} in the original"),
    }
}

pub(super) fn tool_text(tool: &Option<Tool>) -> String {
    tool.as_ref()
        .map_or_else(|| "no tool".to_string(), Tool::to_string)
}

/// Spindle tool, preselected tool, D number.
pub(super) fn tools(t: &State, o: &State) -> Vec<Difference> {
    let mut v = Vec::new();
    if t.tool != o.tool {
        v.push(item("spindle tool", tool_text(&t.tool), tool_text(&o.tool)));
    }
    if t.preselected != o.preselected {
        v.push(item(
            "preselected tool (the next M6 loads it)",
            tool_text(&t.preselected),
            tool_text(&o.preselected),
        ));
    }
    if t.d != o.d {
        v.push(item(
            "cutting edge",
            format!("D{}", num(t.d)),
            format!("D{}", num(o.d)),
        ));
    }
    if t.dl != o.dl {
        v.push(item(
            "sum offset (the tool's length)",
            format!("DL={}", num(t.dl)),
            format!("DL={}", num(o.dl)),
        ));
    }
    v
}

/// G93, G94, G95, or G96 (feed per revolution under constant cutting speed).
fn feed_type(m: &crate::vm::motion::Modal) -> String {
    if m.css {
        "G96".into()
    } else {
        format!("G{}", m.feed_mode.g())
    }
}

fn diameter(s: &State) -> String {
    if s.diameter_axis.is_some() && s.diam90 {
        "DIAM90"
    } else if s.diameter_axis.is_some() {
        "DIAMON"
    } else {
        "DIAMOF"
    }
    .into()
}

fn coolant(s: &State, machine: &MachineCoolant) -> String {
    let base = match (s.mist, s.flood) {
        (false, false) => "off (M9)",
        (true, false) => "M7",
        (false, true) => "M8",
        (true, true) => "M7 M8",
    };
    match machine.on_block(s.machine_coolant) {
        Some(codes) => format!("{base}, {codes}"),
        None => base.into(),
    }
}

fn spindle(s: &State) -> String {
    spindle_text(&Spindle {
        s: s.s,
        rotation: s.rotation,
        position: s.spindle_position,
    })
}

/// `S3000 M3`, `S3000 M5 SPOS=90` (`SPOS` at an angle not known: M19 or an IC from an unknown angle).
fn spindle_text(s: &Spindle) -> String {
    let direction = match s.rotation {
        0 => "M5".to_string(),
        m => format!("M{m}"),
    };
    let position = match s.position {
        None => String::new(),
        Some(a) if a.is_nan() => " SPOS".to_string(),
        Some(a) => format!(" SPOS={}", num(a)),
    };
    format!("S{} {direction}{position}", num(s.s))
}

fn speed_limits(s: &State) -> String {
    let limit = |g: u32, v: Option<f64>| {
        v.map_or_else(|| format!("G{g} none"), |v| format!("G{g} S{}", num(v)))
    };
    format!(
        "{}, {}",
        limit(25, s.speed_limits[0]),
        limit(26, s.speed_limits[1])
    )
}

fn tool_carrier(s: &State) -> String {
    format!("TCARR={}", num(s.kinematics.tool_carrier.unwrap_or(0.0)))
}

fn sync_actions(s: &State) -> String {
    let mut ids: Vec<String> = s
        .sync_actions
        .iter()
        .map(|(n, is_static, _)| format!("{}={n}", if *is_static { "IDS" } else { "ID" }))
        .collect();
    ids.sort();
    if ids.is_empty() {
        "none".into()
    } else {
        ids.join(" ")
    }
}

fn motion(m: u32) -> String {
    match m {
        crate::vm::motion::SPLINE => "spline".into(),
        crate::vm::polynomial::POLY => "POLY".into(),
        g => format!("G{g}"),
    }
}

fn transformation(s: &State) -> String {
    s.kinematics.transformation.unwrap_or("TRAFOOF").to_string()
}

fn swivel(s: &State) -> String {
    match s.kinematics.swivel {
        Some([a, b, c]) => format!("CYCLE800 A{} B{} C{}", num(a), num(b), num(c)),
        None => "none".into(),
    }
}

fn linear(m: &Option<Matrix>) -> String {
    match m {
        None => "none".into(),
        Some(m) => {
            let rows: Vec<String> = m
                .iter()
                .map(|r| r.iter().map(|v| num(*v)).collect::<Vec<_>>().join(" "))
                .collect();
            format!("[{}]", rows.join("; "))
        }
    }
}

/// The programmed position of every axis the original has programmed, beyond `corrected[axis]` (mm): how far
/// driftloop's corrections have moved that axis's offset in this run (twice that on an axis programmed in
/// diameters, where a shift of the offset shows doubled).
pub(super) fn positions(
    t: &State,
    o: &State,
    axes: &[String],
    corrected: &[f64],
) -> Vec<Difference> {
    let shown = |a: usize| {
        if t.diameter_axis == Some(a) { 2.0 } else { 1.0 }
    };
    let within = |d: f64, a: usize| d.is_finite() && d.abs() <= shown(a) * corrected[a] + MM;
    axes.iter()
        .enumerate()
        .filter(|&(a, _)| {
            // The original stands where a frame change left it, not yet traversed on this axis, and the
            // gate went back to that very point in the new frame: the machine is where the original's is.
            // (The plan puts no gate before an incremental move that would traverse the change.)
            let untraversed =
                differ(o.local[a], o.work_position(a)) && within(t.machine[a] - o.machine[a], a);
            o.moved & (1 << a) != 0
                && differ(t.local[a], o.local[a])
                && !within(t.local[a] - o.local[a], a)
                && !untraversed
        })
        .map(|(a, name)| item(name, num(t.local[a]), num(o.local[a])))
        .collect()
}

/// Modal state: coolant, feed and feed mode, G90/G91, plane, path mode, motion mode, spindle, cutter
/// compensation, inch, transformation, swivel, frames (all but the corrected entry).
pub(super) fn modal(t: &State, o: &State, s: &AuditSettings, axes: &[String]) -> Vec<Difference> {
    let (tm, om) = (&t.modal, &o.modal);
    let g = |n: u32| format!("G{n}");
    let items = [
        (
            "coolant",
            coolant(t, &s.machine_coolant),
            coolant(o, &s.machine_coolant),
        ),
        ("feed type", feed_type(tm), feed_type(om)),
        ("dimensions", g90(tm.absolute), g90(om.absolute)),
        ("plane", plane(&tm.plane), plane(&om.plane)),
        ("path mode", g(tm.path), g(om.path)),
        ("exact stop window", g(tm.exact_stop), g(om.exact_stop)),
        ("motion", motion(tm.motion), motion(om.motion)),
        ("spindle", spindle(t), spindle(o)),
        (
            "cutter compensation",
            g(tm.compensation),
            g(om.compensation),
        ),
        (
            "units",
            inch(tm.inch, tm.inch_feed),
            inch(om.inch, om.inch_feed),
        ),
        ("transformation", transformation(t), transformation(o)),
        ("swivel", swivel(t), swivel(o)),
        ("diameter programming", diameter(t), diameter(o)),
        (
            "rotation/scale/mirror",
            linear(&t.frames.linear),
            linear(&o.frames.linear),
        ),
    ];
    let mut v: Vec<Difference> = items
        .into_iter()
        .chain([
            ("spindle speed limits", speed_limits(t), speed_limits(o)),
            ("toolholder", tool_carrier(t), tool_carrier(o)),
            (
                "tool orientation",
                t.kinematics.orientation.to_string(),
                o.kinematics.orientation.to_string(),
            ),
            ("synchronized actions", sync_actions(t), sync_actions(o)),
            (
                "contour offset",
                format!("OFFN={}", num(tm.offn)),
                format!("OFFN={}", num(om.offn)),
            ),
        ])
        .chain(
            SETTING_GROUPS
                .iter()
                .enumerate()
                .map(|(k, (group, names))| {
                    let at = |m: &crate::vm::motion::Modal| {
                        names[usize::from(m.settings[k])].to_string()
                    };
                    (*group, at(tm), at(om))
                }),
        )
        .filter(|(_, here, original)| here != original)
        .map(|(what, here, original)| item(what, here, original))
        .collect();
    for (n, (ts, os)) in t.others.iter().zip(&o.others).enumerate() {
        let (here, original) = (spindle_text(ts), spindle_text(os));
        if here != original {
            v.push(item(&format!("spindle {}", n + 2), here, original));
        }
    }
    let feed = |f: Option<f64>| f.map_or_else(|| "none".to_string(), |f| format!("F{}", num(f)));
    let feeds_differ = match (tm.feed, om.feed) {
        (Some(a), Some(b)) => differ(a, b),
        (a, b) => a.is_some() != b.is_some(),
    };
    if feeds_differ {
        v.push(item("feed", feed(tm.feed), feed(om.feed)));
    }
    v.extend(frames(&t.frames, &o.frames, s, axes));
    v
}

fn g90(absolute: bool) -> String {
    if absolute { "G90" } else { "G91" }.into()
}

fn inch(inch: bool, feed: bool) -> String {
    match (inch, feed) {
        (false, _) => "G71",
        (true, false) => "G70",
        (true, true) => "G700",
    }
    .into()
}

fn plane(p: &[Option<usize>; 3]) -> String {
    match p {
        [Some(0), Some(1), _] => "G17".into(),
        [Some(2), Some(0), _] => "G18".into(),
        [Some(1), Some(2), _] => "G19".into(),
        _ => format!("{p:?}"),
    }
}

/// Selected work offset, active offset, programmable translation and the settable frame table, without
/// the entry driftloop corrects.
fn frames(t: &Frames, o: &Frames, s: &AuditSettings, axes: &[String]) -> Vec<Difference> {
    let mut v = Vec::new();
    if t.selected != o.selected {
        v.push(item("work offset", select(t.selected), select(o.selected)));
    }
    // The corrected entries' axes.
    let corrected: Vec<Option<usize>> = s.corrected().into_iter().map(|k| t.geo[k]).collect();
    let is_corrected = |a: usize| corrected.contains(&Some(a));
    let frame_method = s.method == OffsetMethod::Frame;
    for (a, name) in axes.iter().enumerate() {
        // `active` corrects the offset in force, whichever is selected; a wild value is no correction.
        let skip_active = is_corrected(a)
            && match s.method {
                OffsetMethod::Frame => t.selected == s.frame,
                OffsetMethod::Active => (t.active[a] - o.active[a]).abs() <= WILD_MM,
                OffsetMethod::Trans | OffsetMethod::Atrans => false,
            };
        if !skip_active && t.selected == o.selected && differ(t.active[a], o.active[a]) {
            v.push(item(
                &format!("active work offset {name}"),
                num(t.active[a]),
                num(o.active[a]),
            ));
        }
        // Only the methods that correct through the programmable frame change it; a gate correcting the
        // offset in force (`active`) that loses a TRANS or G58 of the program is a finding.
        let skip_trans =
            matches!(s.method, OffsetMethod::Trans | OffsetMethod::Atrans) && is_corrected(a);
        // The fine part on its own: equal totals split otherwise act differently at the next G58 / G59.
        for (what, here, original) in [
            ("programmable translation", t.trans[a], o.trans[a]),
            (
                "fine part of the programmable translation (ATRANS, G59)",
                t.trans_fine[a],
                o.trans_fine[a],
            ),
        ] {
            if !skip_trans && differ(here, original) {
                v.push(item(&format!("{what} {name}"), num(here), num(original)));
            }
        }
    }
    if let Some(c) = table_difference(t, o, axes, |f, a, fine| {
        frame_method && !fine && f == s.frame && is_corrected(a)
    }) {
        v.push(item(&c.name(), num(c.transformed), num(c.original)));
    }
    v
}

fn select(n: usize) -> String {
    match n {
        0 => "G500".into(),
        1..=4 => format!("G{}", 53 + n),
        n => format!("G{}", 500 + n),
    }
}

/// An entry of the settable frame table (or the programmable translation) whose values differ between the
/// runs.
pub(super) struct Correction {
    pub frame: usize,
    pub axis: String,
    /// `TR`, `FI`, or `TRANS` for the programmable translation.
    pub component: &'static str,
    pub transformed: f64,
    pub original: f64,
}

impl Correction {
    /// `$P_UIFR[1,Z,TR]`, or `TRANS Z`.
    pub fn name(&self) -> String {
        match self.component {
            "TRANS" => format!("the programmable translation {}", self.axis),
            c => format!("$P_UIFR[{},{},{c}]", self.frame, self.axis),
        }
    }
}

fn table_difference(
    t: &Frames,
    o: &Frames,
    axes: &[String],
    skip: impl Fn(usize, usize, bool) -> bool,
) -> Option<Correction> {
    for frame in 0..FRAMES {
        for (a, name) in axes.iter().enumerate() {
            for (fine, tv, ov) in [
                (false, t.table[frame][a], o.table[frame][a]),
                (true, t.fine[frame][a], o.fine[frame][a]),
            ] {
                if differ(tv, ov) && !skip(frame, a, fine) {
                    return Some(Correction {
                        frame,
                        axis: name.clone(),
                        component: if fine { "FI" } else { "TR" },
                        transformed: tv,
                        original: ov,
                    });
                }
            }
        }
    }
    None
}

/// The first persistent work-offset entry (`$P_UIFR`) that differs from the original run's.
pub(super) fn persistent_difference(t: &Frames, o: &Frames, axes: &[String]) -> Option<Correction> {
    table_difference(t, o, axes, |_, _, _| false)
}

/// The temperature compensation SD43900 of an axis that differs from the original run's, described as a
/// finding's end: the original program never writes it, so any difference persists past the program.
pub(super) fn temp_comp_difference(t: &State, o: &State, axes: &[String]) -> Option<String> {
    axes.iter()
        .enumerate()
        .find(|&(a, _)| differ(t.temp_comp[a], o.temp_comp[a]))
        .map(|(a, name)| {
            format!(
                "with $SA_TEMP_COMP_ABS_VALUE[{name}] = {} mm where the original has {} mm: the temperature compensation stays shifted",
                num(t.temp_comp[a]),
                num(o.temp_comp[a])
            )
        })
}

/// A difference this large (mm) is no correction: a probe value orders of magnitude off got through.
const WILD_MM: f64 = 1000.0;

/// A work-offset entry (settable frame or programmable translation) that is NaN or far off the original's.
pub(super) fn wild_entry(t: &Frames, o: &Frames, axes: &[String]) -> Option<Correction> {
    let wild = |a: f64, b: f64| !a.is_finite() || (a - b).abs() > WILD_MM;
    if let Some(c) = table_difference(t, o, axes, |f, a, fine| {
        let (tv, ov) = if fine {
            (t.fine[f][a], o.fine[f][a])
        } else {
            (t.table[f][a], o.table[f][a])
        };
        !wild(tv, ov)
    }) {
        return Some(c);
    }
    axes.iter()
        .enumerate()
        .find(|&(a, _)| wild(t.trans[a], o.trans[a]))
        .map(|(a, name)| Correction {
            frame: 0,
            axis: name.clone(),
            component: "TRANS",
            transformed: t.trans[a],
            original: o.trans[a],
        })
}

/// What makes probing, STOPRE or an offset write unsafe, active now: each as what kind it is (the same
/// kind stays active while its values change) and a text.
pub(super) fn transforms_active(s: &State) -> Vec<(&'static str, String)> {
    let mut v = Vec::new();
    if let Some(m) = &s.frames.linear
        && *m != IDENTITY
    {
        v.push((
            "frame",
            format!("a rotation/scale/mirror frame {}", linear(&s.frames.linear)),
        ));
    }
    if s.kinematics.swivel.is_some() {
        v.push(("swivel", format!("the swivel {}", swivel(s))));
    }
    if let Some(t) = s.kinematics.transformation {
        v.push(("transformation", t.to_string()));
    }
    if s.kinematics.tool_carrier.is_some() {
        v.push((
            "toolholder",
            format!("the orientable toolholder {}", tool_carrier(s)),
        ));
    }
    if matches!(s.modal.compensation, 41 | 42) {
        v.push((
            "compensation",
            format!("cutter radius compensation G{}", s.modal.compensation),
        ));
    }
    v
}
