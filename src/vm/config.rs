//! Interpreter settings and the machine file (`--machine truth.toml`).
//!
//! ```toml
//! [timing]
//! rapid_mm_min = 10000      # G0 path speed
//! tool_change_s = 6         # per M6
//! stop_s = 0                # operator time at M0 / M1
//! [probe]
//! cycles = ["BL9700", "CYCLE978"]
//! result = 2                # R[02] receives the measured position
//! axis = "Z"
//! surface_mm = 0.0          # machine coordinate of the probed surface
//! machine_frame = false     # true: the cycle reports machine coordinates (a reference on the table)
//! diameter = false          # true: the cycle reports a diameter (twice the drift)
//! noise_um = 0.5
//! faults = [{ call = 3, kind = "nan" }]
//! [corrections]
//! include_trans = false     # true: TRANS/ATRANS count as corrections, not as programmed geometry
//! [offsets]                 # settable work offsets at program start, $P_UIFR[n]
//! G54 = { Z = -120.0 }
//! [models]                  # truth: a driftloop model file per axis (path relative to this file)
//! Z = { file = "truth.toml", scale = 1.0 }
//! [signals.ambient_c]       # a model input over time, [minutes, value]; `input = 1`: $A_INA[1] reads it
//! input = 1
//! points = [[0, 20.0], [240, 23.5]]
//! [machine_data]            # MD32750 per axis (not listed: 1, on) and SD43900 at the start (mm)
//! temp_comp_type = { Z = 1 }
//! temp_comp_abs_value = { Z = 0.0 }
//! sumcorr_default = 0       # MD20272: the sum offset DL a new cutting edge D brings (0: none)
//! tool_change_m_code = 6    # MD22560: the M-code that loads the preselected tool
//! [variables]               # values the dry run cannot know: tool data, inputs, outputs, machine data,
//! "$TC_DP3[1,1]" = 120.5    # the measuring cycles' results; a read of one not listed is 0, with a note
//! "$A_IN[1]" = 1
//! "_OVR[16]" = 0.02
//! [tool]                    # the tool in force at the start (loaded by hand or in MDA): its T number
//! number = 3                # ($P_TOOLNO), with tool management its name ($TC_TP2[3]; T="EM_D10" or
//! name = "EM_D10"           # T=3 select it), and the cutting edge ($P_TOOL); without: no tool, D0
//! d = 1
//! [drift]                   # plus piecewise-linear drift per axis, [minutes, µm] points: effects the
//! Z = [[0, 0], [240, -3]]   # model does not declare, or the whole truth when there is no model
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use super::machine::{ProbeFault, SimpleMachine, piecewise_linear};
use super::motion::Tool;
use super::truth::ModelDrift;

/// How many R-parameters the control has (R0 … R999).
pub const R_COUNT: usize = 1000;

/// What the interpreter needs to know about the machine and the run.
#[derive(Debug, Clone)]
pub struct Config {
    /// Axis names, upper case. Names of one letter plus digits that are not listed are not axes.
    pub axes: Vec<String>,
    /// Machine axis names (MD10000), upper case, and the channel axis each moves: a program names one to
    /// move that axis in machine coordinates (`G74 X1=0 Z1=0`, a transfer to a counter spindle). `None`:
    /// each channel axis's name with 1 appended (X1, Y1, Z1 …), the names the Programming Manual's
    /// examples use.
    pub machine_axes: Option<BTreeMap<String, String>>,
    pub rapid_mm_min: f64,
    pub tool_change_min: f64,
    /// Time the operator takes to restart after M0 / M1.
    pub stop_min: f64,
    /// Feed used when a feed move has none programmed; `None`: such a move is an error (alarm 10860).
    pub default_feed_mm_min: Option<f64>,
    /// Upper-cased names of the probe cycles.
    pub probe_cycles: Vec<String>,
    /// Where the probe cycle leaves its result: an R parameter, or an element of a global array such as the
    /// measuring cycles' `_OVR[4]` (created as a REAL array when the program starts).
    pub probe_result: ProbeTarget,
    pub probe_axis: String,
    /// Machine coordinate of the surface the probe touches.
    pub probe_surface_mm: f64,
    /// The probe cycle's argument (0-based) that names the measured axis (1, 2, 3 for X, Y, Z), as
    /// driftloop's `{axis}` placeholder does: a program that measures several axes says which at each call.
    pub probe_axis_arg: Option<usize>,
    /// Run on past a call of a subprogram or cycle that is not found (a manufacturer's cycle, a folder not
    /// given) as if it did nothing, with a message, instead of stopping: the audit compares two runs that
    /// skip it alike.
    pub skip_missing_calls: bool,
    /// Machine coordinate of the surface probed along each axis other than `probe_axis`.
    pub probe_surfaces: std::collections::BTreeMap<String, f64>,
    /// The cycle reports machine coordinates (a reference fixed on the table), not work coordinates.
    pub probe_machine_frame: bool,
    /// The surfaces are given in work coordinates, and the part lies where the work offset in force at the
    /// first probing of each axis puts them (the zero defines where the part is): a program may build its
    /// own offsets before the zero, which no offsets known at the start would follow.
    pub probe_surface_at_first_probing: bool,
    /// The cycle reports a diameter: the surface is a diameter and the drift counts twice.
    pub probe_diameter: bool,
    /// Time one probe cycle takes.
    pub probe_min: f64,
    /// Settable work offsets at the start, `(frame number, axis, value)`: G54 is frame 1.
    pub offsets: Vec<(usize, String, f64)>,
    /// Count TRANS / ATRANS as corrections in the machined error (default: only `$P_UIFR` changes are).
    pub trans_is_correction: bool,
    /// The settable frame selected at the start (0: G500), as the control's reset selects it (MD20150).
    pub reset_frame: usize,
    /// Folders searched for subprograms after the calling program's own folder.
    pub subprogram_dirs: Vec<std::path::PathBuf>,
    /// Executed blocks beyond the main program's own block count after which the run stops with an error
    /// (endless loops); a straight program of any length runs through.
    pub max_blocks: u64,
    /// The machine's own coolant M-codes (through-spindle coolant, air), followed like M7/M8 (an audit takes
    /// them from the profile's `[coolant]`).
    pub machine_coolant: crate::omm::machine_coolant::MachineCoolant,
    /// Keep a trace row per executed block.
    pub trace: bool,
    /// Work out the passes and their machined error (the drift at every cutting move); off, a run only
    /// follows the control's state (the audit).
    pub passes: bool,
    /// `T` loads the tool at once (turrets; TOOL_CHANGE_MODE 0) instead of preselecting it for `M6`.
    pub tool_change_on_t: bool,
    /// The M-code that loads the preselected tool (MD22560 `$MC_TOOL_CHANGE_M_CODE`; an audit takes it
    /// from the profile's `probe.tool_change_m`).
    pub tool_change_m: u32,
    /// Calls a machine profile declares to change tools (`[calls.NAME] loads`), by upper-cased name: `None`
    /// loads the preselected tool, `Some(k)` the tool in argument k (0-based). A subprogram of that name the
    /// run finds runs instead, as the transform reads it.
    pub tool_change_calls: BTreeMap<String, Option<usize>>,
    /// MD32750 `$MA_TEMP_COMP_TYPE` per upper-cased axis; an axis not listed has 1 (position-independent
    /// temperature compensation on), so SD43900 acts.
    pub temp_comp_type: BTreeMap<String, u32>,
    /// SD43900 `$SA_TEMP_COMP_ABS_VALUE` per upper-cased axis at the start (mm; not listed: 0). The drift is
    /// counted from the start, so only a change of the value moves the tool.
    pub temp_comp_start: BTreeMap<String, f64>,
    /// The control's clock at the start (`$A_YEAR` … `$A_SECOND`), minutes since 1970-01-01 00:00.
    pub clock_start_min: f64,
    /// R-parameters at the start (retentive on the control: what the last job left); empty: all 0.
    pub r_initial: Vec<f64>,
    /// MD20272 `$MC_SUMCORR_DEFAULT`: the sum offset (DL number) a newly selected cutting edge brings.
    pub sumcorr_default: f64,
    /// Values of variables the dry run cannot know (tool data `$TC_…`, inputs `$A_IN[n]`, outputs, machine
    /// data, the measuring cycles' results `_OVR[n]`), by their name and index as written upper-cased:
    /// `$TC_DP3[1,1]`, `$AC_TIME`.
    pub variables: BTreeMap<String, f64>,
    /// The tool in force when the program starts; `None`: no tool, D0.
    pub start_tool: Option<StartTool>,
    /// The spindle turning when the program starts (started in MDA); `None`: it stands.
    pub start_spindle: Option<StartSpindle>,
}

/// A spindle the program finds turning, started by the operator before it (MDA): a program that cuts
/// with it before its own M3/M4 must find it turning after every gate too.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpindle {
    pub rpm: f64,
    /// 3 (M3, clockwise) or 4 (M4).
    #[serde(default = "clockwise")]
    pub direction: u32,
}

fn clockwise() -> u32 {
    3
}

/// A tool the program finds in force (loaded by hand or in MDA), the one tool of the dry run's tool table:
/// its T number and its name select it alike, and `$P_TOOLNO` of either is the number.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartTool {
    pub number: f64,
    #[serde(default)]
    pub name: Option<String>,
    #[serde(default = "one")]
    pub d: f64,
}

impl StartTool {
    /// The tool as the program selects it: by its name where it has one.
    pub fn tool(&self) -> Tool {
        match &self.name {
            Some(name) => Tool::Name(name.as_str().into()),
            None => Tool::Number(self.number),
        }
    }

    fn is(&self, t: &Tool) -> bool {
        match t {
            Tool::Number(n) => *n == self.number,
            Tool::Name(name) => self.name.as_deref() == Some(&**name),
        }
    }
}

impl Config {
    /// The channel axis (its index in `axes`) that machine axis `name` (upper case) moves.
    pub fn machine_axis(&self, name: &str) -> Option<usize> {
        let channel = match &self.machine_axes {
            Some(names) => names.get(name)?.as_str(),
            None => name.strip_suffix('1')?,
        };
        self.axes.iter().position(|a| a == channel)
    }

    /// The start tool as [`StartTool::tool`] where `t` selects it (by number or by name), else `t`.
    pub fn known_tool(&self, t: Tool) -> Tool {
        match &self.start_tool {
            Some(s) if s.is(&t) => s.tool(),
            _ => t,
        }
    }

    /// `$P_TOOLNO` of `t`: the start tool's number also where it was selected by name.
    pub fn tool_number(&self, t: &Tool) -> f64 {
        match &self.start_tool {
            Some(s) if s.is(t) => s.number,
            _ => t.number(),
        }
    }

    /// `$TC_TP2[number]`: the name of the tool of that T number, where the dry run knows one.
    pub fn tool_name(&self, number: f64) -> Option<&str> {
        self.start_tool
            .as_ref()
            .filter(|s| s.number == number)
            .and_then(|s| s.name.as_deref())
    }

    /// MD32750 of `axis`.
    pub fn temp_comp_type(&self, axis: &str) -> u32 {
        self.temp_comp_type.get(axis).copied().unwrap_or(1)
    }
}

impl Default for Config {
    fn default() -> Self {
        Config {
            axes: ["X", "Y", "Z", "A", "B", "C"].map(String::from).to_vec(),
            machine_axes: None,
            rapid_mm_min: 10_000.0,
            tool_change_min: 0.1,
            stop_min: 0.0,
            default_feed_mm_min: None,
            probe_cycles: vec!["BL9700".into(), "CYCLE978".into()],
            probe_result: ProbeTarget::R(2),
            probe_axis: "Z".into(),
            probe_surface_mm: 0.0,
            probe_axis_arg: None,
            skip_missing_calls: false,
            probe_surfaces: std::collections::BTreeMap::new(),
            probe_machine_frame: false,
            probe_surface_at_first_probing: false,
            probe_diameter: false,
            probe_min: 0.05,
            offsets: Vec::new(),
            subprogram_dirs: Vec::new(),
            trans_is_correction: false,
            reset_frame: 0,
            max_blocks: 1_000_000,
            trace: true,
            passes: true,
            tool_change_on_t: false,
            tool_change_m: 6,
            tool_change_calls: BTreeMap::new(),
            machine_coolant: Default::default(),
            temp_comp_type: BTreeMap::new(),
            temp_comp_start: BTreeMap::new(),
            // Monday 2025-01-06 06:00.
            clock_start_min: 20_094.0 * 1440.0 + 360.0,
            r_initial: Vec::new(),
            sumcorr_default: 0.0,
            variables: BTreeMap::new(),
            start_tool: None,
            start_spindle: None,
        }
    }
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct MachineFile {
    #[serde(default)]
    timing: Timing,
    #[serde(default)]
    probe: Probe,
    #[serde(default)]
    offsets: BTreeMap<String, BTreeMap<String, f64>>,
    #[serde(default)]
    drift: BTreeMap<String, Vec<[f64; 2]>>,
    #[serde(default)]
    models: BTreeMap<String, ModelRef>,
    #[serde(default)]
    corrections: Corrections,
    #[serde(default)]
    signals: BTreeMap<String, SignalSpec>,
    #[serde(default)]
    machine_data: MachineData,
    #[serde(default)]
    variables: BTreeMap<String, f64>,
    tool: Option<StartTool>,
    spindle: Option<StartSpindle>,
    axes: Option<Vec<String>>,
    machine_axes: Option<BTreeMap<String, String>>,
}

/// Machine and setting data the program reads, per axis.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct MachineData {
    /// MD32750 `$MA_TEMP_COMP_TYPE`.
    #[serde(default)]
    temp_comp_type: BTreeMap<String, u32>,
    /// SD43900 `$SA_TEMP_COMP_ABS_VALUE` at the start (mm).
    #[serde(default)]
    temp_comp_abs_value: BTreeMap<String, f64>,
    /// MD20272 `$MC_SUMCORR_DEFAULT`.
    sumcorr_default: Option<f64>,
    /// MD22560 `$MC_TOOL_CHANGE_M_CODE`.
    tool_change_m_code: Option<u32>,
}

/// A measured quantity over time (ambient temperature …): feeds a truth model's declared input of the same
/// name and, with `input = n`, is readable by the program as `$A_INA[n]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SignalSpec {
    input: Option<usize>,
    points: Vec<[f64; 2]>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct Corrections {
    /// TRANS / ATRANS count as corrections (the program corrects through a programmable frame).
    #[serde(default)]
    include_trans: bool,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelRef {
    file: String,
    #[serde(default = "one")]
    scale: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct Timing {
    rapid_mm_min: Option<f64>,
    tool_change_s: Option<f64>,
    stop_s: Option<f64>,
    probe_s: Option<f64>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct Probe {
    cycles: Option<Vec<String>>,
    result: Option<ResultSpec>,
    axis: Option<String>,
    surface_mm: Option<f64>,
    /// 1-based position of the argument naming the axis; `surfaces`: the surface per further axis.
    axis_arg: Option<usize>,
    #[serde(default)]
    surfaces: BTreeMap<String, f64>,
    machine_frame: Option<bool>,
    diameter: Option<bool>,
    noise_um: Option<f64>,
    #[serde(default)]
    faults: Vec<Fault>,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum ResultSpec {
    Number(usize),
    Name(String),
}

/// Where a probe result goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ProbeTarget {
    R(usize),
    /// A global REAL array element, `_OVR[4]`.
    Array(String, usize),
}

impl ProbeTarget {
    /// `R2`, `R[02]`, `_OVR[4]` (case-insensitive).
    pub fn parse(text: &str) -> Option<ProbeTarget> {
        let t = text.trim().to_ascii_uppercase();
        let (name, index) = match t.split_once('[') {
            Some((name, rest)) => (
                name.to_string(),
                rest.strip_suffix(']')?.trim().parse().ok()?,
            ),
            None if t.starts_with('R') => return t[1..].parse().ok().map(ProbeTarget::R),
            None => return None,
        };
        match name.as_str() {
            "R" => Some(ProbeTarget::R(index)),
            "" => None,
            _ => Some(ProbeTarget::Array(name, index)),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Fault {
    call: usize,
    kind: ProbeFault,
}

/// A parsed machine file: settings for the interpreter and the parts a [`SimpleMachine`] is built from.
#[derive(Debug, Clone, Default)]
pub struct MachineSpec {
    pub noise_um: f64,
    pub faults: Vec<(usize, ProbeFault)>,
    /// Piecewise-linear drift per upper-cased axis: `(minutes, µm)` points in time order.
    pub drift: BTreeMap<String, Vec<(f64, f64)>>,
    /// Model-driven drift per upper-cased axis (added to the piecewise-linear part).
    pub models: BTreeMap<String, ModelDrift>,
    /// Analog inputs: number → `(minutes, value)` points.
    pub analog: Vec<(usize, Vec<(f64, f64)>)>,
}

impl MachineSpec {
    /// The machine: the model's drift for the spindle history plus the points interpolated linearly (held flat
    /// outside them), probe noise from `seed`.
    pub fn build(&self, seed: u64) -> SimpleMachine {
        let table = self.drift.clone();
        let models = self.models.clone();
        let mut m = SimpleMachine::with_drift(move |axis, t, spindle| {
            let axis = axis.to_ascii_uppercase();
            let listed = table.get(&axis).map_or(0.0, |pts| piecewise_linear(pts, t));
            listed + models.get(&axis).map_or(0.0, |m| m.at(t, spindle))
        })
        .noise(self.noise_um, seed);
        for &(call, kind) in &self.faults {
            m = m.fault(call, kind);
        }
        for (n, points) in &self.analog {
            m = m.analog(*n, points.clone());
        }
        m
    }
}

/// Reads a machine file into interpreter settings (starting from `base`) and a machine spec; model files are
/// found relative to `dir`.
pub fn parse_machine_file(
    text: &str,
    dir: &Path,
    base: Config,
) -> Result<(Config, MachineSpec), String> {
    let file: MachineFile = toml::from_str(text).map_err(|e| e.to_string())?;
    let mut cfg = base;
    let t = file.timing;
    cfg.rapid_mm_min = positive(t.rapid_mm_min, cfg.rapid_mm_min, "timing.rapid_mm_min")?;
    cfg.tool_change_min = t.tool_change_s.map_or(cfg.tool_change_min, |s| s / 60.0);
    cfg.stop_min = t.stop_s.map_or(cfg.stop_min, |s| s / 60.0);
    cfg.probe_min = t.probe_s.map_or(cfg.probe_min, |s| s / 60.0);
    let p = file.probe;
    if let Some(c) = p.cycles {
        cfg.probe_cycles = c.iter().map(|c| c.to_ascii_uppercase()).collect();
    }
    if let Some(result) = p.result {
        cfg.probe_result = match result {
            ResultSpec::Number(n) => ProbeTarget::R(n),
            ResultSpec::Name(name) => ProbeTarget::parse(&name).ok_or_else(|| {
                format!("probe.result: `{name}` is neither R<n>, R[<n>] nor NAME[<n>]")
            })?,
        };
    }
    cfg.probe_axis = p.axis.map_or(cfg.probe_axis, |a| a.to_ascii_uppercase());
    cfg.probe_surface_mm = p.surface_mm.unwrap_or(cfg.probe_surface_mm);
    if let Some(n) = p.axis_arg {
        cfg.probe_axis_arg = Some(n.checked_sub(1).ok_or("probe.axis_arg counts from 1")?);
    }
    for (axis, mm) in p.surfaces {
        cfg.probe_surfaces.insert(axis.to_ascii_uppercase(), mm);
    }
    cfg.probe_machine_frame = p.machine_frame.unwrap_or(cfg.probe_machine_frame);
    cfg.probe_diameter = p.diameter.unwrap_or(cfg.probe_diameter);
    cfg.trans_is_correction = file.corrections.include_trans;
    for (axis, t) in file.machine_data.temp_comp_type {
        cfg.temp_comp_type.insert(axis.to_ascii_uppercase(), t);
    }
    for (axis, mm) in file.machine_data.temp_comp_abs_value {
        if !mm.is_finite() {
            return Err(format!(
                "machine_data.temp_comp_abs_value.{axis} must be a number"
            ));
        }
        cfg.temp_comp_start.insert(axis.to_ascii_uppercase(), mm);
    }
    if let Some(dl) = file.machine_data.sumcorr_default {
        if dl < 0.0 || dl.fract() != 0.0 {
            return Err("machine_data.sumcorr_default must be a DL number ≥ 0".into());
        }
        cfg.sumcorr_default = dl;
    }
    if let Some(m) = file.machine_data.tool_change_m_code {
        if let Some(fault) = crate::omm::machine_coolant::tool_change_m_fault(m) {
            return Err(format!("machine_data.tool_change_m_code: {fault}"));
        }
        cfg.tool_change_m = m;
    }
    for (name, v) in file.variables {
        // `R10 = 1`: an R-parameter the program starts with (retentive on the control: what the operator
        // or an earlier program left).
        let upper = name.trim().to_ascii_uppercase();
        if let Some(n) = upper
            .strip_prefix('R')
            .and_then(|n| n.parse::<usize>().ok())
        {
            if n >= R_COUNT {
                return Err(format!("variables: {upper} is beyond R{}", R_COUNT - 1));
            }
            if cfg.r_initial.len() <= n {
                cfg.r_initial.resize(n + 1, 0.0);
            }
            cfg.r_initial[n] = v;
            continue;
        }
        let key = variable_key(&name)
            .ok_or_else(|| format!("variables: `{name}` is not NAME or NAME[i, …]"))?;
        cfg.variables.insert(key, v);
    }
    if let Some(axes) = file.axes {
        cfg.axes = axes.iter().map(|a| a.to_ascii_uppercase()).collect();
    }
    if let Some(names) = file.machine_axes {
        let mut upper = BTreeMap::new();
        for (name, channel) in names {
            let channel = channel.to_ascii_uppercase();
            if !cfg.axes.contains(&channel) {
                return Err(format!(
                    "machine_axes.{name}: `{channel}` is not one of the axes {:?}",
                    cfg.axes
                ));
            }
            upper.insert(name.to_ascii_uppercase(), channel);
        }
        cfg.machine_axes = Some(upper);
    }
    if let Some(tool) = file.tool {
        let whole = |v: f64| v >= 1.0 && v.fract() == 0.0;
        if !whole(tool.number) || !whole(tool.d) {
            return Err("tool.number and tool.d must be whole numbers ≥ 1".into());
        }
        cfg.start_tool = Some(tool);
    }
    if let Some(spindle) = file.spindle {
        if !(spindle.rpm > 0.0 && spindle.rpm.is_finite() && matches!(spindle.direction, 3 | 4)) {
            return Err(
                "spindle.rpm must be a speed > 0 and spindle.direction 3 (M3) or 4 (M4)".into(),
            );
        }
        cfg.start_spindle = Some(spindle);
    }
    for (g, values) in &file.offsets {
        let frame = offset_frame(g).ok_or_else(|| {
            format!("offsets: `{g}` is not a settable work offset (G54…G57, G505…G599)")
        })?;
        for (axis, v) in values {
            cfg.offsets.push((frame, axis.to_ascii_uppercase(), *v));
        }
    }
    let mut drift = BTreeMap::new();
    for (axis, pts) in file.drift {
        let pts: Vec<(f64, f64)> = pts.iter().map(|p| (p[0], p[1])).collect();
        if pts.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(format!("drift.{axis}: times must increase"));
        }
        drift.insert(axis.to_ascii_uppercase(), pts);
    }
    let mut signals = BTreeMap::new();
    let mut analog = Vec::new();
    for (name, sig) in file.signals {
        let pts: Vec<(f64, f64)> = sig.points.iter().map(|p| (p[0], p[1])).collect();
        if pts.is_empty() || pts.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(format!("signals.{name}: points needed, times increasing"));
        }
        if let Some(n) = sig.input {
            analog.push((n, pts.clone()));
        }
        signals.insert(name.to_ascii_lowercase(), pts);
    }
    let mut models = BTreeMap::new();
    for (axis, m) in file.models {
        let model =
            crate::model::DriftModel::read(&dir.join(&m.file)).map_err(|e| e.to_string())?;
        let truth =
            ModelDrift::new(model, m.scale, &signals).map_err(|e| format!("models.{axis}: {e}"))?;
        models.insert(axis.to_ascii_uppercase(), truth);
    }
    let spec = MachineSpec {
        noise_um: p.noise_um.unwrap_or(0.0),
        faults: p.faults.iter().map(|f| (f.call, f.kind)).collect(),
        drift,
        models,
        analog,
    };
    Ok((cfg, spec))
}

fn positive(v: Option<f64>, default: f64, name: &str) -> Result<f64, String> {
    match v {
        Some(x) if x <= 0.0 || !x.is_finite() => Err(format!("{name} must be positive")),
        Some(x) => Ok(x),
        None => Ok(default),
    }
}

/// How `[variables]` and the dry run name a variable: upper case, no spaces, each numeric index as the
/// shortest number (`$tc_dp3[ 1, 01 ]` → `$TC_DP3[1,1]`, `$MA_JOG_VELO[x]` → `$MA_JOG_VELO[X]`).
pub fn variable_key(name: &str) -> Option<String> {
    let name: String = name.chars().filter(|c| !c.is_whitespace()).collect();
    let (base, index) = match name.split_once('[') {
        Some((base, rest)) => (base, Some(rest.strip_suffix(']')?)),
        None => (name.as_str(), None),
    };
    let named = |t: &str| {
        t.chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || matches!(c, '$' | '_'))
            && t.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '$' | '_'))
    };
    if !named(base) {
        return None;
    }
    let mut key = base.to_ascii_uppercase();
    if let Some(index) = index {
        let parts: Option<Vec<String>> = index
            .split(',')
            .map(|p| match p.parse::<f64>() {
                Ok(v) => Some(super::value::format_number(v)),
                Err(_) => named(p).then(|| p.to_ascii_uppercase()),
            })
            .collect();
        key.push('[');
        key.push_str(&parts?.join(","));
        key.push(']');
    }
    Some(key)
}

/// `G54` → 1 … `G57` → 4, `G505` → 5 … `G599` → 99: the `$P_UIFR` number a G code selects.
pub fn offset_frame(g: &str) -> Option<usize> {
    let n: usize = g.strip_prefix(['G', 'g'])?.parse().ok()?;
    match n {
        54..=57 => Some(n - 53),
        505..=599 => Some(n - 500),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_builder_tool_change_code_is_machine_data() {
        let read = |m: &str| {
            let text = format!("[machine_data]\ntool_change_m_code = {m}\n");
            parse_machine_file(&text, Path::new("."), Config::default()).map(|(cfg, _)| cfg)
        };
        assert_eq!(Config::default().tool_change_m, 6);
        assert_eq!(read("16").unwrap().tool_change_m, 16);
        let err = read("9").unwrap_err();
        assert!(err.contains("M9 cannot be the tool change"), "{err}");
    }

    #[test]
    fn machine_file_sets_timing_probe_offsets_and_drift() {
        let text = r#"
[timing]
rapid_mm_min = 20000
tool_change_s = 12
[probe]
cycles = ["bl9700"]
result = 5
noise_um = 0.5
faults = [{ call = 2, kind = "garbage" }]
[offsets]
G54 = { z = -100.0 }
[drift]
z = [[0, 0], [100, -20]]
"#;
        let (cfg, spec) = parse_machine_file(text, Path::new("."), Config::default()).unwrap();
        assert_eq!(cfg.rapid_mm_min, 20000.0);
        assert!((cfg.tool_change_min - 0.2).abs() < 1e-12);
        assert_eq!(cfg.probe_cycles, vec!["BL9700"]);
        assert_eq!(cfg.probe_result, ProbeTarget::R(5));
        assert_eq!(cfg.offsets, vec![(1, "Z".to_string(), -100.0)]);
        assert_eq!(spec.faults, vec![(2, ProbeFault::Garbage)]);
        let mut m = spec.build(1);
        use crate::vm::machine::{Machine, SpindleHistory};
        let h = SpindleHistory::default();
        assert_eq!(m.drift_um("Z", 50.0, &h), -10.0);
        assert_eq!(m.drift_um("Z", 500.0, &h), -20.0);
        assert_eq!(m.drift_um("X", 50.0, &h), 0.0);
    }

    #[test]
    fn probe_targets() {
        assert_eq!(ProbeTarget::parse("R2"), Some(ProbeTarget::R(2)));
        assert_eq!(ProbeTarget::parse("r[02]"), Some(ProbeTarget::R(2)));
        assert_eq!(
            ProbeTarget::parse("_OVR[4]"),
            Some(ProbeTarget::Array("_OVR".into(), 4))
        );
        assert_eq!(ProbeTarget::parse("X"), None);
        let (cfg, _) = parse_machine_file(
            "[probe]\nresult = \"_OVR[4]\"",
            Path::new("."),
            Config::default(),
        )
        .unwrap();
        assert_eq!(cfg.probe_result, ProbeTarget::Array("_OVR".into(), 4));
    }

    #[test]
    fn machine_file_errors_name_the_field() {
        let e = parse_machine_file(
            "[offsets]\nG53 = { Z = 1.0 }",
            Path::new("."),
            Config::default(),
        )
        .unwrap_err();
        assert!(e.contains("G53"), "{e}");
        let e = parse_machine_file(
            "[timing]\nrapid_mm_min = 0",
            Path::new("."),
            Config::default(),
        )
        .unwrap_err();
        assert!(e.contains("rapid_mm_min"), "{e}");
        assert!(
            parse_machine_file("[timing]\nrapid = 1", Path::new("."), Config::default()).is_err()
        );
    }
}
