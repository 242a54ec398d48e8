//! The machine profile: how this machine probes, where it measures, which offset it corrects, the limits of
//! the method and what the timeline assumes. TOML; every key is required except where a default is given,
//! and unknown keys are refused so a misspelt setting cannot silently fall back to a default.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::data::LARGEST_UM;

use super::continuous::Continuous;
use super::declared_calls::{self, DeclaredCall, Loads};
use super::machine_coolant::{MachineCoolant, tool_change_m_fault};
use super::warm::WarmStart;

/// The profile shipped inside the binary (fixtures/omm/blum-tc50.toml), used when `--profile` is absent.
pub const DEFAULT_PROFILE: &str = include_str!("../../fixtures/omm/blum-tc50.toml");

/// The profiles shipped inside the binary: name (what `--profile` takes), when to use it, the TOML.
pub const BUILTIN: &[(&str, &str, &str)] = &[
    (
        "blum-tc50",
        "machining centre, touch probe loaded by a tool change, base surface along Z (the default)",
        DEFAULT_PROFILE,
    ),
    (
        "siemens-cycle978",
        "machining centre, touch probe with the Siemens measuring cycle CYCLE978",
        include_str!("../../fixtures/omm/siemens-cycle978.toml"),
    ),
    (
        "tool-setter",
        "machining centre, tool setter on the table measured with the cutting tool: no tool change (single-tool programs)",
        include_str!("../../fixtures/omm/tool-setter.toml"),
    ),
    (
        "grinder-gauge",
        "cylindrical grinder, in-process gauge on the infeed axis X (diameters): nothing moves, gates at retracts, stops, dressing",
        include_str!("../../fixtures/omm/grinder-gauge.toml"),
    ),
    (
        "lathe-setter",
        "lathe with a turret and a tool-setter arm, X in diameters: no tool change",
        include_str!("../../fixtures/omm/lathe-setter.toml"),
    ),
];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    pub name: String,
    pub probe: Probe,
    pub position: Position,
    pub offset: Offset,
    pub limits: Limits,
    pub registers: Registers,
    pub passes: Passes,
    pub timeline: TimelineSettings,
    /// Optional: without the section the log holds the measured gates only.
    #[serde(default)]
    pub log: LogSettings,
    /// Optional: continuous compensation through the control's temperature compensation between gates.
    #[serde(default, skip_serializing_if = "Continuous::is_default")]
    pub continuous: Continuous,
    /// Optional: the model's states carried from one job to the next.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warm_start: Option<WarmStart>,
    /// Optional: the machine's own coolant M-codes, which gates switch off and give back like M7/M8.
    #[serde(default, skip_serializing_if = "MachineCoolant::is_default")]
    pub coolant: MachineCoolant,
    /// Optional: what a builder's or shop's calls do that driftloop cannot read (`[calls.TC]`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub calls: BTreeMap<String, DeclaredCall>,
}

/// How dense DRIFTLOG is and which analog inputs it carries, for `diagnose` to work with.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogSettings {
    /// Measure (and log) at every gate that can measure, not only where the predicted change reached δ'.
    /// Costs one measurement per gate; meant for a diagnosis period, not for production.
    #[serde(default)]
    pub measure_every_gate: bool,
    /// Signal name → analog input number: `ambient_c = 1` logs `$A_INA[1]` as the column `ambient_c`.
    #[serde(default)]
    pub inputs: std::collections::BTreeMap<String, u32>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Probe {
    /// What measures the drift; decides whether a gate changes tools.
    #[serde(default)]
    pub kind: ProbeKind,
    /// The probe's tool name (`spindle-probe` only).
    #[serde(default)]
    pub tool: String,
    #[serde(default = "one")]
    pub tool_offset: u32,
    /// How the machine changes tools.
    #[serde(default)]
    pub tool_change: ToolChange,
    /// The M-code that loads the preselected tool (MD22560 `$MC_TOOL_CHANGE_M_CODE`, 6 unless the builder
    /// chose another, such as 16): the program's change is read by it, and a gate swaps with it.
    #[serde(default = "six", skip_serializing_if = "is_six")]
    pub tool_change_m: u32,
    /// The machine's own tool change a gate swaps the probe with, instead of `M6`: a call declared in
    /// `[calls]` with `loads`. `{tool}` stands for the tool where the call takes it as an argument;
    /// without it the gate selects the tool with `T=` first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change: Option<String>,
    /// What a gate does where the program's text does not say which tool is in the spindle (no tool change
    /// before it): refuse the place, or read the tool at run time and check it is back before cutting.
    #[serde(default)]
    pub unknown_tool: UnknownTool,
    /// The value of `T=` that selects again the tool whose T number (`$P_TOOLNO`) a gate saved; `{t}` is
    /// replaced by the R-parameter holding it. Used with `unknown_tool = "runtime"`.
    #[serde(default = "Probe::tool_by_name")]
    pub tool_by_number: String,
    /// Call template; `{axis}` → 1/2/3, `{nominal}` → the base-surface nominal.
    pub cycle: String,
    /// Variable the cycle leaves the measured coordinate in (mm).
    pub result: String,
    pub measure_s: f64,
}

fn one() -> u32 {
    1
}

fn six() -> u32 {
    6
}

fn is_six(m: &u32) -> bool {
    *m == 6
}

impl Probe {
    /// With tool management a tool is selected by its name, `$TC_TP2[t]` of its T number `t`.
    fn tool_by_name() -> String {
        "$TC_TP2[{t}]".into()
    }

    /// The probe cycle's name, as its call template begins (`BL9700`).
    pub fn cycle_name(&self) -> &str {
        self.cycle.split('(').next().unwrap_or(&self.cycle).trim()
    }

    /// The probe as a gate writes it after `T=` or as a tool argument: a T number on a machine that
    /// selects tools by plain numbers (`tool_by_number = "{t}"`, no tool management: `T="99"` would be
    /// a name it has not got), else its name in quotes.
    pub fn written_tool(&self) -> String {
        let number = !self.tool.is_empty() && self.tool.bytes().all(|b| b.is_ascii_digit());
        if number && !self.tool_by_number.contains("$TC_TP2") {
            self.tool.clone()
        } else {
            format!("\"{}\"", self.tool)
        }
    }

    /// `T=` of the tool whose T number the R-parameter `reg` holds ([`Probe::tool_by_number`]).
    pub fn reselect(&self, reg: &str) -> String {
        self.tool_by_number.replace("{t}", reg)
    }

    /// The blocks that load `tool` (as the program writes it: `"NAME"` or a number) with the machine's
    /// declared change ([`Probe::change`]): the call with the tool as its argument, or `T=` and the call.
    pub fn swap(&self, tool: &str) -> Option<Vec<String>> {
        let change = self.change.as_ref()?;
        Some(if change.contains("{tool}") {
            vec![change.replace("{tool}", tool)]
        } else {
            vec![format!("T={tool}"), change.clone()]
        })
    }
}

/// What a spindle-probe gate does where the tool in the spindle is not known from the program's text.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UnknownTool {
    /// No gate measures there: the probe could not be swapped for a tool nobody named.
    #[default]
    Refuse,
    /// The gate reads `$P_TOOLNO` and `$P_TOOL` before the swap, selects that tool and edge again after it,
    /// and stops with an alarm unless both read back the same; with no tool or edge active it does not swap.
    Runtime,
}

/// What measures the drift.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ProbeKind {
    /// A touch probe the gate loads into the spindle (tool change), then the cutting tool again.
    #[default]
    SpindleProbe,
    /// A reference fixed on the machine (tool setter, laser, reference sphere) measured with the tool in
    /// the spindle: no tool change; the gate travels to it and back.
    ToolSetter,
    /// An in-process gauge (grinders): read where the machine stands, nothing moves.
    Gauge,
}

impl ProbeKind {
    pub fn name(self) -> &'static str {
        match self {
            ProbeKind::SpindleProbe => "spindle-probe",
            ProbeKind::ToolSetter => "tool-setter",
            ProbeKind::Gauge => "gauge",
        }
    }
}

/// How the machine changes tools.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToolChange {
    /// `T` selects (preselection), `M6` loads: machining centres with tool management.
    #[default]
    M6,
    /// `T` loads at once: turrets, machines without M6.
    T,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Position {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    /// Height on the retract axis at which every travel happens (work coordinates).
    #[serde(alias = "clearance_z")]
    pub clearance: f64,
    pub axis: Axis,
    pub nominal: f64,
    /// Coordinates of the start point: the corrected work offset, or the machine's (`SUPA`: a tool setter
    /// fixed on the table).
    #[serde(default)]
    pub frame: MeasureFrame,
    /// The geometry axes a gate saves and gives back (a lathe has no Y).
    #[serde(default = "xyz")]
    pub axes: Vec<Axis>,
    /// The tool axis: a gate retracts along it to the clearance height before any other move.
    #[serde(default = "z")]
    pub retract_axis: Axis,
    /// The cycle's result and the nominal are diameters (DIAMON on a lathe or grinder): the drift is half
    /// their change.
    #[serde(default)]
    pub diameter: bool,
    /// Further axes every measuring gate measures and corrects, each with its own model channel.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub also: Vec<AlsoMeasured>,
    /// The highest machine coordinate on the retract axis a gate may rise to (a diameter on X with
    /// `diameter`): a gate whose travel height lies above it under the work offset in force stops before
    /// it moves. Unset: the control's software limit is the only bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retract_max: Option<f64>,
}

impl Position {
    /// A coordinate of the profile on `axis` as a gate moves it: a gate moves X in radius (it switches
    /// DIAMON off), and a profile in diameters gives X as a diameter.
    pub fn in_radius(&self, axis: Axis, v: f64) -> f64 {
        if axis == Axis::X && self.diameter {
            v / 2.0
        } else {
            v
        }
    }

    /// The start point's coordinate on `axis` as the profile gives it (a diameter on X with `diameter`).
    pub fn start(&self, axis: Axis) -> f64 {
        match axis {
            Axis::X => self.x,
            Axis::Y => self.y,
            Axis::Z => self.z,
        }
    }

    /// The start point's coordinate on `axis` as a gate moves it, in radius on X.
    pub fn start_in_radius(&self, axis: Axis) -> f64 {
        self.in_radius(axis, self.start(axis))
    }
}

/// A further measured axis: the nominal of its surface, the probing start point, and the model channel
/// that predicts its drift (`--model` of that channel).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlsoMeasured {
    pub axis: Axis,
    pub nominal: f64,
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub channel: String,
}

fn xyz() -> Vec<Axis> {
    vec![Axis::X, Axis::Y, Axis::Z]
}

fn z() -> Axis {
    Axis::Z
}

/// In which coordinates the start point is given, and so whether a measurement sees the correction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MeasureFrame {
    /// The corrected work offset: the measured value moves with the correction (a surface of the part or
    /// fixture).
    #[default]
    Work,
    /// Machine coordinates (SUPA): a reference fixed on the machine, which the correction does not move.
    Machine,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn name(self) -> &'static str {
        match self {
            Axis::X => "X",
            Axis::Y => "Y",
            Axis::Z => "Z",
        }
    }

    /// 1, 2, 3: the axis number measuring cycles take.
    pub fn number(self) -> u32 {
        self as u32 + 1
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Offset {
    /// `G54` … `G57`, `G505` … `G599` (default G54); not used by the `active` method.
    #[serde(default = "Offset::g54")]
    pub select: String,
    pub method: OffsetMethod,
    /// Index of the settable frame `$P_UIFR[frame, …]` (G54 = 1, the default); used by the `frame` method.
    #[serde(default = "Offset::first_frame")]
    pub frame: u32,
    /// The control's reset selects this work offset (MD20150 GCODE_RESET_VALUES): a program that selects
    /// none runs in it, and gates may select it again. Off (the Siemens default resets to G500): a gate goes
    /// only where the program has selected the offset itself, as selecting it would move every coordinate
    /// of a program that runs without it.
    #[serde(default)]
    pub reset_selects: bool,
    /// The offset on the measured axis is written in diameter (a transverse axis whose work offsets the
    /// machine data keep as diameters): twice the drift.
    #[serde(default)]
    pub diameter: bool,
}

impl Offset {
    fn g54() -> String {
        "G54".into()
    }

    fn first_frame() -> u32 {
        1
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OffsetMethod {
    /// `$P_UIFR[frame,axis,TR]` = value at the start + correction.
    Frame,
    /// `TRANS axis=correction` (replaces the programmable frame).
    Trans,
    /// `ATRANS axis=change of the correction` (adds to the programmable frame).
    Atrans,
    /// `$P_IFRAME[axis,TR]` = the stored value of the work offset in force (`$P_UIFR[$P_UIFRNUM,…]`) +
    /// correction: corrects whichever offset the program runs in (G500 included) and acts at once, without
    /// selecting anything; the stored offsets are never written, so a RESET or the program's next selection
    /// of an offset drops the correction (driftloop applies it again after each selection it sees).
    Active,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    pub tolerance_um: f64,
    pub safety_factor: f64,
    pub plausibility_um: f64,
    pub agree_count: u32,
    pub agree_band_um: f64,
    pub max_attempts: u32,
    /// Optional: a gate that can measure does once this many minutes of the program's run passed since the
    /// last measurement, even where the predicted change stayed below δ': a re-zero at least every P
    /// minutes bounds what the model lacks (`diagnose --profile` reports the error with that P).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_interval_min: Option<f64>,
}

impl Limits {
    /// δ' = r·Δ (µm).
    pub fn working_limit_um(&self) -> f64 {
        self.safety_factor * self.tolerance_um
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Registers {
    pub r_first: u32,
    pub r_last: u32,
    pub alarm_implausible: u32,
    pub alarm_scrap: u32,
    /// User alarm of a gate whose tool, read at run time, is not back after the probe's swap.
    #[serde(default = "Registers::tool_alarm")]
    pub alarm_tool: u32,
    pub timer: String,
    pub timer_unit: TimerUnit,
    pub log_file: String,
    /// The condition under which no gate measures: the control interprets the program without machining it
    /// (block search, program test, the panel's simulation), or runs it at the dry-run feed (`DRY`), which
    /// would drive the probe at that feed instead of its measuring feed. A control that lacks one of the
    /// variables (an older one without `$P_SIM`) stops at the first gate with an alarm: leave it out.
    #[serde(default = "Registers::interpreting_only")]
    pub not_machining: String,
}

impl Registers {
    fn tool_alarm() -> u32 {
        65002
    }

    fn interpreting_only() -> String {
        "$P_SEARCH OR $P_ISTEST OR $P_SIM OR $P_DRYRUN".into()
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimerUnit {
    Min,
    S,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Passes {
    pub tool_change: bool,
    pub marker: String,
    pub lines: Vec<usize>,
    pub extra_gates: bool,
    /// Dressing cycles or subprograms (names as called): the block after a call is a place to measure.
    #[serde(default)]
    pub dressing: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimelineSettings {
    pub rapid_mm_per_min: f64,
    pub tool_change_s: f64,
    /// Optional: folders holding the control's subprograms (`NAME.SPF`, `_N_NAME_SPF`, …), relative to the
    /// profile file; a call of one adds its time. `--subprograms DIR` adds more.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub subprograms: Vec<std::path::PathBuf>,
}

#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    /// `at`: `file:line:column` where the TOML could not be read.
    #[error("{at}: not a valid machine profile: {message}")]
    Syntax { at: String, message: String },
    /// `message`: `file:line:column: what is wrong` (`file: …` for a key the file does not hold).
    #[error("{message}")]
    Invalid { message: String },
}

impl Profile {
    /// The shipped default profile.
    pub fn default_profile() -> Profile {
        Profile::from_toml(DEFAULT_PROFILE, "<default profile>")
            .expect("the shipped profile is valid (a test checks it)")
    }

    /// Reads and validates a profile; `file` names it in errors, which point at the line and column of the
    /// value they are about.
    pub fn from_toml(text: &str, file: &str) -> Result<Profile, ProfileError> {
        let profile: Profile = toml::from_str(text).map_err(|e| {
            let (at, message) = crate::toml_span::syntax_error(file, text, &e);
            ProfileError::Syntax { at, message }
        })?;
        profile
            .validate()
            .and_then(|()| profile.validate_nc_values())
            .map_err(|message| ProfileError::Invalid {
                message: crate::toml_span::validation_error(file, text, &message),
            })?;
        Ok(profile)
    }

    /// A builtin profile by name ([`BUILTIN`]).
    pub fn builtin(name: &str) -> Option<Profile> {
        BUILTIN
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|(n, _, text)| {
                Profile::from_toml(text, n)
                    .expect("the shipped profiles are valid (a test checks it)")
            })
    }

    /// The profile in the file `path`, or the builtin profile of that name when no such file exists.
    pub fn read_or_builtin(path: &Path) -> Result<Profile, ProfileError> {
        if !path.exists()
            && let Some(p) = path.to_str().and_then(Profile::builtin)
        {
            return Ok(p);
        }
        Profile::read(path)
    }

    pub fn read(path: &Path) -> Result<Profile, ProfileError> {
        let file = path.display().to_string();
        let text =
            crate::text::read_utf8(path, crate::text::TOML).map_err(|source| ProfileError::Io {
                file: file.clone(),
                source,
            })?;
        let mut profile = Profile::from_toml(&text, &file)?;
        let base = path.parent().unwrap_or(Path::new(""));
        for dir in &mut profile.timeline.subprograms {
            *dir = base.join(&*dir);
        }
        Ok(profile)
    }

    /// The work-offset G number `select` names.
    pub fn offset_g(&self) -> Option<u32> {
        let s = self.offset.select.trim();
        let n: u32 = s.strip_prefix(['G', 'g'])?.parse().ok()?;
        matches!(n, 54..=57 | 505..=599).then_some(n)
    }

    /// The probe cycle call with its placeholders filled in.
    pub fn cycle_call(&self) -> String {
        self.cycle_call_at(&self.position)
    }

    /// The probe cycle call measuring the axis of `at` (one of [`Profile::measured`]).
    pub fn cycle_call_at(&self, at: &Position) -> String {
        self.probe
            .cycle
            .replace("{axis}", &at.axis.number().to_string())
            .replace("{nominal}", &super::nc::number(at.nominal))
    }

    /// The measured axes, each as a position of its own (axis, nominal, start point): `[position]` first,
    /// then its `also` entries.
    pub fn measured(&self) -> Vec<Position> {
        let first = Position {
            also: Vec::new(),
            ..self.position.clone()
        };
        let more = self.position.also.iter().map(|a| Position {
            axis: a.axis,
            nominal: a.nominal,
            x: a.x,
            y: a.y,
            z: a.z,
            ..first.clone()
        });
        std::iter::once(first.clone()).chain(more).collect()
    }

    /// What serde cannot check.
    pub fn validate(&self) -> Result<(), String> {
        let l = &self.limits;
        let positive = [
            ("limits.tolerance_um", l.tolerance_um),
            ("limits.plausibility_um", l.plausibility_um),
            ("limits.agree_band_um", l.agree_band_um),
            ("probe.measure_s", self.probe.measure_s),
            ("timeline.rapid_mm_per_min", self.timeline.rapid_mm_per_min),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} must be a positive number, not {v}"));
            }
        }
        if let Some(p) = l.max_interval_min
            && !(p.is_finite() && p > 0.0 && p <= LONGEST_S / 60.0)
        {
            return Err(format!(
                "limits.max_interval_min must be a positive number of minutes, at most a day, not {p}"
            ));
        }
        if !(self.timeline.tool_change_s.is_finite() && self.timeline.tool_change_s >= 0.0) {
            return Err("timeline.tool_change_s must be zero or positive".into());
        }
        if !(l.safety_factor > 0.0 && l.safety_factor <= 1.0) {
            return Err(format!(
                "limits.safety_factor r must be in (0, 1], not {}",
                l.safety_factor
            ));
        }
        if l.agree_count < 3 {
            return Err(format!(
                "limits.agree_count must be at least 3 (N > 2 agreeing measurements), not {}",
                l.agree_count
            ));
        }
        if l.max_attempts < l.agree_count {
            return Err(format!(
                "limits.max_attempts ({}) must be at least limits.agree_count ({})",
                l.max_attempts, l.agree_count
            ));
        }
        let r = &self.registers;
        if r.r_first > r.r_last {
            return Err(format!(
                "registers.r_first ({}) is above registers.r_last ({})",
                r.r_first, r.r_last
            ));
        }
        for (name, n) in [
            ("registers.alarm_implausible", r.alarm_implausible),
            ("registers.alarm_scrap", r.alarm_scrap),
            ("registers.alarm_tool", r.alarm_tool),
        ] {
            if !(60000..=69999).contains(&n) {
                return Err(format!(
                    "{name} {n} is not a user (cycle) alarm number 60000…69999"
                ));
            }
        }
        if !r.timer.starts_with('$') {
            return Err(format!(
                "registers.timer `{}` must be a system variable such as $AN_SETUP_TIME",
                r.timer
            ));
        }
        if r.not_machining.trim().is_empty() {
            return Err(
                "registers.not_machining must be a condition such as \"$P_SEARCH OR $P_ISTEST\" (leave the key out for the default)"
                    .into(),
            );
        }
        if r.log_file.is_empty() || r.log_file.contains('"') {
            return Err("registers.log_file must be a file name without quotes".into());
        }
        if self.offset_g().is_none() {
            return Err(format!(
                "offset.select `{}` is not a settable work offset (G54…G57, G505…G599)",
                self.offset.select
            ));
        }
        let tool = &self.probe.tool;
        if self.probe.kind == ProbeKind::SpindleProbe && tool.is_empty() {
            return Err(
                "probe.tool must name the probe's tool (kind = \"spindle-probe\" loads it with a tool change)"
                    .into(),
            );
        }
        if tool.contains(['"', '\n', '\r', ';']) || tool.chars().any(char::is_control) {
            return Err("probe.tool must be a tool name without quotes, `;` or line breaks".into());
        }
        let reselect = &self.probe.tool_by_number;
        if !reselect.contains("{t}")
            || reselect.contains(['\n', '\r', ';'])
            || reselect.chars().any(char::is_control)
        {
            return Err(format!(
                "probe.tool_by_number `{reselect}` must be the value of T= that selects the tool whose T number is {{t}} (\"$TC_TP2[{{t}}]\" with tool management, \"{{t}}\" without), on one line without `;`"
            ));
        }
        let p = &self.position;
        if p.axes.is_empty() || !p.axes.contains(&p.retract_axis) {
            return Err(format!(
                "position.axes {:?} must list the retract axis {}",
                p.axes.iter().map(|a| a.name()).collect::<Vec<_>>(),
                p.retract_axis.name()
            ));
        }
        let mut seen = vec![p.axis];
        for a in &p.also {
            if seen.contains(&a.axis) {
                return Err(format!(
                    "position.also measures {} twice: every measured axis once",
                    a.axis.name()
                ));
            }
            seen.push(a.axis);
            if a.channel.trim().is_empty() {
                return Err(format!(
                    "position.also ({}) must name the model channel that predicts its drift",
                    a.axis.name()
                ));
            }
        }
        for (name, v) in [
            ("position.x", p.x),
            ("position.y", p.y),
            ("position.z", p.z),
            ("position.clearance", p.clearance),
            ("position.nominal", p.nominal),
        ] {
            if !(v.is_finite() && v.abs() < 1e5) {
                return Err(format!(
                    "{name} must be a coordinate within ±100000 mm, not {v}"
                ));
            }
        }
        if self.probe.result.trim().is_empty() {
            return Err("probe.result must name the variable the cycle writes".into());
        }
        // The result is read in an assignment, so it is checked as one.
        for (key, text) in [
            ("probe.cycle", self.cycle_call()),
            ("probe.result", format!("R1={}", self.probe.result)),
        ] {
            if let Some(d) = crate::syntax::line_syntax_errors(text.as_bytes()).first() {
                return Err(format!(
                    "{key}: `{text}` is not a valid NC block: {}",
                    d.message
                ));
            }
        }
        self.validate_calls()?;
        self.validate_tool_change_m()?;
        self.continuous
            .validate(self.position.diameter || self.offset.diameter)?;
        if let Some(w) = &self.warm_start {
            w.validate((self.registers.r_first, self.registers.r_last), LAST_R)?;
        }
        for (name, n) in &self.log.inputs {
            let plain = name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if name.is_empty() || !plain || *n == 0 {
                return Err(format!(
                    "log.inputs: `{name} = {n}` must name a column (letters, digits, _) and an analog input number from 1"
                ));
            }
        }
        for p in &self.passes.lines {
            if *p == 0 {
                return Err("passes.lines are 1-based line numbers; 0 is not a line".into());
            }
        }
        Ok(())
    }
}

impl Profile {
    /// `position.retract_max` bounds how high a gate rises: a number a machine reaches, for a probe that
    /// moves, and (for a reference in machine coordinates) not below any start point a gate descends to.
    fn validate_retract_max(&self) -> Result<(), String> {
        let p = &self.position;
        let Some(max) = p.retract_max else {
            return Ok(());
        };
        if !(max.is_finite() && max.abs() < 1e5) {
            return Err(format!(
                "position.retract_max must be a coordinate within ±100000 mm, not {max}"
            ));
        }
        if self.probe.kind == ProbeKind::Gauge {
            return Err(
                "position.retract_max: a gauge gate moves nothing, so it bounds nothing; remove it"
                    .into(),
            );
        }
        if p.frame == MeasureFrame::Machine {
            let axis = p.retract_axis;
            if let Some(start) = self
                .measured()
                .iter()
                .map(|at| at.start(axis))
                .find(|start| max < *start)
            {
                return Err(format!(
                    "position.retract_max {max} lies below the probing start point {}{start} (machine coordinates): a gate travels at or above the start point",
                    axis.name(),
                ));
            }
        }
        Ok(())
    }
}

impl Profile {
    /// `[calls]` and `probe.change`: a spindle probe on a machine whose tool change is a declared call
    /// swaps the probe with that call, in the form the declaration reads (`{tool}` where it takes the tool).
    fn validate_calls(&self) -> Result<(), String> {
        declared_calls::validate(&self.calls, self.probe.cycle_name())?;
        let probe = &self.probe;
        let Some(change) = &probe.change else {
            if let (ProbeKind::SpindleProbe, Some((name, _))) = (
                probe.kind,
                self.calls.iter().find(|(_, c)| c.loads.is_some()),
            ) {
                return Err(format!(
                    "calls.{name} declares a tool change: a spindle probe's gates must swap the probe the same way; set [probe] change (e.g. \"{name}(1)\", or with {{tool}} where the call takes the tool)"
                ));
            }
            return Ok(());
        };
        if probe.kind != ProbeKind::SpindleProbe || probe.tool_change != ToolChange::M6 {
            return Err(
                "probe.change replaces the M6 of a spindle probe's swap: it needs kind = \"spindle-probe\" and tool_change = \"m6\""
                    .into(),
            );
        }
        let (name, args) = change.split_once('(').unwrap_or((change, ""));
        let name = name.trim();
        let Some(loads) = declared_calls::find(&self.calls, name).and_then(|c| c.loads) else {
            return Err(format!(
                "probe.change `{change}` must call a tool change declared in [calls] with loads (no [calls.{name}] loads = …)"
            ));
        };
        let args: Vec<&str> = args.trim_end().trim_end_matches(')').split(',').collect();
        let at = args.iter().position(|a| a.trim() == "{tool}");
        let ok = match loads {
            Loads::Preselected => !change.contains("{tool}"),
            Loads::Arg(n) => at == Some(n - 1) && change.matches("{tool}").count() == 1,
        };
        if !ok {
            return Err(format!(
                "probe.change `{change}` does not fit calls.{name}.loads = \"{loads}\": {}",
                match loads {
                    Loads::Preselected =>
                        "a call that loads the preselected tool takes no {tool} (the gate writes T= before it)".to_string(),
                    Loads::Arg(n) => format!("argument {n} (and only it) must be {{tool}}"),
                }
            ));
        }
        let text = change.replace("{tool}", &probe.written_tool());
        if let Some(d) = crate::syntax::line_syntax_errors(text.as_bytes()).first() {
            return Err(format!(
                "probe.change: `{text}` is not a valid NC block: {}",
                d.message
            ));
        }
        Ok(())
    }
}

impl Profile {
    /// `probe.tool_change_m`: a builder's code must be one the control leaves to the machine, loading a
    /// tool the program preselected with `T`.
    fn validate_tool_change_m(&self) -> Result<(), String> {
        let m = self.probe.tool_change_m;
        if m == 6 {
            return Ok(());
        }
        if self.probe.tool_change != ToolChange::M6 {
            return Err(format!(
                "probe.tool_change_m = {m} names the M-code that loads a preselected tool: it needs tool_change = \"m6\" (with \"t\" the T word loads at once)"
            ));
        }
        if let Some(fault) = tool_change_m_fault(m) {
            return Err(format!("probe.tool_change_m: {fault}"));
        }
        if self.coolant.follows(m) {
            return Err(format!(
                "probe.tool_change_m: M{m} is also one of [coolant] codes"
            ));
        }
        Ok(())
    }
}

/// Highest R-parameter number a profile may give driftloop (the control's MD28050 decides how many exist).
const LAST_R: u32 = 9999;
/// Longest time in a profile (s): a day.
const LONGEST_S: f64 = 86_400.0;

impl Profile {
    /// What reaches the NC program and has to make sense there: texts that cannot break a block or inject
    /// one (printable ASCII only: no line break, no quote inside a quoted name), numbers in the range a
    /// machine works in, and an offset frame that is the selected offset's. Messages start with the key.
    pub fn validate_nc_values(&self) -> Result<(), String> {
        let no_change = String::new();
        let texts = [
            ("name", &self.name, ""),
            ("probe.tool", &self.probe.tool, "\""),
            ("probe.cycle", &self.probe.cycle, ""),
            ("probe.result", &self.probe.result, "\";"),
            ("offset.select", &self.offset.select, " \";"),
            ("registers.timer", &self.registers.timer, "\";"),
            ("registers.log_file", &self.registers.log_file, "\";"),
            (
                "registers.not_machining",
                &self.registers.not_machining,
                "\";",
            ),
            ("passes.marker", &self.passes.marker, ""),
            (
                "probe.change",
                self.probe.change.as_ref().unwrap_or(&no_change),
                ";",
            ),
        ];
        let dressing = self
            .passes
            .dressing
            .iter()
            .map(|d| ("passes.dressing", d, "\";"));
        for (key, text, refused) in texts.into_iter().chain(dressing) {
            if let Some(c) = text
                .chars()
                .find(|c| !(' '..='~').contains(c) || refused.contains(*c))
            {
                return Err(format!(
                    "{key} `{}` holds {c:?}: NC text here must be printable ASCII{}",
                    text.escape_default(),
                    if refused.is_empty() {
                        String::new()
                    } else {
                        format!(" without {}", refused.escape_default())
                    }
                ));
            }
        }
        let l = &self.limits;
        for (key, v) in [
            ("limits.tolerance_um", l.tolerance_um),
            ("limits.plausibility_um", l.plausibility_um),
            ("limits.agree_band_um", l.agree_band_um),
        ] {
            if v > LARGEST_UM {
                return Err(format!(
                    "{key} {v:?} is more than {LARGEST_UM} µm (one metre)"
                ));
            }
        }
        for (key, v) in [
            ("probe.measure_s", self.probe.measure_s),
            ("timeline.tool_change_s", self.timeline.tool_change_s),
        ] {
            if v > LONGEST_S {
                return Err(format!("{key} {v:?} is more than {LONGEST_S} s (a day)"));
            }
        }
        if self.timeline.rapid_mm_per_min > 1e6 {
            return Err(format!(
                "timeline.rapid_mm_per_min {} is more than 1000000 mm/min",
                self.timeline.rapid_mm_per_min
            ));
        }
        if l.agree_count > 100 || l.max_attempts > 1000 {
            return Err(format!(
                "limits.max_attempts {} (agree_count {}): at most 1000 probings for at most 100 agreeing values",
                l.max_attempts, l.agree_count
            ));
        }
        let r = &self.registers;
        if r.r_last > LAST_R {
            return Err(format!(
                "registers.r_last R{} is beyond R{LAST_R}",
                r.r_last
            ));
        }
        if !(1..=32000).contains(&self.probe.tool_offset) {
            return Err(format!(
                "probe.tool_offset D{} is not a tool offset number 1…32000",
                self.probe.tool_offset
            ));
        }
        let p = &self.position;
        let start = p.start(p.retract_axis);
        if p.frame == MeasureFrame::Work
            && self.probe.kind != ProbeKind::Gauge
            && p.clearance <= start
        {
            return Err(format!(
                "position.clearance {} is not above the probing start point ({}{start}): a gate travels at the clearance height and descends to the start point",
                p.clearance,
                p.retract_axis.name()
            ));
        }
        self.validate_retract_max()?;
        self.coolant.validate()?;
        let g = self.offset_g().unwrap_or(0);
        let frame_of_select = match g {
            54..=57 => g - 53,
            _ => g.saturating_sub(500),
        };
        if self.offset.method == OffsetMethod::Frame && self.offset.frame != frame_of_select {
            return Err(format!(
                "offset.frame {} is not the frame of {} ($P_UIFR[{frame_of_select}]): the correction would go into another work offset than the one selected",
                self.offset.frame, self.offset.select
            ));
        }
        for (name, n) in &self.log.inputs {
            if *n > 999 {
                return Err(format!(
                    "log.inputs: `{name} = {n}` is beyond the analog inputs $A_INA[1…999]"
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_profile_is_valid_and_named_by_its_kind() {
        for (name, _, text) in BUILTIN {
            let p = Profile::from_toml(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
            let kind = match *name {
                "tool-setter" | "lathe-setter" => ProbeKind::ToolSetter,
                "grinder-gauge" => ProbeKind::Gauge,
                _ => ProbeKind::SpindleProbe,
            };
            assert_eq!(p.probe.kind, kind, "{name}");
            assert!(Profile::builtin(name).is_some());
        }
        let lathe = Profile::builtin("lathe-setter").unwrap();
        assert_eq!(lathe.position.retract_axis, Axis::X);
        assert!(lathe.position.diameter && lathe.probe.tool_change == ToolChange::T);
        assert!(Profile::builtin("no-such").is_none());
    }

    #[test]
    fn shipped_profiles_are_valid() {
        let p = Profile::default_profile();
        assert_eq!(p.probe.result, "R2");
        assert_eq!(p.probe.kind, ProbeKind::SpindleProbe);
        assert_eq!(p.position.clearance, 100.0);
        assert_eq!(p.offset_g(), Some(54));
        assert_eq!(
            p.cycle_call(),
            "BL9700(1,3,0,10,0.5,300,0,0,0,0,0,0,0,0,0,0)"
        );
        let text = include_str!("../../fixtures/omm/siemens-cycle978.toml");
        let s = Profile::from_toml(text, "cycle978").unwrap();
        assert!(s.cycle_call().starts_with("CYCLE978("));
        assert_eq!(s.probe.result, "_OVR[4]");
    }

    #[test]
    fn unknown_keys_and_bad_values_are_refused() {
        let unknown = DEFAULT_PROFILE.replace("[limits]", "[limits]\ntolerance = 5");
        let err = Profile::from_toml(&unknown, "p.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("unknown field `tolerance`"), "{err}");
        let two = DEFAULT_PROFILE.replace("agree_count = 3", "agree_count = 2");
        let err = Profile::from_toml(&two, "p.toml").unwrap_err().to_string();
        assert!(err.contains("N > 2"), "{err}");
        let g = DEFAULT_PROFILE.replace("select = \"G54\"", "select = \"G53\"");
        let err = Profile::from_toml(&g, "p.toml").unwrap_err().to_string();
        assert!(err.contains("not a settable work offset"), "{err}");
        let cycle = DEFAULT_PROFILE.replace("BL9700(1,", "BL9700((1,");
        let err = Profile::from_toml(&cycle, "p.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a valid NC block"), "{err}");
    }

    #[test]
    fn a_tool_change_m_code_the_control_reserves_or_a_turret_is_refused() {
        let with = |change: &str, m: &str| {
            DEFAULT_PROFILE.replace(
                "tool_change = \"m6\"",
                &format!("tool_change = \"{change}\"\ntool_change_m = {m}"),
            )
        };
        let err = |text: String| Profile::from_toml(&text, "p.toml").unwrap_err().to_string();
        for m in ["8", "30", "100000"] {
            assert!(err(with("m6", m)).contains(&format!("M{m} cannot be the tool change")));
        }
        assert!(err(with("t", "16")).contains("needs tool_change = \"m6\""));
        let both = with("m6", "16").replace(
            "[limits]",
            "[coolant]\ncodes = [[16, 61]]\nm9_ends = false\n[limits]",
        );
        let e = err(both);
        assert!(e.contains("M16 is also one of [coolant] codes"), "{e}");
        let m16 = Profile::from_toml(&with("m6", "16"), "p.toml").unwrap();
        assert_eq!(m16.probe.tool_change_m, 16);
        assert_eq!(
            Profile::from_toml(DEFAULT_PROFILE, "p.toml")
                .unwrap()
                .probe
                .tool_change_m,
            6
        );
    }
}
