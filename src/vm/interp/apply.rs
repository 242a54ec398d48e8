//! What a block does to the machine: modal G codes, spindle, tool, frames, moves with their time and cut,
//! dwell, probe, program end.

use super::*;
use crate::MM_PER_INCH;

/// What a tool change takes from its block: the edge and sum offset it selects, and whether it starts
/// the spindle again (M3/M4).
struct ToolChangeWords {
    d: Option<f64>,
    dl: Option<f64>,
    starts_spindle: bool,
}

impl Interp<'_> {
    pub(super) fn apply(&mut self, u: &Rc<Unit>, i: usize, w: Words) -> Result<Flow, String> {
        let w_tool_change = ToolChangeWords {
            d: w.d,
            dl: w.dl,
            starts_spindle: w.m.iter().any(|m| matches!(m, 3 | 4)),
        };
        let mut dwell = false;
        // G25 / G26 (0, 1): S is the spindle's lower / upper speed limit, axis values the working area's.
        let mut limit = None;
        let mut suppress = w.suppress_frames;
        // G58 / G59: the block's axis values replace a part of the programmable translation.
        let mut axial = None;
        let planes = PLANES.map(|p| self.plane(p));
        for &g in &w.g {
            let modal = &mut self.motion.modal;
            match g {
                0..=3 => modal.motion = g,
                g if is_thread(g) => modal.motion = g,
                4 => dwell = true,
                25 | 26 => limit = Some(g as usize - 25),
                450 | 451 => {
                    let (k, v) = setting(&format!("G{g}")).expect("G450 and G451 are settings");
                    modal.settings[k] = v;
                }
                // Exact stop / continuous path change corners, not the path length this dry run times.
                9 => {}
                60 | 64 | 641..=645 => modal.path = g,
                601..=603 => modal.exact_stop = g,
                17..=19 => modal.plane = planes[g as usize - 17],
                // Cutter radius compensation moves the contour in the plane, never the depth.
                40..=42 => modal.compensation = g,
                53 | 153 => suppress = true,
                58 | 59 => axial = Some(g == 59),
                // G74: its axes go to their reference points; G75 FP=n: to the fixed point (machine
                // positions, below).
                74 | 75 => suppress = true,
                54..=57 => self.motion.frames.select(g as usize - 53),
                505..=599 => self.motion.frames.select(g as usize - 500),
                500 => self.motion.frames.select(0),
                70 | 700 | 71 | 710 => {
                    modal.inch = matches!(g, 70 | 700);
                    modal.inch_feed = g == 700;
                }
                90 => modal.absolute = true,
                91 => modal.absolute = false,
                // G93 … G97 are one group (15): a feed type ends constant cutting speed, G96 is feed per
                // revolution with it.
                93 => (modal.feed_mode, modal.css) = (FeedMode::InverseTime, false),
                94 => (modal.feed_mode, modal.css) = (FeedMode::PerMinute, false),
                95 => (modal.feed_mode, modal.css) = (FeedMode::PerRevolution, false),
                96 => (modal.feed_mode, modal.css) = (FeedMode::PerRevolution, true),
                97 => modal.css = false,
                _ => return Err(format!("G{g} is not supported by the dry run")),
            }
        }
        if w.spline {
            self.motion.modal.motion = SPLINE;
        }
        if w.poly {
            self.motion.modal.motion = POLY;
        }
        let mut w = w;
        // Under SETMS(n) a speed and M3 / M4 / M5 / M19 without an address extension act on the master
        // spindle n (a dwell's revolutions and a speed limit stay as they are).
        let master = self.motion.master;
        if master >= 2 {
            if let Some(s) = w.s.take_if(|_| !dwell && limit.is_none()) {
                w.other_s.push((master, s));
            }
            let (own, spindle): (Vec<u32>, Vec<u32>) =
                w.m.iter().partition(|m| !matches!(m, 3 | 4 | 5 | 19));
            w.m = own;
            w.other_m.extend(spindle.into_iter().map(|m| (master, m)));
        }
        if self.motion.modal.inch {
            for (_, _, v) in &mut w.axes {
                *v *= MM_PER_INCH;
            }
            for (v, _) in w.centre.iter_mut().flatten() {
                *v *= MM_PER_INCH;
            }
            for c in w
                .poly_coefficients
                .iter_mut()
                .flat_map(|(_, c)| c.iter_mut())
            {
                *c *= MM_PER_INCH;
            }
            if let Some(cr) = &mut w.cr {
                *cr *= MM_PER_INCH;
            }
        }
        if let Some(f) = w.feed.filter(|_| !dwell) {
            self.program_feed(f);
        }
        if let Some(l) = w.lims {
            self.motion.modal.lims = Some(l);
        }
        match (w.s.filter(|_| !dwell), limit) {
            (Some(s), Some(k)) => self.motion.speed_limits[k] = Some(s),
            (Some(s), None) => self.motion.s = s,
            (None, _) => {}
        }
        if (w.s.is_some() || w.g.iter().any(|g| matches!(g, 96 | 97)) || w.lims.is_some())
            && self.motion.rotation != 0
        {
            self.spindle.set(self.time_min, self.motion.spindle_rpm());
        }
        if let Some(t) = w.tool.take() {
            let t = self.cfg.known_tool(t);
            self.name_tool(&t);
            if self.cfg.tool_change_on_t {
                self.passes.end_segment();
                self.motion.tool = Some(t.clone());
                self.done.tool_change = true;
                self.time_min += self.cfg.tool_change_min;
            }
            self.motion.preselected = Some(t);
        }
        if let Some(d) = w.d {
            self.select_edge(d, w.dl);
        } else if let Some(dl) = w.dl {
            // DL of D0 is no offset (the manual's example: "DL=2 ; No effect").
            self.motion.dl = if self.motion.d == 0.0 { 0.0 } else { dl };
        }
        if let Some(n) = w.tool_carrier {
            self.motion.kinematics.tool_carrier = (n != 0.0).then_some(n);
        }
        if !w.orientation.is_empty() {
            let kinematics = &mut self.motion.kinematics;
            if kinematics.transformation != Some("TRAORI") {
                return Err(format!(
                    "orientation {}= without the orientation transformation TRAORI",
                    w.orientation[0].0
                ));
            }
            kinematics.orientation.program(&w.orientation);
        }
        if let Some(offn) = w.offn {
            self.motion.modal.offn = offn;
        }
        self.done.stopre = w.stopre;
        let mut end = None;
        for &m in &w.m {
            let machine = &self.cfg.machine_coolant;
            self.motion.machine_coolant = machine.after(self.motion.machine_coolant, m);
            match m {
                3 | 4 => {
                    self.motion.rotation = m;
                    self.motion.spindle_position = None;
                    self.spindle.set(self.time_min, self.motion.spindle_rpm());
                }
                // M19 positions the spindle at the angle of SD43240, which the dry run does not know.
                19 => self.position_spindle(1, f64::NAN),
                // M70 switches the spindle to axis mode (a C axis): stopped in position control, like
                // SPOS, until M3 / M4 / M5 switch it back.
                70 => self.position_spindle(1, f64::NAN),
                m if m == self.cfg.tool_change_m => self.change_tool(&w_tool_change),
                5 | 0 | 1 | 2 | 30 | 17 => {}
                7..=9 => {
                    let st = &mut self.motion;
                    (st.mist, st.flood) = match m {
                        7 => (true, st.flood),
                        8 => (st.mist, true),
                        _ => (false, false),
                    };
                    self.aux(format!("M{m}"));
                }
                _ => self.aux(format!("M{m}")),
            }
        }
        for &(n, angle) in &w.spos {
            self.position_spindle(n, angle);
        }
        self.other_spindles(&w);
        if let Some(frame) = &w.frame_command {
            if axial.is_some() {
                return Err(format!("{frame} and G58/G59 in one block"));
            }
            self.frame_command(frame, &w.axes, w.rpl)?;
        } else if let Some(fine) = axial {
            for &(a, _, v) in &w.axes {
                self.motion.frames.replace_translation(a, v, fine);
            }
        } else if w.g.contains(&75) {
            self.fixed_point(u, i, &w)?;
        } else if w.g.contains(&74) {
            self.reference_point(u, i, &w)?;
        } else if !w.axes.is_empty() && limit.is_none() {
            self.travel(u, i, &w, suppress)?;
        }
        // G331 / G332 turn the spindle in position control with the axis (whether SPOS came before or the
        // machine switches itself): it stands positioned at an angle the dry run does not follow until
        // M3 / M4 / M5.
        if w.g.iter().any(|g| matches!(g, 331 | 332)) {
            self.position_spindle(1, f64::NAN);
        }
        if dwell {
            let minutes = match (w.feed, w.s) {
                (Some(s), None) => s / 60.0,
                (None, Some(rev)) if self.motion.master_rpm() > 0.0 => {
                    rev / self.motion.master_rpm()
                }
                (None, Some(_)) => {
                    return Err(
                        "G4 S… dwells spindle revolutions, but the spindle is stopped".into(),
                    );
                }
                _ => return Err("G4 needs exactly one of F (seconds) or S (revolutions)".into()),
            };
            self.time_min += minutes;
        }
        for &m in &w.m {
            match m {
                5 => {
                    self.passes.end_segment();
                    self.motion.rotation = 0;
                    self.motion.spindle_position = None;
                    self.spindle.set(self.time_min, 0.0);
                }
                0 | 1 => {
                    self.done.stop = Some(m);
                    self.time_min += self.cfg.stop_min;
                }
                2 | 30 => {
                    self.done.stop = Some(m);
                    end = Some(End::ProgramEnd {
                        code: format!("M{m}"),
                    })
                }
                17 => end = end.or(Some(End::ProgramEnd { code: "M17".into() })),
                _ => {}
            }
        }
        if let Some((cycle, args)) = &w.probe {
            self.done.probe = true;
            self.probe(u, i, cycle, args);
        }
        if let Some((number, text)) = w.alarm {
            self.run.alarms.push(Alarm {
                at: self.at(u, i),
                number,
                text,
            });
            return Ok(Flow::End(End::Alarm { number }));
        }
        match end {
            Some(End::ProgramEnd { code }) if code == "M17" => return Ok(Flow::Return),
            Some(end) => return Ok(Flow::End(end)),
            None => {}
        }
        if w.ret {
            return Ok(Flow::Return);
        }
        let mut skipped = false;
        if let Some((name, args, refs)) = w.call {
            match self.load(u, &name) {
                Ok(unit) => {
                    return Ok(Flow::Call {
                        unit,
                        args,
                        refs,
                        repeats: w.repeat.unwrap_or(1).max(1),
                        modally: false,
                    });
                }
                // A call the profile declares to change tools: as M6, with the tool its argument gives.
                Err(_) if let Some(&arg) = self.cfg.tool_change_calls.get(&name) => {
                    if let Some(k) = arg {
                        let tool = match args.get(k) {
                            Some(Some(v)) => Tool::from(v),
                            _ => {
                                return Err(format!(
                                    "{name} is declared to load the tool in its argument {}, which this call does not give",
                                    k + 1
                                ));
                            }
                        };
                        let tool = self.cfg.known_tool(tool);
                        self.name_tool(&tool);
                        self.motion.preselected = Some(tool);
                    }
                    self.change_tool(&w_tool_change);
                }
                Err(why) if self.cfg.skip_missing_calls => {
                    skipped = true;
                    let under = self.top().modal_call.clone();
                    self.done.skipped = Some(SkippedCall::new(
                        &name,
                        &args,
                        &w.call_unknown,
                        false,
                        under.as_ref(),
                    ));
                    if let Some(f) = feed_left_by_cycle(&name, &args) {
                        self.program_feed(f);
                    }
                    let at = self.at(u, i);
                    self.run.messages.push(Message {
                        at,
                        text: format!("skipped as doing nothing: {why}"),
                    });
                }
                Err(why) => return Err(why),
            }
        }
        if let Some((start, end)) = w.section {
            let passes = w.repeat.unwrap_or(1);
            self.top().sections.push(Section {
                start,
                end,
                left: passes - 1,
                resume: i + 1,
            });
            return Ok(Flow::Jump(start));
        }
        // `L200 P3` skipped as missing: its P repeats nothing.
        if w.repeat.is_some() && !skipped {
            return Err("P (repetitions) without a subprogram call or REPEAT".into());
        }
        if let Some(call) = w.modal_call {
            self.top().modal_call = call;
        } else if w.jump.is_none()
            && self.done.movement.is_some()
            && let Some((name, args)) = self.top().modal_call.clone()
        {
            return self.modal_call(u, i, &name, args);
        }
        Ok(w.jump.map_or(Flow::Next, Flow::Jump))
    }

    /// The call `MCALL NAME` asks for after block `i` moved: NAME with its arguments, as a modal call; a
    /// subprogram or cycle the dry run cannot find is skipped (noted once) where missing calls are.
    fn modal_call(
        &mut self,
        u: &Unit,
        i: usize,
        name: &str,
        args: CallArgs,
    ) -> Result<Flow, String> {
        match self.load(u, name) {
            Ok(unit) => Ok(Flow::Call {
                unit,
                args,
                refs: Vec::new(),
                repeats: 1,
                modally: true,
            }),
            Err(why) if self.cfg.skip_missing_calls => {
                self.done.skipped = Some(SkippedCall::new(name, &args, &[], true, None));
                self.note(
                    u,
                    i,
                    format!("MCALL {name}: not run after the moves ({why})"),
                );
                Ok(Flow::Next)
            }
            Err(why) => Err(format!("MCALL {name}: {why}")),
        }
    }

    /// F in the program's units (G700: inch per minute) made the modal feed, in mm.
    fn program_feed(&mut self, f: f64) {
        let unit = if self.motion.modal.inch_feed {
            MM_PER_INCH
        } else {
            1.0
        };
        self.motion.modal.feed = Some(f * unit);
    }

    /// Notes the name of a tool selected by name, for `$TC_TP2`.
    fn name_tool(&mut self, t: &Tool) {
        if let Tool::Name(name) = t
            && !self.named_tools.contains(name)
        {
            self.named_tools.push(name.clone());
        }
    }

    /// M6, or a call declared to change tools: the preselected tool loaded, the spindle stopped.
    fn change_tool(&mut self, w: &ToolChangeWords) {
        self.passes.end_segment();
        if let Some(t) = &self.motion.preselected {
            self.motion.tool = Some(t.clone());
        }
        // The new tool's first cutting edge unless the block selects one (MD20270
        // CUTTING_EDGE_DEFAULT = 1).
        self.select_edge(w.d.unwrap_or(1.0), w.dl);
        // The change macro turns the spindle to its own change angle.
        self.motion.spindle_position = None;
        // The change cycle stops the spindle to swap the tool; the program starts it again.
        if self.motion.rotation != 0 && !w.starts_spindle {
            self.motion.rotation = 0;
            self.spindle.set(self.time_min, 0.0);
        }
        self.done.tool_change = true;
        self.time_min += self.cfg.tool_change_min;
    }

    /// Selects cutting edge `d` with sum offset `dl`, or the one MD20272 gives a new edge (D0: none).
    fn select_edge(&mut self, d: f64, dl: Option<f64>) {
        self.motion.d = d;
        self.motion.dl = if d == 0.0 {
            0.0
        } else {
            dl.unwrap_or(self.cfg.sumcorr_default)
        };
    }

    /// SPOS / M19: spindle `n` stops in position control at `angle` (NaN: not known).
    fn position_spindle(&mut self, n: usize, angle: f64) {
        if n == 1 {
            self.passes.end_segment();
            self.motion.rotation = 0;
            self.motion.spindle_position = Some(angle);
            self.spindle.set(self.time_min, 0.0);
        } else {
            let s = &mut self.motion.others[n - 2];
            (s.rotation, s.position) = (0, Some(angle));
        }
    }

    /// `Sn=` and `Mn=` of spindles 2 … 4: speed, M3 / M4 / M5, M19; another M code goes to the PLC.
    fn other_spindles(&mut self, w: &Words) {
        for &(n, s) in &w.other_s {
            self.motion.others[n - 2].s = s;
        }
        for &(n, m) in &w.other_m {
            let s = &mut self.motion.others[n - 2];
            match m {
                3..=5 => (s.rotation, s.position) = (if m == 5 { 0 } else { m }, None),
                19 => (s.rotation, s.position) = (0, Some(f64::NAN)),
                _ => self.aux(format!("M{n}={m}")),
            }
        }
    }

    pub(super) fn plane(&self, names: [&str; 3]) -> [Option<usize>; 3] {
        names.map(|n| self.axis_index(n))
    }

    pub(super) fn frame_command(
        &mut self,
        name: &str,
        axes: &[(usize, Dim, f64)],
        rpl: Option<f64>,
    ) -> Result<(), String> {
        let absolute = ABSOLUTE_FRAMES.contains(&name);
        let part = if absolute { name } else { &name[1..] };
        let linear = match part {
            "TRANS" => None,
            "ROT" => Some(self.rotation(name, axes, rpl)?),
            "SCALE" | "MIRROR" => {
                let mut m = IDENTITY;
                for &(a, _, v) in axes {
                    let k = self.geo_axis(a, name)?;
                    m[k][k] = if part == "SCALE" { v } else { -1.0 };
                }
                Some(m)
            }
            _ => return Err(format!("{name} is not a frame command")),
        };
        if rpl.is_some() && part != "ROT" {
            return Err(format!("RPL= belongs to ROT / AROT, not to {name}"));
        }
        let f = &mut self.motion.frames;
        if absolute {
            f.reset_programmable();
        }
        match linear {
            Some(m) => f.compose(&m),
            None => {
                for &(a, _, v) in axes {
                    f.translate(a, v, !absolute);
                }
            }
        }
        Ok(())
    }

    /// Position of axis `a` among the geometry axes X, Y, Z (0, 1, 2), which alone rotate, scale and mirror.
    fn geo_axis(&self, a: usize, command: &str) -> Result<usize, String> {
        self.motion
            .frames
            .geo
            .iter()
            .position(|g| *g == Some(a))
            .ok_or_else(|| {
                format!(
                    "{command} {}: only the geometry axes X, Y, Z rotate, scale and mirror in the dry run",
                    self.cfg.axes[a]
                )
            })
    }

    /// The rotation of `ROT`/`AROT`: angles about the named geometry axes, applied Z, then Y', then X''
    /// (RPY, MD10600 = 1), or `RPL=` about the infeed axis of the working plane.
    fn rotation(
        &self,
        name: &str,
        axes: &[(usize, Dim, f64)],
        rpl: Option<f64>,
    ) -> Result<Matrix, String> {
        let mut angles = [0.0; 3];
        for &(a, _, v) in axes {
            angles[self.geo_axis(a, name)?] = v;
        }
        if let Some(angle) = rpl {
            if angles.iter().any(|a| *a != 0.0) {
                return Err(format!("{name} with both RPL= and axis angles"));
            }
            let infeed = self.motion.modal.plane[2]
                .and_then(|a| self.motion.frames.geo.iter().position(|g| *g == Some(a)))
                .ok_or("RPL= in a plane without an infeed geometry axis")?;
            return Ok(rotation(infeed, angle));
        }
        Ok(multiply(
            &multiply(&rotation(2, angles[2]), &rotation(1, angles[1])),
            &rotation(0, angles[0]),
        ))
    }

    /// G75 FP=n: the axes the block names go to fixed point n at rapid, a machine position
    /// (`$MA_FIX_POINT_POS[n-1,axis]` from the machine file's `[variables]`, else 0, noted); the values
    /// written with them are placeholders. Without FP= the control approaches fixed point 1 (a DMG post's
    /// `G75 Z0`).
    fn fixed_point(&mut self, u: &Unit, i: usize, w: &Words) -> Result<(), String> {
        let fp = w.fixed_point.unwrap_or(1);
        self.rapid_to_machine_positions(u, i, w, |axis| {
            format!("$MA_FIX_POINT_POS[{},{axis}]", fp - 1)
        })
    }

    /// G74: the axes the block names go to their reference points at rapid, machine positions
    /// (`$MA_REFP_SET_POS[0,axis]`, MD34100, from the machine file's `[variables]`, else 0, noted); the
    /// values written with them (`G74 X1=0 Z1=0`) are placeholders.
    fn reference_point(&mut self, u: &Unit, i: usize, w: &Words) -> Result<(), String> {
        self.rapid_to_machine_positions(u, i, w, |axis| format!("$MA_REFP_SET_POS[0,{axis}]"))
    }

    /// The axes `w` names to the machine positions the machine data `variable(axis)` holds, at rapid.
    fn rapid_to_machine_positions(
        &mut self,
        u: &Unit,
        i: usize,
        w: &Words,
        variable: impl Fn(&str) -> String,
    ) -> Result<(), String> {
        let mut axes = Vec::new();
        for &(a, _, _) in &w.axes {
            let name = variable(&self.cfg.axes[a]);
            let key = crate::vm::config::variable_key(&name)
                .ok_or_else(|| format!("{name} cannot be a variable's name"))?;
            axes.push((a, Dim::Absolute, self.external(key)));
        }
        let to = Words {
            axes,
            ..Words::default()
        };
        let motion = std::mem::replace(&mut self.motion.modal.motion, 0);
        let moved = self.travel(u, i, &to, true);
        self.motion.modal.motion = motion;
        moved
    }

    /// Moves the programmed axes: geometry, time, and the cut it makes.
    pub(super) fn travel(
        &mut self,
        u: &Unit,
        i: usize,
        w: &Words,
        suppress: bool,
    ) -> Result<(), String> {
        let st = &mut self.motion;
        let start_local = st.local.clone();
        let start_machine = st.machine.clone();
        let from = st.work_geometry();
        let mut geometry_moved = false;
        let mut any_in_machine = suppress;
        for &(a, dim, v) in &w.axes {
            let absolute = match dim {
                Dim::Modal => st.modal.absolute,
                Dim::Absolute | Dim::Machine => true,
                Dim::Incremental => false,
            };
            let suppress = suppress || dim == Dim::Machine;
            any_in_machine |= suppress;
            let offset = if suppress { 0.0 } else { st.frames.offset(a) };
            // Under DIAM90 an incremental value of the diameter axis is a radius: twice it on the diameter.
            let step = if st.diam90 && st.diameter_axis == Some(a) {
                2.0 * v
            } else {
                v
            };
            st.local[a] = if absolute { v } else { st.local[a] + step };
            let radius = if st.diameter_axis == Some(a) {
                st.local[a] / 2.0
            } else {
                st.local[a]
            };
            st.machine[a] = radius + offset;
            st.moved |= 1 << a;
            if suppress {
                st.suppressed |= 1 << a;
            } else {
                st.suppressed &= !(1 << a);
            }
            geometry_moved |= st.frames.geo.contains(&Some(a));
        }
        if geometry_moved && !any_in_machine && st.frames.is_linear() {
            st.place_geometry();
        }
        let motion = st.modal.motion;
        let mut work_centre = None;
        let chord: f64 = start_machine
            .iter()
            .zip(&st.machine)
            .map(|(a, b)| (b - a).powi(2))
            .sum::<f64>()
            .sqrt();
        let length = if matches!(motion, 2 | 3) {
            let [Some(p), Some(q), infeed] = st.modal.plane else {
                return Err("circle in a plane whose axes this machine lacks".into());
            };
            let centre_of = |axis: usize| -> Option<(f64, bool)> {
                let name = self.cfg.axes[axis].as_str();
                let k = ["X", "Y", "Z"].iter().position(|&n| n == name)?;
                w.centre[k]
            };
            let (cp, cq) = (centre_of(p), centre_of(q));
            let centre = match (cp, cq) {
                (None, None) => None,
                _ => Some([cp.map_or(0.0, |c| c.0), cq.map_or(0.0, |c| c.0)]),
            };
            let centre_absolute = cp.is_some_and(|c| c.1) || cq.is_some_and(|c| c.1);
            let arc = ArcSpec {
                clockwise: motion == 2,
                centre,
                centre_absolute,
                radius: w.cr,
                turns: w.turn.unwrap_or(0.0),
            };
            let rise = infeed.map_or(0.0, |k| st.local[k] - start_local[k]);
            let (start, end) = ([start_local[p], start_local[q]], [st.local[p], st.local[q]]);
            let length = arc_length(&arc, start, end, rise)?;
            work_centre = st.work_centre(&arc, start, end, [p, q], &start_local);
            length
        } else if motion == POLY && st.modal.poly_axes && !w.poly_coefficients.is_empty() {
            let curves: Vec<AxisCurve> = w
                .axes
                .iter()
                .map(|&(a, _, _)| {
                    let given = w.poly_coefficients.iter().find(|(k, _)| *k == a);
                    // A diameter axis moves half its programmed values.
                    let scale = if st.diameter_axis == Some(a) {
                        0.5
                    } else {
                        1.0
                    };
                    AxisCurve {
                        start: start_machine[a],
                        end: st.machine[a],
                        coefficients: given.map_or([0.0; 4], |(_, c)| c.map(|v| v * scale)),
                    }
                })
                .collect();
            polynomial::length(&curves, w.pl.unwrap_or(1.0))
        } else {
            chord
        };
        let minutes = if motion == 0 {
            length / self.cfg.rapid_mm_min
        } else if is_thread(motion) && motion != 63 {
            // The axis follows the spindle: the lead (I, J or K, mm per revolution; G34 / G35 change it
            // along the thread, taken as the starting lead) at the spindle's speed, the programmed S
            // under position control (G331 / G332).
            let lead = w
                .centre
                .iter()
                .flatten()
                .map(|(l, _)| l.abs())
                .reduce(f64::max)
                .ok_or_else(|| format!("G{motion} without a lead (I, J or K)"))?;
            let rpm = if matches!(motion, 331 | 332) {
                st.s.abs()
            } else {
                st.master_rpm()
            };
            if lead * rpm <= 0.0 {
                return Err(format!("G{motion} with the spindle stopped or no lead"));
            }
            length / (lead * rpm)
        } else {
            let feed = st
                .modal
                .feed
                .or(self.cfg.default_feed_mm_min)
                .ok_or("feed move without a programmed feed F (alarm 10860)")?;
            if feed <= 0.0 {
                return Err(format!("feed F{feed} must be positive"));
            }
            match st.modal.feed_mode {
                FeedMode::PerMinute => length / feed,
                FeedMode::PerRevolution => {
                    let rpm = st.master_rpm();
                    if rpm <= 0.0 {
                        return Err("G95 feed per revolution with the spindle stopped".into());
                    }
                    length / (feed * rpm)
                }
                FeedMode::InverseTime => 1.0 / feed,
            }
        };
        self.done.movement = Some(Movement {
            motion,
            from,
            to: st.work_geometry(),
            centre: work_centre,
            plane: st
                .modal
                .plane
                .map(|a| a.and_then(|a| st.frames.geo.iter().position(|g| *g == Some(a)))),
        });
        let t0 = self.time_min;
        self.time_min += minutes;
        if motion == 0 {
            self.passes.end_segment();
            return Ok(());
        }
        if !self.cfg.passes {
            return Ok(());
        }
        let rpm = self.motion.spindle_rpm();
        if rpm <= 0.0 || length == 0.0 {
            return Ok(());
        }
        let mid = (t0 + self.time_min) / 2.0;
        for name in ["X", "Y", "Z"] {
            let Some(a) = self.axis_index(name) else {
                continue;
            };
            let drift = self.machine.drift_um(name, mid, &self.spindle);
            let correction = if suppress {
                0.0
            } else {
                self.motion.frames.correction(a) * 1000.0
            } + self.temp_comp_shift(a) * 1000.0;
            self.run
                .cutting_error
                .entry(name.to_string())
                .or_default()
                .add(drift - correction, drift, minutes);
        }
        let Some(z) = self.axis_index("Z") else {
            return Ok(());
        };
        let drift = self.machine.drift_um("Z", mid, &self.spindle);
        let correction = if suppress {
            0.0
        } else {
            self.motion.frames.correction(z) * 1000.0
        } + self.temp_comp_shift(z) * 1000.0;
        let planar = (start_local[z] - self.motion.local[z]).abs() < 1e-9;
        self.passes.feed_move(Cut {
            file: u.name.clone(),
            line: i + 1,
            start_min: t0,
            end_min: self.time_min,
            z_mm: self.motion.local[z],
            spindle_rpm: rpm,
            error_um: drift - correction,
            drift_um: drift,
            planar_length_mm: if planar { length } else { 0.0 },
        });
        Ok(())
    }

    pub(super) fn probe(&mut self, u: &Unit, i: usize, cycle: &str, args: &[Option<f64>]) {
        self.passes.end_segment();
        let named = self
            .cfg
            .probe_axis_arg
            .and_then(|k| args.get(k).copied().flatten())
            .filter(|n| matches!(*n as i64, 1..=3) && n.fract() == 0.0)
            .map(|n| ["X", "Y", "Z"][n as usize - 1].to_string());
        let axis = named.unwrap_or_else(|| self.cfg.probe_axis.clone());
        let surface = self
            .cfg
            .probe_surfaces
            .get(&axis)
            .copied()
            .unwrap_or(self.cfg.probe_surface_mm);
        let offset = self
            .axis_index(&axis)
            .map_or(0.0, |a| self.motion.frames.offset(a));
        let surface = if self.cfg.probe_surface_at_first_probing && !self.cfg.probe_machine_frame {
            *self
                .surfaces_at_first_probing
                .entry(axis.clone())
                .or_insert(surface + offset)
        } else {
            surface
        };
        let t = self.time_min;
        let true_drift = self.machine.drift_um(&axis, t, &self.spindle);
        let result = self.machine.probe(&ProbeCall {
            cycle,
            args,
            axis: &axis,
            t_min: t,
            spindle: &self.spindle,
        });
        let compensated = self
            .axis_index(&axis)
            .map_or(0.0, |a| self.temp_comp_shift(a));
        let written = match result {
            // The probe triggers when the real tool tip (commanded − drift) reaches the surface, so the control
            // reads the surface plus the drift; the temperature compensation moves the axis without showing in
            // the actual value, so it is taken off.
            ProbeResult::Drift(d) => {
                let frame = if self.cfg.probe_machine_frame {
                    0.0
                } else {
                    offset
                };
                let scale = if self.cfg.probe_diameter { 2.0 } else { 1.0 };
                Some(surface - frame + scale * (d / 1000.0 - compensated))
            }
            ProbeResult::Raw(v) => Some(v),
            ProbeResult::Nothing => None,
        };
        let value_mm = self.probe_result(written);
        let at = self.at(u, i);
        self.run.measurements.push(Measurement {
            at,
            cycle: cycle.to_string(),
            axis,
            true_drift_um: true_drift,
            result,
            value_mm,
        });
        self.time_min += self.cfg.probe_min;
    }

    /// Writes the probe result (if any) where the configuration says; returns what is there afterwards.
    fn probe_result(&mut self, value: Option<f64>) -> f64 {
        match &self.cfg.probe_result {
            ProbeTarget::R(r) => match self.r.get_mut(*r) {
                Some(slot) => {
                    if let Some(v) = value {
                        *slot = v;
                    }
                    *slot
                }
                None => f64::NAN,
            },
            ProbeTarget::Array(name, index) => {
                let array = self.globals.get_mut(name).expect("created at start");
                if let Some(v) = value {
                    let _ = array.set(&[*index], Value::Num(v));
                }
                array
                    .get(&[*index])
                    .ok()
                    .and_then(|v| v.num().ok())
                    .unwrap_or(f64::NAN)
            }
        }
    }
}

/// The feed a skipped stock-removal cycle leaves in force. The Siemens cycles are declared SAVE, which gives
/// back the G functions and the frame at their end but not F: the blocks after `CYCLE95` run at the feed it
/// programmed last (Fusion's mill-turn post writes the contour there again, with no F of its own). That is
/// the finishing feed FF3 (8th parameter) when the cycle finishes (VARI 5 … 12: finishing or complete), else
/// the roughing feed FF1 (6th). `None` where the call does not give it: F stays as it was.
fn feed_left_by_cycle(name: &str, args: &[Option<Value>]) -> Option<f64> {
    if name != "CYCLE95" {
        return None;
    }
    let num = |k: usize| match args.get(k) {
        Some(Some(v)) => v.num().ok(),
        _ => None,
    };
    let finishes = num(8)? >= 5.0;
    num(if finishes { 7 } else { 5 }).filter(|f| *f > 0.0)
}
