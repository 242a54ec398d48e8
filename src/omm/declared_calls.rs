//! The profile's `[calls.NAME]` tables: what a machine builder's cycle does that the program calls and
//! driftloop cannot read (DMG's `TC(1)`, Burkhardt+Weber's `L706`, a change-point retract `L710`, a datum
//! cycle `NPL`). Without a declaration such a call may cut and may change anything, so no gate measures
//! after it until the next tool change, and a first cut that is such a call leaves no place for the zero.
//! A declaration is the user's claim about the builder's macro: it narrows what the call may change, and
//! the transform then relies on it (docs/safety.md, "Declared calls").

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// What a declared call does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeclaredCall {
    /// The call changes tools, as M6 does: which tool it loads.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loads: Option<Loads>,
    /// What else the call may change; the rest of the modal state holds across it. A tool change's
    /// default is `["coolant", "position"]` (its spindle stops as at M6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leaves: Option<Vec<Leaves>>,
    /// The call switches the coolant off itself (as M9): after it the coolant is known to be off.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub coolant_off: bool,
}

/// Which tool a declared tool-change call loads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loads {
    /// The tool the last `T=` / `T` selected (DMG's `T="NAME"` then `TC(1)`).
    Preselected,
    /// The tool its n-th argument gives (1-based; Burkhardt+Weber's `L706(, 5, , "1")` is `arg 2`).
    Arg(usize),
}

impl fmt::Display for Loads {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Loads::Preselected => f.write_str("preselected"),
            Loads::Arg(n) => write!(f, "arg {n}"),
        }
    }
}

impl std::str::FromStr for Loads {
    type Err = String;

    fn from_str(s: &str) -> Result<Loads, String> {
        if s == "preselected" {
            return Ok(Loads::Preselected);
        }
        match s.strip_prefix("arg ").map(|n| n.trim().parse::<usize>()) {
            Some(Ok(n)) if n >= 1 => Ok(Loads::Arg(n)),
            _ => Err(format!(
                "loads `{s}` must be \"preselected\" (the tool the last T selected) or \"arg N\" (the tool in the call's N-th argument, from 1)"
            )),
        }
    }
}

impl Serialize for Loads {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Loads {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Loads, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

/// A part of the machine's state a declared call may change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Leaves {
    /// Where the axes stand (a change-point retract): a gate reads the position from the control.
    Position,
    /// G0/G1/G2/G3.
    Motion,
    /// F.
    Feed,
    /// G93/G94/G95.
    FeedMode,
    /// G90/G91.
    Absolute,
    /// G17/G18/G19.
    Plane,
    /// G60/G64/G641 …
    PathMode,
    /// S and M3/M4/M5.
    Spindle,
    /// M7/M8/M9 and the profile's `[coolant]` codes.
    Coolant,
    /// G40/G41/G42.
    Compensation,
    /// D.
    Edge,
    /// The work offset selected (G54 …).
    Offset,
    /// Work offsets' or frames' contents, as a `$P_UIFR[…]=` of the program writes them.
    Frames,
    /// DIAMON/DIAMOF.
    Diameter,
    /// G70/G71/G700/G710.
    Units,
}

impl DeclaredCall {
    /// What the call may change: the declaration's, else a tool change's default.
    pub fn leaves(&self) -> Vec<Leaves> {
        match (&self.leaves, self.loads) {
            (Some(l), _) => l.clone(),
            (None, Some(_)) if self.coolant_off => vec![Leaves::Position],
            (None, Some(_)) => vec![Leaves::Coolant, Leaves::Position],
            (None, None) => Vec::new(),
        }
    }
}

/// `[calls]` checked: names a call can have and driftloop does not read itself, each saying what it does.
/// Messages start with the key (`calls.TC.loads`) so that they point into the file.
pub fn validate(calls: &BTreeMap<String, DeclaredCall>, probe_cycle: &str) -> Result<(), String> {
    for (name, call) in calls {
        let plain = name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !plain {
            return Err(format!(
                "calls.{name}: `{name}` is not the name of a subprogram or cycle (letters, digits, _)"
            ));
        }
        let upper = name.to_ascii_uppercase();
        if crate::views::is_predefined_command(&upper)
            || reads_itself(&upper)
            || upper.eq_ignore_ascii_case(probe_cycle)
        {
            return Err(format!(
                "calls.{name}: {upper} is a command or cycle driftloop reads itself (or the probe's cycle); declare only a builder's or shop's own calls"
            ));
        }
        if calls
            .keys()
            .filter(|k| k.eq_ignore_ascii_case(name))
            .count()
            > 1
        {
            return Err(format!(
                "calls.{name} is declared twice (names are case-insensitive)"
            ));
        }
        if call.loads.is_none() && call.leaves.is_none() {
            return Err(format!(
                "calls.{name} says nothing: give loads = \"preselected\" / \"arg N\" (a tool change) or leaves = [ … ] (what it may change; [] for nothing)"
            ));
        }
        if call.coolant_off
            && call
                .leaves
                .as_ref()
                .is_some_and(|l| l.contains(&Leaves::Coolant))
        {
            return Err(format!(
                "calls.{name}.coolant_off: the coolant is either switched off by the call (coolant_off) or unknown after it (\"coolant\" in leaves), not both"
            ));
        }
        if let Some(l) = &call.leaves
            && let Some(twice) = l.iter().find(|a| l.iter().filter(|b| b == a).count() > 1)
        {
            return Err(format!("calls.{name}.leaves lists {twice:?} twice"));
        }
    }
    Ok(())
}

/// Names whose meaning driftloop follows itself: Siemens' standard cycles (`CYCLE81` …, `CYCLE800`), and
/// what the timeline reads as a transformation or a blank description.
fn reads_itself(name: &str) -> bool {
    crate::views::is_numbered_cycle(name)
        || matches!(
            name,
            "WORKPIECE"
                | "TRAORI"
                | "TRANSMIT"
                | "TRACYL"
                | "TRAANG"
                | "TRAFOOF"
                | "SETMS"
                | "MSG"
                | "SETAL"
        )
}

/// The declaration of `name` (as called, any case).
pub fn find<'a>(calls: &'a BTreeMap<String, DeclaredCall>, name: &str) -> Option<&'a DeclaredCall> {
    calls
        .iter()
        .find(|(k, _)| k.eq_ignore_ascii_case(name))
        .map(|(_, c)| c)
}
