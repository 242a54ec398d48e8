//! Subprogram calls and built-in procedures (MSG, SETAL, WRITE, probe cycles), parameter binding.

use super::*;

/// Procedures the dry run carries out as nothing: it positions a spindle at once (`WAITS`: nothing to wait
/// for), the blank description and the editor's program-block markers act only on the panel, and
/// `SETPIECE` counts a workpiece for the tool monitoring.
const MOVE_NOTHING: &[&str] = &["WAITS", "WORKPIECE", "GROUP_BEGIN", "GROUP_END", "SETPIECE"];

impl Interp<'_> {
    pub(super) fn call(
        &mut self,
        u: &Unit,
        i: usize,
        node: &Node,
        w: &mut Words,
    ) -> Result<(), String> {
        let name = u.upper(&node.children[0]);
        let args = node.call_arguments();
        // Which axes F is the path feed of (it times rotary axes differently), how an axis accelerates,
        // waiting for positioning axes (which the dry run ends at once): each moves nothing.
        if name == "FGROUP" || crate::views::AXIS_PROCEDURES.contains(&name.as_str()) {
            return self.axes_named(u, &name, &args);
        }
        // The online tool length offset along an axis, which the dry run does not follow: no gate measures
        // while it is on, so both runs keep the program's.
        if let ("TOFFON" | "TOFFOF", [axis, rest @ ..]) = (name.as_str(), &args[..]) {
            self.axes_named(u, &name, std::slice::from_ref(axis))?;
            for v in rest.iter().flatten() {
                self.eval(u, v)?.num()?;
            }
            return Ok(());
        }
        let values = self.argument_values(u, &name, &args)?;
        let refs = args
            .iter()
            .map(|a| a.and_then(|a| self.reference(u, a)))
            .collect();
        match name.as_str() {
            "MSG" => {
                if let Some(Some(v)) = values.first() {
                    let text = v.text();
                    let at = self.at(u, i);
                    self.run.messages.push(Message { at, text });
                }
            }
            "SETAL" => {
                let number = match values.first() {
                    Some(Some(v)) => v.num()? as i64,
                    _ => return Err("SETAL needs an alarm number".into()),
                };
                let text = values.get(1).and_then(|v| v.as_ref()).map(Value::text);
                w.alarm = Some((number, text));
            }
            "WRITE" => {
                let ([Some(status), Some(_), Some(_)], [_, Some(file), Some(line)]) =
                    (&args[..], &values[..])
                else {
                    return Err("WRITE needs (status variable, file, text)".into());
                };
                let (file, line) = (file.text(), line.text());
                let content = self.run.files.entry(file.to_ascii_uppercase()).or_default();
                content.push_str(&line);
                content.push('\n');
                self.store(u, status, Value::Num(0.0), w)?;
            }
            _ if MOVE_NOTHING.contains(&name.as_str()) => {}
            // The master spindle, whose speed a feed per revolution, a dwell in revolutions and a thread
            // follow; SETMS alone gives it back to spindle 1.
            "SETMS" => {
                let n = match values.first() {
                    Some(Some(Value::Num(n))) => *n,
                    None | Some(None) => 1.0,
                    Some(Some(v)) => return Err(format!("SETMS({v:?}): a spindle number")),
                };
                if n.fract() != 0.0 || !(1.0..=SPINDLES as f64).contains(&n) {
                    return Err(format!(
                        "SETMS({n}): the dry run follows spindles 1 … {SPINDLES}"
                    ));
                }
                self.motion.master = n as usize;
            }
            "CYCLE800" => self.motion.kinematics.swivel = swivel_angles(&values)?,
            "TRAORI" | "TRANSMIT" | "TRACYL" | "TRAANG" => self.select_transformation(&name),
            "ORIRESET" => {
                let kinematics = &mut self.motion.kinematics;
                if kinematics.transformation != Some("TRAORI") {
                    return Err("ORIRESET without the orientation transformation TRAORI".into());
                }
                let positions = values
                    .iter()
                    .map(|v| v.as_ref().map_or(Ok(0.0), Value::num))
                    .collect::<Result<_, _>>()?;
                kinematics.orientation.reset(positions);
            }
            "CANCEL" => self.cancel(&values)?,
            // Which axis groups follow their polynomials: the path axes ("AXES") and the orientation
            // ("VECT", which the dry run does not follow); a group not named goes linearly.
            "POLYPATH" => {
                let mut axes = false;
                for v in values.iter().flatten() {
                    match v.text().to_ascii_uppercase().as_str() {
                        "AXES" => axes = true,
                        "VECT" => {}
                        other => {
                            return Err(format!("POLYPATH: `{other}` is neither AXES nor VECT"));
                        }
                    }
                }
                self.motion.modal.poly_axes = axes;
            }
            _ if self.cfg.probe_cycles.contains(&name) => {
                let nums = values
                    .iter()
                    .map(|v| v.as_ref().and_then(|v| v.num().ok()))
                    .collect();
                w.probe = Some((name, nums));
            }
            _ => {
                w.call_unknown = args
                    .iter()
                    .zip(&values)
                    .map(|(a, v)| a.is_some() && v.is_none())
                    .collect();
                w.call = Some((name, values, refs));
            }
        }
        Ok(())
    }

    /// Arguments that must each name an axis of the machine (`SOFTA(X,Y)`, `FGROUP()`).
    fn axes_named(&self, u: &Unit, name: &str, args: &[Option<&Node>]) -> Result<(), String> {
        match args
            .iter()
            .flatten()
            .find(|a| self.axis_index(&u.upper(a)).is_none())
        {
            Some(a) => Err(format!("{name}: {} is not an axis", u.upper(a))),
            None => Ok(()),
        }
    }

    /// A kinematic transformation selected: an orientation programmed under another one no longer holds.
    fn select_transformation(&mut self, name: &str) {
        let kinematics = &mut self.motion.kinematics;
        kinematics.transformation = Some(transformation(name));
        kinematics.orientation = Default::default();
    }

    /// The variable an argument names, if it is one (for `VAR` parameters).
    pub(super) fn reference(&self, u: &Unit, arg: &Node) -> Option<Ref> {
        match arg.kind {
            NodeKind::RParam => self.r_index(u, arg).ok().map(Ref::R),
            NodeKind::Var => {
                let name = u.upper(arg.find(NodeKind::Name)?);
                self.variable(&name)?;
                Some(Ref::Var(name, self.indices(u, arg).ok()?))
            }
            _ => None,
        }
    }

    pub(super) fn command(&mut self, u: &Unit, node: &Node, w: &mut Words) -> Result<(), String> {
        let name = u.upper(node);
        match name.as_str() {
            "RET" => w.ret = true,
            "STOPRE" => w.stopre = true,
            "TRAORI" | "TRANSMIT" | "TRACYL" | "TRAANG" => self.select_transformation(&name),
            "TRAFOOF" => {
                let kinematics = &mut self.motion.kinematics;
                kinematics.transformation = None;
                kinematics.orientation = Default::default();
            }
            "SUPA" => w.suppress_frames = true,
            // SETMS alone: spindle 1 is the master again.
            "SETMS" => self.motion.master = 1,
            // Which frame the tool length acts in (TOWSTD … TOWKCS) matters under a tilted tool, which
            // the dry run's lengths do not follow; a gate never writes them, so both runs keep the program's.
            "TOWSTD" | "TOWMCS" | "TOWWCS" | "TOWBCS" | "TOWTCS" | "TOWKCS" => {}
            // The last programmed X is kept in the unit it is programmed in: switching converts it, as the
            // control shows the same position as a diameter or a radius.
            "DIAMON" | "DIAM90" => {
                let x = self.cfg.axes.iter().position(|a| a == "X");
                if let (None, Some(a)) = (self.motion.diameter_axis, x) {
                    self.motion.local[a] *= 2.0;
                }
                self.motion.diameter_axis = x;
                self.motion.diam90 = name == "DIAM90";
            }
            "DIAMOF" => {
                self.motion.diam90 = false;
                if let Some(a) = self.motion.diameter_axis.take() {
                    self.motion.local[a] /= 2.0;
                }
            }
            "BSPLINE" | "ASPLINE" | "CSPLINE" => w.spline = true,
            "POLY" => w.poly = true,
            "TRANS" | "ATRANS" | "ROT" | "AROT" | "SCALE" | "ASCALE" | "MIRROR" | "AMIRROR" => {
                w.frame_command = Some(name)
            }
            _ if crate::views::NEUTRAL_COMMANDS.contains(&name.as_str()) => {}
            _ if let Some((group, v)) = setting(&name) => self.motion.modal.settings[group] = v,
            _ if crate::views::is_predefined_command(&name) => {
                return Err(format!("{name} is not supported by the dry run"));
            }
            _ => w.call = Some((name, Vec::new(), Vec::new())),
        }
        Ok(())
    }

    pub(super) fn program_call(
        &mut self,
        u: &Unit,
        i: usize,
        node: &Node,
        w: &mut Words,
    ) -> Result<(), String> {
        let parts: Vec<&Node> = node.significant().collect();
        let keyword = u.upper(parts[0]);
        match (keyword.as_str(), parts.get(1)) {
            // CALL BLOCK start TO end: the program's own blocks from one label to the other, once, then on
            // after the call (a section repetition with one pass).
            ("CALL", Some(kw)) if kw.kind == NodeKind::Keyword && u.upper(kw) == "BLOCK" => {
                let (Some(first), Some(last)) = (parts.get(2), parts.get(4)) else {
                    return Err("CALL BLOCK needs a start and an end label".into());
                };
                let (first, last) = (u.upper(first), u.upper(last));
                let (start, end) = u.section_labels(i, &first, Some(&last));
                let start = start
                    .ok_or_else(|| format!("CALL BLOCK: label {first} not found (alarm 14080)"))?;
                let end = end.ok_or_else(|| {
                    format!("CALL BLOCK: end label {last} not found after {first}")
                })?;
                if (start..=end).contains(&i) {
                    return Err("CALL BLOCK would call itself".into());
                }
                w.section = Some((start, end));
                Ok(())
            }
            ("CALL", Some(target)) if target.kind != NodeKind::Text => {
                let name = self.eval(u, target)?.text().to_ascii_uppercase();
                w.call = Some((name, Vec::new(), Vec::new()));
                Ok(())
            }
            // EXTCALL loads the program from an external drive, PCALL by its path: the dry run looks the
            // name up where it looks up any subprogram.
            ("EXTCALL" | "PCALL", Some(target)) => {
                let (name, args) = match target.kind {
                    NodeKind::Str => (self.eval(u, target)?.text(), Vec::new()),
                    NodeKind::FnCall => {
                        let mut args = Vec::new();
                        for a in target.call_arguments() {
                            args.push(a.map(|a| self.eval(u, a)).transpose()?);
                        }
                        (u.upper(&target.children[0]), args)
                    }
                    _ => (u.upper(target), Vec::new()),
                };
                w.call = Some((crate::walk::program_name(&name), args, Vec::new()));
                Ok(())
            }
            // A modal call runs its subprogram or cycle after every later block of this program that moves,
            // until `MCALL` alone.
            ("MCALL", None) => {
                w.modal_call = Some(None);
                Ok(())
            }
            ("MCALL", Some(target)) => {
                let call = if target.kind == NodeKind::FnCall {
                    let name = u.upper(&target.children[0]);
                    let args = self.argument_values(u, &name, &target.call_arguments())?;
                    (name, args)
                } else {
                    (u.upper(target), Vec::new())
                };
                w.modal_call = Some(Some(call));
                Ok(())
            }
            // An ISO-dialect subprogram, which the dry run does not run: skipped like a missing one.
            ("ISOCALL", Some(target)) if self.cfg.skip_missing_calls => {
                let text = u.upper(target);
                self.note(
                    u,
                    i,
                    format!(
                        "ISOCALL {text} skipped: the dry run does not run ISO-dialect programs"
                    ),
                );
                Ok(())
            }
            _ => Err(format!("{keyword} is not supported by the dry run")),
        }
    }

    /// The values of a call's arguments (`None` where one is left out).
    fn argument_values(
        &self,
        u: &Unit,
        name: &str,
        args: &[Option<&Node>],
    ) -> Result<CallArgs, String> {
        let mut values = Vec::with_capacity(args.len());
        for a in args {
            values.push(match a {
                Some(a) => match self.eval(u, a) {
                    Ok(v) => Some(v),
                    // A cycle's symbolic arguments (`_ORI_FINISH`) come from definitions the dry run
                    // does not have: when missing calls are skipped, such a call is skipped too.
                    Err(_) if self.cfg.skip_missing_calls && !self.is_builtin(name) => None,
                    Err(e) => return Err(e),
                },
                None => None,
            });
        }
        Ok(values)
    }

    /// The procedures and cycles the dry run carries out itself.
    fn is_builtin(&self, name: &str) -> bool {
        matches!(
            name,
            "MSG"
                | "SETAL"
                | "WRITE"
                | "SETMS"
                | "CYCLE800"
                | "TRAORI"
                | "TRANSMIT"
                | "TRACYL"
                | "TRAANG"
                | "CANCEL"
                | "ORIRESET"
                | "POLYPATH"
        ) || MOVE_NOTHING.contains(&name)
            || self.cfg.probe_cycles.iter().any(|c| c == name)
    }

    /// Finds `NAME.SPF` / `NAME.MPF` (any case, or `_N_NAME_SPF`) beside the calling program, then in the
    /// configured subprogram folders (the control's SPF directory).
    pub(super) fn load(&mut self, from: &Unit, name: &str) -> Result<Rc<Unit>, String> {
        if let Some(unit) = from.sibling(name) {
            let key = (Rc::as_ptr(&from.source) as usize, unit.start);
            let unit = self
                .archive_units
                .entry(key)
                .or_insert_with(|| Rc::new(unit));
            return Ok(unit.clone());
        }
        let dirs = self.search_dirs(from);
        let found = dirs.iter().find_map(|dir| {
            let listing = self
                .listings
                .entry(dir.clone())
                .or_insert_with(|| crate::walk::programs_by_name(dir));
            listing.get(name).map(|path| (dir.clone(), path.clone()))
        });
        let Some((dir, path)) = found else {
            let searched: Vec<String> = dirs.iter().map(|d| d.display().to_string()).collect();
            return Err(format!(
                "{name} is neither a supported command nor a subprogram (no {name}.SPF or {name}.MPF in {})",
                if searched.is_empty() {
                    "any folder: the program was not read from a file".to_string()
                } else {
                    searched.join(", ")
                }
            ));
        };
        if let Some(unit) = self.loaded.get(&path) {
            return Ok(unit.clone());
        }
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let display = path.file_name().map_or_else(
            || path.display().to_string(),
            |f| f.to_string_lossy().into_owned(),
        );
        let unit = Rc::new(Unit::new(display, Some(dir), crate::parse_owned(bytes)));
        self.loaded.insert(path, unit.clone());
        Ok(unit)
    }

    /// The folders the files a program uses are looked up in: its own, then the configured subprogram
    /// folders (the control's SPF directory).
    pub(super) fn search_dirs(&self, unit: &Unit) -> Vec<PathBuf> {
        unit.dir
            .iter()
            .chain(&self.cfg.subprogram_dirs)
            .cloned()
            .collect()
    }

    /// Local variables of a program from its PROC parameters and the call's arguments.
    pub(super) fn bind_params(&self, unit: &Unit, args: &[Option<Value>]) -> Result<Bound, String> {
        let mut vars = HashMap::new();
        let mut by_ref = Vec::new();
        let proc = unit.proc();
        let params: Vec<&Node> = proc
            .as_ref()
            .and_then(|p| p.find(NodeKind::Args))
            .map(|a| {
                a.significant()
                    .filter(|c| c.kind == NodeKind::Param)
                    .collect()
            })
            .unwrap_or_default();
        if args.len() > params.len() {
            return Err(format!(
                "{} takes {} parameter(s), the call passes {}",
                unit.name,
                params.len(),
                args.len()
            ));
        }
        for (k, p) in params.iter().enumerate() {
            let mut ty = None;
            let mut var_param = false;
            for c in p.significant().filter(|c| c.kind == NodeKind::Keyword) {
                let word = unit.upper(c);
                var_param |= word == "VAR";
                ty = ty.or(VarType::from_keyword(&word));
            }
            let ty = ty.ok_or("PROC parameter without a supported type")?;
            let at_name = p
                .children
                .iter()
                .position(|c| c.kind == NodeKind::Name)
                .ok_or("PROC parameter without name")?;
            // `STRING[32] _NAME` gives the string's length before the name; an index after it is an array.
            if p.children[at_name..]
                .iter()
                .any(|c| c.kind == NodeKind::Index)
            {
                return Err("array parameters are not supported".into());
            }
            let name = unit.upper(&p.children[at_name]);
            let mut var = Variable::new(ty, Vec::new());
            if let Some(Some(v)) = args.get(k) {
                var.set(&[], v.clone())?;
            }
            if var_param {
                by_ref.push((name.clone(), k));
            }
            vars.insert(name, var);
        }
        Ok((vars, by_ref))
    }
}

/// The swivel a CYCLE800 call leaves active: its angles A, B, C (parameters 8 to 10 of
/// `CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, …)`), `None` when all are zero or absent
/// (`CYCLE800()` resets the swivel).
fn swivel_angles(values: &[Option<Value>]) -> Result<Option<[f64; 3]>, String> {
    let mut angles = [0.0; 3];
    for (k, angle) in angles.iter_mut().enumerate() {
        if let Some(Some(v)) = values.get(7 + k) {
            *angle = v
                .num()
                .map_err(|e| format!("CYCLE800 angle (parameter {}): {e}", 8 + k))?;
        }
    }
    Ok(angles.iter().any(|a| *a != 0.0).then_some(angles))
}

fn transformation(name: &str) -> &'static str {
    match name {
        "TRAORI" => "TRAORI",
        "TRANSMIT" => "TRANSMIT",
        "TRAANG" => "TRAANG",
        _ => "TRACYL",
    }
}

pub(super) fn proc_has_save(unit: &Unit) -> bool {
    unit.proc().is_some_and(|p| {
        p.significant()
            .any(|c| c.kind == NodeKind::Name && unit.upper(c) == "SAVE")
    })
}
