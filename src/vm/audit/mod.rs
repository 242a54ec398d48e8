//! The safety audit: runs the original and the transformed program side by side on the virtual machine and
//! reports where the blocks driftloop inserted (the lines ending in `;DL`) break the rule of design.md §6 —
//! where the original program resumes, the control is in the state the original alone would have there.
//!
//! The two runs go in lockstep: the transformed run executes its inserted blocks, then both runs execute the
//! same original block; the state is compared at each resume point (the first original block after inserted
//! ones) and at the end. Memory does not grow with the program's length: only the two interpreters' states
//! and the findings are kept. The abort paths the clean run does not take are followed on a copy of the
//! transformed run, with a probe that returns NaN, a value orders of magnitude off, and a scrap-size drift.
//!
//! ```
//! use driftloop::omm::Profile;
//! use driftloop::vm::Config;
//! use driftloop::vm::audit::{AuditSettings, Kind, audit};
//! let original = b"T1 M6\nS1000 M3 M8\nG0 X50 Y50 Z5\nG1 Z-1 F100\nG1 X80\nG0 Z50\nM30\n";
//! // An inserted block switches the coolant off and nothing switches it on again.
//! let transformed = b"; driftloop-omm ;DL\nT1 M6\nS1000 M3 M8\nM9 ;DL\nG0 X50 Y50 Z5\nG1 Z-1 F100\nG1 X80\nG0 Z50\nM30\n";
//! let settings = AuditSettings::from_profile(&Profile::default_profile());
//! let found = audit(original, transformed, &settings, &Config::default()).unwrap();
//! assert_eq!(found.findings[0].kind, Kind::ModalNotRestored);
//! assert_eq!(found.findings[0].line, 5);
//! ```

mod cycles;
mod geometry;
mod lockstep;
#[cfg(test)]
mod planner_agreement;
mod report;
mod state;

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use super::VmError;
use super::config::{Config, MachineSpec, ProbeTarget};
use super::truth::ModelDrift;
use crate::model::DriftModel;
use crate::omm::Profile;
use crate::omm::declared_calls::Loads;
use crate::omm::machine_coolant::MachineCoolant;
use crate::omm::profile::{Axis, MeasureFrame, OffsetMethod, ProbeKind, ToolChange};

/// What the audit needs to know about the inserted blocks' intent, from the machine profile.
#[derive(Debug, Clone)]
pub struct AuditSettings {
    /// `position.clearance` on `position.retract_axis` (0, 1, 2 for X, Y, Z): inside inserted blocks, travel
    /// across that axis happens at or above it (work coordinates, mm).
    pub clearance: f64,
    pub retract_axis: usize,
    /// `probe.tool`: the probe's tool name (`T="NAME"`), for a probe loaded into the spindle.
    pub probe_tool: Option<String>,
    /// `position.x`, `.y`, `.z` with the nominal on the measured axis: the point the probe touches (mm); `None`
    /// for an in-process gauge, which does not move to a point.
    pub probe_point: Option<[f64; 3]>,
    /// The probe point is in machine coordinates (`position.frame = "machine"`: a reference on the table).
    pub probe_point_in_machine: bool,
    /// For a reference in machine coordinates: the highest start point on the retract axis (machine
    /// coordinates, radius on X); inside inserted blocks, travel across that axis happens at or above it too.
    pub reference_start: Option<f64>,
    /// `position.nominal` and `position.diameter`: what the cycle reports when nothing drifts, and whether it
    /// reports a diameter (twice the drift).
    pub nominal: f64,
    pub diameter: bool,
    /// `position.axis`: 0, 1, 2 for X, Y, Z.
    pub axis: usize,
    /// `position.also`: the further measured and corrected axes (0, 1, 2) with their surfaces' nominals.
    pub also: Vec<(usize, f64)>,
    /// The probe cycle's argument (0-based) that names the axis (`{axis}` in the profile's template).
    pub probe_axis_arg: Option<usize>,
    /// `offset.method` and `offset.frame`: the entry the correction writes, the one difference allowed.
    pub method: OffsetMethod,
    pub frame: usize,
    /// `offset.reset_selects`: both runs start with the profile's work offset selected, as the control's
    /// reset selects it.
    pub reset_selects: bool,
    /// The probe cycle's upper-cased name and where it leaves its result.
    pub probe_cycle: String,
    pub probe_result: Option<ProbeTarget>,
    /// `probe.tool_change = "t"`: T loads the tool at once (no M6).
    pub tool_change_on_t: bool,
    /// `probe.tool_change_m`: the M-code that loads the preselected tool.
    pub tool_change_m: u32,
    /// `[calls]` declared to change tools ([`Config::tool_change_calls`]): both runs load a tool there.
    pub tool_change_calls: BTreeMap<String, Option<usize>>,
    /// `registers.alarm_tool` where gates read the tool at run time: the alarm of their check that the tool
    /// is back, which inserted blocks must never reach in a clean run.
    pub tool_alarm: Option<u32>,
    /// `[coolant]`: the machine's own coolant M-codes both runs follow and the comparison includes.
    pub machine_coolant: MachineCoolant,
    /// `limits.tolerance_um`, `limits.plausibility_um`: the scrap-size drift of the abort runs lies between.
    pub tolerance_um: f64,
    pub plausibility_um: f64,
    /// A cutting move of the original closer than this (mm, across the measured axis) to the probe point
    /// touches it.
    pub probe_margin_mm: f64,
    /// `probe.kind = "spindle-probe"`: the probe touches the part itself, so a milling cycle whose region
    /// is not known is reported too.
    pub spindle_probe: bool,
    /// The machine both programs run on (drift, probe noise and faults); the default does not drift.
    pub machine: MachineSpec,
    pub seed: u64,
    /// Names in messages and the folder subprograms are looked up in first.
    pub original_name: String,
    pub transformed_name: String,
    pub dir: Option<PathBuf>,
}

/// How far below a reference's start point [`AuditSettings::shifted_offsets`] puts the clearance height (mm).
pub const REFERENCE_MARGIN_MM: f64 = 50.0;
/// The work offsets (X, Y, Z, mm) of [`AuditSettings::shifted_offsets`]: a part on a milling table below a
/// spindle whose machine zero is at the top.
const SHIFT: [f64; 3] = [120.0, 80.0, -450.0];

/// A tool loaded by hand before the program, for a dry run that must not start without one: named, so
/// that it is selected again alike by its name (tool management) and by its T number.
pub fn hand_loaded_tool() -> crate::vm::StartTool {
    crate::vm::StartTool {
        number: 1.0,
        name: Some("TOOL_IN_SPINDLE".into()),
        d: 1.0,
    }
}

/// A spindle the operator started in MDA before the program, for the dry run of a program that cuts with
/// it: a gate before the program's own spindle words must leave it turning.
pub fn hand_started_spindle() -> crate::vm::StartSpindle {
    crate::vm::StartSpindle {
        rpm: 3000.0,
        direction: 3,
    }
}

/// `--probe-margin` default (mm).
pub const DEFAULT_PROBE_MARGIN_MM: f64 = 5.0;

impl AuditSettings {
    pub fn from_profile(profile: &Profile) -> AuditSettings {
        let p = &profile.position;
        let axis = p.axis.number() as usize - 1;
        // The argument of the cycle template that holds `{axis}`, for several measured axes.
        let probe_axis_arg = profile
            .probe
            .cycle
            .split_once('(')
            .and_then(|(_, args)| args.split(',').position(|a| a.contains("{axis}")));
        let mut point = [p.in_radius(Axis::X, p.x), p.y, p.z];
        point[axis] = p.nominal;
        let cycle = profile.probe.cycle_name();
        let probe = &profile.probe;
        AuditSettings {
            clearance: p.in_radius(p.retract_axis, p.clearance),
            retract_axis: p.retract_axis.number() as usize - 1,
            probe_tool: (probe.kind == ProbeKind::SpindleProbe && !probe.tool.is_empty())
                .then(|| probe.tool.clone()),
            probe_point: (probe.kind != ProbeKind::Gauge).then_some(point),
            probe_point_in_machine: p.frame == MeasureFrame::Machine,
            reference_start: (p.frame == MeasureFrame::Machine && probe.kind != ProbeKind::Gauge)
                .then(|| {
                    profile
                        .measured()
                        .iter()
                        .map(|at| at.start_in_radius(p.retract_axis))
                        .fold(f64::NEG_INFINITY, f64::max)
                }),
            nominal: p.nominal,
            diameter: p.diameter,
            axis,
            also: p
                .also
                .iter()
                .map(|a| (a.axis.number() as usize - 1, a.nominal))
                .collect(),
            probe_axis_arg,
            method: profile.offset.method,
            frame: profile.offset.frame as usize,
            reset_selects: profile.offset.reset_selects,
            probe_cycle: cycle.to_ascii_uppercase(),
            probe_result: ProbeTarget::parse(&probe.result),
            tool_change_on_t: probe.tool_change == ToolChange::T,
            tool_change_m: probe.tool_change_m,
            tool_change_calls: profile
                .calls
                .iter()
                .filter_map(|(name, c)| {
                    let arg = match c.loads? {
                        Loads::Preselected => None,
                        Loads::Arg(n) => Some(n - 1),
                    };
                    Some((name.to_ascii_uppercase(), arg))
                })
                .collect(),
            tool_alarm: crate::omm::plan::reads_tool(profile)
                .then_some(profile.registers.alarm_tool),
            machine_coolant: profile.coolant.clone(),
            tolerance_um: profile.limits.tolerance_um,
            plausibility_um: profile.limits.plausibility_um,
            probe_margin_mm: DEFAULT_PROBE_MARGIN_MM,
            spindle_probe: probe.kind == ProbeKind::SpindleProbe,
            machine: MachineSpec::default(),
            seed: 1,
            original_name: "original".into(),
            transformed_name: "transformed".into(),
            dir: None,
        }
    }

    /// The machine drifts along the measured axis as `model` predicts for the program's own spindle
    /// schedule, so the probe sees what the program's predictions expect and the clean run does not abort
    /// as scrap. A model that takes other inputs (ambient temperature, sensors) needs their signals: give a
    /// machine file instead.
    pub fn drifting_as(self, model: &DriftModel) -> Result<AuditSettings, String> {
        self.drifting_as_axes(&[model])
    }

    /// [`AuditSettings::drifting_as`] with one model per measured axis (`[position]`'s, then `also`'s).
    pub fn drifting_as_axes(mut self, models: &[&DriftModel]) -> Result<AuditSettings, String> {
        for (axis, model) in self.corrected().into_iter().zip(models) {
            let truth = ModelDrift::new((*model).clone(), 1.0, &BTreeMap::new())?;
            self.machine
                .models
                .insert(["X", "Y", "Z"][axis].to_string(), truth);
        }
        Ok(self)
    }

    /// Work offsets for a dry run that must not start at 0, where every position in work coordinates is
    /// one in machine coordinates and a mix-up of the two never shows: every settable offset
    /// (`$P_UIFR[0…99]`, G500 included) at X120 Y80 Z-450, but on the retract axis of a gate measuring at a
    /// reference in machine coordinates where it finds it worst: the clearance height
    /// [`REFERENCE_MARGIN_MM`] below the reference's start point. For `Config::offsets`.
    pub fn shifted_offsets(&self) -> Vec<(usize, String, f64)> {
        let mut shift = SHIFT;
        if let Some(start) = self.reference_start {
            shift[self.retract_axis] = start - REFERENCE_MARGIN_MM - self.clearance;
        }
        (0..super::motion::FRAMES)
            .flat_map(|frame| {
                ["X", "Y", "Z"]
                    .iter()
                    .zip(shift)
                    .map(move |(axis, mm)| (frame, axis.to_string(), mm))
            })
            .collect()
    }

    /// The measured and corrected axes (0, 1, 2): `position.axis` first.
    pub fn corrected(&self) -> Vec<usize> {
        std::iter::once(self.axis)
            .chain(self.also.iter().map(|a| a.0))
            .collect()
    }

    /// The interpreter settings for both runs: `cfg` with the profile's probe cycle, result, probed surface
    /// (the nominal) and tool change, no trace and no passes.
    pub fn vm_config(&self, cfg: &Config) -> Config {
        let mut cfg = cfg.clone();
        cfg.trace = false;
        cfg.passes = false;
        // Both runs skip a cycle neither can find alike: what the inserted blocks do is still compared.
        cfg.skip_missing_calls = true;
        if !cfg.probe_cycles.contains(&self.probe_cycle) {
            cfg.probe_cycles.push(self.probe_cycle.clone());
        }
        if let Some(target) = &self.probe_result {
            cfg.probe_result = target.clone();
        }
        let axis = ["X", "Y", "Z"][self.axis];
        cfg.probe_axis = axis.to_string();
        cfg.tool_change_on_t = self.tool_change_on_t;
        cfg.tool_change_m = self.tool_change_m;
        cfg.tool_change_calls
            .extend(self.tool_change_calls.iter().map(|(k, v)| (k.clone(), *v)));
        cfg.machine_coolant = self.machine_coolant.clone();
        if self.reset_selects {
            cfg.reset_frame = self.frame;
        }
        // The probed surface where the profile says it is: the nominal, in machine coordinates or in those of
        // the work offset in force at the zero (which the program may have built itself before it).
        cfg.probe_machine_frame = self.probe_point_in_machine;
        cfg.probe_surface_at_first_probing = !self.probe_point_in_machine;
        cfg.probe_diameter = self.diameter;
        cfg.probe_surface_mm = self.nominal;
        for &(a, nominal) in &self.also {
            cfg.probe_surfaces
                .insert(["X", "Y", "Z"][a].to_string(), nominal);
        }
        if !self.also.is_empty() {
            cfg.probe_axis_arg = self.probe_axis_arg;
        }
        cfg.subprogram_dirs.splice(0..0, self.dir.iter().cloned());
        cfg
    }
}

/// What a finding is about. The names (kebab-case) are stable: scripts and the transform key on them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    /// Travel across the tool axis in inserted blocks below the clearance height (X/Y below Z on a milling
    /// machine), or a move out of the probe point that is not straight up the tool axis.
    XyBelowClearance,
    /// Spindle tool, preselected tool or D number differ where the original resumes; a tool other than the
    /// original's in the spindle at the end.
    ToolState,
    /// Probing, STOPRE or a work-offset write under a rotation/scale/mirror frame, a swivel, a kinematic
    /// transformation or cutter radius compensation.
    MeasureUnderTransform,
    /// Modal state differs where the original resumes (beyond the one corrected offset entry).
    ModalNotRestored,
    /// The programmed position of an axis the original has programmed differs where it resumes.
    PositionNotRestored,
    /// STOPRE inserted between two feed moves of a continuous-path contour.
    StopreInContour,
    /// The corrected persistent work offset is not back at its value when an inserted stop or alarm ends the
    /// program, or at the end.
    OffsetLeftOnAbort,
    /// A probe value that is NaN or orders of magnitude off reaches the work offset: the abort path the
    /// plausibility check should take is not taken.
    FaultReachesOffset,
    /// The original's cutting moves, or the region a Siemens milling cycle of it machines, pass the probe
    /// point: the probe would touch machined material.
    ProbeInMachinedVolume,
    /// A Siemens milling cycle of the original machines a region the audit cannot know (a contour, an
    /// argument it cannot evaluate): the probe point is not checked against it.
    MachinedVolumeUnknown,
    /// The original's blocks run in another order in the transformed program.
    FlowChanged,
    /// A line of the original is not in the transformed program as it was.
    OriginalChanged,
    /// Inserted blocks run where the original's modal motion is thread cutting or tapping (G33, G34, G35,
    /// G331, G332, G63): between a tapping-in and its tapping-out, inside a chained thread.
    GateInThread,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::XyBelowClearance => "xy-below-clearance",
            Kind::ToolState => "tool-state",
            Kind::MeasureUnderTransform => "measure-under-transform",
            Kind::ModalNotRestored => "modal-not-restored",
            Kind::PositionNotRestored => "position-not-restored",
            Kind::StopreInContour => "stopre-in-contour",
            Kind::OffsetLeftOnAbort => "offset-left-on-abort",
            Kind::FaultReachesOffset => "fault-reaches-offset",
            Kind::ProbeInMachinedVolume => "probe-in-machined-volume",
            Kind::MachinedVolumeUnknown => "machined-volume-unknown",
            Kind::FlowChanged => "flow-changed",
            Kind::OriginalChanged => "original-changed",
            Kind::GateInThread => "gate-in-thread",
        }
    }
}

impl Kind {
    /// Whether the finding is about where the profile puts the probe point relative to what the original
    /// machines — the user's choice, warned of — rather than a hazard the inserted blocks caused.
    pub fn is_probe_point_warning(self) -> bool {
        matches!(
            self,
            Kind::ProbeInMachinedVolume | Kind::MachinedVolumeUnknown
        )
    }
}

/// One hazard, at a line of the transformed program.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    pub kind: Kind,
    /// 1-based line of the transformed program (of `file` when the block is in a subprogram).
    pub line: usize,
    pub message: String,
    /// The line of the original program it corresponds to, where there is one.
    pub original_line: Option<usize>,
    /// The subprogram file, when the block is not in the transformed program itself.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// How often the run met it (a gate in a loop meets it on every pass); reported once.
    pub times: usize,
}

impl Finding {
    /// Where it is, for a message about the program the audit was given: `line N` of the original where
    /// the block is one, else `line N of the output`; in a subprogram, that file's line.
    pub fn place(&self) -> String {
        match (&self.file, self.original_line) {
            (Some(file), _) => format!("{file} line {}", self.line),
            (None, Some(line)) => format!("line {line}"),
            (None, None) => format!("line {} of the output", self.line),
        }
    }
}

/// The audit's result.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Audit {
    /// In the order the runs met them.
    pub findings: Vec<Finding>,
    /// Findings per kind.
    pub counts: BTreeMap<&'static str, usize>,
    pub original_blocks: u64,
    pub transformed_blocks: u64,
    /// Points where the original resumed after inserted blocks.
    pub resume_points: u64,
    /// Abort paths followed with a faulty probe, and how many of them reached an abort.
    pub abort_runs: u64,
    pub aborts_reached: u64,
    /// Why the comparison ended before both programs did (an alarm of the transformed program's own).
    pub stopped: Option<String>,
    /// What the dry run took without knowing it (values read as 0, synchronized actions not run): the
    /// audit holds only as far as these hold.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

impl Audit {
    /// Records a finding, or counts it again when the same kind was found at the same line before.
    fn add(&mut self, finding: Finding) {
        let seen = self
            .findings
            .iter_mut()
            .find(|f| f.kind == finding.kind && f.line == finding.line && f.file == finding.file);
        match seen {
            Some(f) => f.times += 1,
            None => {
                *self.counts.entry(finding.kind.name()).or_default() += 1;
                self.findings.push(finding);
            }
        }
    }
}

/// Audits `transformed` against `original` (which must be `transformed` without its `;DL` lines, or an
/// `original-changed` finding says where it is not). Both run on `cfg` (with the profile's probe cycle and
/// result, see [`AuditSettings::vm_config`]) against the settings' machine. An error is a construct the
/// virtual machine cannot run; its message names the program and line.
pub fn audit(
    original: &[u8],
    transformed: &[u8],
    settings: &AuditSettings,
    cfg: &Config,
) -> Result<Audit, VmError> {
    audit_owned(original.to_vec(), transformed.to_vec(), settings, cfg)
}

/// [`audit`] taking the programs' bytes over, so a large program is not held twice.
pub fn audit_owned(
    original: Vec<u8>,
    transformed: Vec<u8>,
    settings: &AuditSettings,
    cfg: &Config,
) -> Result<Audit, VmError> {
    lockstep::run(original, transformed, settings, &settings.vm_config(cfg))
}
