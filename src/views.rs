//! Typed views over block trees: what a program transformer needs to know about each block without walking
//! syntax nodes itself: block numbers, labels, variables read and written, tool, spindle, feed, motion, axis
//! targets and work-offset selections.
//!
//! Names are compared upper-cased (the control ignores case). A name of one letter with optional digits
//! (`X`, `X1`, `M3`) is an address or axis, and the predefined addresses (`CR`, `ANG`, `SPOS`, `ID`, …) are
//! not user variables either.

use std::collections::BTreeSet;

use serde::Serialize;

use crate::source::Span;
use crate::syntax::{Block, Node, NodeKind, Program};

/// A value as written: a plain number, a string literal, or any other expression (by its span).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Value {
    Number(f64),
    Text(String),
    Expr(Span),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Access {
    Read,
    Write,
    /// Declared by DEF (a write when it has an initialiser is reported separately).
    Declare,
}

#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum VarName {
    /// `R12`; `None` when the number is computed (`R[R1+1]`).
    R(Option<u32>),
    /// `$P_UIFR`, `$AA_IM` (indices not included).
    System(String),
    /// A user variable (DEF / PROC parameter / GUD).
    User(String),
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VarAccess {
    pub name: VarName,
    pub access: Access,
    pub span: Span,
}

/// An address value with the optional extended-address number: `S1=1000` → spindle 1, `T="MILL"`, `M3=5`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AddressValue {
    /// The number after the address letter in the extended form (`S1=…` → 1, `M3=5` → 3).
    pub extension: Option<u32>,
    pub value: Value,
    pub span: Span,
}

/// How an axis value is meant: `AC(…)`, `IC(…)`, `DC`, `ACP`, `ACN`, or as the modal G90/G91 says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisMode {
    Modal,
    Ac,
    Ic,
    Dc,
    Acp,
    Acn,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisTarget {
    pub axis: String,
    pub mode: AxisMode,
    pub value: Value,
    pub span: Span,
}

/// A work-offset or frame selection.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum WorkOffset {
    /// G53, G153, G500, G54…G57, G505…G599.
    G(u32),
    /// SUPA, TRANS, ATRANS, CTRANS, ROT, AROT, SCALE, ASCALE, MIRROR, AMIRROR, … (upper case).
    Frame(String),
    /// A write to a frame system variable such as `$P_UIFR[1,Z,TR]`.
    FrameWrite(String),
}

/// Everything a transformer reads off one block.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct BlockFacts {
    pub index: usize,
    /// `N10` → 10 (`:10` main blocks too).
    pub block_number: Option<u64>,
    /// Upper-cased label defined on this block.
    pub label: Option<String>,
    pub variables: Vec<VarAccess>,
    /// `T` words and `T=` / `Tn=` assignments.
    pub tools: Vec<AddressValue>,
    /// `S` words and `S=` / `Sn=` assignments.
    pub spindle_speeds: Vec<AddressValue>,
    /// `M` words and `Mn=` assignments (`M3=5`: spindle 3, code 5).
    pub m_codes: Vec<AddressValue>,
    pub feed: Option<AddressValue>,
    /// Every G code of the block in order (modal settings such as G90/G91, G17, G70/G71 included).
    pub g_codes: Vec<u32>,
    /// Motion G codes in the block (0, 1, 2, 3, 33, …).
    pub motion: Vec<u32>,
    pub axes: Vec<AxisTarget>,
    pub work_offsets: Vec<WorkOffset>,
    /// Upper-cased names the block calls or commands: cycles and subprograms with arguments (`CYCLE800(…)`,
    /// `MSG(…)`) and bare names (`SUBPROG`, `STOPRE`, `TRANS`).
    pub calls: Vec<String>,
}

const MOTION_G: &[u32] = &[0, 1, 2, 3, 33, 34, 35, 331, 332];
const AXIS_LETTERS: &[u8] = b"XYZABCUVW";
const FRAME_COMMANDS: &[&str] = &[
    "SUPA", "TRANS", "ATRANS", "CTRANS", "ROT", "AROT", "CROT", "ROTS", "AROTS", "SCALE", "ASCALE",
    "CSCALE", "MIRROR", "AMIRROR", "CMIRROR",
];

/// Predefined bare commands that change no programmed position (spline end conditions, the default feed
/// profile, acceleration, look-ahead, display and single-block switches, the end of a transformation the
/// dry run does not model): the dry run accepts them as they are.
pub const NEUTRAL_COMMANDS: &[&str] = &[
    "BNAT",
    "BTAN",
    "BAUTO",
    "ENAT",
    "ETAN",
    "EAUTO",
    "FNORM",
    "TRAFOOF",
    "STOPRE",
    "DISPLOF",
    "DISPLON",
    "SBLOF",
    "SBLON",
    "SOFT",
    "BRISK",
    "DRIVE",
    "FFWON",
    "FFWOF",
    "CFC",
    "CFTCP",
    "CFIN",
    "STOPFIFO",
    "STARTFIFO",
    "SAVE",
    // Rapid traverse interpolated as a straight line or axis by axis: a gate moves one axis at a time,
    // or X and Y together at its clearance height.
    "RTLION",
    "RTLIOF",
    // The stop delay area (what an operator's stop waits for): no position.
    "DELAYFSTON",
    "DELAYFSTOF",
];

/// Predefined procedures whose every argument names an axis and that leave positions, feeds and the modal
/// state a gate gives back as they were: how an axis accelerates (`SOFTA`, `BRISKA`, `DRIVEA`, `JERKA`, the
/// per-axis forms of SOFT/BRISK/DRIVE, Siemens PGA "Acceleration mode"; a gate's moves end where they
/// did, only their ramps differ) and `WAITP`, which holds the block change until the positioning axes it
/// names have reached their end points (it moves nothing).
pub const AXIS_PROCEDURES: &[&str] = &["SOFTA", "BRISKA", "DRIVEA", "JERKA", "WAITP"];

/// The other predefined instructions written as a bare name in a block (no `=`, no arguments): program
/// flow, path and interpolation modes, kinematic transformations, tool compensation, retraction. With
/// [`NEUTRAL_COMMANDS`] and the frame commands, any other bare name calls a subprogram (`MYSUB`, `SUB2 P3`).
const PREDEFINED_COMMANDS: &[&str] = &[
    "RET",
    "STOPREOF",
    "FIFOCTRL",
    "CPRECON",
    "CPRECOF",
    "CIP",
    "CT",
    "POLY",
    "ASPLINE",
    "BSPLINE",
    "CSPLINE",
    "FLIN",
    "FCUB",
    "UPATH",
    "SPATH",
    "NORM",
    "KONT",
    "KONTC",
    "KONTT",
    "INVCW",
    "INVCCW",
    "CDON",
    "CDOF",
    "CDOF2",
    "CUT2D",
    "CUT2DF",
    "CUT3DC",
    "CUT3DFS",
    "CUT3DFF",
    "CUT3DF",
    "CUT3DCC",
    "CUT3DCCD",
    "COMPON",
    "COMPCURV",
    "COMPCAD",
    "COMPSURF",
    "COMPOF",
    "TRAORI",
    "TRANSMIT",
    "ORIWKS",
    "ORIMKS",
    "ORIEULER",
    "ORIRPY",
    "ORIC",
    "ORID",
    "ORIPATHS",
    "ORIAXPOS",
    "ORIROTA",
    "ORIROTR",
    "ORIROTT",
    "ORIROTC",
    "ORIRPY2",
    "ORIVIRT1",
    "ORIVIRT2",
    "ORISON",
    "ORISOF",
    "PTPWOC",
    "CUTCONON",
    "CUTCONOF",
    "OSOF",
    "OSC",
    "OST",
    "OSD",
    "OSS",
    "OSSE",
    "PTP",
    "CP",
    "PTPG0",
    "DIAMON",
    "DIAMOF",
    "DIAM90",
    "DIAMCYCOF",
    "TOFRAME",
    "TOFRAMEX",
    "TOFRAMEY",
    "TOFRAMEZ",
    "TOROT",
    "TOROTX",
    "TOROTY",
    "TOROTZ",
    "TOROTOF",
    "PAROT",
    "PAROTOF",
    "TCOABS",
    "TCOFR",
    "SETMS",
    "TOWSTD",
    "TOWMCS",
    "TOWWCS",
    "TOWBCS",
    "TOWTCS",
    "TOWKCS",
    "TCOFRX",
    "TCOFRY",
    "TCOFRZ",
    "WALIMON",
    "WALIMOF",
    "LFON",
    "LFOF",
    "LFTXT",
    "LFWP",
    "LFPOS",
    "RMB",
    "RME",
    "RMI",
    "RMN",
    "LIFTFAST",
    "RDISABLE",
    "DYNNORM",
    "DYNPOS",
    "DYNROUGH",
    "DYNSEMIFIN",
    "DYNFINISH",
    "FTOCON",
    "FTOCOF",
    "EXTCLOSE",
    "SPIF1",
    "SPIF2",
    "SPOF",
    "FENDNORM",
];

/// `CYCLE` and digits: the name of a Siemens standard cycle (`CYCLE81` … `CYCLE998`).
pub fn is_numbered_cycle(name: &str) -> bool {
    name.strip_prefix("CYCLE")
        .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
}

/// The orientation interpolations (G group 51) under an orientation transformation.
pub const ORIENTATION_INTERPOLATIONS: &[&str] = &[
    "ORIVECT",
    "ORIAXES",
    "ORIPATH",
    "ORIPLANE",
    "ORICONCW",
    "ORICONCCW",
    "ORICONIO",
    "ORICONTO",
    "ORICURVE",
];

/// A bare name in a block is a subprogram call unless the control predefines it (upper-case `name`).
pub fn is_predefined_command(name: &str) -> bool {
    PREDEFINED_COMMANDS.contains(&name)
        || ORIENTATION_INTERPOLATIONS.contains(&name)
        || NEUTRAL_COMMANDS.contains(&name)
        || FRAME_COMMANDS.contains(&name)
}

/// Predefined addresses that take `=` but are not variables (arc radius, chamfer, spindle positioning, …).
const PREDEFINED_ADDRESSES: &[&str] = &[
    "CR", "AR", "AP", "RP", "ANG", "RND", "RNDM", "CHF", "CHR", "SPOS", "SPOSA", "OFFN", "PRIO",
    "ID", "IDS", "AX", "FA", "FL", "POS", "POSA", "ACC", "OVR", "SF", "DISC", "DISR", "DISCL",
    "FAD", "TRUE", "FALSE",
];

/// Words that give the tool's direction: Euler / RPY angles (A2 B2 C2) or the direction vector
/// (A3 B3 C3). A block that programs a direction replaces the last one whichever way it was written, and
/// a component it leaves out is 0 (Programming Manual 03/2006, 7.2 "Programming of directional vector").
pub const ORIENTATION_DIRECTION: [[&str; 3]; 2] = [["A2", "B2", "C2"], ["A3", "B3", "C3"]];

/// Further orientation words, each kept on its own: the surface normal at block start (A4 B4 C4) and end
/// (A5 B5 C5) for LEAD / TILT, the cone's axis (A6 B6 C6) and intermediate orientation (A7 B7 C7) of the
/// ORICONxx interpolations, the lead and tilt angles, the tool's rotation about itself (THETA), the
/// cone's opening angle (NUT) and the second point of ORICURVE (XH YH ZH).
const ORIENTATION_OTHERS: [&str; 19] = [
    "A4", "B4", "C4", "A5", "B5", "C5", "A6", "B6", "C6", "A7", "B7", "C7", "LEAD", "TILT",
    "THETA", "NUT", "XH", "YH", "ZH",
];

/// The orientation word `name` (upper case) is, if it is one (programmed under TRAORI).
pub fn orientation_word(name: &str) -> Option<&'static str> {
    ORIENTATION_DIRECTION
        .iter()
        .flatten()
        .chain(ORIENTATION_OTHERS.iter())
        .find(|w| **w == name)
        .copied()
}

/// The G groups whose codes the dry run and the timeline follow, each code in the order the control
/// numbers them (group 8, the settable offsets, in [`indirect_g`]).
const G_GROUPS: &[(u32, &[u32])] = &[
    (1, &[0, 1, 2, 3]),
    (6, &[17, 18, 19]),
    (7, &[40, 41, 42]),
    (10, &[60, 64, 641, 642, 643, 644, 645]),
    (12, &[601, 602, 603]),
    (13, &[70, 71, 700, 710]),
    (14, &[90, 91]),
    (15, &[93, 94, 95, 96, 97]),
    (18, &[450, 451]),
];

/// The G code `G[group]=number` selects: its position in its group as the control numbers them (group 8:
/// 1 = G500, 2 = G54 …). The groups whose codes the dry run and the timeline follow; `None` for others.
pub fn indirect_g(group: f64, number: f64) -> Option<u32> {
    if group.fract() != 0.0 || number.fract() != 0.0 || number < 1.0 {
        return None;
    }
    let k = number as usize - 1;
    if group == 8.0 {
        // G500, G54 … G57, then G505 … G599.
        return match k {
            0 => Some(500),
            1..=4 => Some(53 + k as u32),
            5..=99 => Some(500 + k as u32),
            _ => None,
        };
    }
    G_GROUPS
        .iter()
        .find(|(g, _)| f64::from(*g) == group)
        .and_then(|(_, codes)| codes.get(k).copied())
}

/// The number `$P_GG[group]` reads while G code `g` is active: its position in its group, the inverse of
/// [`indirect_g`].
pub fn g_position(group: u32, g: u32) -> Option<u32> {
    if group == 8 {
        return match g {
            500 => Some(1),
            54..=57 => Some(g - 52),
            505..=599 => Some(g - 499),
            _ => None,
        };
    }
    let (_, codes) = G_GROUPS.iter().find(|(n, _)| *n == group)?;
    let k = codes.iter().position(|&c| c == g)?;
    Some(k as u32 + 1)
}

fn upper(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).to_ascii_uppercase()
}

fn is_work_offset_g(n: u32) -> bool {
    matches!(n, 53 | 153 | 500 | 54..=57 | 505..=599)
}

/// `X`, `X1`, `M3`: an address letter with optional digits.
fn address_parts(name: &str) -> Option<(u8, Option<u32>)> {
    let (&letter, digits) = name.as_bytes().split_first()?;
    if !letter.is_ascii_alphabetic() || !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    let ext = if digits.is_empty() {
        None
    } else {
        std::str::from_utf8(digits).ok()?.parse().ok()
    };
    Some((letter, ext))
}

fn number(text: &[u8]) -> Option<f64> {
    let t = upper(text).replace("EX", "E");
    t.parse().ok()
}

fn value_of(block: &Block<'_>, node: &Node) -> Value {
    match node.kind {
        NodeKind::Number => number(block.text(node)).map_or(Value::Expr(node.span), Value::Number),
        NodeKind::Unary if node.children.first().is_some_and(|c| block.text(c) == b"-") => {
            match node.significant().nth(1).map(|n| value_of(block, n)) {
                Some(Value::Number(v)) => Value::Number(-v),
                _ => Value::Expr(node.span),
            }
        }
        NodeKind::Str => {
            let t = block.text(node);
            Value::Text(String::from_utf8_lossy(&t[1..t.len() - 1]).into_owned())
        }
        _ => Value::Expr(node.span),
    }
}

/// The facts of block `block`.
pub fn facts(block: &Block<'_>) -> BlockFacts {
    let mut f = BlockFacts {
        index: block.index,
        ..BlockFacts::default()
    };
    for node in block.root.significant() {
        match node.kind {
            NodeKind::BlockNumber => {
                f.block_number = node
                    .address_and_number()
                    .and_then(|(_, digits)| std::str::from_utf8(block.text(digits)).ok())
                    .and_then(|t| t.parse().ok());
            }
            NodeKind::Label => f.label = node.find(NodeKind::Name).map(|n| upper(block.text(n))),
            NodeKind::Word => word_facts(block, node, &mut f),
            NodeKind::Assign => assign_facts(block, node, &mut f),
            NodeKind::Command => {
                let name = upper(block.text(node));
                if FRAME_COMMANDS.contains(&name.as_str()) {
                    f.work_offsets.push(WorkOffset::Frame(name.clone()));
                }
                f.calls.push(name);
            }
            NodeKind::Call => f.calls.push(upper(block.text(&node.children[0]))),
            _ => {}
        }
    }
    collect_variables(block, &block.root, &mut f.variables);
    f
}

fn word_facts(block: &Block<'_>, node: &Node, f: &mut BlockFacts) {
    let Some((address, num)) = node.address_and_number() else {
        return;
    };
    let letter = block.text(address)[0].to_ascii_uppercase();
    let value = value_of(block, num);
    let av = AddressValue {
        extension: None,
        value: value.clone(),
        span: node.span,
    };
    let int = match value {
        Value::Number(v) if v >= 0.0 && v.fract() == 0.0 => Some(v as u32),
        _ => None,
    };
    match letter {
        b'G' => {
            if let Some(g) = int {
                f.push_g(g);
            }
        }
        b'T' => f.tools.push(av),
        b'S' => f.spindle_speeds.push(av),
        b'M' => f.m_codes.push(av),
        b'F' => f.feed = Some(av),
        l if AXIS_LETTERS.contains(&l) => f.axes.push(AxisTarget {
            axis: (l as char).to_string(),
            mode: AxisMode::Modal,
            value,
            span: node.span,
        }),
        _ => {}
    }
}

fn assign_facts(block: &Block<'_>, node: &Node, f: &mut BlockFacts) {
    let mut parts = node.significant();
    let (Some(target), _, Some(value)) = (parts.next(), parts.next(), parts.next()) else {
        return;
    };
    let name = target
        .find(NodeKind::Name)
        .map(|n| upper(block.text(n)))
        .unwrap_or_default();
    if target.kind == NodeKind::SysVar {
        if name.starts_with("$P_UIFR")
            || name.starts_with("$P_PFRAME")
            || name.starts_with("$P_SETFRAME")
            || name.starts_with("$P_IFRAME")
            || name.starts_with("$P_BFRAME")
            || name.starts_with("$P_UBFR")
            || name.starts_with("$P_CHBFR")
            || name.starts_with("$P_NCBFR")
        {
            f.work_offsets.push(WorkOffset::FrameWrite(name));
        }
        return;
    }
    if target.kind != NodeKind::Var {
        return;
    }
    if let Some(index) = target.find(NodeKind::Index) {
        if name == "G" {
            indirect_g_facts(block, index, value, f);
        }
        return;
    }
    let Some((letter, extension)) = address_parts(&name) else {
        return;
    };
    let av = AddressValue {
        extension,
        value: value_of(block, value),
        span: node.span,
    };
    match letter.to_ascii_uppercase() {
        b'T' => f.tools.push(av),
        b'S' => f.spindle_speeds.push(av),
        b'M' => f.m_codes.push(av),
        b'F' => f.feed = Some(av),
        l if AXIS_LETTERS.contains(&l) => {
            let (mode, value) = axis_mode(block, value);
            f.axes.push(AxisTarget {
                axis: name,
                mode,
                value,
                span: node.span,
            });
        }
        _ => {}
    }
}

/// `G[8]=2` with literal numbers: the G code it selects, as if written (G54).
fn indirect_g_facts(block: &Block<'_>, index: &Node, value: &Node, f: &mut BlockFacts) {
    let groups: Vec<&Node> = index
        .significant()
        .filter(|n| n.kind != NodeKind::Punct)
        .collect();
    let ([group], Value::Number(number)) = (groups.as_slice(), value_of(block, value)) else {
        return;
    };
    let Value::Number(group) = value_of(block, group) else {
        return;
    };
    if let Some(g) = indirect_g(group, number) {
        f.push_g(g);
    }
}

impl BlockFacts {
    /// A G code of the block: a motion, a work-offset selection or another setting.
    fn push_g(&mut self, g: u32) {
        self.g_codes.push(g);
        if MOTION_G.contains(&g) {
            self.motion.push(g);
        } else if is_work_offset_g(g) {
            self.work_offsets.push(WorkOffset::G(g));
        }
    }
}

/// `X=IC(5)` → (Ic, 5); anything else is modal.
fn axis_mode(block: &Block<'_>, value: &Node) -> (AxisMode, Value) {
    if value.kind == NodeKind::FnCall {
        let mode = match upper(block.text(&value.children[0])).as_str() {
            "AC" => Some(AxisMode::Ac),
            "IC" => Some(AxisMode::Ic),
            "DC" => Some(AxisMode::Dc),
            "ACP" => Some(AxisMode::Acp),
            "ACN" => Some(AxisMode::Acn),
            _ => None,
        };
        let args: Vec<&Node> = value
            .find(NodeKind::Args)
            .map(|a| {
                a.significant()
                    .filter(|n| n.kind != NodeKind::Punct)
                    .collect()
            })
            .unwrap_or_default();
        if let (Some(mode), [arg]) = (mode, args.as_slice()) {
            return (mode, value_of(block, arg));
        }
    }
    (AxisMode::Modal, value_of(block, value))
}

/// Every R parameter, system variable and user variable the block reads, writes or declares.
fn collect_variables(block: &Block<'_>, node: &Node, out: &mut Vec<VarAccess>) {
    match node.kind {
        NodeKind::Assign | NodeKind::For => {
            let mut written = false;
            for c in &node.children {
                if !written && matches!(c.kind, NodeKind::RParam | NodeKind::Var | NodeKind::SysVar)
                {
                    written = true;
                    record_access(block, c, Access::Write, out);
                } else {
                    collect_variables(block, c, out);
                }
            }
        }
        NodeKind::Declarator | NodeKind::Param => {
            if let Some(n) = node.find(NodeKind::Name) {
                let name = VarName::User(upper(block.text(n)));
                out.push(VarAccess {
                    name,
                    access: Access::Declare,
                    span: n.span,
                });
            }
            for c in node.children.iter().filter(|c| c.kind != NodeKind::Name) {
                collect_variables(block, c, out);
            }
        }
        NodeKind::RParam | NodeKind::Var | NodeKind::SysVar => {
            record_access(block, node, Access::Read, out)
        }
        // Jump targets and macro bodies name labels and text, not variables.
        NodeKind::Goto | NodeKind::Define | NodeKind::Repeat | NodeKind::ProgramCall => {}
        _ => {
            for c in &node.children {
                collect_variables(block, c, out);
            }
        }
    }
}

/// Records the access of a variable node; the variables in its index are read.
fn record_access(block: &Block<'_>, node: &Node, access: Access, out: &mut Vec<VarAccess>) {
    if let Some(name) = var_name(block, node) {
        out.push(VarAccess {
            name,
            access,
            span: node.span,
        });
    }
    if let Some(index) = node.find(NodeKind::Index) {
        collect_variables(block, index, out);
    }
}

fn var_name(block: &Block<'_>, node: &Node) -> Option<VarName> {
    let name = upper(block.text(node.find(NodeKind::Name)?));
    match node.kind {
        NodeKind::SysVar => Some(VarName::System(name)),
        NodeKind::RParam if name.len() > 1 => Some(VarName::R(name[1..].parse().ok())),
        NodeKind::RParam => {
            let index = node.find(NodeKind::Index)?;
            let mut inner = index.significant().filter(|n| n.kind != NodeKind::Punct);
            let literal = match (inner.next(), inner.next()) {
                (Some(n), None) if n.kind == NodeKind::Number => {
                    std::str::from_utf8(block.text(n)).ok()?.parse().ok()
                }
                _ => None,
            };
            Some(VarName::R(literal))
        }
        _ if address_parts(&name).is_some() || PREDEFINED_ADDRESSES.contains(&name.as_str()) => {
            None
        }
        _ => Some(VarName::User(name)),
    }
}

/// Facts of every block, in order.
pub fn program_facts(program: &Program) -> impl Iterator<Item = BlockFacts> + '_ {
    program.blocks().map(|b| facts(&b))
}

/// R-parameter numbers the program uses anywhere (literal indices only), e.g. to pick free ones.
pub fn used_r_parameters(program: &Program) -> BTreeSet<u32> {
    program_facts(program)
        .flat_map(|f| f.variables)
        .filter_map(|v| match v.name {
            VarName::R(Some(n)) => Some(n),
            _ => None,
        })
        .collect()
}

/// Upper-cased user-variable names the program declares, reads or writes.
pub fn user_variables(program: &Program) -> BTreeSet<String> {
    program_facts(program)
        .flat_map(|f| f.variables)
        .filter_map(|v| match v.name {
            VarName::User(n) => Some(n),
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_position_in_a_group_is_what_selects_the_g_code_again() {
        for group in [1, 6, 7, 8, 10, 12, 13, 14, 15, 18] {
            for number in 1..=120 {
                if let Some(g) = indirect_g(f64::from(group), f64::from(number)) {
                    assert_eq!(
                        g_position(group, g),
                        Some(number),
                        "G[{group}]={number} is G{g}"
                    );
                }
            }
        }
        assert_eq!(
            (g_position(8, 54), g_position(8, 505), g_position(6, 18)),
            (Some(2), Some(6), Some(2))
        );
        assert_eq!((g_position(2, 4), g_position(6, 90)), (None, None));
    }
}
