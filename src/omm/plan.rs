//! The measurement plan: the model's predicted drift along the timeline and the gates where the program
//! updates its own prediction, corrects, and — where the predicted change since the last measurement reached
//! δ' = r·Δ — measures. The reference measurement (the "zero") is taken before the first pass; the machine
//! is taken to start from rest there, as the model's runs do.

use std::collections::BTreeMap;
use std::sync::Arc;

use serde::Serialize;

use crate::model::effects::{Effect, Kind};
use crate::model::lag::step;
use crate::model::speed_grid::SpeedGrid;
use crate::model::{DriftModel, extrapolation_warning};

use super::loops::{Loop, site_runs};
use super::nc::number;
use super::profile::{Axis, MeasureFrame, OffsetMethod, Position, ProbeKind, Profile, UnknownTool};
use super::timeline::{self, LoopKind, Modal, Site, SiteKind, Timeline};

/// What a gate does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum GateKind {
    /// Stage 1 and 4: probe loaded, offset selected, the base surface measured: the zero.
    Reference,
    /// A pass starts: update, measure if the predicted change reached δ', correct.
    PassStart,
    /// An extra measuring cycle inside a long pass, at a retract.
    Extra,
    /// The spindle speed changes: update the prediction and the correction only.
    Update,
    /// Continuous compensation (`[continuous]`): update the prediction and the temperature compensation
    /// only, at a safe place between gates once the profile's interval has passed.
    Refresh,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Gate {
    pub number: usize,
    pub kind: GateKind,
    /// Block the gate is inserted before.
    pub block: usize,
    pub pass: usize,
    /// Planned time at the gate, measurements before it included (min from program start).
    pub time_min: f64,
    /// Spindle speed from the gate on (rpm).
    pub rpm: f64,
    /// Predicted drift relative to the zero (µm).
    pub predicted_um: f64,
    /// Whether the plan expects a measurement here (the program decides again with the real time).
    pub measure: bool,
    /// Whether the gate can measure at all (tool clear of the part, modal state restorable).
    pub can_measure: bool,
    /// Why it cannot, where it cannot: what `plan` tells the user beside the table.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cannot_measure: Option<String>,
    /// Whether the block after the gate changes the tool itself (no re-load needed).
    pub tool_change_follows: bool,
    /// How often the gate runs (more than once in the body of a counted loop); time and prediction above
    /// are those of the first run the plan keeps it for (for an extra measuring cycle, the first that
    /// measures).
    pub runs: usize,
    /// In how many of its runs the plan expects a measurement.
    pub measurements: usize,
    /// Minutes from the end of the last cut before the gate to the gate: the scrap decision judges the
    /// part by the drift at that cut, not by what the machine drifted since without cutting.
    pub idle_min: f64,
    /// The gate stands where the program cuts with the operator's spindle (`on_hand_spindle`): it
    /// measures only where that spindle stands at run time.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub hand_spindle: bool,
    #[serde(skip)]
    pub before: Modal,
}

impl Gate {
    /// The plan for the gate in words: "measure", "no measurement", "measure in 2 of 5 runs".
    pub fn planned(&self) -> String {
        match (self.measurements, self.runs) {
            (0, _) => "no measurement".into(),
            (_, 1) => "measure".into(),
            (m, n) => format!("measure in {m} of {n} runs"),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    pub working_limit_um: f64,
    pub gates: Vec<Gate>,
    pub measurements: usize,
    pub max_predicted_um: f64,
    /// Program time plus the planned measurements (min).
    pub total_min: f64,
    /// The program's loops and how often the plan counts each.
    pub loops: Vec<Loop>,
    /// False when a loop runs so often that the plan does not follow every run of its gates (their time
    /// is still counted).
    pub every_run_planned: bool,
    /// Stretches where the predicted change exceeds δ' (or Δ) with no place to measure in between.
    pub warnings: Vec<String>,
}

/// A lagged response to an analog input the control reads (`$A_INA[n]`): the model's `inputs` and its
/// `input_lag` effects, x ← g + (x − g)·e^(−Δt/τ) with g = gain·(u − u₀), u₀ the input at the zero.
#[derive(Debug, Clone, PartialEq)]
pub struct InputTerm {
    pub signal: String,
    /// Analog input number the profile maps the signal to.
    pub input: u32,
    pub tau_min: f64,
    pub gain_per_unit: f64,
}

/// An analog input acting without lag: gain·(u − u₀), u₀ the input at the zero. The model's `static_input`
/// terms and its `input_slope` terms at the measuring position (gain·p), summed per signal.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticTerm {
    pub signal: String,
    /// Analog input number the profile maps the signal to.
    pub input: u32,
    /// µm per unit of the input at the measuring position.
    pub gain_per_unit: f64,
}

/// The model's spindle modes and input lags at work: state, targets and the exact update.
#[derive(Debug, Clone)]
pub struct Predictor {
    grid: SpeedGrid,
    taus: Vec<f64>,
    gains: Vec<Vec<f64>>,
    x: Vec<f64>,
    target: Vec<f64>,
    inputs: Vec<InputTerm>,
    input_x: Vec<f64>,
    input_target: Vec<f64>,
    statics: Vec<StaticTerm>,
    static_du: Vec<f64>,
    trend_um_per_h: f64,
    elapsed_min: f64,
}

/// The coordinate of the measuring position on the axis a position column names: `x_mm`, `y_mm`, `z_mm`
/// (X, Y, Z). On the measured axis that is the base surface's nominal, on the others the probing start
/// point ([position] of the profile, work-offset coordinates).
fn measuring_coordinate(column: &str, at: &Position) -> Result<f64, String> {
    let axis = match column.strip_suffix("_mm") {
        Some("x") => Axis::X,
        Some("y") => Axis::Y,
        Some("z") => Axis::Z,
        _ => {
            return Err(format!(
                "the model's slope runs along the position column `{column}`, which names no axis: the NC program evaluates it at the measuring position, so the column must be x_mm, y_mm or z_mm"
            ));
        }
    };
    Ok(if axis == at.axis {
        at.nominal
    } else {
        match axis {
            Axis::X => at.x,
            Axis::Y => at.y,
            Axis::Z => at.z,
        }
    })
}

impl Predictor {
    /// `analog`: signal name → analog input number (the profile's `[log] inputs`); `at`: the measuring
    /// position the position-dependent terms are evaluated at. A `geometric` term is constant there: it is
    /// part of the zero, like the model's offset.
    pub fn new(
        model: &DriftModel,
        analog: &BTreeMap<String, u32>,
        at: &Position,
    ) -> Result<Predictor, String> {
        let input_of = |signal: &str| {
            analog.get(signal).copied().ok_or_else(|| {
                format!(
                    "the model reads `{signal}`, which the NC program cannot read: map it to an analog input in the profile (`[log] inputs = {{ {signal} = n }}` for $A_INA[n])"
                )
            })
        };
        let mut inputs = Vec::new();
        for i in &model.inputs {
            inputs.push(InputTerm {
                signal: i.signal.clone(),
                input: input_of(&i.signal)?,
                tau_min: i.tau_min,
                gain_per_unit: i.gain_um_per_unit,
            });
        }
        let mut statics: Vec<StaticTerm> = Vec::new();
        // (τ, µm per 1000 rpm) of `extra_mode` effects: a mode whose target is proportional to the speed,
        // which the speed grid's piecewise-linear gains (0 at 0 rpm, the last segment continued) hold exactly.
        let mut extra_modes: Vec<(f64, f64)> = Vec::new();
        // `time_trend`: µm per hour since the run's start, i.e. since the zero.
        let mut trend_um_per_h = 0.0;
        for spec in &model.effects {
            let e = Effect::from_spec(spec).map_err(|e| e.to_string())?;
            let (signal, gain) = match (e.kind, &e.signal, &e.position) {
                (Kind::ExtraMode, _, _) => {
                    extra_modes.push((e.theta[0], e.amplitudes[0]));
                    continue;
                }
                (Kind::TimeTrend, _, _) => {
                    trend_um_per_h += e.amplitudes[0];
                    continue;
                }
                (Kind::InputLag, Some(signal), _) => {
                    inputs.push(InputTerm {
                        signal: signal.clone(),
                        input: input_of(signal)?,
                        tau_min: e.theta[0],
                        gain_per_unit: e.amplitudes[0],
                    });
                    continue;
                }
                (Kind::Geometric, _, _) => continue,
                (Kind::StaticInput, Some(signal), _) => (signal, e.amplitudes[0]),
                (Kind::InputSlope, Some(signal), Some(position)) => (
                    signal,
                    e.amplitudes[0] * measuring_coordinate(position, at)?,
                ),
                _ => {
                    return Err(format!(
                        "the model carries a `{}` effect, which the NC program cannot predict; refusing rather than predicting without it",
                        spec.kind
                    ));
                }
            };
            match statics.iter_mut().find(|t| &t.signal == signal) {
                Some(t) => t.gain_per_unit += gain,
                None => statics.push(StaticTerm {
                    signal: signal.clone(),
                    input: input_of(signal)?,
                    gain_per_unit: gain,
                }),
            }
        }
        model.validate_for_nc()?;
        let grid = model
            .speed_grid()
            .ok_or_else(|| "the model has no spindle speed grid".to_string())?;
        let modes = &model.spindle.modes;
        let taus: Vec<f64> = modes
            .iter()
            .map(|m| m.tau_min)
            .chain(extra_modes.iter().map(|&(tau, _)| tau))
            .collect();
        let gains: Vec<Vec<f64>> = modes
            .iter()
            .map(|m| m.gain_um.clone())
            .chain(extra_modes.iter().map(|&(_, per_krpm)| {
                model
                    .spindle
                    .grid_rpm
                    .iter()
                    .map(|rpm| per_krpm * rpm.abs() / 1000.0)
                    .collect()
            }))
            .collect();
        Ok(Predictor {
            grid,
            x: vec![0.0; taus.len()],
            target: vec![0.0; taus.len()],
            taus,
            gains,
            input_x: vec![0.0; inputs.len()],
            input_target: vec![0.0; inputs.len()],
            inputs,
            static_du: vec![0.0; statics.len()],
            statics,
            trend_um_per_h,
            elapsed_min: 0.0,
        })
    }

    pub fn inputs(&self) -> &[InputTerm] {
        &self.inputs
    }

    pub fn statics(&self) -> &[StaticTerm] {
        &self.statics
    }

    pub fn taus(&self) -> &[f64] {
        &self.taus
    }

    /// Steady-state drift of each mode at `rpm` (µm).
    pub fn targets_at(&self, rpm: f64) -> Vec<f64> {
        let w = self.grid.weights(rpm);
        self.gains.iter().map(|g| w.apply(g)).collect()
    }

    pub fn set_rpm(&mut self, rpm: f64) {
        self.target = self.targets_at(rpm);
    }

    /// The inputs' changes since the zero (one per [`Predictor::inputs`]), holding from now on.
    pub fn set_input_changes(&mut self, du: &[f64]) {
        for ((g, term), du) in self.input_target.iter_mut().zip(&self.inputs).zip(du) {
            *g = term.gain_per_unit * du;
        }
    }

    /// The static inputs' changes since the zero (one per [`Predictor::statics`]), as read now.
    pub fn set_static_changes(&mut self, du: &[f64]) {
        self.static_du.copy_from_slice(du);
    }

    /// µm per hour of the model's `time_trend` effects (0 without one).
    pub fn trend_um_per_h(&self) -> f64 {
        self.trend_um_per_h
    }

    pub fn advance(&mut self, minutes: f64) {
        self.elapsed_min += minutes;
        let taus = self
            .taus
            .iter()
            .chain(self.inputs.iter().map(|i| &i.tau_min));
        let states = self.x.iter_mut().chain(self.input_x.iter_mut());
        let targets = self.target.iter().chain(&self.input_target);
        for ((x, g), tau) in states.zip(targets).zip(taus) {
            *x = step(*x, *g, (-minutes / tau).exp());
        }
    }

    /// Predicted drift relative to rest (µm).
    pub fn drift(&self) -> f64 {
        let statics: f64 = self
            .statics
            .iter()
            .zip(&self.static_du)
            .map(|(t, du)| t.gain_per_unit * du)
            .sum();
        self.x.iter().chain(&self.input_x).sum::<f64>()
            + statics
            + self.trend_um_per_h * self.elapsed_min / 60.0
    }
}

/// Minutes one measurement takes on the machine: N probings, probe in and tool back.
pub fn measurement_min(profile: &Profile) -> f64 {
    (f64::from(profile.limits.agree_count) * profile.probe.measure_s
        + 2.0 * profile.timeline.tool_change_s)
        / 60.0
}

/// Why a program gets no plan.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error("the program moves no axis and calls no subprogram: there is nothing to compensate")]
    NothingToCompensate,
    #[error("{0}")]
    NoReference(String),
    /// The profile's `[calls]` declaration does not fit a call of the program.
    #[error("{0}")]
    Declaration(String),
    /// The model cannot be predicted in NC with this profile.
    #[error("{0}")]
    Model(String),
}

/// Why a gate that moves cannot measure here (see [`Modal::route_unfit`]); a gauge moves nothing. Gates
/// that move Y (a milling machine's) run in G17 and give a G18/G19 back after their moves.
fn route_unfit(site: &Site, profile: &Profile) -> Option<&'static str> {
    let switches_plane = profile.position.axes.contains(&Axis::Y);
    (profile.probe.kind != ProbeKind::Gauge)
        .then(|| site.before.route_unfit(switches_plane))
        .flatten()
}

/// Why the probe cannot measure in this state: a programmable translation would move a probe point given
/// in work coordinates, and the zero and later readings would not compare.
fn frame_blocks(site: &Site, profile: &Profile) -> Option<&'static str> {
    (profile.position.frame == MeasureFrame::Work
        && site.before.frames & timeline::frame::TRANSLATION != 0)
        .then_some(
            "a programmable translation (TRANS/ATRANS) is active and would move the probe point",
        )
}

/// Which work offset a gate needs selected.
#[derive(Debug, Clone, Copy, PartialEq)]
enum OffsetRule {
    /// The profile's (`method = "frame"`, which corrects it and selects it again); `None`: the program
    /// selected none there, which is the profile's only where the control's reset selects it.
    Profile,
    /// The one in force at the first cut (`method = "active"` measuring in work coordinates: the zero and
    /// later readings compare only under one offset); `None`: the program selected none.
    AtFirstCut(Option<u32>),
    /// Any (`method = "active"` measuring in machine coordinates or with a gauge).
    Any,
}

impl OffsetRule {
    fn of(timeline: &Timeline, profile: &Profile) -> OffsetRule {
        let in_work =
            profile.position.frame == MeasureFrame::Work && profile.probe.kind != ProbeKind::Gauge;
        match profile.offset.method {
            OffsetMethod::Active if in_work => {
                let cut = timeline.first_cut.unwrap_or(usize::MAX);
                OffsetRule::AtFirstCut(
                    timeline
                        .sites
                        .iter()
                        .take_while(|s| s.block <= cut)
                        .last()
                        .and_then(|s| s.before.offset),
                )
            }
            OffsetMethod::Active => OffsetRule::Any,
            _ => OffsetRule::Profile,
        }
    }
}

/// Why no gate may go here for this profile: the place is unfit ([`Modal::unfit`]), or the work offset the
/// gates correct is not the one `rule` wants selected.
fn unfit_for_gate(site: &Site, profile: &Profile, rule: OffsetRule) -> Option<&'static str> {
    if let Some(why) = site.before.unfit() {
        return Some(why);
    }
    // A probe point in work coordinates is on the part, which a rotary axis has turned or tilted (a fixed
    // reference in machine coordinates is not).
    let on_part =
        profile.position.frame == MeasureFrame::Work && profile.probe.kind != ProbeKind::Gauge;
    if on_part && site.before.frames & timeline::frame::ROTARY != 0 {
        return Some(
            "a rotary axis (A, B or C) stands away from 0, so the part is turned or tilted under the probe point in work coordinates",
        );
    }
    if let Some(why) = tilted_over_the_setter(site, profile) {
        return Some(why);
    }
    if site.in_contour {
        return Some(IN_CONTOUR);
    }
    if site.frame_traverse {
        return Some(
            "a frame change (TRANS, ATRANS, G54 …) is not yet traversed: the program's next incremental move carries it, and a gate, which goes back to where the axes are, would take it away",
        );
    }
    match rule {
        OffsetRule::Any => None,
        OffsetRule::AtFirstCut(g) => (site.before.offset != g).then_some(
            "another work offset is selected there than at the first cut, and the probe point is in work coordinates (measure in machine coordinates, [position] frame = \"machine\", to gate under any offset)",
        ),
        OffsetRule::Profile => {
            let selected = match site.before.offset {
                Some(g) => Some(g),
                None if profile.offset.reset_selects => profile.offset_g(),
                None => None,
            };
            (selected != profile.offset_g()).then_some(
                "the profile's work offset is not selected there (a gate selects it again after correcting it, which would move every coordinate of a program that runs without it; where the control's reset selects it, set [offset] reset_selects = true, or correct the offset in force with [offset] method = \"active\")",
            )
        }
    }
}

/// A reference in machine coordinates (a tool setter, a lathe's setter arm) is not turned with the part,
/// but an A or B axis away from 0 may tilt the tool itself (a swivel head, a turn-mill's B axis; driftloop
/// does not know the kinematics): the setter would touch the tilted tool off its axis, and the gate give
/// the reading as drift or carry the tool over the setter tilted. CYCLE800() deletes the swivel's frames
/// and leaves its axes turned (red team 5). A turned C axis (a table or the lathe's spindle) tilts nothing.
fn tilted_over_the_setter(site: &Site, profile: &Profile) -> Option<&'static str> {
    const A_OR_B: u8 = 0b11 << timeline::frame::ROTARY_SHIFT;
    let setter =
        profile.position.frame != MeasureFrame::Work && profile.probe.kind != ProbeKind::Gauge;
    (setter && site.before.frames & A_OR_B != 0).then_some(
        "a rotary axis A or B stands away from 0 (after a swivel or a rotary move): on a swivel head it tilts the tool the setter in machine coordinates would measure",
    )
}

const IN_CONTOUR: &str = "it lies between two feed moves of a contour under continuous path (G64 … G645, or no G60 written): a gate's STOPRE would stop the path there and the tool would dwell on the contour";

const SKIPPED: &str = "it lies in what a jump of the program (GOTOF …) skips, so the jump's path would run the program's gates and its end without the zero and the initial data (with the offset method \"active\" and no continuous compensation or warm start, the zero may go there and the gates after the jump's target are left out)";

/// The forward jump of the program whose skipped blocks hold `block`, the one with the earliest target.
fn skip_around(timeline: &Timeline, block: usize) -> Option<(usize, usize)> {
    timeline
        .skips
        .iter()
        .filter(|&&(jump, target)| jump < block && block <= target)
        .min_by_key(|s| s.1)
        .copied()
}

/// Nothing driftloop runs besides the gates needs stage 1's registers: the correction in force is
/// rebuilt from the stored offset (method `active`, its register set to 0 at the program's top), and no
/// setting data or retentive state is written back at the end.
fn skipped_zero_is_safe(profile: &Profile) -> bool {
    profile.offset.method == OffsetMethod::Active
        && profile.continuous.is_default()
        && profile.warm_start.is_none()
}

const SUM_OFFSET: &str = "a sum offset (DL=) is active, which the probe's tool change and the cutting tool's return would not give back";

const TOOL_OFFSET: &str = "a programmed tool offset (TOFFL, TOFFR, TOFF[axis], the online offset of TOFFON) is in force, which the control keeps through the probe's tool change and a tool setter reads with the tool: a reading taken under another offset than the zero's would show the difference as drift";

const TOOL_DATA: &str = "the program writes cutting-edge data ($TC_DP…) after the zero, which a tool setter reads with the tool: the change would read as drift";

const IN_PART: &str = "the tool may stand in the part there (no rapid clear of what was cut since the last cut: inside a bore, under the part), and a gate retracts along the tool axis";
/// `CT` takes its arc's tangent from the move before it, which a gate that moves replaces with its own
/// descent to the saved height: the arc would leave the contour.
const TANGENT_START: &str = "the block after it starts its arc tangent to the move before it (CT): a gate's last move would change that tangent";

/// `RND`/`CHF`/`CHR` join a move's end to the next move, which after a STOPRE and the blocks without
/// motion a gate begins with would be the gate's rise: how the control joins across them is a machine
/// matter (red team 4, S3).
const ROUNDED_INTO: &str = "the move before it rounds or chamfers its end into the next move (RND, CHF, CHR), which would be a gate's first move";

/// Why a gate that moves cannot go between the moves around the site: the block after it takes its
/// tangent from the move before it, or the move before it is joined to the next.
fn joined(site: &Site) -> Option<&'static str> {
    if site.tangent_start {
        Some(TANGENT_START)
    } else if site.rounded_into {
        Some(ROUNDED_INTO)
    } else {
        None
    }
}

const D0: &str =
    "D0 is active: heights are the spindle's, and the probe would travel a probe length above it";

const STEP_TOOLS: &str = "the tool in the spindle is not known there, and the program's ShopMill steps (E_… cycles) load their tools themselves: a tool setter would measure a tool that does not cut (or the bare spindle); load the first step's tool before the first step (a G-code step with T=\"NAME\" M6, D1 and a move to a safe height, G0 Z100), so that the zero measures a tool that cuts";

const MACHINE_COOLANT_ON: &str = "a machine coolant of the profile's [coolant] codes is on, and the program's own tool change follows: the gate would have to give it back with the probe still in the spindle";

const SETUP_CALL: &str = "no tool of the program's is known there and its first cut is a call driftloop cannot read: a builder's or shop's cycle at the program's start (a tool change such as TC(1), L706 or WZW, a datum cycle such as NPL or NEWCOORD, a table or clamp cycle) sets up the tool, the work offset and the part more often than it cuts, so a zero before it would measure with what the previous program left";

const REFRESH_ONLY: &str = "it only refreshes the continuous compensation between gates";
const BEFORE_THE_ZERO: &str =
    "it is the program's start, where only the reference gate measures (the zero is taken once)";
const SPEED_CHANGE_TURNING: &str = "the spindle changes speed while it turns there, so the tool may be in the cut: a speed change measures only where the spindle stops or starts from standstill";
const PASS_MEASURES: &str = "the spindle starts there, but the start of its pass can measure already and nothing has cut since";
const LOWERED: &str = "the spindle starts there after the tool went down with the spindle stopped: it may stand under the part (a back-boring bar lowered through its bore)";

/// `why`, with the call that left the state unsure where that is the reason.
fn unsure_call_named(timeline: &Timeline, block: usize, why: &str) -> String {
    match timeline.unsure_after_call.get(&block) {
        Some((line, name, fields)) if why == STATE_VARIES => format!(
            "{why}: the call {name} (line {line}) may leave {fields} otherwise than the program had them before it"
        ),
        _ => why.to_string(),
    }
}

/// Why a speed change cannot measure, the place itself being fit: only where the spindle stops, or starts
/// from standstill, is the tool out of the cut. Where it starts, not where the tool went down since it
/// last rose (a back-boring bar lowered through its bore with the spindle stopped stands under the part),
/// and not where the pass's start (`measurable_pass`) could measure already: that place serves, after a
/// tool change whose `SUPA Z0 D0` left the pass start unfit.
fn speed_change_unfit(site: &Site, measurable_pass: Option<usize>) -> Option<&'static str> {
    if site.rpm_after == 0.0 {
        None
    } else if site.before.rpm() != 0.0 {
        Some(SPEED_CHANGE_TURNING)
    } else if site.lowered {
        Some(LOWERED)
    } else if measurable_pass == Some(site.pass) {
        Some(PASS_MEASURES)
    } else {
        None
    }
}
const STATE_VARIES: &str = "its modal state is not known for sure (later runs of a loop reach it in another state, or a subprogram or cycle ran before it)";

const TOOL_UNKNOWN: &str = "the tool in the spindle is not known there (no tool change before it), so the probe could not be swapped for it again";

const TOOL_LOADED_BY_CALL: &str = "a subprogram called later, before the first cut, loads the tool that cuts: a tool setter's zero here would measure another tool";

const SWAP_BY_ARGUMENT: &str = "the program changes tools with a subprogram that takes the tool as its argument, which a gate cannot call for the probe (called without it, it selects T0: the spindle emptied); declare the probe's own change in the profile ([probe] change = \"TC({tool})\", docs/profiles.md)";

const OUTSIDE_PRESELECTION: &str = "the program's tool change later loads a tool preselected outside the program (an M6 with no T before it), and the probe's swap would replace that preselection";

/// Whether a gate that moves (and stops the spindle on the way) at `site` stands where the program cuts
/// with the spindle as the operator left it (no M3/M4/M5 or tool change of its own before the cut: started
/// in MDA). Its M5 would stop that spindle for good, as the gate cannot give back a speed it never knew: it
/// measures only where the spindle stands at run time (`$AA_S[1]`), and a standing spindle stays standing.
fn on_hand_spindle(timeline: &Timeline, site: &Site, profile: &Profile) -> bool {
    profile.probe.kind != ProbeKind::Gauge
        && timeline.hand_spindle.is_some_and(|set| site.block < set)
}

const TURNING_READS_TOOL: &str = "the program turns or grinds (X in diameters or constant cutting speed: DIAMON, DIAM90, G96) and names no tool loaded by M6 there, so a spindle-probe gate would read the tool at run time and swap it with M6 after a retract along Z alone: a turret indexes on T wherever X stands, a grinding wheel is not changed by M6, and Y0 may be no axis; measure with `--profile lathe-setter` or `grinder-gauge`, or with a lathe probe profile ([position] diameter = true)";

/// Why a spindle-probe gate that reads the tool at run time may not measure at `site`: the program is a
/// lathe's or a grinder's, whose tools the milling probe's M6 swap does not change as it assumes.
fn turning_reads_tool(site: &Site, profile: &Profile) -> Option<&'static str> {
    (profile.probe.kind == ProbeKind::SpindleProbe
        && !names_tool(site, profile)
        && !profile.position.diameter
        && (site.before.diameter.on() || site.before.css_rpm.is_some()))
    .then_some(TURNING_READS_TOOL)
}

const MILLING_UNDER_A_LATHE_GATE: &str = "the program mills there (the milling plane G17 in force, or selected before the program's first cut, X in radius): the profile's gate retracts along X to a clearance diameter as on a lathe, which would drag a milling tool sideways through the part; choose a milling profile (blum-tc50, siemens-cycle978, tool-setter), or for a lathe's axial drilling under G17 select G18 again before the place";

/// A tool setter reads the tool's length with the cutting-edge data in force: once the program writes
/// them after the zero (a wear it adds, wherever in the program, loops included), a reading would show
/// the change as drift and the correction would undo it. No gate after the zero measures then.
fn tool_data_unfit(profile: &Profile, tool_data_after_zero: bool) -> Option<&'static str> {
    (profile.probe.kind == ProbeKind::ToolSetter && tool_data_after_zero).then_some(TOOL_DATA)
}

/// Why the profile's kind of gate does not suit the machining at `site`: a milling probe's swap where the
/// program turns or grinds, or a lathe's gate, which retracts along X, where it mills (a gauge, which
/// moves nothing, measures where it is).
fn machine_unfit(timeline: &Timeline, site: &Site, profile: &Profile) -> Option<&'static str> {
    turning_reads_tool(site, profile).or_else(|| {
        (profile.position.retract_axis == Axis::X
            && profile.probe.kind != ProbeKind::Gauge
            && site.before.plane.or(timeline.setup_plane) == Some(17)
            && !site.before.diameter.on())
        .then_some(MILLING_UNDER_A_LATHE_GATE)
    })
}

/// Why a spindle probe may not be swapped in at `site`: a later M6 of the program loads the tool the
/// operator preselected, which the swap's `T` would replace (the control cannot tell the gate which it
/// was); or the program changes tools with a subprogram that takes the tool as its argument, which a gate
/// would call without it (T0: the spindle emptied, the probe cycle run with none), and the profile
/// declares no change of its own.
fn swap_unfit(timeline: &Timeline, site: &Site, profile: &Profile) -> Option<&'static str> {
    if profile.probe.kind != ProbeKind::SpindleProbe {
        return None;
    }
    if timeline.tool_change_by_argument.is_some() && profile.probe.change.is_none() {
        return Some(SWAP_BY_ARGUMENT);
    }
    timeline
        .outside_load
        .is_some_and(|load| site.block <= load)
        .then_some(OUTSIDE_PRESELECTION)
}

/// A spindle probe whose gates read the tool in force at run time where the program does not name it.
pub fn reads_tool(profile: &Profile) -> bool {
    profile.probe.kind == ProbeKind::SpindleProbe
        && profile.probe.unknown_tool == UnknownTool::Runtime
}

/// Why no zero goes inside a loop: run again on each pass of the loop, it would take the drift of the
/// passes before it as the reference and start the model cold again, so no later part is corrected for it.
const IN_LOOP: &str = "it lies inside a loop of the program, which runs it again on every pass, and the zero must be measured once, before the loop";

/// Whether a gate at `site` knows from the program which tool to load again after the probe (or needs
/// none); otherwise it reads the tool at run time.
fn names_tool(site: &Site, profile: &Profile) -> bool {
    !reads_tool(profile)
        || site.before.tool.is_some()
        || matches!(site.kind, SiteKind::PassStart { tool_change: true })
}

/// Why a site cannot carry the reference measurement with this profile's probe; `None` when it can.
fn unfit_for_reference(
    timeline: &Timeline,
    site: &Site,
    profile: &Profile,
    rule: OffsetRule,
) -> Option<&'static str> {
    let tool_change_follows = matches!(site.kind, SiteKind::PassStart { tool_change: true });
    if profile.probe.kind == ProbeKind::ToolSetter
        && timeline
            .tool_load_call
            .as_ref()
            .is_some_and(|(line, _)| site.block < *line)
    {
        return Some(TOOL_LOADED_BY_CALL);
    }
    if let Some(why) = unfit_for_gate(site, profile, rule)
        .or_else(|| frame_blocks(site, profile))
        .or_else(|| machine_unfit(timeline, site, profile))
    {
        return Some(why);
    }
    if site.conditional {
        return Some(
            "it lies inside an IF … ENDIF of the program, which does not run every time, and the zero must",
        );
    }
    if timeline.loops.iter().any(|l| {
        // A section repeat starts at its label's line: what goes before that line runs once.
        let section = matches!(l.kind, LoopKind::Repeat | LoopKind::RepeatBlock);
        (l.body.0 + usize::from(section)..=l.body.1).contains(&site.block)
    }) {
        return Some(IN_LOOP);
    }
    if site.in_part {
        return Some(IN_PART);
    }
    if let Some(why) = joined(site) {
        return Some(why);
    }
    if site.state_varies {
        return Some(STATE_VARIES);
    }
    // Before a tool change of the program's own the zero checks less of the state it gives back, but it
    // moves as every gate does (a gauge moves nothing).
    if let Some(why) = route_unfit(site, profile) {
        return Some(why);
    }
    match profile.probe.kind {
        // The probe travels with its tip at the height the spindle stood at: a whole probe length
        // higher, beyond the top after the `SUPA Z0 D0` posts write before a tool change.
        ProbeKind::SpindleProbe if site.before.d == Some(0) => Some(D0),
        ProbeKind::SpindleProbe | ProbeKind::ToolSetter
            if site.before.unknown & timeline::unknown::TOOL_OFFSET != 0 =>
        {
            Some(TOOL_OFFSET)
        }
        ProbeKind::SpindleProbe if tool_change_follows && site.before.machine_coolant != 0 => {
            Some(MACHINE_COOLANT_ON)
        }
        ProbeKind::SpindleProbe if tool_change_follows => None,
        ProbeKind::SpindleProbe if site.before.tool.is_none() && !reads_tool(profile) => {
            Some(TOOL_UNKNOWN)
        }
        ProbeKind::SpindleProbe if site.before.unknown & timeline::unknown::SUM_OFFSET != 0 => {
            Some(SUM_OFFSET)
        }
        ProbeKind::ToolSetter if tool_change_follows => {
            Some("a tool change follows: the zero must be measured with the tool that cuts")
        }
        ProbeKind::Gauge => None,
        _ => site.before.not_restorable(),
    }
}

/// For a reference fixed on the machine (or a gauge), which reads nothing through the program's frames:
/// the last fit place before the setup (`from`) and after the last tool load.
fn zero_before_setup(
    timeline: &Timeline,
    profile: &Profile,
    rule: OffsetRule,
    (last_load, from): (usize, usize),
    steps_load_tools: bool,
) -> Option<usize> {
    if !(profile.position.frame == MeasureFrame::Machine || profile.probe.kind == ProbeKind::Gauge)
    {
        return None;
    }
    let before_setup = |s: &Site| {
        !(before_setup_call(timeline, s, profile) || steps_load_tools && s.before.tool.is_none())
            && s.block >= last_load.max(timeline.preamble_end)
            && s.block < from
            && !writes_frame_after(timeline, s.block)
            && skip_around(timeline, s.block).is_none()
            && unfit_for_reference(timeline, s, profile, rule).is_none()
    };
    timeline.sites.iter().rposition(before_setup)
}

/// Whether the program writes a frame itself (`$P_UIFR[…]=`) at or after `block`: a zero before that write
/// is refused (the write and the corrections overwrite each other), while one after it may stand.
fn writes_frame_after(timeline: &Timeline, block: usize) -> bool {
    timeline.frame_writes.iter().any(|&w| w >= block)
}

/// The site of the reference measurement: the first fit one after the program's own setup (declarations,
/// work offset, frames) and not after its first cut; else the first fit pass start.
fn reference_site(
    timeline: &Timeline,
    profile: &Profile,
    rule: OffsetRule,
) -> Result<usize, PlanError> {
    if !timeline.moves {
        return Err(PlanError::NothingToCompensate);
    }
    let to = timeline.first_cut.unwrap_or(usize::MAX);
    // A tool setter measures the tool in the spindle: the zero after the last tool load before the first
    // cut, so that it is the tool that cuts.
    let last_load = timeline
        .sites
        .iter()
        .filter(|s| matches!(s.kind, SiteKind::PassStart { tool_change: true }) && s.block < to)
        .map(|s| s.block + 1)
        .max()
        .filter(|_| profile.probe.kind == ProbeKind::ToolSetter)
        .unwrap_or(0);
    let from = timeline.setup_end.max(timeline.preamble_end).max(last_load);
    let mut unfit: Option<(usize, &str)> = None;
    // A zero in what a forward jump skips first; then, where nothing driftloop runs on the jump's path
    // needs what stage 1 sets, there too (the gates from the jump's target on are then left out).
    let passes = if skipped_zero_is_safe(profile) {
        &[false, true][..]
    } else {
        &[false][..]
    };
    // ShopMill's step cycles (E_MI_PL, E_DR, …) load the tool each step names: a tool setter's zero where
    // no tool is known would measure whatever the spindle holds from before (or its bare nose), not a tool
    // that cuts.
    let steps_load_tools = profile.probe.kind == ProbeKind::ToolSetter
        && timeline
            .untimed_calls
            .iter()
            .any(|(_, name)| name.starts_with("E_") && name != "E_HEAD");
    for &allow_skipped in passes {
        let fit = |site: &Site| {
            if !allow_skipped && skip_around(timeline, site.block).is_some() {
                return Some(SKIPPED);
            }
            if steps_load_tools && site.before.tool.is_none() {
                return Some(STEP_TOOLS);
            }
            if before_setup_call(timeline, site, profile) {
                return Some(SETUP_CALL);
            }
            unfit_for_reference(timeline, site, profile, rule)
                .or_else(|| swap_unfit(timeline, site, profile))
        };
        // A place whose tool the program names comes first: one that reads the tool at run time measures
        // nothing where the operator left none in force.
        let mut unnamed = None;
        for (k, site) in timeline.sites.iter().enumerate() {
            if site.block < from || site.block > to {
                continue;
            }
            match fit(site) {
                None if names_tool(site, profile) => return Ok(k),
                None => {
                    unnamed.get_or_insert(k);
                }
                Some(why) => {
                    unfit.get_or_insert((site.block, why));
                }
            }
        }
        if let Some(k) = unnamed {
            return Ok(k);
        }
        // A reference fixed on the machine (or a gauge) reads nothing through the program's frames: where the
        // setup runs straight into the first cut (`TRANS X40 Y30` then a subprogram that cuts), the last fit
        // place before the setup and after the last tool load holds the zero as well — before the cut,
        // which a place after it does not.
        if let Some(k) =
            zero_before_setup(timeline, profile, rule, (last_load, from), steps_load_tools)
        {
            return Ok(k);
        }
        // After the first cut: the first fit pass start, else the first fit place after the setup (a post
        // that retracts with D0 before every tool change leaves no pass start fit for a spindle probe).
        let pass_start = |s: &Site| matches!(s.kind, SiteKind::PassStart { .. });
        let after_setup = |s: &Site| s.block >= from;
        for wanted in [&pass_start as &dyn Fn(&Site) -> bool, &after_setup] {
            if let Some(k) = timeline
                .sites
                .iter()
                .position(|s| wanted(s) && fit(s).is_none())
            {
                return Ok(k);
            }
        }
        // With no place before the first cut, the message says why the first place after the setup is not
        // fit either.
        if unfit.is_none() {
            unfit = timeline
                .sites
                .iter()
                .filter(|s| after_setup(s))
                .find_map(|s| fit(s).map(|why| (s.block, why)));
        }
    }
    let cut = timeline
        .first_cut
        .map_or("the program's end".to_string(), |b| {
            format!("line {}", b + 1)
        });
    let mut message = match timeline.first_cut {
        // A call that sets up and cuts at once ends the setup after the first cut.
        Some(first) if from > first => format!(
            "no place for the reference measurement before the program's first cut ({cut}), which its setup ends with"
        ),
        _ => format!(
            "no place for the reference measurement between the program's setup (line {}) and its first cut ({cut})",
            from + 1
        ),
    };
    let setup_call = timeline
        .setup_call
        .as_ref()
        .filter(|(line, _)| *line == from && timeline.first_cut == Some(from - 1));
    if let Some((line, name)) = setup_call {
        // What is unfit after the call says nothing more: the call is the setup and the cut.
        unfit = None;
        message.push_str(&format!(
            ": the subprogram {name} (line {line}) selects the work offset (or writes a frame) and cuts too, so no place before it measures in the coordinates it cuts in (select the work offset before the call, or measure in machine coordinates: [position] frame = \"machine\")"
        ));
    }
    let tool_unknown = unfit.is_some_and(|(_, why)| why == TOOL_UNKNOWN);
    if let Some((block, why)) = unfit {
        message.push_str(&format!(": at line {}, {why}", block + 1));
        if let (STATE_VARIES, Some((line, name, fields))) =
            (why, timeline.unsure_after_call.get(&block))
        {
            message.push_str(&format!(
                ": the call {name} (line {line}) may leave {fields} otherwise than the program had them before it, and the program's own words do not set them again before that place, so a gate there would give back the state from before the call (write them after the call, e.g. `G0` or `G1 F…`; a frame cannot be written so; where driftloop did not read the subprogram, give its file beside the program or with --subprograms DIR)"
            ));
        }
    }
    if let (Some((_, SETUP_CALL)), Some((line, name))) = (unfit, &timeline.first_cut_call) {
        message.push_str(&format!(
            "; if {name} (line {line}) changes the tool, put its file beside the program or in its SPF folder (spf or subroutines inside it, _N_SPF_DIR beside _N_MPF_DIR), or give its folder with --subprograms DIR, or load the first tool (T=\"NAME\" M6, D1) before it"
        ));
    }
    if tool_unknown {
        message.push_str(
            "; for a program that never changes tools measure with the tool in the spindle (`--profile tool-setter`, `grinder-gauge` or `lathe-setter`, or [probe] kind = \"tool-setter\" or \"gauge\" in your profile; `driftloop profiles` lists them), or add the tool change T=\"NAME\" M6 before the first cut",
        );
        // A shop's tool-change subprogram counts once its file is read (Siemens' cycles change no tool).
        let before_cut = |line: usize| timeline.first_cut.is_none_or(|b| line <= b + 1);
        let candidate = |(line, name): &&(usize, String)| {
            before_cut(*line) && !name.to_ascii_uppercase().starts_with("CYCLE")
        };
        if let Some((line, name)) = timeline.untimed_calls.iter().find(candidate) {
            message.push_str(&format!(
                "; if {name} (line {line}) changes the tool, put its file beside the program or in its SPF folder (spf or subroutines inside it, _N_SPF_DIR beside _N_MPF_DIR), or give its folder with --subprograms DIR"
            ));
        }
    } else if unfit.is_none() {
        message.push_str("; mark a pass at a safe place ([passes] marker / lines)");
    }
    if let Some((line, m)) = timeline.m_beside_t {
        message.push_str(&format!(
            "; if M{m} (line {line}, beside the T word) is this machine's tool change (MD22560 TOOL_CHANGE_M_CODE), set tool_change_m = {m} in the profile's [probe]"
        ));
    }
    Err(PlanError::NoReference(message))
}

/// A gate that moves would measure at `site` before a builder's or shop's cycle that is the program's first
/// cut, with no tool of the program's known: what it measures with is what the previous program left
/// (a gauge reads where the machine stands and moves nothing; a spindle probe before the program's own
/// tool change leaves that change to load the program's tool).
fn before_setup_call(timeline: &Timeline, site: &Site, profile: &Profile) -> bool {
    let own_change_follows = profile.probe.kind == ProbeKind::SpindleProbe
        && matches!(site.kind, SiteKind::PassStart { tool_change: true });
    profile.probe.kind != ProbeKind::Gauge
        && !own_change_follows
        && site.before.tool.is_none()
        && timeline
            .first_cut_call
            .as_ref()
            .is_some_and(|(line, _)| site.block < *line)
}

/// Why a gate here cannot measure, or `None` when it can: the place must be fit, its state the same on
/// every run and restorable, and the probe must be able to give the tool back (a tool setter compares only
/// readings of the tool the zero was measured with).
fn unfit_for_measuring(
    site: &Site,
    profile: &Profile,
    rule: OffsetRule,
    reference_tool: Option<&Arc<str>>,
) -> Option<&'static str> {
    let tool_change_follows = matches!(site.kind, SiteKind::PassStart { tool_change: true });
    // A gauge moves nothing and restores nothing: only the place must be fit.
    if profile.probe.kind == ProbeKind::Gauge {
        return unfit_for_gate(site, profile, rule);
    }
    if site.state_varies {
        return Some(STATE_VARIES);
    }
    if site.in_part {
        return Some(IN_PART);
    }
    if let Some(why) = joined(site) {
        return Some(why);
    }
    if let Some(why) = site
        .before
        .not_restorable()
        .or_else(|| route_unfit(site, profile))
        .or_else(|| frame_blocks(site, profile))
    {
        return Some(why);
    }
    match profile.probe.kind {
        ProbeKind::SpindleProbe | ProbeKind::ToolSetter
            if site.before.unknown & timeline::unknown::TOOL_OFFSET != 0 =>
        {
            Some(TOOL_OFFSET)
        }
        ProbeKind::SpindleProbe if tool_change_follows && site.before.machine_coolant != 0 => {
            Some(MACHINE_COOLANT_ON)
        }
        ProbeKind::SpindleProbe
            if !tool_change_follows && site.before.tool.is_none() && !reads_tool(profile) =>
        {
            Some("the tool in the spindle is not known")
        }
        ProbeKind::SpindleProbe
            if !tool_change_follows && site.before.unknown & timeline::unknown::SUM_OFFSET != 0 =>
        {
            Some(SUM_OFFSET)
        }
        ProbeKind::ToolSetter if site.before.tool.as_ref() != reference_tool => {
            Some("another tool than the one the zero was measured with is in the spindle")
        }
        _ => None,
    }
}

/// A speed the timeline cannot evaluate: the prediction, in the plan and in the program's gates, runs on
/// with the speed before it, so the drift there may be larger than planned.
fn unknown_speed_warning(timeline: &Timeline) -> Option<String> {
    let mut lines = timeline.unknown_speed_lines.clone();
    lines.sort_unstable();
    lines.dedup();
    let first = *lines.first()?;
    let more = match lines.len() {
        1 => String::new(),
        n => format!(" (and {} more line(s))", n - 1),
    };
    Some(format!(
        "line {first}{more}: the spindle speed is set by an expression driftloop cannot evaluate; the prediction runs on with the speed before it, so the drift there may be larger than planned: write the speed as a number or a variable assigned a number, or bound the time between measurements with `[limits] max_interval_min`"
    ))
}

/// The predictors of every measured axis, stepped together.
struct Axes(Vec<Predictor>);

impl Axes {
    fn set_rpm(&mut self, rpm: f64) {
        self.0.iter_mut().for_each(|p| p.set_rpm(rpm));
    }

    fn advance(&mut self, minutes: f64) {
        self.0.iter_mut().for_each(|p| p.advance(minutes));
    }

    fn drifts(&self) -> Vec<f64> {
        self.0.iter().map(Predictor::drift).collect()
    }
}

/// The largest change on any axis between two predictions.
fn largest_change(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

/// The plan for one model per measured axis ([`Profile::measured`], in that order).
pub fn plan(
    timeline: &Timeline,
    models: &[&DriftModel],
    profile: &Profile,
) -> Result<Plan, PlanError> {
    if let Some((line, why)) = &timeline.bad_declaration {
        return Err(PlanError::Declaration(format!("line {line}: {why}")));
    }
    let measured = profile.measured();
    if models.len() != measured.len() {
        return Err(PlanError::Model(format!(
            "the profile measures {} axis/axes but {} model(s) were given: one model per measured axis",
            measured.len(),
            models.len()
        )));
    }
    // The plan cannot know the inputs ahead: they are taken to stay at their value at the zero.
    let mut p = Axes(
        models
            .iter()
            .zip(&measured)
            .map(|(m, at)| Predictor::new(m, &profile.log.inputs, at))
            .collect::<Result<_, _>>()
            .map_err(PlanError::Model)?,
    );
    let limit = profile.limits.working_limit_um();
    let rule = OffsetRule::of(timeline, profile);
    let first = reference_site(timeline, profile, rule)?;
    let reference_tool = timeline.sites[first].before.tool.clone();
    let zero_block = timeline.sites[first].block;
    let tool_data_after_zero = timeline.tool_data_writes.iter().any(|&w| w >= zero_block);
    // A zero in what a jump skips: from the jump's target on, the jump's path reaches the gates without
    // the zero, so no gate goes there.
    let skipped = skip_around(timeline, timeline.sites[first].block);
    let per_measurement = measurement_min(profile);
    // The sites in the order the program runs them: a counted loop's body comes once per run.
    let runs = site_runs(timeline);
    let start = runs
        .sites
        .iter()
        .position(|&(k, _)| k == first)
        .expect("every site runs at least once");
    let mut visits = vec![0usize; timeline.sites.len()];
    let mut gates: BTreeMap<usize, Gate> = BTreeMap::new();
    let mut shift = 0.0;
    let mut pending = 0.0;
    let mut last_time = runs.sites[start].1;
    let mut rpm = 0.0;
    // Planned time of the last gate or refresh: continuous compensation refreshes once its interval passed.
    let mut last_update = runs.sites[start].1;
    let mut at_last_measurement = vec![0.0; models.len()];
    // Planned time of the last measurement: where the profile bounds the time between measurements, a
    // gate that can measure does once it ran out.
    let mut last_measured = runs.sites[start].1;
    // The pass of the last gate that could measure: a spindle start measures only in a pass where no
    // gate before it could (one place at a tool change is enough).
    let mut measurable_pass: Option<usize> = None;
    let mut max: f64 = 0.0;
    // Speeds the model was never characterised at: say so, with the law its gains follow there.
    let mut speeds: Vec<f64> = timeline.speeds.iter().map(|s| s.1).collect();
    speeds.sort_by(f64::total_cmp);
    speeds.dedup();
    let speed_warnings: Vec<String> = models
        .iter()
        .flat_map(|m| {
            speeds
                .iter()
                .filter_map(|rpm| extrapolation_warning(m, *rpm))
        })
        .collect();
    let mut watch = Watch {
        chance: (
            format!("line {}", timeline.sites[first].block + 1),
            runs.sites[start].1,
            vec![0.0; models.len()],
        ),
        cut: None,
        limit,
        tolerance: profile.limits.tolerance_um,
        warnings: speed_warnings,
    };
    if let Some(warning) = unknown_speed_warning(timeline) {
        watch.warnings.push(warning);
    }
    if let Some((jump, target)) = skipped {
        watch.warnings.push(format!(
            "the zero at line {} lies in what the jump at line {} skips: no gate from line {} on (on the jump's path they would run without the zero); the correction in force there is the last one before",
            timeline.sites[first].block + 1,
            jump + 1,
            target + 1
        ));
    }
    for (n, &(k, time)) in runs.sites[start..].iter().enumerate() {
        let site = &timeline.sites[k];
        let reference = k == first;
        // No inserted block where it would stop a contour or act on a tilted axis: the program's own
        // prediction then runs on at the speed of its last gate, and so does the plan's.
        let mid_cut = site.kind == SiteKind::SpeedChange
            && site.before.motion != 0
            && site.before.rpm() > 0.0
            && site.rpm_after > 0.0;
        let past_skip = skipped.is_some_and(|(_, target)| site.block >= target);
        if !reference && (unfit_for_gate(site, profile, rule).is_some() || mid_cut || past_skip) {
            continue;
        }
        // The program's own update uses the real time, measurements included, at the speed set last.
        p.set_rpm(rpm);
        let cut_end = time - site.idle_min;
        if cut_end > last_time {
            p.advance(cut_end - last_time + pending);
            watch.cut = Some((cut_end, p.drifts()));
            p.advance(time - cut_end);
        } else {
            p.advance(time - last_time + pending);
        }
        last_time = time;
        pending = 0.0;
        let drifts = p.drifts();
        let predicted = drifts[0];
        max = drifts.iter().fold(max, |m, d| m.max(d.abs()));
        visits[k] += 1;
        // The zero is planned once; should its block lie in a loop body, its further runs are not planned.
        if reference && n > 0 {
            rpm = site.rpm_after;
            continue;
        }
        let tool_change_follows = matches!(site.kind, SiteKind::PassStart { tool_change: true });
        // Declarations must stay first: a pass marked inside them is measured after them.
        let block = if reference {
            site.block.max(timeline.preamble_end)
        } else {
            site.block
        };
        let unfit = unfit_for_measuring(site, profile, rule, reference_tool.as_ref())
            .or_else(|| tool_data_unfit(profile, tool_data_after_zero))
            .or_else(|| swap_unfit(timeline, site, profile))
            .or_else(|| machine_unfit(timeline, site, profile));
        // Why the gate cannot measure, if it cannot.
        let (kind, why_not) = match site.kind {
            _ if reference => (GateKind::Reference, None),
            SiteKind::PassStart { .. } => (GateKind::PassStart, unfit),
            SiteKind::Retract { .. } | SiteKind::Stop | SiteKind::Dressing => {
                (GateKind::Extra, unfit)
            }
            SiteKind::SpeedChange => (
                GateKind::Update,
                unfit.or_else(|| speed_change_unfit(site, measurable_pass)),
            ),
            SiteKind::Start => (GateKind::Update, unfit.or(Some(BEFORE_THE_ZERO))),
        };
        let can_measure = why_not.is_none();
        if can_measure {
            measurable_pass = Some(site.pass);
        }
        if can_measure && !reference {
            watch.chance(format!("line {}", site.block + 1), time, drifts.clone());
        }
        let overdue = profile
            .limits
            .max_interval_min
            .is_some_and(|p| time + shift - last_measured >= p);
        let measure = kind == GateKind::Reference
            || (can_measure
                && (profile.log.measure_every_gate
                    || overdue
                    || largest_change(&drifts, &at_last_measurement) >= limit));
        let in_loop = matches!(
            site.kind,
            SiteKind::Retract {
                first_in_loop: true
            }
        );
        let gate_exists = gates.contains_key(&k);
        let continuous = &profile.continuous;
        let kind = if kind == GateKind::Extra
            && !gate_exists
            && !((measure || in_loop) && profile.passes.extra_gates)
        {
            let due = time - last_update >= continuous.interval_min || in_loop;
            if !(continuous.on() && due) {
                rpm = site.rpm_after;
                continue;
            }
            GateKind::Refresh
        } else {
            kind
        };
        let (measure, can_measure, why_not) = match kind {
            GateKind::Refresh => (false, false, Some(REFRESH_ONLY)),
            _ => (measure, can_measure, why_not),
        };
        let cannot_measure = why_not.map(|why| unsure_call_named(timeline, site.block, why));
        last_update = time;
        if measure {
            at_last_measurement = drifts;
            last_measured = time + shift;
            pending = per_measurement;
        }
        rpm = site.rpm_after;
        let time_min = super::timeline::on_tick(time + shift);
        shift += pending;
        let gate = gates.entry(k).or_insert_with(|| Gate {
            number: 0,
            kind,
            block,
            pass: site.pass.max(1),
            time_min,
            rpm,
            predicted_um: predicted,
            measure: false,
            can_measure,
            cannot_measure: cannot_measure.clone(),
            tool_change_follows,
            runs: 0,
            measurements: 0,
            idle_min: site.idle_min,
            hand_spindle: on_hand_spindle(timeline, site, profile),
            before: site.before.clone(),
        });
        // A refresh a later run of a loop measures at becomes that run's gate.
        if gate.kind == GateKind::Refresh && measure {
            gate.kind = kind;
            gate.can_measure = can_measure;
            gate.cannot_measure = cannot_measure;
        }
        gate.measure |= measure;
        gate.measurements += usize::from(measure);
    }
    p.set_rpm(rpm);
    let cut_end = timeline.last_cut_min;
    if cut_end > last_time {
        p.advance(cut_end - last_time + pending);
        watch.cut = Some((cut_end, p.drifts()));
        p.advance(timeline.total_min - cut_end);
    } else {
        p.advance(timeline.total_min - last_time + pending);
    }
    let drifts = p.drifts();
    max = drifts.iter().fold(max, |m, d| m.max(d.abs()));
    watch.chance("the program's end".to_string(), timeline.total_min, drifts);
    let gates: Vec<Gate> = gates
        .into_iter()
        .enumerate()
        .map(|(number, (k, mut g))| {
            g.number = number + 1;
            g.runs = if g.kind == GateKind::Reference {
                1
            } else {
                visits[k]
            };
            g
        })
        .collect();
    Ok(Plan {
        working_limit_um: limit,
        measurements: gates.iter().map(|g| g.measurements).sum(),
        gates,
        max_predicted_um: max,
        total_min: super::timeline::on_tick(timeline.total_min + shift),
        loops: timeline.loops.clone(),
        every_run_planned: runs.complete,
        warnings: watch.warnings,
    })
}

/// The stretches of cutting between two places that can measure: where the predicted drift changes by
/// more than δ' while cutting, parts are cut that no measurement watches.
struct Watch {
    /// The last place that could measure: line, time, prediction of every axis.
    chance: (String, f64, Vec<f64>),
    /// The end of the last cut since then: time, prediction of every axis.
    cut: Option<(f64, Vec<f64>)>,
    limit: f64,
    tolerance: f64,
    warnings: Vec<String>,
}

impl Watch {
    /// A place that can measure (or the program's end): warns when the cut since the last one drifted
    /// too far, and starts the next stretch here.
    fn chance(&mut self, at: String, time: f64, predicted: Vec<f64>) {
        let (from, from_time, from_pred) = &self.chance;
        if let Some((cut_time, cut_pred)) = self.cut.take()
            && cut_time > *from_time
        {
            let change = largest_change(&cut_pred, from_pred);
            if change > self.limit {
                let what = if change > self.tolerance {
                    format!("more than the tolerance Δ = {} µm", number(self.tolerance))
                } else {
                    format!("more than δ' = {} µm", number(self.limit))
                };
                self.warnings.push(format!(
                    "the model predicts a change of {change:.1} µm while cutting between {from} and {at}, {what}, with no place to measure in between: the error of the parts cut there is not watched; add a safe place (a retract, a pass marker) in between"
                ));
            }
        }
        self.chance = (at, time, predicted);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Schedule;

    /// Probing at X 150, Y 40, the base surface at Z −5.
    /// The end time of each schedule segment (min).
    fn segment_ends(schedule: &Schedule) -> Vec<f64> {
        schedule
            .segments
            .iter()
            .scan(0.0, |t, s| {
                *t += s.minutes;
                Some(*t)
            })
            .collect()
    }

    fn at() -> Position {
        Position {
            x: 150.0,
            y: 40.0,
            z: 10.0,
            clearance: 100.0,
            frame: super::super::profile::MeasureFrame::Work,
            axes: vec![Axis::X, Axis::Y, Axis::Z],
            retract_axis: Axis::Z,
            diameter: false,
            also: Vec::new(),
            retract_max: None,
            axis: Axis::Z,
            nominal: -5.0,
        }
    }

    #[test]
    fn predictor_steps_agree_with_the_model() {
        // The update the NC program runs at its gates, over an uneven schedule, equals the model's own
        // prediction: the exact update does not depend on where the steps fall.
        let model = DriftModel::from_modes(
            "drift_z_um",
            vec![1000.0, 3000.0, 5000.0],
            &[(12.0, vec![2.0, 7.0, 12.0]), (90.0, vec![5.0, 16.0, 28.0])],
            0.0,
        );
        let schedule: Schedule = "4000:37,0:11,2500:52".parse().unwrap();
        let ds = schedule.to_dataset(1.0);
        let truth = model.predict(&ds).unwrap();
        let mut p = Predictor::new(&model, &BTreeMap::new(), &at()).unwrap();
        let mut t = 0.0;
        for seg in &schedule.segments {
            p.set_rpm(seg.rpm);
            // Two uneven steps per segment, like gates at arbitrary blocks.
            p.advance(seg.minutes * 0.3);
            p.advance(seg.minutes * 0.7);
            t += seg.minutes;
        }
        let last = *truth.last().unwrap();
        assert!((ds.time_min.last().unwrap() - t).abs() < 1e-9);
        assert!((p.drift() - last).abs() < 1e-9, "{} vs {last}", p.drift());
        assert!(last > 1.0);
    }

    #[test]
    fn input_lags_agree_with_the_model() {
        // `inputs` and an `input_lag` effect, each on an analog input the profile maps, over a
        // piecewise-constant signal that changes with the schedule: the gates' update equals the model.
        let mut model =
            DriftModel::from_modes("drift_z_um", vec![4000.0], &[(30.0, vec![20.0])], 0.0);
        model.inputs.push(crate::model::InputLag {
            signal: "ambient_c".into(),
            tau_min: 60.0,
            tau_se_min: None,
            gain_um_per_unit: -1.5,
            gain_se_um_per_unit: None,
        });
        model.effects.push(crate::model::EffectSpec {
            kind: "input_lag".into(),
            signal: Some("coolant_c".into()),
            position: None,
            params: [
                ("tau_min".to_string(), 20.0),
                ("gain_um_per_unit".to_string(), 2.5),
            ]
            .into(),
        });
        let schedule: Schedule = "4000:37,0:11,2500:52".parse().unwrap();
        let ambient = [20.0, 23.5, 18.0];
        let coolant = [22.0, 22.0, 25.0];
        let mut ds = schedule.to_dataset(1.0);
        let ends = segment_ends(&schedule);
        let segment = |t: f64| {
            ends.iter()
                .position(|e| t < *e - 1e-9)
                .unwrap_or(ends.len() - 1)
        };
        let column = |v: &[f64]| {
            ds.time_min
                .iter()
                .map(|&t| v[segment(t)])
                .collect::<Vec<_>>()
        };
        let (a, c) = (column(&ambient), column(&coolant));
        ds.push_column("ambient_c", a);
        ds.push_column("coolant_c", c);
        let truth = model.predict(&ds).unwrap();

        let analog = BTreeMap::from([("ambient_c".to_string(), 1), ("coolant_c".to_string(), 2)]);
        let mut p = Predictor::new(&model, &analog, &at()).unwrap();
        assert_eq!(p.inputs().len(), 2);
        for (k, seg) in schedule.segments.iter().enumerate() {
            p.set_rpm(seg.rpm);
            p.set_input_changes(&[ambient[k] - ambient[0], coolant[k] - coolant[0]]);
            p.advance(seg.minutes * 0.3);
            p.advance(seg.minutes * 0.7);
        }
        let last = *truth.last().unwrap();
        let spindle_only =
            DriftModel::from_modes("drift_z_um", vec![4000.0], &[(30.0, vec![20.0])], 0.0)
                .predict(&ds)
                .unwrap();
        assert!(
            (last - spindle_only.last().unwrap()).abs() > 1.0,
            "the inputs matter"
        );
        assert!((p.drift() - last).abs() < 1e-9, "{} vs {last}", p.drift());
    }

    #[test]
    fn static_inputs_and_slopes_agree_with_the_model() {
        // A sensor regression (`sensors --position-column -o`) on top of a spindle mode and an input lag:
        // static terms act at their own row, the slope at the measuring position (x_mm = X 150, z_mm =
        // the nominal −5 on the measured axis), the geometric term is part of the zero.
        let mut model =
            DriftModel::from_modes("drift_z_um", vec![4000.0], &[(30.0, vec![20.0])], 3.0);
        let term = |kind: Kind, signal: Option<&str>, position: Option<&str>, a: Vec<f64>| {
            Effect {
                kind,
                signal: signal.map(str::to_string),
                position: position.map(str::to_string),
                theta: if kind == Kind::InputLag {
                    vec![20.0]
                } else {
                    vec![]
                },
                amplitudes: a,
            }
            .to_spec()
        };
        model.effects = vec![
            term(Kind::Geometric, None, Some("x_mm"), vec![0.01, -2e-5]),
            term(Kind::InputLag, Some("coolant_c"), None, vec![2.5]),
            term(Kind::StaticInput, Some("a1_c"), None, vec![4.0]),
            term(Kind::InputSlope, Some("a1_c"), Some("x_mm"), vec![0.02]),
            term(Kind::InputSlope, Some("b1_c"), Some("z_mm"), vec![0.3]),
            term(Kind::StaticInput, Some("b1_c"), None, vec![-2.5]),
        ];
        let schedule: Schedule = "4000:37,0:11,2500:52".parse().unwrap();
        let (a1, b1, coolant) = ([20.0, 23.5, 22.0], [22.0, 21.0, 24.0], [22.0, 22.0, 25.0]);
        let mut ds = schedule.to_dataset(1.0);
        let ends = segment_ends(&schedule);
        let column = |v: &[f64]| -> Vec<f64> {
            ds.time_min
                .iter()
                .map(|&t| {
                    let k = ends.iter().position(|e| t < *e - 1e-9);
                    v[k.unwrap_or(ends.len() - 1)]
                })
                .collect()
        };
        let columns = [
            ("a1_c", column(&a1)),
            ("b1_c", column(&b1)),
            ("coolant_c", column(&coolant)),
            ("x_mm", vec![150.0; ds.len()]),
            ("z_mm", vec![-5.0; ds.len()]),
        ];
        for (name, values) in columns {
            ds.push_column(name, values);
        }
        let truth = model.predict(&ds).unwrap();

        let analog = BTreeMap::from([
            ("a1_c".to_string(), 3),
            ("b1_c".to_string(), 4),
            ("coolant_c".to_string(), 2),
        ]);
        let mut p = Predictor::new(&model, &analog, &at()).unwrap();
        assert_eq!(p.inputs().len(), 1);
        let statics: Vec<(&str, u32, f64)> = p
            .statics()
            .iter()
            .map(|t| (t.signal.as_str(), t.input, t.gain_per_unit))
            .collect();
        assert_eq!(
            statics,
            [
                ("a1_c", 3, 4.0 + 0.02 * 150.0),
                ("b1_c", 4, -2.5 + 0.3 * -5.0)
            ]
        );
        for (k, seg) in schedule.segments.iter().enumerate() {
            p.set_rpm(seg.rpm);
            p.set_input_changes(&[coolant[k] - coolant[0]]);
            p.set_static_changes(&[a1[k] - a1[0], b1[k] - b1[0]]);
            p.advance(seg.minutes * 0.3);
            p.advance(seg.minutes * 0.7);
        }
        // The last row reads the last segment's sensors, as the predictor does. Relative to the zero (the
        // first row): the offset and the geometric term drop out.
        let last = truth.last().unwrap() - truth[0];
        assert!((p.drift() - last).abs() < 1e-9, "{} vs {last}", p.drift());
        let statics_part = (4.0 + 3.0) * (a1[2] - a1[0]) + (-4.0) * (b1[2] - b1[0]);
        assert!(statics_part.abs() > 1.0, "the static terms matter");
    }

    #[test]
    fn an_extra_mode_and_a_time_trend_agree_with_the_model_also_above_the_grid() {
        // What `diagnose` adds for a slower mode (k·|rpm|/1000 through its own lag, predicted in NC as one
        // more spindle mode; 5000 rpm lies above the grid's top speed) and for a creep since the zero.
        let mut model = DriftModel::from_modes(
            "drift_z_um",
            vec![2000.0, 4000.0],
            &[(20.0, vec![6.0, 15.0])],
            1.0,
        );
        model.effects = vec![
            Effect {
                kind: Kind::ExtraMode,
                signal: None,
                position: None,
                theta: vec![180.0],
                amplitudes: vec![3.5],
            }
            .to_spec(),
            Effect {
                kind: Kind::TimeTrend,
                signal: None,
                position: None,
                theta: vec![],
                amplitudes: vec![0.8],
            }
            .to_spec(),
        ];
        let schedule: Schedule = "3000:50,0:20,5000:90,1000:30".parse().unwrap();
        let truth = model.predict(&schedule.to_dataset(1.0)).unwrap();
        let mut p = Predictor::new(&model, &BTreeMap::new(), &at()).unwrap();
        assert_eq!(p.taus(), [20.0, 180.0]);
        for seg in &schedule.segments {
            p.set_rpm(seg.rpm);
            p.advance(seg.minutes);
        }
        let last = truth.last().unwrap() - truth[0];
        assert!((p.drift() - last).abs() < 1e-9, "{} vs {last}", p.drift());
        let without = DriftModel {
            effects: vec![],
            ..model.clone()
        }
        .predict(&schedule.to_dataset(1.0))
        .unwrap();
        assert!(
            (truth.last().unwrap() - without.last().unwrap()).abs() > 1.0,
            "the mode matters"
        );
    }

    #[test]
    fn a_slope_along_a_column_that_names_no_axis_is_refused() {
        let mut model = DriftModel::from_modes("drift_z_um", vec![], &[], 0.0);
        model.effects.push(
            Effect {
                kind: Kind::InputSlope,
                signal: Some("a1_c".into()),
                position: Some("pos_mm".into()),
                theta: vec![],
                amplitudes: vec![0.02],
            }
            .to_spec(),
        );
        let analog = BTreeMap::from([("a1_c".to_string(), 3)]);
        let err = Predictor::new(&model, &analog, &at()).unwrap_err();
        assert!(
            err.contains("`pos_mm`") && err.contains("x_mm, y_mm or z_mm"),
            "{err}"
        );
        model.effects[0].position = Some("y_mm".into());
        let p = Predictor::new(&model, &analog, &at()).unwrap();
        assert!((p.statics()[0].gain_per_unit - 0.02 * 40.0).abs() < 1e-12);
    }

    #[test]
    fn unmapped_inputs_and_other_effects_are_refused() {
        let mut model =
            DriftModel::from_modes("drift_z_um", vec![4000.0], &[(30.0, vec![20.0])], 0.0);
        model.effects.push(crate::model::EffectSpec {
            kind: "input_lag".into(),
            signal: Some("ambient_c".into()),
            position: None,
            params: [
                ("tau_min".to_string(), 20.0),
                ("gain_um_per_unit".to_string(), 2.5),
            ]
            .into(),
        });
        let err = Predictor::new(&model, &BTreeMap::new(), &at()).unwrap_err();
        assert!(err.contains("ambient_c = n"), "{err}");
        // A step at a time on the data's own axis has no meaning for a program run later.
        model.effects[0] = crate::model::EffectSpec {
            kind: "step".into(),
            signal: None,
            position: None,
            params: [
                ("at_min".to_string(), 300.0),
                ("offset_um".to_string(), 4.0),
            ]
            .into(),
        };
        let err = Predictor::new(&model, &BTreeMap::new(), &at()).unwrap_err();
        assert!(err.contains("`step` effect"), "{err}");
    }
}
