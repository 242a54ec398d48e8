//! Reading a block from its syntax tree: any block the word scanner does not take (assignments, control
//! statements, calls, frames, expressions), reduced to the same [`Scan`].

use std::sync::Arc;

use crate::syntax::{Block, BlockKind, Node, NodeKind, Program};
use crate::views::{AxisMode, Value, VarName, WorkOffset, facts, is_predefined_command};

use super::{Bound, CallArg, Count, Scan, comment, frame_op};
use crate::omm::timeline::modal::{Diameter, POSITIONED, unknown};

pub(crate) fn scan_tree(program: &Program, i: usize, marker: &str) -> Scan {
    let block = program.block(i);
    // A synchronized action's words (`WHEN … DO M8`) act in the interpolator when its condition holds,
    // not as the block runs: the timeline follows none of them.
    if block
        .root
        .significant()
        .any(|n| n.kind == NodeKind::SyncCondition)
    {
        // One with an `ID=`/`IDS=` stays active after the block, until `CANCEL`.
        let modal = block.root.significant().any(|n| {
            n.kind == NodeKind::Assign
                && n.children.first().is_some_and(|t| {
                    let name = block.text(t);
                    name.eq_ignore_ascii_case(b"ID") || name.eq_ignore_ascii_case(b"IDS")
                })
        });
        return Scan {
            statement: true,
            label: facts(&block).label,
            unknown: if modal { unknown::SYNC_ACTION } else { 0 },
            ..Scan::default()
        };
    }
    let f = facts(&block);
    let mut s = Scan {
        skippable: block.root.significant().any(|n| n.kind == NodeKind::Skip),
        kind_header: block.kind == BlockKind::Header,
        label: f.label.clone(),
        statement: block.root.significant().any(|n| match n.kind {
            NodeKind::Comment
            | NodeKind::BlockNumber
            | NodeKind::Def
            | NodeKind::Proc
            | NodeKind::Extern
            | NodeKind::Define
            | NodeKind::Header
            | NodeKind::Word => false,
            // `CR=5`, `X=R1`: an address with a value, read like a word.
            NodeKind::Assign => !n.children.first().is_some_and(|t| {
                let name = block.text(t);
                t.kind == NodeKind::Var
                    && name.len() <= 2
                    && name.iter().all(u8::is_ascii_alphabetic)
            }),
            _ => true,
        }),
        ..Scan::default()
    };
    for v in &f.variables {
        if let VarName::R(n) = v.name {
            s.r.push(n);
        }
    }
    for a in &f.axes {
        let k = match a.axis.as_str() {
            "X" => 0,
            "Y" => 1,
            "Z" => 2,
            other => {
                s.other_axes = true;
                s.orients |= crate::views::orientation_word(other).is_some();
                if let Some(bit) = ["A", "B", "C"].iter().position(|r| *r == other) {
                    let bit = 1 << bit;
                    match (&a.value, a.mode) {
                        // DC, ACP and ACN go to the absolute angle too, by their own way round.
                        (
                            Value::Number(v),
                            AxisMode::Modal
                            | AxisMode::Ac
                            | AxisMode::Dc
                            | AxisMode::Acp
                            | AxisMode::Acn,
                        ) if *v == 0.0 => s.rotary_home |= bit,
                        (Value::Expr(span), AxisMode::Modal | AxisMode::Ac)
                            if is_name(&program.source()[span.start..span.end]) =>
                        {
                            let name = &program.source()[span.start..span.end];
                            s.rotary_vars.push((bit, upper_text(name)));
                        }
                        _ => s.rotary_away |= bit,
                    }
                }
                continue;
            }
        };
        match (&a.value, a.mode) {
            (Value::Number(v), AxisMode::Modal | AxisMode::Ac) => {
                s.mv.axes[k] = Some((*v, a.mode == AxisMode::Ac))
            }
            (Value::Number(v), AxisMode::Ic) => {
                s.mv.axes[k] = Some((*v, false));
                s.mv.incremental[k] = true;
            }
            _ => {
                s.inexact = true;
                s.mv.expression[k] = true;
            }
        }
    }
    let num = |v: &Value| match v {
        Value::Number(x) => Some(*x),
        _ => None,
    };
    s.mv.f = f.feed.as_ref().and_then(|a| num(&a.value));
    if f.feed.is_some() && s.mv.f.is_none() {
        s.unknown |= unknown::FEED;
    }
    let speed = f
        .spindle_speeds
        .iter()
        .find(|a| a.extension.is_none_or(|e| e == 1));
    s.s = speed.and_then(|a| num(&a.value));
    if speed.is_some() && s.s.is_none() {
        s.unknown |= unknown::S;
        if let Some(Value::Expr(span)) = speed.map(|a| &a.value) {
            let text = &program.source()[span.start..span.end];
            s.speed_var = is_name(text).then(|| upper_text(text));
        }
    }
    for v in f
        .m_codes
        .iter()
        .filter(|a| a.extension.is_none_or(|e| e == 1))
        .filter_map(|a| num(&a.value))
    {
        s.m.push(v as u32);
    }
    // A speed or a spindle function of another spindle (`S4=1500`, `M4=3`); `M20=151` and the like are a
    // builder's functions with an address extension, not spindles.
    let other = |a: &&crate::views::AddressValue| a.extension.is_some_and(|e| e != 1);
    let spindle_function = |a: &crate::views::AddressValue| {
        num(&a.value).is_none_or(|m| matches!(m as u32, 3 | 4 | 5 | 19 | 40..=45 | 70))
    };
    if f.spindle_speeds.iter().any(|a| other(&a))
        || f.m_codes.iter().filter(other).any(spindle_function)
    {
        s.unknown |= unknown::OTHER_SPINDLE;
    }
    if let Some(a) = f.tools.first() {
        let text = tool_text(&block, a.span);
        if is_tool_literal(text) {
            s.tool = Some(Arc::from(String::from_utf8_lossy(text).as_ref()));
        } else {
            s.unknown |= unknown::TOOL;
            s.tool_variable = variable_alone(text);
        }
    }
    for &g in &f.g_codes {
        if !s.g.contains(g) {
            s.g.push(g);
        }
    }
    // G58 / G59 replace the absolute or the additive translation of the programmable frame on the axes
    // they name (the axial offsets): a translation like TRANS, not a move.
    if f.g_codes.iter().any(|g| matches!(g, 58 | 59)) && !f.axes.is_empty() {
        s.frame_ops |= frame_op::TRANSLATE;
    }
    for w in &f.work_offsets {
        match w {
            WorkOffset::G(g) => s.offsets.push(*g),
            // SUPA moves in machine coordinates as G53 and G153 do.
            WorkOffset::Frame(name) if name == "SUPA" => s.offsets.push(53),
            _ => {}
        }
    }
    for node in block.root.children.iter() {
        match node.kind {
            NodeKind::Word => word(&block, node, &mut s),
            NodeKind::Assign => assign(&block, node, &mut s),
            NodeKind::Comment => comment(block.text(node), marker, &mut s),
            NodeKind::Def | NodeKind::Proc | NodeKind::Extern | NodeKind::Define => {
                s.declaration = true;
                s.saves |= node.kind == NodeKind::Proc
                    && node.significant().any(|c| {
                        c.kind == NodeKind::Name && block.text(c).eq_ignore_ascii_case(b"SAVE")
                    });
                if node.kind == NodeKind::Proc {
                    s.params = proc_params(&block, node);
                }
            }
            NodeKind::For => s.count = for_bounds(&block, node),
            NodeKind::Repeat => s.count = section_repeat(&block, node),
            NodeKind::Call => {
                let name = String::from_utf8_lossy(block.text(&node.children[0]));
                let name = name.to_ascii_uppercase();
                s.frame_ops |= transformation_op(&name);
                if name == "CYCLE800" {
                    s.frame_ops |= swivel_op(&block, node);
                    if turns_home(&block, node) {
                        s.rotary_home |= 0b111;
                    }
                }
                online_tool_offset(&block, node, &name, &mut s);
                if name == "SETMS" && master_spindle(&block, node).is_some_and(|n| n != Some(1.0)) {
                    s.unknown |= unknown::OTHER_SPINDLE;
                }
                if corrects_work_offset(&block, node, &name) {
                    s.frame_ops |= frame_op::WRITE;
                }
                // With no argument it ends every modal synchronized action; with numbers it may leave others.
                s.cancels_sync_actions |= name == "CANCEL" && node.call_arguments().is_empty();
                if name == "GEOAX" {
                    s.geometry_axes = Some(!node.call_arguments().is_empty());
                }
                // A transformation selected by its data set (`TRAORI(1)`, `TRACYL(40)`) is the
                // transformation the bare word selects, which the frame operations above follow.
                let known = TIMELESS_PROCEDURES.contains(&name.as_str())
                    || crate::views::AXIS_PROCEDURES.contains(&name.as_str())
                    || ONLINE_TOOL_OFFSET.contains(&name.as_str())
                    || transformation_op(&name) != 0
                    || (name == "FGROUP" && feed_group_keeps_geometry_axes(&block, node));
                if !known {
                    s.call = Some(name);
                    s.call_args = node
                        .call_arguments()
                        .iter()
                        .map(|a| call_arg(&block, *a))
                        .collect();
                }
            }
            NodeKind::Command => {
                let name = String::from_utf8_lossy(block.text(node)).to_ascii_uppercase();
                s.frame_ops |= transformation_op(&name) | frame_command_op(&name, &f, &block);
                match name.as_str() {
                    "RET" => s.leaves = true,
                    "DIAMON" => s.diameter = Some(Diameter::On),
                    "DIAM90" => s.diameter = Some(Diameter::Absolute),
                    "DIAMOF" => s.diameter = Some(Diameter::Off),
                    "CT" => s.tangent_start = true,
                    "WALIMON" => s.work_area_monitor = Some(true),
                    "WALIMOF" => s.work_area_monitor = Some(false),
                    "CANCEL" => s.cancels_sync_actions = true,
                    "GEOAX" => s.geometry_axes = Some(false),
                    _ if is_spline_mode(&name) => s.spline = true,
                    _ => {}
                }
                if !is_predefined_command(&name) && !TIMELESS_PROCEDURES.contains(&name.as_str()) {
                    s.call = Some(name);
                }
            }
            // GOTOS starts the program again: for what driftloop restores, an end.
            NodeKind::Goto => {
                s.leaves |= block
                    .text(node)
                    .get(..5)
                    .is_some_and(|t| t.eq_ignore_ascii_case(b"GOTOS"));
            }
            NodeKind::ProgramCall => match program_call(&block, node) {
                Some(ProgramCall::Once(name, shown)) if s.call.is_none() => {
                    s.call = Some(name);
                    s.call_shown = shown;
                }
                Some(ProgramCall::Once(..)) => {}
                Some(ProgramCall::Modal(name)) => s.modal_call = Some(name),
                None => {}
            },
            _ => {}
        }
    }
    for w in &f.work_offsets {
        if let WorkOffset::FrameWrite(name) = w {
            s.frame_ops |= frame_op::WRITE;
            s.writes_frame_in_force |= name.starts_with("$P_IFRAME");
        }
    }
    // The axis words of a frame command are its values, not a move.
    if s.frame_ops & (frame_op::TRANSLATE | frame_op::ROTATE) != 0 {
        s.mv.axes = [None; 3];
        s.inexact = false;
    }
    s
}

/// A call's argument as a tool: a literal a gate can write back, left out, or anything else.
fn call_arg(block: &Block<'_>, arg: Option<&Node>) -> CallArg {
    match arg.map(|a| block.text(a).trim_ascii()) {
        None | Some([]) => CallArg::Empty,
        Some(text) if is_tool_literal(text) => {
            CallArg::Literal(Arc::from(String::from_utf8_lossy(text).as_ref()))
        }
        Some(_) => CallArg::Other,
    }
}

/// The names of a `PROC`'s parameters, in order.
fn proc_params(block: &Block<'_>, proc: &Node) -> Vec<String> {
    proc.find(NodeKind::Args)
        .into_iter()
        .flat_map(|a| a.significant().filter(|c| c.kind == NodeKind::Param))
        .map(|p| {
            p.find(NodeKind::Name)
                .map(|n| String::from_utf8_lossy(block.text(n)).to_ascii_uppercase())
                .unwrap_or_default()
        })
        .collect()
}

/// A tool written as a name in quotes or a number: what a gate can write back as it is.
fn is_tool_literal(text: &[u8]) -> bool {
    let quoted = text.len() >= 2 && text[0] == b'"' && text[text.len() - 1] == b'"';
    quoted || (!text.is_empty() && text.iter().all(u8::is_ascii_digit))
}

/// The programmed tool offset an assignment to `name` writes, as a bit: `TOFFL`, `TOFFR`, `TOFF[X]`,
/// `TOFF[Y]`, `TOFF[Z]`, any other `TOFF[…]`; 0 for another name. One bit each, so that setting one of
/// them to 0 leaves another in force.
fn tool_offset_bit(name: &[u8]) -> u16 {
    match name {
        b"TOFFL" => 1,
        b"TOFFR" => 2,
        b"TOFF[X]" => 4,
        b"TOFF[Y]" => 8,
        b"TOFF[Z]" => 16,
        _ if name.starts_with(b"TOFF[") => 32,
        _ => 0,
    }
}

/// `POS[A]=`, `POSA[B]=`, … of a rotary axis, which turns it as `A=` does: its bit and whether the block
/// waits for the end point (`POS`, not `POSA`).
fn positioned_rotary(name: &[u8]) -> Option<(u8, bool)> {
    let (axis, waits) = match name {
        [b'P', b'O', b'S', b'[', rest @ ..] => (rest, true),
        [b'P', b'O', b'S', b'A', b'[', rest @ ..] => (rest, false),
        _ => return None,
    };
    let bit = match axis {
        b"A]" => 1,
        b"B]" => 2,
        b"C]" => 4,
        _ => return None,
    };
    Some((bit, waits))
}

/// The online tool length offset (Siemens PGA "Online tool length compensation"): `TOFFON(axis[, value])`
/// overlays the tool length along a geometry axis (a value now, more by synchronized actions) until
/// `TOFFOF(axis)`. A tool setter reads the tool with it, a spindle probe's change carries it: kept as the
/// programmed offsets are (`unknown::TOOL_OFFSET`), one bit per axis.
const ONLINE_TOOL_OFFSET: [&str; 2] = ["TOFFON", "TOFFOF"];

fn online_tool_offset(block: &Block<'_>, call: &Node, name: &str, s: &mut Scan) {
    let axis = call
        .call_arguments()
        .first()
        .copied()
        .flatten()
        .map(|a| block.text(a).trim_ascii().to_ascii_uppercase());
    // A direction the timeline cannot read (an expression) is one no TOFFOF is known to end.
    let bit = match axis.as_deref() {
        Some(b"X") => 64,
        Some(b"Y") => 128,
        Some(b"Z") => 256,
        _ => 512,
    };
    match name {
        "TOFFON" => s.tool_offset_on |= bit,
        "TOFFOF" if bit != 512 => s.tool_offset_off |= bit,
        _ => {}
    }
}

/// TRAORI, TRANSMIT, TRACYL, TRAANG switch a transformation on, TRAFOOF off.
fn transformation_op(name: &str) -> u8 {
    match name {
        "TRAORI" | "TRANSMIT" | "TRACYL" | "TRAANG" => frame_op::TRANSFORM_ON,
        "TRAFOOF" => frame_op::TRANSFORM_OFF,
        _ => 0,
    }
}

/// A frame command with its values (axis words, `RPL=`), or an absolute one alone, which deletes the
/// programmable frame.
fn frame_command_op(name: &str, f: &crate::views::BlockFacts, block: &Block<'_>) -> u8 {
    let rpl = block.root.significant().any(|n| {
        n.kind == NodeKind::Assign
            && n.children
                .first()
                .is_some_and(|t| block.text(t).eq_ignore_ascii_case(b"RPL"))
    });
    let valued = !f.axes.is_empty() || rpl;
    match name {
        "TRANS" | "ATRANS" | "CTRANS" if valued => frame_op::TRANSLATE,
        "ROT" | "AROT" | "CROT" | "ROTS" | "AROTS" | "CROTS" | "SCALE" | "ASCALE" | "CSCALE"
        | "MIRROR" | "AMIRROR" | "CMIRROR"
            if valued =>
        {
            frame_op::ROTATE
        }
        "TRANS" | "ROT" | "SCALE" | "MIRROR" => frame_op::CLEAR,
        // The frame turned to the tool's orientation or the part's: a rotation whose angles come from the
        // kinematics, not from the block. TOROTOF and PAROTOF end only their own share of the rotation,
        // which the timeline does not keep apart from a ROT's: the rotation counts until a bare ROT or TRANS.
        "TOFRAME" | "TOFRAMEX" | "TOFRAMEY" | "TOFRAMEZ" | "TOROT" | "TOROTX" | "TOROTY"
        | "TOROTZ" | "PAROT" => frame_op::ROTATE,
        _ => 0,
    }
}

/// `CYCLE800()` and a CYCLE800 whose every numeric argument from the fifth on (the swivel's offsets and
/// angles) is 0 or empty end the swivel; any other call swivels (an expression counts as an angle).
fn swivel_op(block: &Block<'_>, call: &Node) -> u8 {
    let args = call.call_arguments();
    // _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1: the later ones (direction, retract feed, mode) are
    // settings, not a tilt.
    let tilted = args.iter().skip(4).take(9).flatten().any(|a| {
        // Strings (the swivel data record's name) and empty arguments do not tilt.
        a.kind != NodeKind::Str && literal(block, a) != Some(0.0)
    });
    if tilted {
        frame_op::SWIVEL_ON
    } else {
        frame_op::SWIVEL_OFF
    }
}

/// A CYCLE800 to the untilted plane that turns the rotary axes (`_DIR`, the fourteenth argument, -1 or 1;
/// 0 computes the frames alone and leaves them where they stand): it sends them to the position of the
/// untilted plane, as `G0 A0 C0` does. CAM posts return to the top plane so before its cuts.
fn turns_home(block: &Block<'_>, call: &Node) -> bool {
    let args = call.call_arguments();
    swivel_op(block, call) == frame_op::SWIVEL_OFF
        && args
            .get(13)
            .copied()
            .flatten()
            .and_then(|a| literal(block, a))
            .is_some_and(|dir| dir == 1.0 || dir == -1.0)
}

/// The workpiece measuring cycles that can write what they measure into a work offset (S_KNUM, their
/// second parameter, or the `_KNUM` the program sets before calling one without arguments).
pub(in crate::omm::timeline) fn measures_workpiece(name: &str) -> bool {
    matches!(
        name,
        "CYCLE961" | "CYCLE977" | "CYCLE978" | "CYCLE979" | "CYCLE997" | "CYCLE998"
    )
}

/// A workpiece measuring cycle whose result number (S_KNUM, the second parameter) is not 0 writes the
/// measured position into a work offset, as the program's own frame write would.
fn corrects_work_offset(block: &Block<'_>, call: &Node, name: &str) -> bool {
    if !measures_workpiece(name) {
        return false;
    }
    let args = call.call_arguments();
    args.get(1)
        .and_then(Option::as_ref)
        .is_some_and(|a| literal(block, a) != Some(0.0))
}

/// Built-in procedures called like cycles that take no machine time: no note that they are not timed.
/// `WAITS` waits for a positioning spindle to reach its position: it moves nothing itself. The operator
/// panel's editor marks program blocks with `GROUP_BEGIN`/`GROUP_END`, cycles that do nothing. `SETPIECE`
/// counts a finished workpiece for the tool monitoring of the tools in use. `CANCEL` ends modal
/// synchronized actions and leaves the modal state alone. `POLYPATH("AXES")` chooses which axes a `POLY`
/// block interpolates as polynomials: a gate writes no `POLY` block.
const TIMELESS_PROCEDURES: &[&str] = &[
    "CANCEL",
    "MSG",
    "SETPIECE",
    "SETAL",
    "WRITE",
    "SETMS",
    "GETT",
    "GETSELT",
    "STOPRE",
    "WAITS",
    "GROUP_BEGIN",
    "GROUP_END",
    "POLYPATH",
];

/// `FGROUP()` (the machine data's feed axes, the geometry axes) or an `FGROUP` that names X, Y and Z
/// among others: a gate moves only those, so its feeds mean what they meant before (an axis outside the
/// group follows as a synchronous axis and would move at another speed than its F). Any other group is
/// read as a call the timeline cannot see into.
fn feed_group_keeps_geometry_axes(block: &Block<'_>, call: &Node) -> bool {
    let axes: Vec<String> = call
        .call_arguments()
        .iter()
        .flatten()
        .map(|a| String::from_utf8_lossy(block.text(a).trim_ascii()).to_ascii_uppercase())
        .collect();
    axes.is_empty() || ["X", "Y", "Z"].iter().all(|g| axes.iter().any(|a| a == g))
}

/// What a `CALL`, `PCALL`, `EXTCALL`, `ISOCALL` or `MCALL` statement does.
enum ProgramCall {
    /// Runs the program now: its name (`NAME` for `CALL`, the program a path names for `EXTCALL` and
    /// `PCALL`, `ISOCALL NAME`, which runs in the ISO dialect driftloop does not read) and, where it is
    /// not that, how the call is shown (`EXTCALL NAME`).
    Once(String, Option<String>),
    /// `MCALL NAME` (the cycle's name) or `MCALL` alone, which ends the modal call.
    Modal(Option<String>),
}

fn program_call(block: &Block<'_>, node: &Node) -> Option<ProgramCall> {
    let mut parts = node.significant();
    let keyword = String::from_utf8_lossy(block.text(parts.next()?)).to_ascii_uppercase();
    let Some(target) = parts.next() else {
        return (keyword == "MCALL").then_some(ProgramCall::Modal(None));
    };
    // `CALL BLOCK start TO end` runs the program's own blocks between two labels: named for the section,
    // which the timeline reads as it reads a subprogram (see [`crate::omm::timeline::build`]).
    if keyword == "CALL"
        && target.kind == NodeKind::Keyword
        && block.text(target).eq_ignore_ascii_case(b"BLOCK")
    {
        let labels: Vec<String> = parts
            .filter(|n| n.kind != NodeKind::Keyword)
            .map(|n| String::from_utf8_lossy(block.text(n)).to_ascii_uppercase())
            .collect();
        let [start, end] = labels.as_slice() else {
            return Some(ProgramCall::Once("CALL BLOCK".into(), None));
        };
        let name = section_call_name(start, end);
        return Some(ProgramCall::Once(
            name.clone(),
            Some(format!("CALL {name}")),
        ));
    }
    // A cycle with its arguments (`MCALL CYCLE82(…)`) is named by its name.
    let target = match target.kind {
        NodeKind::FnCall => &target.children[0],
        _ => target,
    };
    let text = String::from_utf8_lossy(block.text(target));
    let name = text.trim_matches('"').to_ascii_uppercase();
    Some(match keyword.as_str() {
        "CALL" => ProgramCall::Once(name, None),
        "MCALL" => ProgramCall::Modal(Some(name)),
        "EXTCALL" | "PCALL" => {
            let program = crate::walk::program_name(&name);
            ProgramCall::Once(program.clone(), Some(format!("{keyword} {program}")))
        }
        _ => ProgramCall::Once(format!("{keyword} {name}"), None),
    })
}

/// The name a `CALL BLOCK start TO end` is read under: `BLOCK START TO END`.
pub(in crate::omm::timeline) fn section_call_name(start: &str, end: &str) -> String {
    format!("BLOCK {start} TO {end}")
}

/// The labels of a call named by [`section_call_name`].
pub(in crate::omm::timeline) fn section_call_labels(name: &str) -> Option<(&str, &str)> {
    name.strip_prefix("BLOCK ")?.split_once(" TO ")
}

/// `FOR var = from TO to`: the bounds.
fn for_bounds(block: &Block<'_>, node: &Node) -> Option<Count> {
    let parts: Vec<&Node> = node.significant().collect();
    match parts.as_slice() {
        [_, _, _, from, _, to] => Some(Count::For {
            from: bound(block, from),
            to: bound(block, to),
        }),
        _ => None,
    }
}

/// `REPEAT a [b]` / `REPEATB a` with its labels (`P=n` follows as an assignment); `None` for the REPEAT
/// that opens a REPEAT … UNTIL loop.
fn section_repeat(block: &Block<'_>, node: &Node) -> Option<Count> {
    let mut parts = node.significant();
    let keyword = block.text(parts.next()?);
    let labels: Vec<String> = parts
        .filter(|n| n.kind == NodeKind::Name)
        .map(|n| String::from_utf8_lossy(block.text(n)).to_ascii_uppercase())
        .collect();
    (!labels.is_empty()).then(|| Count::Section {
        labels,
        single: keyword.eq_ignore_ascii_case(b"REPEATB"),
        times: Bound::Number(1.0),
    })
}

fn bound(block: &Block<'_>, node: &Node) -> Bound {
    if let Some(v) = literal(block, node) {
        return Bound::Number(v);
    }
    match node.kind {
        NodeKind::RParam => r_number(block.text(node)).map_or(Bound::Other, Bound::R),
        _ => Bound::Other,
    }
}

/// `R12` → 12 (not `R[…]`).
fn r_number(text: &[u8]) -> Option<u32> {
    let digits = text
        .strip_prefix(b"R")
        .or_else(|| text.strip_prefix(b"r"))?;
    std::str::from_utf8(digits).ok()?.parse().ok()
}

/// An expression that is one variable's name alone (`_NR`), upper case.
fn variable_alone(text: &[u8]) -> Option<String> {
    let name = text
        .first()
        .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
        && text.iter().all(|c| c.is_ascii_alphanumeric() || *c == b'_');
    name.then(|| String::from_utf8_lossy(text).to_ascii_uppercase())
}

/// The text after `T`/`T=` in a tool word or assignment.
fn tool_text<'a>(block: &'a Block<'_>, span: crate::Span) -> &'a [u8] {
    let node = Node::leaf(NodeKind::Text, span);
    let text = block.text(&node);
    let text = &text[1..];
    let text = text.strip_prefix(b"=").unwrap_or(text);
    text.trim_ascii()
}

fn word(block: &Block<'_>, node: &Node, s: &mut Scan) {
    let Some((address, number)) = node.address_and_number() else {
        return;
    };
    let letter = block.text(address).to_ascii_uppercase();
    let value = std::str::from_utf8(block.text(number))
        .ok()
        .and_then(|t| t.parse::<f64>().ok());
    match (letter.as_slice(), value) {
        (b"D", Some(d)) if d >= 0.0 && d.fract() == 0.0 => s.d = Some(d as u32),
        (b"D", _) => s.unknown |= unknown::D,
        (b"I", Some(v)) => s.mv.centre[0] = Some(v),
        (b"J", Some(v)) => s.mv.centre[1] = Some(v),
        (b"K", Some(v)) => s.mv.centre[2] = Some(v),
        // `L123 P3`: subprogram 123, run three times.
        (b"P", Some(p)) => s.repeats = Some(p),
        (b"L", Some(_)) => {
            s.call = Some(format!("L{}", String::from_utf8_lossy(block.text(number))))
        }
        _ => {}
    }
}

fn assign(block: &Block<'_>, node: &Node, s: &mut Scan) {
    let mut parts = node.significant();
    let (Some(target), _, Some(value)) = (parts.next(), parts.next(), parts.next()) else {
        return;
    };
    let name = block.text(target).to_ascii_uppercase();
    let v = literal(block, value);
    if target.kind == NodeKind::RParam {
        if let Some(n) = r_number(&name) {
            s.r_set.push((n, v));
        }
        return;
    }
    match name.as_slice() {
        b"P" => {
            if let Some(Count::Section { times, .. }) = &mut s.count {
                *times = bound(block, value);
            }
        }
        b"CR" => s.mv.radius = v,
        b"LIMS" => s.lims = v,
        b"D" => match v {
            Some(d) if d >= 0.0 && d.fract() == 0.0 => s.d = Some(d as u32),
            _ => {
                s.unknown |= unknown::D;
                s.d_variable = variable_alone(block.text(value).trim_ascii());
            }
        },
        b"DL" => s.sum_offset = Some(v != Some(0.0)),
        b"RNDM" => s.rounding = Some(v != Some(0.0)),
        b"AP" | b"RP" => s.polar = true,
        b"RND" | b"CHF" | b"CHR" => s.joins_next = true,
        _ if name.starts_with(b"$TC_DP") => s.writes_tool_data = true,
        _ if tool_offset_bit(&name) != 0 => {
            let bit = tool_offset_bit(&name);
            if v == Some(0.0) {
                s.tool_offset_off |= bit;
            } else {
                s.tool_offset_on |= bit;
            }
        }
        b"TCARR" => s.tool_carrier = Some(v != Some(0.0)),
        _ if name.starts_with(b"FXS[") => {
            let axis = String::from_utf8_lossy(&name[4..])
                .trim_end_matches(']')
                .to_string();
            s.fixed_stop.push((axis, v != Some(0.0)));
        }
        _ if let Some((bit, waits)) = positioned_rotary(&name) => {
            // POS ends its block at the end point; POSA goes on moving across blocks until WAITP, so
            // even a return to 0 leaves the axis away from home until then.
            if waits && v == Some(0.0) {
                s.rotary_home |= bit;
            } else {
                s.rotary_away |= bit;
            }
        }
        // The master spindle stops in position control.
        b"SPOS" | b"SPOSA" | b"SPOS[0]" | b"SPOSA[0]" | b"SPOS[1]" | b"SPOSA[1]" => {
            s.m.push(POSITIONED);
        }
        _ if name.starts_with(b"SPOS[") || name.starts_with(b"SPOSA[") => {
            s.unknown |= unknown::OTHER_SPINDLE;
        }
        b"I" => s.mv.centre[0] = v,
        b"J" => s.mv.centre[1] = v,
        b"K" => s.mv.centre[2] = v,
        _ if target.kind == NodeKind::Var && target.find(NodeKind::Index).is_none() => {
            s.var_set
                .push((String::from_utf8_lossy(&name).into_owned(), v));
        }
        _ => {}
    }
}

/// The spline and polynomial interpolations of G group 1 (`ASPLINE`, `BSPLINE`, `CSPLINE`, `POLY`): the
/// control joins the blocks under them into one curve through (or near) their points.
fn is_spline_mode(name: &str) -> bool {
    matches!(name, "ASPLINE" | "BSPLINE" | "CSPLINE" | "POLY")
}

/// A variable's or R-parameter's name alone (`_A_HOME`, `R5`), as an axis value.
fn is_name(text: &[u8]) -> bool {
    let text = text.trim_ascii();
    text.first()
        .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
        && text.iter().all(|c| c.is_ascii_alphanumeric() || *c == b'_')
}

fn upper_text(text: &[u8]) -> String {
    String::from_utf8_lossy(text.trim_ascii()).to_ascii_uppercase()
}

/// The spindle `SETMS(n)` makes the master: `None` for `SETMS` alone (back to the machine's default
/// master), `Some(None)` for an expression.
fn master_spindle(block: &Block<'_>, call: &Node) -> Option<Option<f64>> {
    let args = call.call_arguments();
    let first = args.first()?.as_ref()?;
    Some(literal(block, first))
}

/// A number written as such, with an optional sign (`12.5`, `-3`); `None` for any other expression.
fn literal(block: &Block<'_>, node: &Node) -> Option<f64> {
    match node.kind {
        NodeKind::Number => std::str::from_utf8(block.text(node)).ok()?.parse().ok(),
        NodeKind::Unary => {
            let mut parts = node.significant();
            let sign = match block.text(parts.next()?) {
                b"-" => -1.0,
                b"+" => 1.0,
                _ => return None,
            };
            Some(sign * literal(block, parts.next()?)?)
        }
        _ => None,
    }
}
