//! The statements of a plain block: words, assignments, declarations.

use super::*;

impl Interp<'_> {
    pub(super) fn plain(&mut self, u: &Rc<Unit>, i: usize, root: &Node) -> Result<Flow, String> {
        let mut w = Words::default();
        let mut condition = true;
        for node in root.significant() {
            match node.kind {
                NodeKind::BlockNumber | NodeKind::Label | NodeKind::Skip | NodeKind::Header => {}
                NodeKind::Error => {
                    return Err(
                        first_message(u, i).unwrap_or_else(|| "the block cannot be parsed".into())
                    );
                }
                NodeKind::Word => self.word(u, node, &mut w)?,
                NodeKind::Assign => {
                    let parts: Vec<&Node> = node.significant().collect();
                    let [target, _, value] = parts[..] else {
                        return Err("malformed assignment".into());
                    };
                    self.assign(u, i, target, value, &mut w)?;
                }
                NodeKind::Call => self.call(u, i, node, &mut w)?,
                NodeKind::Command => self.command(u, node, &mut w)?,
                NodeKind::If => condition = self.condition(u, node)?,
                NodeKind::Goto if condition => {
                    w.jump = self.goto(u, i, node)?;
                }
                NodeKind::Goto => {}
                NodeKind::Case => w.jump = self.case(u, i, node)?,
                NodeKind::Def => self.def(u, node)?,
                // Parameters are bound when the program is called; EXTERN only declares a signature.
                NodeKind::Proc | NodeKind::Extern => {}
                NodeKind::ProgramCall => self.program_call(u, i, node, &mut w)?,
                NodeKind::Repeat => w.section = Some(self.section(u, i, node)?),
                // The rest of the block is the action, which runs in the interpolator, not here.
                NodeKind::SyncCondition => return self.sync_action(u, i, node, w.sync_id),
                k => {
                    return Err(format!(
                        "{} `{}` is not supported by the dry run",
                        k.name(),
                        String::from_utf8_lossy(u.text(node)).trim()
                    ));
                }
            }
        }
        self.apply(u, i, w)
    }

    pub(super) fn word(&mut self, u: &Unit, node: &Node, w: &mut Words) -> Result<(), String> {
        let (address, number) = node.address_and_number().ok_or("malformed word")?;
        let letter = u.upper(address);
        let value = eval::parse_number(&String::from_utf8_lossy(u.text(number)))?;
        let whole = || {
            if value >= 0.0 && value.fract() == 0.0 {
                Ok(value as u32)
            } else {
                Err(format!("{letter}{value} needs a whole number"))
            }
        };
        match letter.as_str() {
            "G" => w.g.push(whole()?),
            "M" => w.m.push(whole()?),
            "F" => w.feed = Some(value),
            "S" => w.s = Some(value),
            "T" => w.tool = Some(Tool::Number(value)),
            "D" => w.d = Some(value),
            "L" => w.call = Some((format!("L{}", whole()?), Vec::new(), Vec::new())),
            "P" => w.repeat = Some(whole()?),
            "I" | "J" | "K" => w.centre[ijk(&letter)] = Some((value, false)),
            // H: an auxiliary function for the PLC, like M codes beyond the modelled ones.
            "H" => self.aux(format!("H{}", crate::vm::value::format_number(value))),
            _ => match self.axis_index(&letter) {
                Some(a) => w.axes.push((a, Dim::Modal, value)),
                None => return Err(format!("address {letter} is not supported by the dry run")),
            },
        }
        Ok(())
    }

    pub(super) fn assign(
        &mut self,
        u: &Unit,
        i: usize,
        target: &Node,
        value: &Node,
        w: &mut Words,
    ) -> Result<(), String> {
        if target.kind == NodeKind::Var {
            let index = target.find(NodeKind::Index);
            let name = match index {
                Some(_) => u.upper(target.find(NodeKind::Name).ok_or("variable without name")?),
                None => u.upper(target),
            };
            // `X=…`, or `AX[X]=…` / `AX[_AXVAR]=…`: the axis the index names.
            let axis = match index {
                None => self.axis_index(&name),
                Some(index) if name == "AX" && self.variable(&name).is_none() => {
                    match index_nodes(index)[..] {
                        [axis] => Some(self.axis_arg(u, axis)?),
                        _ => None,
                    }
                }
                Some(_) => None,
            };
            if let Some(a) = axis {
                if index.is_none()
                    && value.kind == NodeKind::FnCall
                    && u.upper(&value.children[0]) == "PO"
                {
                    return self.polynomial_axis(u, a, &value.call_arguments(), w);
                }
                let (dim, v) = self.axis_target(u, a, value)?;
                w.axes.push((a, dim, v));
                return Ok(());
            }
            if self.variable(&name).is_some_and(|v| v.ty == VarType::Axis)
                && let Some(axis) = self.axis_named(u, value)
            {
                return self.store(u, target, Value::Str(axis), w);
            }
            if let (None, Some(a), None) =
                (index, self.cfg.machine_axis(&name), self.variable(&name))
            {
                let (dim, v) = self.axis_target(u, a, value)?;
                if dim == Dim::Incremental {
                    return Err(format!(
                        "{name}=IC(…): a machine axis goes to a machine position"
                    ));
                }
                w.axes.push((a, Dim::Machine, v));
                return Ok(());
            }
            if self.variable(&name).is_none() {
                let done = match index {
                    None => self.address(u, &name, value, w)?,
                    Some(index) => self.indexed_address(u, &name, &index_nodes(index), value, w)?,
                };
                if done {
                    return Ok(());
                }
            }
        }
        if target.kind == NodeKind::SysVar {
            return self.write_sysvar(u, i, target, value);
        }
        let v = self.eval(u, value)?;
        self.store(u, target, v, w)
    }

    /// `NAME = value` where NAME is an address: F, S, Sn, T, D, DL, M, Mn, CR, TURN, I, J, K, SPOS, TCARR, ….
    pub(super) fn address(
        &mut self,
        u: &Unit,
        name: &str,
        value: &Node,
        w: &mut Words,
    ) -> Result<bool, String> {
        match name {
            "F" => w.feed = Some(self.num(u, value)?),
            "S" | "S1" => w.s = Some(self.num(u, value)?),
            "D" => w.d = Some(self.num(u, value)?),
            "CR" => w.cr = Some(self.num(u, value)?),
            "TURN" => {
                let n = self.num(u, value)?;
                if !(0.0..=999.0).contains(&n) || n.fract() != 0.0 {
                    return Err(format!("TURN={n} must be a whole number of turns, 0 … 999"));
                }
                w.turn = Some(n);
            }
            "LIMS" => w.lims = Some(self.num(u, value)?),
            "T" => w.tool = Some(Tool::from(&self.eval(u, value)?)),
            "RPL" => w.rpl = Some(self.num(u, value)?),
            "I" | "J" | "K" => w.centre[ijk(name)] = Some(self.centre_value(u, value)?),
            "M" => w.m.push(self.num(u, value)? as u32),
            "G" => {
                let g = self.num(u, value)?;
                if g < 0.0 || g.fract() != 0.0 {
                    return Err(format!("G={g} needs a whole number"));
                }
                w.g.push(g as u32);
            }
            "H" => self.aux(format!("H{}", self.eval(u, value)?.text())),
            "P" => {
                let p = self.num(u, value)?;
                if p < 1.0 || p.fract() != 0.0 {
                    return Err(format!("P={p}: repetitions must be a whole number ≥ 1"));
                }
                w.repeat = Some(p as u32);
            }
            _ if name.starts_with(['M', 'S']) && name[1..].bytes().all(|b| b.is_ascii_digit()) => {
                let spindle = spindle_number(&name[1..])?;
                let v = self.num(u, value)?;
                match (name.starts_with('M'), spindle) {
                    (true, 1) => w.m.push(v as u32),
                    (false, 1) => w.s = Some(v),
                    (true, n) => w.other_m.push((n, v as u32)),
                    (false, n) => w.other_s.push((n, v)),
                }
            }
            "SPOS" | "SPOSA" => w.spos.push((1, self.spindle_angle(u, 1, value)?)),
            "DL" => w.dl = Some(self.num(u, value)?),
            "TCARR" => w.tool_carrier = Some(self.num(u, value)?),
            "OFFN" => w.offn = Some(self.num(u, value)?),
            "FP" => {
                let n = self.num(u, value)?;
                if !(1.0..=4.0).contains(&n) || n.fract() != 0.0 {
                    return Err(format!("FP={n}: a fixed point is 1 … 4"));
                }
                w.fixed_point = Some(n as u32);
            }
            // Rounding of G641 / G642 corners, and a chamfer or rounding at a contour's corner (and the
            // feeds along them): how the path blends between the same points, not where they are.
            "ADIS" | "ADISPOS" | "CHR" | "CHF" | "RND" | "RNDM" | "FRC" | "FRCM" => {
                self.num(u, value)?;
            }
            "ID" | "IDS" => {
                let n = self.num(u, value)?;
                if !(1.0..=255.0).contains(&n) || n.fract() != 0.0 {
                    return Err(format!(
                        "{name}={n}: a synchronized action's number is 1 … 255"
                    ));
                }
                w.sync_id = Some((n as u32, name == "IDS"));
            }
            // Point weight and degree shape a spline, not where its points are.
            "PW" | "SD" => {
                self.num(u, value)?;
            }
            "PL" => {
                let pl = self.num(u, value)?;
                if pl <= 0.0 {
                    return Err(format!("PL={pl}: the parameter interval must be positive"));
                }
                w.pl = Some(pl);
            }
            "AP" | "RP" => return Err(format!("{name}= (polar coordinates) is not supported")),
            _ if let Some(word) = crate::vm::orientation::word(name) => {
                w.orientation.push((word, self.num(u, value)?));
            }
            _ => return Ok(false),
        }
        Ok(true)
    }

    pub(super) fn centre_value(&self, u: &Unit, value: &Node) -> Result<(f64, bool), String> {
        let (dim, v) = self.axis_value(u, value, false)?;
        Ok((v, dim == Dim::Absolute))
    }

    /// The value written to axis `a`, a rotary one unless it is a geometry axis ([`Interp::axis_value`]).
    fn axis_target(&self, u: &Unit, a: usize, value: &Node) -> Result<(Dim, f64), String> {
        let rotary = !self.motion.frames.geo.contains(&Some(a));
        self.axis_value(u, value, rotary)
    }

    /// `AC(v)`, `IC(v)` or a plain value; on a rotary axis also `DC(v)`, `ACP(v)`, `ACN(v)`, which go to the
    /// absolute angle v by the shortest way or in one direction (the dry run takes the straight way).
    pub(super) fn axis_value(
        &self,
        u: &Unit,
        value: &Node,
        rotary: bool,
    ) -> Result<(Dim, f64), String> {
        if value.kind == NodeKind::FnCall {
            let name = u.upper(&value.children[0]);
            let dim = match name.as_str() {
                "AC" => Some(Dim::Absolute),
                "IC" => Some(Dim::Incremental),
                "DC" | "ACP" | "ACN" if rotary => Some(Dim::Absolute),
                "DC" | "ACP" | "ACN" => {
                    return Err(format!(
                        "{name}() positions a rotary axis or a spindle, not a linear axis (alarm 16830)"
                    ));
                }
                _ => None,
            };
            if let Some(dim) = dim {
                let args = value.call_arguments();
                let [Some(arg)] = args[..] else {
                    return Err(format!("{name}() takes one value"));
                };
                return Ok((dim, self.num(u, arg)?));
            }
        }
        Ok((Dim::Modal, self.num(u, value)?))
    }

    /// `NAME[index] = value` where NAME is not a variable: `SPOS[n]`, `SPOSA[n]` (spindle n), `G[group]`
    /// (a G code by its number in its group), and the axis-wise dynamics `ACC`, `FA`, `FL`, `OVRA`, `JERKA`
    /// (how fast, not where: accepted as they are).
    fn indexed_address(
        &mut self,
        u: &Unit,
        name: &str,
        index: &[&Node],
        value: &Node,
        w: &mut Words,
    ) -> Result<bool, String> {
        let [index] = index else {
            return Ok(false);
        };
        match name {
            "SPOS" | "SPOSA" => {
                let n = self.num(u, index)?;
                let spindle = spindle_number(&crate::vm::value::format_number(n))?;
                w.spos
                    .push((spindle, self.spindle_angle(u, spindle, value)?));
            }
            "G" => {
                let (group, number) = (self.num(u, index)?, self.num(u, value)?);
                let g = crate::views::indirect_g(group, number).ok_or_else(|| {
                    format!(
                        "G[{group}]={number}: that G group or number is not modelled by the dry run"
                    )
                })?;
                w.g.push(g);
            }
            "PO" if value.kind == NodeKind::Args => {
                let axis = u.upper(index);
                let a = self
                    .axis_index(&axis)
                    .ok_or_else(|| format!("PO[{axis}]: {axis} is not an axis"))?;
                self.polynomial_axis(u, a, &value.arguments(), w)?;
            }
            "ACC" | "FA" | "FL" | "OVRA" | "JERKA" => {
                let axis = u.upper(index);
                let spindle = axis.strip_prefix('S').map(spindle_number);
                if self.axis_index(&axis).is_none() && !matches!(spindle, Some(Ok(_))) {
                    return Err(format!(
                        "{name}[{axis}]: {axis} is neither an axis nor a spindle"
                    ));
                }
                self.num(u, value)?;
            }
            _ => return Ok(false),
        }
        Ok(true)
    }

    /// `PO[X]=(end, a2, …, a5)` or `X=PO(end, a2, …)`: the axis goes to `end`, along its polynomial while
    /// POLY is active (the last coefficients may be left out when 0).
    fn polynomial_axis(
        &self,
        u: &Unit,
        a: usize,
        items: &[Option<&Node>],
        w: &mut Words,
    ) -> Result<(), String> {
        let values = items
            .iter()
            .map(|item| self.num(u, item.ok_or("PO: an empty value")?))
            .collect::<Result<Vec<f64>, String>>()?;
        let [end, higher @ ..] = &values[..] else {
            return Err("PO needs the end point".into());
        };
        if higher.len() > 4 {
            return Err("PO takes the end point and at most the coefficients a2 … a5".into());
        }
        let mut coefficients = [0.0; 4];
        coefficients[..higher.len()].copy_from_slice(higher);
        w.axes.push((a, Dim::Modal, *end));
        w.poly_coefficients.push((a, coefficients));
        Ok(())
    }

    /// The angle a `SPOS` of `spindle` goes to (degrees, 0 … 360): `AC`, `DC`, `ACP`, `ACN` or plain are
    /// absolute, `IC` from where the spindle is positioned (NaN when it is not: the angle is not known).
    fn spindle_angle(&self, u: &Unit, spindle: usize, value: &Node) -> Result<f64, String> {
        let mode = (value.kind == NodeKind::FnCall).then(|| u.upper(&value.children[0]));
        let (incremental, v) = match mode.as_deref() {
            Some(m @ ("AC" | "IC" | "DC" | "ACP" | "ACN")) => {
                let [Some(arg)] = value.call_arguments()[..] else {
                    return Err(format!("{m}() takes one value"));
                };
                (m == "IC", self.num(u, arg)?)
            }
            _ => (false, self.num(u, value)?),
        };
        let at = match spindle {
            1 => self.motion.spindle_position,
            n => self.motion.others[n - 2].position,
        };
        let angle = if incremental {
            at.map_or(f64::NAN, |a| a + v)
        } else {
            v
        };
        Ok(angle.rem_euclid(360.0))
    }

    /// Stores into an R parameter or a user variable.
    pub(super) fn store(
        &mut self,
        u: &Unit,
        target: &Node,
        v: Value,
        w: &mut Words,
    ) -> Result<(), String> {
        match target.kind {
            NodeKind::RParam => {
                let i = self.r_index(u, target)?;
                self.r[i] = v.num()?;
                Ok(())
            }
            NodeKind::Var => {
                let name = u.upper(target.find(NodeKind::Name).ok_or("variable without name")?);
                let index = self.indices(u, target)?;
                let axis = self.axis_index(&name).filter(|_| index.is_empty());
                let frame = self.stack.last_mut().expect("a frame while running");
                let var = frame.vars.get_mut(&name).or(self.globals.get_mut(&name));
                match (var, axis) {
                    (Some(var), _) => var.set(&index, v),
                    (None, Some(a)) => {
                        w.axes.push((a, Dim::Modal, v.num()?));
                        Ok(())
                    }
                    (None, None) if external::is_cycle_result(&name) => {
                        let nodes: Vec<&Node> = target
                            .find(NodeKind::Index)
                            .map(index_nodes)
                            .unwrap_or_default();
                        let key = self.external_key(u, &name, &nodes)?;
                        // A tool's name (`_TNAME="BALL6"`) is read by the cycle, never by the dry run.
                        if !matches!(v, Value::Str(_)) {
                            self.written.insert(key, v.num()?);
                        }
                        Ok(())
                    }
                    (None, None) => Err(format!("variable {name} is not defined (alarm 12550)")),
                }
            }
            k => Err(format!("cannot assign to {}", k.name())),
        }
    }

    pub(super) fn write_sysvar(
        &mut self,
        u: &Unit,
        i: usize,
        target: &Node,
        value: &Node,
    ) -> Result<(), String> {
        let name = u.upper(
            target
                .find(NodeKind::Name)
                .ok_or("system variable without name")?,
        );
        let idx: Vec<&Node> = target
            .find(NodeKind::Index)
            .map(index_nodes)
            .unwrap_or_default();
        match (name.as_str(), idx.as_slice()) {
            ("$P_UIFR", [frame, axis, part]) => {
                let (f, a, fine) = self.uifr_address(u, frame, axis, part)?;
                let new = self.num(u, value)?;
                let frames = &mut self.motion.frames;
                let slot = if fine {
                    &mut frames.fine[f][a]
                } else {
                    &mut frames.table[f][a]
                };
                let old = std::mem::replace(slot, new);
                self.record_correction(u, i, (f, a, fine), (old, new), false);
                Ok(())
            }
            // A whole settable frame built from translations (what it does not name is 0, coarse and
            // fine): a program setting up its offsets, which driftloop never writes so. Not noted as a
            // correction, whose size is what the audit lets a gate's way back differ by, nor counted as
            // one in the machined error (it counted the program's 611 mm as a correction).
            ("$P_UIFR", [frame]) => {
                let f = self.uifr_number(u, frame)?;
                let shift = self.ctrans(u, value)?;
                self.motion.frames.set_whole(f, shift);
                Ok(())
            }
            ("$P_IFRAME", [axis, part]) => {
                let (a, fine) = (self.axis_arg(u, axis)?, Interp::fine_part(u, part)?);
                let new = self.num(u, value)?;
                let frames = &mut self.motion.frames;
                let f = frames.selected;
                // The frame in force is kept as coarse plus fine: the part not written stays as stored.
                let kept = if fine {
                    frames.table[f][a]
                } else {
                    frames.fine[f][a]
                };
                let old = frames.active[a] - kept;
                frames.active[a] = new + kept;
                self.record_correction(u, i, (f, a, fine), (old, new), true);
                Ok(())
            }
            ("$SA_TEMP_COMP_ABS_VALUE", [axis]) => {
                let a = self.axis_arg(u, axis)?;
                let new = self.num(u, value)?;
                let old = std::mem::replace(&mut self.motion.temp_comp[a], new);
                self.run.temp_comp_writes.push(TempCompWrite {
                    at: self.at(u, i),
                    axis: self.cfg.axes[a].clone(),
                    old_mm: old,
                    new_mm: new,
                });
                Ok(())
            }
            _ if external::is_system(&name) => {
                let key = self.external_key(u, &name, &idx)?;
                let v = self.num(u, value)?;
                self.written.insert(key, v);
                Ok(())
            }
            _ => Err(format!("writing {name} is not supported by the dry run")),
        }
    }

    /// The translation of every axis a `CTRANS(axis, value, …)` frame expression sets (0 where it names
    /// none); another frame expression (a rotation, scale or mirror) is not run.
    fn ctrans(&self, u: &Unit, value: &Node) -> Result<Vec<f64>, String> {
        let call = (value.kind == NodeKind::FnCall)
            .then(|| u.upper(&value.children[0]))
            .filter(|name| name == "CTRANS")
            .ok_or("writing a whole $P_UIFR frame is supported for CTRANS(…) only")?;
        let args: Vec<&Node> = value.call_arguments().into_iter().flatten().collect();
        if args.len() % 2 != 0 {
            return Err(format!("{call} needs axis and value pairs"));
        }
        let mut shift = vec![0.0; self.cfg.axes.len()];
        for pair in args.chunks(2) {
            shift[self.axis_arg(u, pair[0])?] = self.num(u, pair[1])?;
        }
        Ok(shift)
    }

    /// Notes a write to entry (frame, axis, fine) of a settable frame, stored or `in_force`.
    fn record_correction(
        &mut self,
        u: &Unit,
        i: usize,
        (frame, axis, fine): (usize, usize, bool),
        (old_mm, new_mm): (f64, f64),
        in_force: bool,
    ) {
        self.run.corrections.push(Correction {
            at: self.at(u, i),
            frame,
            component: if fine { "FI" } else { "TR" }.to_string(),
            axis: self.cfg.axes[axis].clone(),
            old_mm,
            new_mm,
            in_force,
        });
    }

    pub(super) fn def(&mut self, u: &Unit, node: &Node) -> Result<(), String> {
        for (name, var) in self.definitions(u, node)? {
            self.top().vars.insert(name, var);
        }
        Ok(())
    }

    /// The variables a DEF statement declares, with their initial values.
    fn definitions(&self, u: &Unit, node: &Node) -> Result<Vec<(String, Variable)>, String> {
        let mut out = Vec::new();
        let mut ty = None;
        for c in node.significant() {
            match c.kind {
                NodeKind::Keyword => {
                    let word = u.upper(c);
                    if let Some(t) = VarType::from_keyword(&word) {
                        ty = Some(t);
                    } else if word == "FRAME" {
                        return Err(format!("DEF {word} variables are not supported"));
                    }
                }
                NodeKind::Declarator => {
                    let ty = ty.ok_or("DEF without a type")?;
                    out.push(self.declare(u, ty, c)?);
                }
                _ => {}
            }
        }
        Ok(out)
    }

    /// The GUD variables of the definition files beside the program: the archive's definition sections,
    /// then the `.DEF` files of its folder and of the subprogram folders.
    pub(super) fn global_user_data(&mut self, main: &Unit) -> Result<(), VmError> {
        for section in main.definition_sections() {
            self.define_globals(&section)?;
        }
        for path in self
            .search_dirs(main)
            .iter()
            .flat_map(|d| crate::walk::definition_files(d))
        {
            let bytes = std::fs::read(&path).map_err(|e| VmError {
                file: path.display().to_string(),
                line: 0,
                message: e.to_string(),
            })?;
            let name = path.display().to_string();
            let unit = Unit::new(
                name,
                path.parent().map(PathBuf::from),
                crate::parse_owned(bytes),
            );
            self.define_globals(&unit)?;
        }
        Ok(())
    }

    /// The global user data (GUD) the control holds: the DEF statements of a definition unit (an archive's
    /// `%_N_UGUD_DEF` section, a `UGUD.DEF` file). The first definition of a name counts; the unit's other
    /// statements (macros, `M30`) are not run.
    pub(super) fn define_globals(&mut self, u: &Unit) -> Result<(), VmError> {
        for i in u.start..u.end {
            let root = u.root(i);
            for node in root.children.iter().filter(|c| c.kind == NodeKind::Def) {
                for (name, var) in self.definitions(u, node).map_err(|e| err_at(u, i, e))? {
                    self.globals.entry(name).or_insert(var);
                }
            }
        }
        Ok(())
    }

    fn declare(&self, u: &Unit, ty: VarType, d: &Node) -> Result<(String, Variable), String> {
        let name = u.upper(d.find(NodeKind::Name).ok_or("declarator without name")?);
        let dims: Vec<usize> = match d.find(NodeKind::Index) {
            Some(ix) => index_nodes(ix)
                .into_iter()
                .map(|e| {
                    let v = self.num(u, e)?;
                    if v >= 1.0 && v.fract() == 0.0 {
                        Ok(v as usize)
                    } else {
                        Err(format!("array size {v} must be a whole number ≥ 1"))
                    }
                })
                .collect::<Result<_, String>>()?,
            None => Vec::new(),
        };
        let mut var = Variable::new(ty, dims);
        let init = d
            .significant()
            .skip_while(|c| !(c.kind == NodeKind::Punct && u.text(c) == b"="))
            .nth(1);
        if let Some(init) = init {
            self.initialise(u, &mut var, init)?;
        }
        Ok((name, var))
    }

    /// An initial value of a variable of type `ty`: an AXIS variable takes an axis's name.
    fn initial(&self, u: &Unit, ty: VarType, value: &Node) -> Result<Value, String> {
        if ty == VarType::Axis
            && let Some(axis) = self.axis_named(u, value)
        {
            return Ok(Value::Str(axis));
        }
        self.eval(u, value)
    }

    /// The axis an AXIS variable takes: its name (`_X=X`), also in brackets as shop macros write it
    /// (`AXIVAR=(C)`, `DEF AXIS A1=(Z)`).
    fn axis_named(&self, u: &Unit, value: &Node) -> Option<String> {
        let mut v = value;
        while v.kind == NodeKind::Paren {
            v = v.significant().find(|c| c.kind != NodeKind::Punct)?;
        }
        let axis =
            (v.kind == NodeKind::Var && v.find(NodeKind::Index).is_none()).then(|| u.upper(v))?;
        self.axis_index(&axis).is_some().then_some(axis)
    }

    /// `= value`, `= SET(a, , c)`, `= (a, b)`, `= REP(v [, n])`.
    pub(super) fn initialise(
        &self,
        u: &Unit,
        var: &mut Variable,
        init: &Node,
    ) -> Result<(), String> {
        let fn_name = (init.kind == NodeKind::FnCall).then(|| u.upper(&init.children[0]));
        let list = match (init.kind, fn_name.as_deref()) {
            (NodeKind::Args, _) => Some(init.arguments()),
            (NodeKind::FnCall, Some("SET")) => init.find(NodeKind::Args).map(Node::arguments),
            (NodeKind::FnCall, Some("REP")) => {
                let args = init.call_arguments();
                let (v, n) = match args[..] {
                    [Some(v)] => (self.eval(u, v)?, var.data.len()),
                    [Some(v), Some(n)] => (self.eval(u, v)?, self.num(u, n)? as usize),
                    _ => return Err("REP takes a value and an optional count".into()),
                };
                let v = var.ty.convert(v)?;
                for slot in var.data.iter_mut().take(n) {
                    *slot = v.clone();
                }
                return Ok(());
            }
            _ => None,
        };
        match list {
            Some(items) => {
                if items.len() > var.data.len() {
                    return Err(format!(
                        "{} initial values for {} elements",
                        items.len(),
                        var.data.len()
                    ));
                }
                for (slot, item) in var.data.iter_mut().zip(items) {
                    if let Some(item) = item {
                        *slot = var.ty.convert(self.initial(u, var.ty, item)?)?;
                    }
                }
                Ok(())
            }
            None if var.dims.is_empty() => var.set(&[], self.initial(u, var.ty, init)?),
            None => Err("an array is initialised with SET(…) or REP(…)".into()),
        }
    }
}

/// The spindle an address extension names (`S2=`, `M2=`, `SPOS[2]`): 0 and 1 are the master spindle.
fn spindle_number(digits: &str) -> Result<usize, String> {
    match digits.parse::<usize>() {
        Ok(0 | 1) => Ok(1),
        Ok(n) if n <= SPINDLES => Ok(n),
        _ => Err(format!(
            "spindle {digits}: the dry run follows spindles 1 … {SPINDLES}"
        )),
    }
}

pub(super) fn ijk(letter: &str) -> usize {
    match letter {
        "I" => 0,
        "J" => 1,
        _ => 2,
    }
}
