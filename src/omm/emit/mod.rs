//! The NC text driftloop inserts: the header comment, the initial block with the reference measurement,
//! the gates (prediction update, Cycle_in decision, measurement module, scrap decision, correction
//! recalculation, correction) and the restore before the program ends. Every line ends in the comment
//! [`MARK`] so inserted blocks can be told from the program's own at a glance.
//!
//! A gate measures every axis the profile names (`[position]` and its `also` entries), each predicted by
//! its own model and corrected in its own component of the work offset; time, probing series and the way
//! in and out are shared.

mod temp_comp;
mod warm;

use std::collections::BTreeSet;

use temp_comp::TempCompRegisters;
use warm::WarmRegisters;

use super::nc::number;
use super::plan::{Gate, GateKind, Plan, Predictor};
use super::profile::{
    Axis, MeasureFrame, OffsetMethod, Position, ProbeKind, Profile, TimerUnit, ToolChange,
};
use super::timeline::Modal;

/// Metric dimensions for geometry, feed and system variables: what inserted blocks run in where the program
/// is in inch.
const METRIC: &str = "G710";
/// Comment every inserted block ends with.
pub const MARK: &str = ";DL";
/// A value no measurement gives (mm): marks "nothing measured yet" and "the cycle returned nothing".
const SENTINEL: u32 = 99999;
/// Text of the header comment; a program that carries it was transformed already.
pub const SIGNATURE: &str = "driftloop-omm";

/// The registers of one measured axis: its prediction's states, its zero, its correction.
#[derive(Debug, Clone)]
struct AxisRegisters {
    /// The prediction at the last cut.
    pred_cut: u32,
    x: Vec<u32>,
    g: Vec<u32>,
    /// Per time constant of the model's lagged analog-input terms: one lag state and one target. The terms
    /// are linear, so all terms of one τ add into one state (a model over 16 sensors at 3 lags needs 6
    /// registers here, not 96).
    lags: Vec<InputLag>,
    /// Per analog input the model reads: its number and its value at the zero.
    zeros: Vec<(u32, u32)>,
    /// The unlagged (static) terms' sum now, when the model has any.
    statics: Option<u32>,
    pred: u32,
    pred_at_measurement: u32,
    eps: u32,
    corr: u32,
    applied: u32,
    base: u32,
    zero: u32,
    delta: u32,
}

/// The lagged analog-input terms of one time constant: their shared state and target registers, and the
/// terms (indices into [`Predictor::inputs`]).
#[derive(Debug, Clone)]
struct InputLag {
    tau_min: f64,
    terms: Vec<usize>,
    x: u32,
    g: u32,
}

/// The distinct time constants of `p`'s lagged input terms with their terms, and the distinct analog
/// inputs it reads, in the order of first use.
fn input_layout(p: &Predictor) -> (Vec<(f64, Vec<usize>)>, Vec<u32>) {
    let mut lags: Vec<(f64, Vec<usize>)> = Vec::new();
    for (i, t) in p.inputs().iter().enumerate() {
        match lags.iter_mut().find(|(tau, _)| *tau == t.tau_min) {
            Some((_, terms)) => terms.push(i),
            None => lags.push((t.tau_min, vec![i])),
        }
    }
    let mut inputs: Vec<u32> = Vec::new();
    let used = p.inputs().iter().map(|t| t.input);
    for n in used.chain(p.statics().iter().map(|t| t.input)) {
        if !inputs.contains(&n) {
            inputs.push(n);
        }
    }
    (lags, inputs)
}

impl AxisRegisters {
    fn count(p: &Predictor) -> usize {
        let (lags, inputs) = input_layout(p);
        10 + 2 * p.taus().len()
            + 2 * lags.len()
            + inputs.len()
            + usize::from(!p.statics().is_empty())
    }

    fn take(p: &Predictor, next: &mut impl FnMut() -> u32) -> AxisRegisters {
        let (layout, inputs) = input_layout(p);
        let modes = p.taus().len();
        let mut many = |n: usize| (0..n).map(|_| next()).collect::<Vec<u32>>();
        let (x, g) = (many(modes), many(modes));
        let lags = layout
            .into_iter()
            .map(|(tau_min, terms)| {
                let r = many(2);
                InputLag {
                    tau_min,
                    terms,
                    x: r[0],
                    g: r[1],
                }
            })
            .collect();
        let zeros = inputs.iter().map(|&n| (n, many(1)[0])).collect();
        let statics = (!p.statics().is_empty()).then(|| many(1)[0]);
        let mut one = || many(1)[0];
        AxisRegisters {
            pred_cut: one(),
            x,
            g,
            lags,
            zeros,
            statics,
            pred: one(),
            pred_at_measurement: one(),
            eps: one(),
            corr: one(),
            applied: one(),
            base: one(),
            zero: one(),
            delta: one(),
        }
    }

    fn all(&self) -> impl Iterator<Item = u32> + '_ {
        [
            self.pred_cut,
            self.pred,
            self.pred_at_measurement,
            self.eps,
            self.corr,
            self.applied,
            self.base,
            self.zero,
            self.delta,
        ]
        .into_iter()
        .chain(self.x.iter().copied())
        .chain(self.g.iter().copied())
        .chain(self.lags.iter().flat_map(|l| [l.x, l.g]))
        .chain(self.zeros.iter().map(|z| z.1))
        .chain(self.statics)
    }

    /// The register holding analog input `n`'s value at the zero.
    fn zero_of(&self, n: u32) -> u32 {
        self.zeros
            .iter()
            .find(|z| z.0 == n)
            .expect("every input the model reads has a zero")
            .1
    }
}

/// At most this many terms in one block of a sum over analog inputs: a model over many sensors would
/// otherwise write blocks longer than the control takes.
const TERMS_PER_BLOCK: usize = 6;

/// `reg` = the sum of `terms`, written over as many blocks as [`TERMS_PER_BLOCK`] asks, with `comment`.
fn sum_blocks(reg: u32, terms: &[String], comment: &str) -> Vec<String> {
    if terms.is_empty() {
        return vec![format!("{}=0 ; {comment}", r(reg))];
    }
    // A negative term carries its own sign: `a-b`, never `a+-b`.
    let joined = |first: &str, rest: &[String]| {
        rest.iter().fold(first.to_string(), |mut s, t| {
            if !t.starts_with('-') {
                s.push('+');
            }
            s.push_str(t);
            s
        })
    };
    terms
        .chunks(TERMS_PER_BLOCK)
        .enumerate()
        .map(|(k, chunk)| {
            let reg = r(reg);
            if k == 0 {
                format!("{reg}={} ; {comment}", joined(&chunk[0], &chunk[1..]))
            } else {
                format!("{reg}={} ; {comment}", joined(&reg, chunk))
            }
        })
        .collect()
}

/// The R-parameters the inserted blocks use, each with its role.
#[derive(Debug, Clone)]
pub struct Registers {
    t0: u32,
    t_last: u32,
    dt: u32,
    /// The part of `dt` until the last cut.
    dt_cut: u32,
    nbl: u32,
    write_error: u32,
    attempts: u32,
    agreeing: u32,
    series_first: u32,
    series_sum: u32,
    value: u32,
    mean: u32,
    /// The position the gate left the program at, one per profile axis, and the height it travels at.
    saved: Vec<u32>,
    height: u32,
    saved_result: Option<u32>,
    /// One set per measured axis, in the order of [`Profile::measured`].
    axes: Vec<AxisRegisters>,
    /// Continuous compensation's, when the profile turns it on.
    temp_comp: Option<TempCompRegisters>,
    /// The warm start's, when the profile turns it on.
    warm: Option<WarmRegisters>,
    /// The T number and D number a gate reads where the program does not name the tool
    /// ([`crate::omm::profile::UnknownTool::Runtime`]).
    tool: Option<[u32; 2]>,
    /// The timer at the last measurement, where the profile bounds the time between measurements
    /// (`limits.max_interval_min`).
    measured_at: Option<u32>,
}

/// Registers shared by every axis (not counting the saved position).
const SHARED: usize = 13;

impl Registers {
    /// Picks free R-parameters from the profile's range, skipping those the program uses; one predictor
    /// per measured axis.
    pub fn allocate(
        profile: &Profile,
        predictors: &[Predictor],
        used: &BTreeSet<u32>,
        read_tool: bool,
    ) -> Result<Registers, String> {
        let r = &profile.registers;
        let result_r = result_r_number(&profile.probe.result);
        let save = result_r.is_some_and(|n| used.contains(&n));
        let axes = profile.position.axes.len();
        let continuous = profile.continuous.on();
        let warm = profile.warm_start.is_some();
        let interval = profile.limits.max_interval_min.is_some();
        let needed = SHARED
            + axes
            + usize::from(save)
            + predictors.iter().map(AxisRegisters::count).sum::<usize>()
            + if continuous {
                TempCompRegisters::count(predictors.len())
            } else {
                0
            }
            + if warm {
                WarmRegisters::count(predictors.len())
            } else {
                0
            }
            + if read_tool { 2 } else { 0 }
            + usize::from(interval);
        let free: Vec<u32> = (r.r_first..=r.r_last)
            .filter(|n| !used.contains(n) && Some(*n) != result_r)
            .take(needed)
            .collect();
        if free.len() < needed {
            let taken = (r.r_first..=r.r_last).filter(|n| used.contains(n)).count();
            return Err(format!(
                "not enough free R-parameters: driftloop needs {needed} in R{}…R{} (registers.r_first/r_last), but the program uses {taken} of them; widen or move the range in the profile",
                r.r_first, r.r_last
            ));
        }
        let mut it = free.into_iter();
        let mut next = || it.next().expect("counted above");
        Ok(Registers {
            t0: next(),
            t_last: next(),
            dt: next(),
            dt_cut: next(),
            nbl: next(),
            write_error: next(),
            attempts: next(),
            agreeing: next(),
            series_first: next(),
            series_sum: next(),
            value: next(),
            mean: next(),
            height: next(),
            saved: (0..axes).map(|_| next()).collect(),
            saved_result: save.then(&mut next),
            axes: predictors
                .iter()
                .map(|p| AxisRegisters::take(p, &mut next))
                .collect(),
            temp_comp: continuous.then(|| TempCompRegisters::take(predictors.len(), &mut next)),
            warm: warm.then(|| WarmRegisters::take(predictors.len(), &mut next)),
            tool: read_tool.then(|| [next(), next()]),
            measured_at: interval.then(&mut next),
        })
    }

    /// Every register, ascending.
    pub fn all(&self) -> Vec<u32> {
        let mut v = vec![
            self.t0,
            self.t_last,
            self.dt,
            self.dt_cut,
            self.nbl,
            self.write_error,
            self.attempts,
            self.agreeing,
            self.series_first,
            self.series_sum,
            self.value,
            self.mean,
            self.height,
        ];
        v.extend(&self.saved);
        v.extend(self.saved_result);
        for a in &self.axes {
            v.extend(a.all());
        }
        if let Some(t) = &self.temp_comp {
            v.extend(t.all());
        }
        if let Some(w) = &self.warm {
            v.extend(w.all());
        }
        v.extend(self.tool.iter().flatten());
        v.extend(self.measured_at);
        v.sort_unstable();
        v
    }
}

/// Whether a gate of the plan reads the tool at run time (`Emitter::reads_tool_at`): the registers for it
/// are taken only then, so other programs' outputs keep theirs.
pub fn reads_tool(plan: &Plan, profile: &Profile) -> bool {
    crate::omm::plan::reads_tool(profile) && plan.gates.iter().any(swaps_unnamed_tool)
}

/// A gate that swaps the probe for a tool the program's text does not name.
fn swaps_unnamed_tool(gate: &Gate) -> bool {
    gate.can_measure && !gate.tool_change_follows && gate.before.tool.is_none()
}

/// `R2` / `R[2]` → 2.
fn result_r_number(result: &str) -> Option<u32> {
    let rest = result.trim().strip_prefix(['R', 'r'])?;
    let rest = rest
        .strip_prefix('[')
        .and_then(|r| r.strip_suffix(']'))
        .unwrap_or(rest);
    rest.trim().parse().ok()
}

/// One measured axis as the emitter sees it: where and what it measures, and its model.
pub struct MeasuredAxis<'a> {
    /// Axis, nominal and start point ([`Profile::measured`]).
    pub at: Position,
    pub predictor: &'a Predictor,
    /// The model's channel (the log's column).
    pub channel: &'a str,
}

/// Writes the inserted blocks for one program.
pub struct Emitter<'a> {
    pub profile: &'a Profile,
    pub regs: &'a Registers,
    pub axes: Vec<MeasuredAxis<'a>>,
    /// Label prefix no label of the program starts with.
    pub label_prefix: String,
    /// Tells the models apart in the warm-start store ([`crate::omm::warm::fingerprint`]).
    pub fingerprint: u32,
    /// The subprogram the program changes tools with (`L6`): the gates' tool changes call it too, after
    /// `T=`, instead of the profile's M6, which the machine may not take outside its macro.
    pub tool_change_call: Option<String>,
}

fn r(n: u32) -> String {
    format!("R{n}")
}

impl Emitter<'_> {
    /// Lines with the marker comment appended.
    fn finish(lines: Vec<String>) -> String {
        let mut out = String::new();
        for l in lines {
            out.push_str(&l);
            if !l.is_empty() {
                out.push(' ');
            }
            out.push_str(MARK);
            out.push('\n');
        }
        out.pop();
        out
    }

    /// The header comment; `models` are the channels and the SHA-256 of their files.
    pub fn header(&self, models: &[(&str, &str)]) -> String {
        let models: Vec<String> = models
            .iter()
            .map(|(channel, sha)| format!("model {channel} sha256 {}", &sha[..sha.len().min(16)]))
            .collect();
        Emitter::finish(vec![format!(
            "; {SIGNATURE} {}: thermal drift compensation by on-machine measurement; {}, profile {}",
            env!("CARGO_PKG_VERSION"),
            models.join(", "),
            self.profile.name
        )])
    }

    fn mm(um: f64) -> String {
        number(um / 1000.0)
    }

    fn reg(&self, k: usize) -> &AxisRegisters {
        &self.regs.axes[k]
    }

    fn frame_target(&self, k: usize) -> String {
        let axis = self.axes[k].at.axis.name();
        match self.profile.offset.method {
            OffsetMethod::Active => format!("$P_IFRAME[{axis},TR]"),
            _ => format!("$P_UIFR[{},{axis},TR]", self.profile.offset.frame),
        }
    }

    /// The stored coarse translation of the work offset in force on axis `k` (`method = "active"`).
    fn stored_in_force(&self, k: usize) -> String {
        format!("$P_UIFR[$P_UIFRNUM,{},TR]", self.axes[k].at.axis.name())
    }

    /// `method = "active"`: sets the offset in force to its stored value plus the correction in `reg`.
    fn set_in_force(&self, k: usize, reg: u32) -> String {
        format!(
            "{}={}+{}",
            self.frame_target(k),
            self.stored_in_force(k),
            self.offset_value(reg)
        )
    }

    /// Whether a correction must select the offset again to act (`active` writes the offset in force).
    fn selects(&self) -> bool {
        self.profile.offset.method != OffsetMethod::Active
    }

    /// The stored value of every corrected offset component as it was before the program, and of the
    /// temperature compensation.
    fn restore_values(&self) -> Vec<String> {
        let mut v = self.restore_offset_values();
        v.extend(self.temp_comp_restore());
        v
    }

    fn restore_offset_values(&self) -> Vec<String> {
        (0..self.axes.len())
            .map(|k| {
                let axis = self.axes[k].at.axis.name();
                let reg = self.reg(k);
                match self.profile.offset.method {
                    OffsetMethod::Frame => format!("{}={}", self.frame_target(k), r(reg.base)),
                    OffsetMethod::Active => {
                        format!("{}={}", self.frame_target(k), self.stored_in_force(k))
                    }
                    OffsetMethod::Trans => "TRANS".to_string(),
                    OffsetMethod::Atrans => format!("ATRANS {axis}=-{}", r(reg.applied)),
                }
            })
            .collect::<Vec<_>>()
            .into_iter()
            .fold(Vec::new(), |mut v, line| {
                if !v.contains(&line) {
                    v.push(line);
                }
                v
            })
    }

    /// Blocks that put the work offset back to its value before the program, and select it.
    fn restore_offset(&self) -> Vec<String> {
        let mut v = self.restore_values();
        if self.selects() {
            v.push(self.profile.offset.select.clone());
        }
        v
    }

    /// The correction register as the offset takes it: doubled for an offset kept in diameter.
    fn offset_value(&self, reg: u32) -> String {
        if self.profile.offset.diameter {
            format!("2*{}", r(reg))
        } else {
            r(reg)
        }
    }

    /// Blocks that apply every axis's correction `corr` and re-select the work offset.
    fn apply_correction(&self) -> Vec<String> {
        let mut v = Vec::new();
        for k in 0..self.axes.len() {
            let axis = self.axes[k].at.axis.name();
            let reg = self.reg(k);
            match self.profile.offset.method {
                OffsetMethod::Frame => v.push(format!(
                    "{}={}+{}",
                    self.frame_target(k),
                    r(reg.base),
                    self.offset_value(reg.corr)
                )),
                OffsetMethod::Active => v.push(self.set_in_force(k, reg.corr)),
                OffsetMethod::Trans => {
                    v.push(format!("TRANS {axis}={}", self.offset_value(reg.corr)))
                }
                OffsetMethod::Atrans => {
                    let change = if self.profile.offset.diameter {
                        format!("2*({}-{})", r(reg.corr), r(reg.applied))
                    } else {
                        format!("{}-{}", r(reg.corr), r(reg.applied))
                    };
                    v.push(format!("ATRANS {axis}={change}"));
                }
            }
            v.push(format!("{}={}", r(reg.applied), r(reg.corr)));
        }
        if self.selects() {
            v.push(self.profile.offset.select.clone());
        }
        v
    }

    /// `method = "active"`: the correction in force now, read back from the offset, as the program's own
    /// selection of a work offset (or a RESET) drops it.
    fn correction_in_force(&self) -> Vec<String> {
        if self.selects() {
            return Vec::new();
        }
        (0..self.axes.len())
            .map(|k| {
                let change = format!("{}-{}", self.frame_target(k), self.stored_in_force(k));
                let change = if self.profile.offset.diameter {
                    format!("({change})/2")
                } else {
                    change
                };
                format!("{}={change}", r(self.reg(k).applied))
            })
            .collect()
    }

    /// `method = "active"`, once before the program's first statement: no correction applied yet (an
    /// R-parameter keeps its value from an earlier program, which a selection must not apply).
    pub fn no_correction_yet(&self) -> Option<String> {
        (!self.selects()).then(|| {
            let mut v = vec!["; driftloop: no correction applied yet".to_string()];
            v.extend((0..self.axes.len()).map(|k| format!("{}=0", r(self.reg(k).applied))));
            Emitter::finish(v)
        })
    }

    /// `method = "active"`, after a block that selects a work offset: the correction again, on the newly
    /// selected offset; in metric when `inch` (G70, G700) is in force there.
    pub fn reapply(&self, inch: Option<u32>) -> Option<String> {
        (!self.selects()).then(|| {
            let mut v = vec![
                "; driftloop: the program selected a work offset: the correction again".to_string(),
            ];
            v.extend(inch.map(|_| METRIC.to_string()));
            v.extend((0..self.axes.len()).map(|k| self.set_in_force(k, self.reg(k).applied)));
            v.extend(inch.map(|g| format!("G{g}")));
            Emitter::finish(v)
        })
    }

    /// `lines` (a comment first) in metric where the program has inch dimensions in force (`b`): the
    /// registers, the profile's lengths and the frames driftloop writes are mm; G710 also reads and writes
    /// system variables in mm, where G70 reads them in the basic system and G700 in inch. The program's
    /// unit comes back at the end, with its feed, which only G700 reads in inch.
    fn in_metric(b: &Modal, mut lines: Vec<String>) -> Vec<String> {
        if let (true, Some(g)) = (b.inch(), b.units) {
            lines.insert(1.min(lines.len()), METRIC.to_string());
            let feed = b
                .feed
                .map(|f| format!(" F{}", number(f)))
                .unwrap_or_default();
            lines.push(format!("G{g}{feed}"));
        }
        lines
    }

    /// Stops the program for good: the work offset back to its value before the program first — SETAL stops
    /// the interpreter, so nothing after it runs, and the offset persists through a RESET — then message,
    /// user alarm, and M0 / M30 should the control go on.
    fn abort(&self, message: &str, alarm: u32) -> Vec<String> {
        self.abort_with(&format!("\"{}\"", message.replace('"', "'")), alarm)
    }

    /// [`Emitter::abort`] with the message an NC string expression (`"…"<<R1`).
    fn abort_with(&self, message: &str, alarm: u32) -> Vec<String> {
        let mut v = self.restore_offset();
        v.push(format!("MSG({message})"));
        v.push(format!("SETAL({alarm})"));
        v.push("M0".into());
        v.push("M30".into());
        v
    }

    /// Where the profile bounds the time between measurements: the timer now is the last measurement's.
    fn note_measured(&self) -> Option<String> {
        let at = self.regs.measured_at?;
        Some(format!("{}={}", r(at), r(self.regs.t_last)))
    }

    /// Where the profile bounds the time between measurements: the condition that it has not run out
    /// (the timer counts in its own unit).
    fn interval_left(&self) -> Option<String> {
        let at = self.regs.measured_at?;
        let minutes = self.profile.limits.max_interval_min?;
        let limit = match self.profile.registers.timer_unit {
            TimerUnit::S => minutes * 60.0,
            TimerUnit::Min => minutes,
        };
        Some(format!(
            "{}-{}<{}",
            r(self.regs.t_last),
            r(at),
            number(limit)
        ))
    }

    /// Reads the timer into `dt` (minutes since the last update) and advances `t_last`.
    fn read_timer(&self) -> Vec<String> {
        let reg = &self.regs;
        let timer = &self.profile.registers.timer;
        let mut v = vec![
            "STOPRE".into(),
            format!("{}={timer}-{}", r(reg.dt), r(reg.t_last)),
            format!("{}={}+{}", r(reg.t_last), r(reg.t_last), r(reg.dt)),
        ];
        if self.profile.registers.timer_unit == TimerUnit::S {
            v.push(format!("{}={}/60", r(reg.dt), r(reg.dt)));
        }
        v
    }

    /// The exact state update of every axis's modes and input lags over `dt`, then the targets for the
    /// speed and inputs from here on. With `idle` (a gate that can measure, some minutes after the last cut)
    /// the update goes in two steps and keeps each prediction at the cut in `pred_cut`: the same result, as
    /// the update is exact for a constant target.
    fn update_prediction(&self, rpm: f64, idle: Option<f64>) -> Vec<String> {
        let mut v = Vec::new();
        if let Some(idle) = idle {
            let (dt, cut) = (r(self.regs.dt), r(self.regs.dt_cut));
            v.push(format!("{cut}={dt}-{}", number(idle)));
            v.push(format!("IF {cut}<0"));
            v.push(format!("{cut}=0"));
            v.push("ENDIF".into());
        }
        for k in 0..self.axes.len() {
            v.extend(self.update_axis(k, rpm, idle.is_some()));
        }
        v
    }

    fn update_axis(&self, k: usize, rpm: f64, split: bool) -> Vec<String> {
        let reg = self.reg(k);
        let predictor = self.axes[k].predictor;
        let lags: Vec<(u32, u32, f64)> = reg
            .x
            .iter()
            .zip(&reg.g)
            .zip(predictor.taus())
            .map(|((x, g), tau)| (*x, *g, *tau))
            .chain(reg.lags.iter().map(|l| (l.x, l.g, l.tau_min)))
            .collect();
        let step = |dt: &str| -> Vec<String> {
            lags.iter()
                .map(|&(x, g, tau)| {
                    format!(
                        "{x}={g}+({x}-{g})*EXP(-{dt}/{tau})",
                        x = r(x),
                        g = r(g),
                        tau = number(tau)
                    )
                })
                .collect()
        };
        let mut v = Vec::new();
        let (dt, cut) = (r(self.regs.dt), r(self.regs.dt_cut));
        if split {
            v.extend(step(&cut));
            v.push(format!("{}={}", r(reg.pred_cut), self.prediction_sum(k)));
            v.extend(step(&format!("({dt}-{cut})")));
        } else {
            v.extend(step(&dt));
        }
        v.extend(self.set_targets(k, rpm));
        let term = |gain: f64, n: u32| {
            format!("{}*($A_INA[{n}]-{})", Emitter::mm(gain), r(reg.zero_of(n)))
        };
        let names = |signals: Vec<&str>| signals.join(", ");
        // The input holds from here to the next gate, as a log row's inputs do.
        for lag in &reg.lags {
            let terms: Vec<_> = lag.terms.iter().map(|&i| &predictor.inputs()[i]).collect();
            let sum: Vec<String> = terms
                .iter()
                .map(|t| term(t.gain_per_unit, t.input))
                .collect();
            let signals = names(terms.iter().map(|t| t.signal.as_str()).collect());
            let comment = format!("{signals} lagged {} min", number(lag.tau_min));
            v.extend(sum_blocks(lag.g, &sum, &comment));
        }
        // Static inputs act at once: read now, not held from the last gate.
        if let Some(statics) = reg.statics {
            let terms = predictor.statics();
            let sum: Vec<String> = terms
                .iter()
                .map(|t| term(t.gain_per_unit, t.input))
                .collect();
            let signals = names(terms.iter().map(|t| t.signal.as_str()).collect());
            v.extend(sum_blocks(statics, &sum, &signals));
        }
        v.push(format!("{}={}", r(reg.pred), self.prediction_sum(k)));
        v
    }

    /// The predicted drift of axis `k` from its states: modes, input lags, static inputs and the trend.
    fn prediction_sum(&self, k: usize) -> String {
        let reg = self.reg(k);
        let sum: Vec<String> = reg
            .x
            .iter()
            .copied()
            .chain(reg.lags.iter().map(|l| l.x))
            .chain(reg.statics)
            .map(r)
            .chain(self.trend(k))
            .collect();
        let sum = if sum.is_empty() {
            "0".into()
        } else {
            sum.join("+")
        };
        match self.minus_at_zero(k) {
            Some(zero) => format!("{sum}{zero}"),
            None => sum,
        }
    }

    /// The `time_trend` term of axis `k`: µm per hour times the time since the zero.
    fn trend(&self, k: usize) -> Option<String> {
        let per_h = self.axes[k].predictor.trend_um_per_h();
        // mm per hour keeps the written rate's precision (a slow creep is a few nm per minute).
        let timer_units_per_h = match self.profile.registers.timer_unit {
            TimerUnit::Min => 60,
            TimerUnit::S => 3600,
        };
        (per_h != 0.0).then(|| {
            format!(
                "{}*({}-{})/{timer_units_per_h}",
                Emitter::mm(per_h),
                r(self.regs.t_last),
                r(self.regs.t0)
            )
        })
    }

    fn set_targets(&self, k: usize, rpm: f64) -> Vec<String> {
        self.reg(k)
            .g
            .iter()
            .zip(self.axes[k].predictor.targets_at(rpm))
            .map(|(g, um)| format!("{}={} ; {} rpm", r(*g), Emitter::mm(um), number(rpm)))
            .collect()
    }

    /// Rapid along the tool axis to the travel height, in absolute work coordinates.
    fn clear(&self) -> String {
        format!(
            "G0 G90 {}=R{}",
            self.profile.position.retract_axis.name(),
            self.regs.height
        )
    }

    /// The axes a gate travels along at the clearance height: all but the retract axis.
    fn travel_axes(&self) -> impl Iterator<Item = (usize, Axis)> + '_ {
        let p = &self.profile.position;
        p.axes
            .iter()
            .copied()
            .enumerate()
            .filter(move |(_, a)| *a != p.retract_axis)
    }

    /// The program's position (work coordinates), read after the gate's STOPRE: where the gate brings it
    /// back, whatever loop run or expression led there; and the height to travel at: the highest of the
    /// clearance height, the program's own (the tool never moves down to travel) and, for a reference in
    /// machine coordinates, its start point under the work offset in force. Nothing when the gate does not
    /// move the machine.
    fn save_position(&self, gate: &Gate) -> Vec<String> {
        let p = &self.profile.position;
        if self.profile.probe.kind == ProbeKind::Gauge {
            return Vec::new();
        }
        // In radius from here to the modal line: the saved X, the clearance and every move of the gate
        // mean the same on any control, whatever $AA_IW reports under DIAMON.
        let radius = gate.before.diameter.on().then(|| "DIAMOF".to_string());
        let saves: Vec<String> = p
            .axes
            .iter()
            .zip(&self.regs.saved)
            .map(|(a, reg)| format!("{}=$AA_IW[{}]", r(*reg), a.name()))
            .collect();
        let (h, clearance) = (
            r(self.regs.height),
            number(p.in_radius(p.retract_axis, p.clearance)),
        );
        let mut v: Vec<String> = radius
            .into_iter()
            .chain([
                saves.join(" "),
                format!("{h}={}", r(self.regs.saved[self.retract_index()])),
            ])
            .collect();
        if p.frame == MeasureFrame::Machine {
            // The clearance is a height over the part in the work offset's coordinates, the saved
            // position one in the program's, which a programmable translation on the retract axis
            // (`TRANS Z-40`, `G58`, `ATRANS`, `G59`) moves: the gate travels at the clearance under the
            // work offset, not under the program's translation. A gate in work coordinates never moves
            // under a programmable translation (it does not measure there).
            let clearance = format!("{clearance}-{}", self.frame_shift("$P_PFRAME"));
            v.extend(at_least(&h, &clearance));
            // The start point is in machine coordinates, the clearance in work coordinates: under a work
            // offset on the retract axis the clearance can lie below the start point, and the way to it and
            // back would run down towards the part. The highest start point, in work coordinates here.
            let start = self
                .axes
                .iter()
                .map(|a| a.at.start_in_radius(p.retract_axis))
                .fold(f64::NEG_INFINITY, f64::max);
            let start = format!("{}-{}", number(start), self.frame_shift("$P_ACTFRAME"));
            v.extend(at_least(&h, &start));
        } else {
            v.extend(at_least(&h, &clearance));
        }
        v.extend(self.within_retract_max());
        v
    }

    /// The translation of `frame` (`$P_ACTFRAME`: every frame in force, what `SUPA` leaves out;
    /// `$P_PFRAME`: the programmable one) on the retract axis (NC expression, radius on X). A gate moves
    /// under no rotation, scale or mirror, so a coordinate plus this is where the frame puts it. The offsets
    /// of an X kept in diameter count half.
    fn frame_shift(&self, frame: &str) -> String {
        let a = self.profile.position.retract_axis;
        let sum = format!("{frame}[{n},TR]+{frame}[{n},FI]", n = a.name());
        if a == Axis::X && self.profile.offset.diameter {
            format!("({sum})/2")
        } else {
            format!("({sum})")
        }
    }

    /// `position.retract_max`: a travel height above the machine's highest coordinate for the retract
    /// cannot be reached by rising; the gate stops before it moves (a tool already that high stays there).
    fn within_retract_max(&self) -> Vec<String> {
        let p = &self.profile.position;
        let Some(max) = p.retract_max else {
            return Vec::new();
        };
        let axis = p.retract_axis;
        let (h, here) = (
            r(self.regs.height),
            r(self.regs.saved[self.retract_index()]),
        );
        let mut v = vec![format!(
            "IF {}",
            all_of(&[
                format!("{h}>{here}"),
                format!(
                    "{h}+{}>{}",
                    self.frame_shift("$P_ACTFRAME"),
                    number(p.in_radius(axis, max))
                ),
            ])
        )];
        v.extend(self.abort(
            &format!(
                "driftloop: the travel height lies above {}{} (machine coordinates, [position] retract_max) under the work offset in force: lower [position] clearance",
                axis.name(),
                number(max)
            ),
            self.profile.registers.alarm_implausible,
        ));
        v.push("ENDIF".into());
        v
    }

    /// Index of the retract axis in the profile's axes (and the saved position).
    fn retract_index(&self) -> usize {
        let p = &self.profile.position;
        p.axes
            .iter()
            .position(|a| *a == p.retract_axis)
            .expect("validated: the axes list the retract axis")
    }

    /// Travel at the travel height to the start point of axis `k`'s probing, then along the tool axis to it.
    fn to_start_point(&self, k: usize) -> Vec<String> {
        let p = &self.profile.position;
        let coordinate = |a: Axis| self.axes[k].at.start_in_radius(a);
        let supa = match p.frame {
            MeasureFrame::Work => "",
            MeasureFrame::Machine => "SUPA ",
        };
        let across: Vec<String> = self
            .travel_axes()
            .map(|(_, a)| format!("{}{}", a.name(), number(coordinate(a))))
            .collect();
        let mut v = Vec::new();
        if !across.is_empty() {
            v.push(format!("{supa}{}", across.join(" ")));
        }
        v.push(format!(
            "{supa}{}{}",
            p.retract_axis.name(),
            number(coordinate(p.retract_axis))
        ));
        v
    }

    /// `T=<tool>` with M6 (or the builder's code), with the program's tool-change subprogram, or alone (a
    /// turret), as the machine changes tools; the profile's declared change ([`Profile::probe`] `change`) before all.
    fn load(&self, tool: &str) -> Vec<String> {
        if let Some(swap) = self.profile.probe.swap(tool) {
            return swap;
        }
        let probe = &self.profile.probe;
        match (probe.tool_change, &self.tool_change_call) {
            (ToolChange::M6, Some(call)) => vec![format!("T={tool}"), call.clone()],
            (ToolChange::M6, None) => vec![format!("T={tool} M{}", probe.tool_change_m)],
            (ToolChange::T, _) => vec![format!("T={tool}")],
        }
    }

    /// Where the control interprets the program without machining it: a block search (`$P_SEARCH`, 1…5,
    /// also during SERUPRO), program test (`$P_ISTEST`) or the operator panel's simulation (`$P_SIM`). The
    /// probe does not touch anything there, so the gate's agreement loop would stop with an alarm, and a
    /// reading taken from a stale result would correct the part wrongly. In a dry run (`$P_DRYRUN`) the
    /// probing move would run at the dry-run feed. A comment and the profile's condition that leaves the
    /// measurement out.
    fn not_machining(&self) -> [String; 2] {
        [
            "; driftloop: no measurement in a block search, program test, simulation or dry run"
                .into(),
            self.profile.registers.not_machining.clone(),
        ]
    }

    /// The run-time checks that leave a gate's measurement out, in this order: the gate's own `first`, not
    /// machining, no tool to swap the probe back for, the operator's spindle turning, then `last`. Where
    /// one holds the gate still logs its row, without a reading, shows `message` (if any) and jumps to
    /// `skip`.
    fn skip_measurement(
        &self,
        gate: &Gate,
        [first, last]: [Option<String>; 2],
        message: Option<&str>,
        rpm: f64,
        skip: &str,
    ) -> Vec<String> {
        let [why, searching] = self.not_machining();
        let mut v = vec![why];
        let mut skips: Vec<String> = first.into_iter().chain([searching]).collect();
        if let Some(read) = self.reads_tool_at(gate) {
            v.extend(Emitter::read_tool(read));
            v.extend(self.probe_left_in(gate, read));
            skips.extend(Emitter::no_tool(read));
        }
        if let Some([why, turns]) = Emitter::hand_spindle_turns(gate) {
            v.push(why);
            skips.push(turns);
        }
        skips.extend(last);
        let skip_if = format!("IF {}", any_of(&skips));
        v.push(skip_if.clone());
        v.extend(self.log_checked(rpm, gate.pass, false));
        v.extend(message.map(|m| format!("MSG(\"{m}\")")));
        v.push("ENDIF".into());
        v.push(format!("{skip_if} GOTOF {skip}"));
        v
    }

    /// Where the tool read at run time is the probe itself, a gate stopped before had left it in the
    /// spindle (its alarm ends the program with the probe loaded): the program would cut with it, so the
    /// gate stops before any move until the operator loads the program's tool. The name is read only for
    /// a tool that exists (T0 has no data, and the control evaluates both sides of an AND), and only under
    /// tool management, where tools are selected by name (`$TC_TP2`).
    fn probe_left_in(&self, gate: &Gate, [t, _]: [u32; 2]) -> Vec<String> {
        let probe = &self.profile.probe.tool;
        if !self.profile.probe.tool_by_number.contains("$TC_TP2") {
            return Vec::new();
        }
        let mut v = vec![
            format!("IF {}>0", r(t)),
            format!("IF $TC_TP2[{}]==\"{probe}\"", r(t)),
        ];
        v.extend(self.abort(
            &format!(
                "driftloop: gate {}: the probe {probe} is in the spindle: load the program's tool, then start again",
                gate.number
            ),
            self.profile.registers.alarm_tool,
        ));
        v.extend(["ENDIF".into(), "ENDIF".into()]);
        v
    }

    /// Where the gate stands before the program sets its spindle while it cuts with the operator's: a
    /// comment and the condition that leaves the measurement out when that spindle turns (`$AA_S[1]`, the
    /// actual speed of spindle 1, a main-run value: the gate's STOPRE before makes it that of the blocks run
    /// so far). The gate's M5 would stop it for good: it cannot give back a speed it never knew.
    fn hand_spindle_turns(gate: &Gate) -> Option<[String; 2]> {
        gate.hand_spindle.then(|| {
            [
                "; driftloop: the spindle as the operator left it: measured only where it stands"
                    .into(),
                "$AA_S[1]<>0".into(),
            ]
        })
    }

    /// The T and D registers of a gate that reads the tool in force before it swaps in the probe.
    fn reads_tool_at(&self, gate: &Gate) -> Option<[u32; 2]> {
        self.regs.tool.filter(|_| swaps_unnamed_tool(gate))
    }

    /// Reads the tool and cutting edge in force into `t` and `d`: preprocessing values, which a STOPRE before
    /// (the gate's first) makes those of the blocks run so far.
    fn read_tool([t, d]: [u32; 2]) -> [String; 2] {
        [format!("{}=$P_TOOLNO", r(t)), format!("{}=$P_TOOL", r(d))]
    }

    /// No tool or no cutting edge active: nothing to swap the probe back for.
    fn no_tool([t, d]: [u32; 2]) -> [String; 2] {
        [format!("{}<=0", r(t)), format!("{}<=0", r(d))]
    }

    /// After the tool read at run time is selected again: once the change has run (STOPRE), the tool and
    /// edge in force must be those read, else the program stops before the first move with the wrong one.
    fn tool_back(&self, gate: &Gate, [t, d]: [u32; 2]) -> Vec<String> {
        let wrong = [format!("$P_TOOLNO<>{}", r(t)), format!("$P_TOOL<>{}", r(d))];
        let mut v = vec!["STOPRE".to_string(), format!("IF {}", any_of(&wrong))];
        v.extend(self.abort_with(
            &format!(
                "\"driftloop: gate {}: the tool in force after the probe is not T\"<<{}<<\" D\"<<{}<<\" as before it: stopped before cutting\"",
                gate.number,
                r(t),
                r(d)
            ),
            self.profile.registers.alarm_tool,
        ));
        v.push("ENDIF".into());
        v
    }

    /// From the program's position to the first probing start point: up along the tool axis with the
    /// cutting tool, spindle and coolant off, the probe in (spindle probe), across at the travel height,
    /// down.
    fn probe_in(&self, gate: &Gate) -> Vec<String> {
        let p = self.profile;
        let mut v = Vec::new();
        if p.probe.kind == ProbeKind::Gauge {
            return v;
        }
        // The probe and its cycle work in G17, and so does every move of the gate until the way back:
        // with SD42940 TOOL_LENGTH_CONST = 0 the tool length acts along the axis perpendicular to the
        // plane, Y under G18 and X under G19, so a height along Z there is the spindle's, the tool's tip
        // a tool length lower, and the retract and the travel across would run that much below the
        // clearance. In G17 the retract (to at least the height saved in the program's plane) rises by
        // the length or more. `give_back` writes the program's plane again after its last move along Z.
        if self.other_plane(&gate.before).is_some() {
            v.push("G17".into());
        }
        v.push(self.clear());
        v.push("M5".into());
        if matches!(gate.before.coolant, Some(7 | 8 | 78)) {
            v.push("M9".into());
        }
        // Through-spindle coolant or air must not go through the probe, nor onto the setter.
        v.extend(p.coolant.off_block(gate.before.machine_coolant));
        // The cycle's probing feed is mm/min: under G93 it would be an inverse time (a probing stroke in a
        // fraction of a second), under G95 or G96 a feed per revolution of the spindle the gate has just
        // stopped. `modal_back` writes the program's feed type (and G96 with its cutting speed) again.
        if matches!(gate.before.feed_mode, Some(93 | 95)) || gate.before.css_rpm.is_some() {
            v.push("G94".into());
        }
        if p.probe.kind == ProbeKind::SpindleProbe {
            v.extend(self.load(&p.probe.written_tool()));
            v.push(format!("D{}", p.probe.tool_offset));
            v.push(self.clear());
        }
        v.extend(self.to_start_point(0));
        v
    }

    /// Measures every axis in turn: the first from where [`Emitter::probe_in`] left the probe, each next
    /// one after a retract and the travel to its start point; `expected(k)` is the value the prediction
    /// expects, `done(k)` what follows each axis's mean (its zero, or its measured drift).
    fn measure_axes(
        &self,
        what: &str,
        expected: impl Fn(usize) -> String,
        done: impl Fn(usize) -> String,
    ) -> Vec<String> {
        let mut v = Vec::new();
        for k in 0..self.axes.len() {
            if k > 0 && self.profile.probe.kind != ProbeKind::Gauge {
                v.extend(self.to_start_point(k));
            }
            v.extend(self.measure(k, &expected(k), what));
            v.push(done(k));
        }
        v
    }

    /// The measurement module of axis `k`: repeat the probing until N plausible values agree within the
    /// band; abort when the attempts are used up. `expected` is the value the prediction expects (NC
    /// expression).
    fn measure(&self, k: usize, expected: &str, what: &str) -> Vec<String> {
        let reg = &self.regs;
        let l = &self.profile.limits;
        let n = l.agree_count;
        let axis = if self.axes.len() > 1 {
            format!(" on {}", self.axes[k].at.axis.name())
        } else {
            String::new()
        };
        let mut v = vec![
            format!("{}=0", r(reg.attempts)),
            format!("{}=0", r(reg.agreeing)),
            format!("{}={SENTINEL}", r(reg.series_first)),
        ];
        if let Some(s) = reg.saved_result {
            v.push(format!("{}={}", r(s), self.profile.probe.result));
        }
        v.push(format!("WHILE {}<{n}", r(reg.agreeing)));
        v.push(format!("{}={}+1", r(reg.attempts), r(reg.attempts)));
        v.push(format!("IF {}>{}", r(reg.attempts), l.max_attempts));
        v.extend(self.abort(
            &format!(
                "driftloop: no {n} agreeing probe values{axis} in {} attempts at {what}: stopped",
                l.max_attempts
            ),
            self.profile.registers.alarm_implausible,
        ));
        v.push("ENDIF".into());
        v.push(format!("{}={}+1 ; NBL", r(reg.nbl), r(reg.nbl)));
        // A cycle that returns nothing must not leave the last value looking like a new one.
        v.push(format!("{}={SENTINEL}", self.profile.probe.result));
        v.push(self.profile.cycle_call_at(&self.axes[k].at));
        v.push("STOPRE".into());
        v.push(format!("{}={}", r(reg.value), self.profile.probe.result));
        v.push(format!(
            "IF ABS({}-({expected}))<={}",
            r(reg.value),
            Emitter::mm(l.plausibility_um)
        ));
        v.push(format!(
            "IF ABS({}-{})<={}",
            r(reg.value),
            r(reg.series_first),
            Emitter::mm(l.agree_band_um)
        ));
        v.push(format!("{}={}+1", r(reg.agreeing), r(reg.agreeing)));
        v.push(format!(
            "{}={}+{}",
            r(reg.series_sum),
            r(reg.series_sum),
            r(reg.value)
        ));
        v.push("ELSE".into());
        v.push(format!("{}=1", r(reg.agreeing)));
        v.push(format!("{}={}", r(reg.series_first), r(reg.value)));
        v.push(format!("{}={}", r(reg.series_sum), r(reg.value)));
        v.push("ENDIF".into());
        v.push("ENDIF".into());
        v.push("ENDWHILE".into());
        v.push(format!(
            "{}={}/{}",
            r(reg.mean),
            r(reg.series_sum),
            r(reg.agreeing)
        ));
        if let Some(s) = reg.saved_result {
            v.push(format!("{}={}", self.profile.probe.result, r(s)));
        }
        if self.profile.probe.kind != ProbeKind::Gauge {
            v.push(self.clear());
        }
        v
    }

    /// The cycle's result units per mm of drift: 2 for a diameter.
    fn result_factor(&self) -> &'static str {
        if self.profile.position.diameter {
            "2*"
        } else {
            ""
        }
    }

    /// The result the prediction expects on axis `k` (NC expression): the zero plus the predicted drift,
    /// less the correction in force when the measured point moves with the work offset.
    fn expected(&self, k: usize) -> String {
        let reg = self.reg(k);
        let f = self.result_factor();
        match self.profile.position.frame {
            MeasureFrame::Work => format!(
                "{}+{f}({}-{}{})",
                r(reg.zero),
                r(reg.pred),
                r(reg.applied),
                self.minus_temp_comp(k)
            ),
            MeasureFrame::Machine => match self.regs.temp_comp {
                Some(_) => format!(
                    "{}+{f}({}{})",
                    r(reg.zero),
                    r(reg.pred),
                    self.minus_temp_comp(k)
                ),
                None => format!("{}+{f}{}", r(reg.zero), r(reg.pred)),
            },
        }
    }

    /// The measured drift of axis `k` since the zero (mm), from the mean reading.
    fn measured_drift(&self, k: usize) -> String {
        let reg = self.reg(k);
        let mean = r(self.regs.mean);
        let change = if self.profile.position.diameter {
            format!("({mean}-{})/2", r(reg.zero))
        } else {
            format!("{mean}-{}", r(reg.zero))
        };
        match self.profile.position.frame {
            MeasureFrame::Work => format!(
                "{}={change}+{}{}",
                r(reg.delta),
                r(reg.applied),
                self.plus_temp_comp(k)
            ),
            MeasureFrame::Machine => format!("{}={change}{}", r(reg.delta), self.plus_temp_comp(k)),
        }
    }

    /// One CSV line of the measurement log: time_min, spindle_rpm, one drift (µm) per axis, pass, run.
    /// Without `measured` the drift cells are empty: a gate that did not measure still logs the time and
    /// the inputs from here on, which hold until the next row, so the log keeps the whole spindle and input
    /// history.
    fn log(&self, rpm: f64, pass: usize, measured: bool) -> String {
        let reg = &self.regs;
        let minutes = match self.profile.registers.timer_unit {
            TimerUnit::Min => format!("({}-{})", r(reg.t_last), r(reg.t0)),
            TimerUnit::S => format!("({}-{})/60", r(reg.t_last), r(reg.t0)),
        };
        let inputs: String = self
            .profile
            .log
            .inputs
            .values()
            .map(|n| format!("<<\",\"<<$A_INA[{n}]"))
            .collect();
        let drifts: Vec<String> = (0..self.axes.len())
            .map(|k| {
                if measured {
                    format!("\"<<{}*1000<<\"", r(self.reg(k).delta))
                } else {
                    String::new()
                }
            })
            .collect();
        format!(
            "WRITE({},\"{}\",\"\"<<{minutes}<<\",{},{},{pass},\"<<{}{inputs})",
            r(reg.write_error),
            self.profile.registers.log_file,
            number(rpm),
            drifts.join(","),
            r(reg.t0)
        )
    }

    /// A log row, and a message when the control could not append it (full memory, no file access): the
    /// part is not at risk, but the log misses a row.
    fn log_checked(&self, rpm: f64, pass: usize, measured: bool) -> Vec<String> {
        vec![
            self.log(rpm, pass, measured),
            format!("IF {}<>0", r(self.regs.write_error)),
            format!(
                "MSG(\"driftloop: {} not written (WRITE error \"<<{}<<\")\")",
                self.profile.registers.log_file,
                r(self.regs.write_error)
            ),
            "ENDIF".into(),
        ]
    }

    /// After measuring: the cutting tool back (spindle probe) and its preselection, across at the clearance
    /// height to where the program stood, spindle and coolant on, down along the tool axis, and the modal
    /// state as the program left it. Before a tool change of the program's own only the preselection and
    /// the modal state: the probe goes out with that change.
    fn give_back(&self, gate: &Gate) -> Vec<String> {
        let b: &Modal = &gate.before;
        let p = self.profile;
        let mut v = Vec::new();
        let preselection = b.selected.as_ref().filter(|s| b.tool.as_ref() != Some(*s));
        if p.probe.kind == ProbeKind::SpindleProbe {
            if gate.tool_change_follows {
                // The program's M6 loads what it selected; the probe's T replaced that selection.
                if let (ToolChange::M6, Some(sel)) = (p.probe.tool_change, &b.selected) {
                    v.push(format!("T={sel}"));
                }
                // The tool change stops the spindle, not the coolant: the program's next tool starts in
                // the coolant it had.
                v.extend(coolant_on(b.coolant));
                v.extend(self.modal_back(b));
                return v;
            }
            let read = self.reads_tool_at(gate);
            match (&b.tool, read) {
                (Some(tool), _) => v.extend(self.load(tool)),
                (None, Some([t, _])) => v.extend(self.load(&p.probe.reselect(&r(t)))),
                (None, None) => {}
            }
            if let (ToolChange::M6, Some(sel)) = (p.probe.tool_change, preselection) {
                v.push(format!("T={sel}"));
            }
            match (read, b.d) {
                (Some([_, d]), _) => v.push(format!("D={}", r(d))),
                (None, Some(d)) => v.push(format!("D{d}")),
                (None, None) => {}
            }
            if let Some(read) = read {
                v.extend(self.tool_back(gate, read));
            }
            // Up in G17 (the tool tip at the travel height), then the program's plane: its length
            // acts on Z again only with the descent to the saved height, after the travel across.
            v.push(self.clear());
            v.extend(self.other_plane(b));
        } else if p.probe.kind != ProbeKind::Gauge {
            v.extend(self.other_plane(b));
        }
        if p.probe.kind != ProbeKind::Gauge {
            let across: Vec<String> = self
                .travel_axes()
                .map(|(k, a)| format!("{}=R{}", a.name(), self.regs.saved[k]))
                .collect();
            if !across.is_empty() {
                v.push(across.join(" "));
            }
            if b.rpm() > 0.0 {
                // The probing ran in G94 (`probe_in`): under constant cutting speed S is a speed again
                // only with G96 in the block.
                let css = if b.css_rpm.is_some() { "G96 " } else { "" };
                v.push(format!("{css}S{} M{}", number(b.s), b.direction));
            }
            v.extend(coolant_on(b.coolant));
            v.extend(p.coolant.on_block(b.machine_coolant));
            v.push(format!(
                "{}=R{}",
                p.position.retract_axis.name(),
                self.regs.saved[self.retract_index()]
            ));
            v.extend(self.modal_back(b));
        }
        // A gauge gate moves nothing and changes no modal state (its cycle must leave the state as it
        // found it): nothing to give back, and nothing written from a state the timeline may not know
        // (after a dressing subprogram, say).
        v
    }

    /// On a milling machine (gates that move Y), the program's plane when it is G18 or G19, which the
    /// gate leaves for G17 before its first move: the travel back to the saved position and the descent
    /// run in the program's plane, its tool length acting as it did. A lathe works in G18 and its setter
    /// with it.
    fn other_plane(&self, b: &Modal) -> Option<String> {
        let milling = self.profile.position.axes.contains(&Axis::Y);
        b.plane
            .filter(|p| milling && matches!(p, 18 | 19))
            .map(|p| format!("G{p}"))
    }

    /// The modal G codes and feed the gate's moves and the cycle may have changed, as the program had them.
    fn modal_back(&self, b: &Modal) -> Vec<String> {
        let mut words = Vec::new();
        // Under constant cutting speed the feed type is G96 with its cutting speed: G95 (its group) would
        // end it and leave the spindle at a fixed speed for the rest of the program.
        let feed_mode = match b.css_rpm {
            Some(_) => Some(format!("G96 S{}", number(b.s))),
            None => b.feed_mode.map(|g| format!("G{g}")),
        };
        let plane = b.plane.map(|g| format!("G{g}"));
        let path = b.path_mode.map(|g| format!("G{g}"));
        words.extend([plane, feed_mode, path].into_iter().flatten());
        words.push(format!("G{}", b.motion));
        words.push(if b.absolute { "G90" } else { "G91" }.to_string());
        if b.diameter.on() && self.profile.probe.kind != ProbeKind::Gauge {
            words.push(b.diameter.command().into());
        }
        if let Some(f) = b.feed {
            words.push(format!("F{}", number(f)));
        }
        vec![words.join(" ")]
    }

    fn describe(gate: &Gate, pass_tool: Option<&str>) -> String {
        let tool = pass_tool
            .map(|t| match t.strip_prefix('"') {
                Some(name) => format!(" {}", name.trim_end_matches('"').replace('"', "")),
                None => format!(" T{t}"),
            })
            .unwrap_or_default();
        match gate.kind {
            GateKind::Reference => {
                format!("gate {} (reference, pass {}{tool})", gate.number, gate.pass)
            }
            _ => format!("gate {} (pass {}{tool})", gate.number, gate.pass),
        }
    }

    /// The initial block: stage 1 (initial data) and stage 4 (reference measurement, the zero of every
    /// axis). `cut_rpm` is the speed the first pass cuts at: a log row's inputs hold until the next row,
    /// and the spindle is only stopped for the zero itself.
    pub fn reference(&self, gate: &Gate, pass_tool: Option<&str>, cut_rpm: f64) -> String {
        let reg = &self.regs;
        let p = self.profile;
        let what = Emitter::describe(gate, pass_tool);
        let mut v = vec![
            "; driftloop stage 1: initial data".to_string(),
            "STOPRE".into(),
        ];
        v.extend(self.temp_comp_start());
        v.extend([
            format!("{}={}", r(reg.t0), p.registers.timer),
            format!("{}={}", r(reg.t_last), r(reg.t0)),
            format!("{}=0", r(reg.nbl)),
        ]);
        v.extend(self.note_measured());
        for (k, axis) in self.axes.iter().enumerate() {
            let a = self.reg(k);
            let lags = a.lags.iter().flat_map(|l| [l.x, l.g]);
            for x in a.x.iter().copied().chain(lags).chain(a.statics) {
                v.push(format!("{}=0", r(x)));
            }
            let model = axis.predictor;
            let signals = model.inputs().iter().map(|t| (t.input, &t.signal));
            let signals: Vec<_> = signals
                .chain(model.statics().iter().map(|t| (t.input, &t.signal)))
                .collect();
            for &(input, zero) in &a.zeros {
                let signal = signals.iter().find(|s| s.0 == input).map_or("", |s| s.1);
                v.push(format!("{}=$A_INA[{input}] ; {signal}", r(zero)));
            }
            for reg_n in [
                a.pred,
                a.pred_at_measurement,
                a.eps,
                a.corr,
                a.applied,
                a.delta,
            ] {
                v.push(format!("{}=0", r(reg_n)));
            }
            v.push(match p.offset.method {
                OffsetMethod::Frame => format!("{}={}", r(a.base), self.frame_target(k)),
                OffsetMethod::Trans | OffsetMethod::Atrans | OffsetMethod::Active => {
                    format!("{}=0", r(a.base))
                }
            });
        }
        v.extend(self.warm_load());
        let channels: String = self
            .axes
            .iter()
            .map(|a| format!(",{}", a.channel))
            .collect();
        v.push(format!(
            "WRITE({},\"{}\",\"time_min,{}{channels},pass,run{}\")",
            r(reg.write_error),
            p.registers.log_file,
            crate::data::SPINDLE,
            p.log
                .inputs
                .keys()
                .map(|k| format!(",{k}"))
                .collect::<String>()
        ));
        if self.selects() {
            v.push(p.offset.select.clone());
        }
        // With no tool active there is no zero: the gates after see the measurement counter at 0 and do not
        // measure either.
        let skip = format!("{}SKIP{}", self.label_prefix, gate.number);
        // Without the zero no gate of this run measures: the operator is told at once, not by the log.
        let message = "driftloop: no zero measured (block search, test, dry run, no tool or the spindle turning): this run corrects by the model only";
        v.extend(self.skip_measurement(gate, [None, None], Some(message), cut_rpm, &skip));
        v.extend(self.save_position(gate));
        v.extend(self.probe_in(gate));
        v.push("; driftloop stage 4: reference measurement, the zero".into());
        v.extend(self.measure_axes(
            &what,
            |k| number(self.axes[k].at.nominal),
            |k| format!("{}={}", r(self.reg(k).zero), r(reg.mean)),
        ));
        v.extend(self.log_checked(cut_rpm, gate.pass, true));
        v.extend(self.give_back(gate));
        v.push(format!("{skip}:"));
        for k in 0..self.axes.len() {
            v.extend(self.set_targets(k, gate.rpm));
        }
        Emitter::finish(Emitter::in_metric(&gate.before, v))
    }

    /// A gate: prediction update; if it can measure, the Cycle_in decision and the measurement module;
    /// then the correction.
    pub fn gate(&self, gate: &Gate, pass_tool: Option<&str>) -> String {
        let l = &self.profile.limits;
        let what = Emitter::describe(gate, pass_tool);
        let mut v = vec![format!(
            "; driftloop {what}: predicted {} um, planned: {}",
            number((gate.predicted_um * 10.0).round() / 10.0),
            gate.planned()
        )];
        v.extend(self.read_timer());
        v.extend(self.correction_in_force());
        let idle = (gate.can_measure && gate.idle_min > 0.0).then_some(gate.idle_min);
        v.extend(self.update_prediction(gate.rpm, idle));
        v.extend(self.warm_store());
        if gate.can_measure {
            let skip = format!("{}SKIP{}", self.label_prefix, gate.number);
            // Cycle_in: no axis's prediction changed by δ' since its last measurement (nor, where the
            // profile bounds it, did the time between measurements run out).
            let calm = (!self.profile.log.measure_every_gate).then(|| {
                let mut calm: Vec<String> = (0..self.axes.len())
                    .map(|k| {
                        let a = self.reg(k);
                        format!(
                            "ABS({}-{})<{}",
                            r(a.pred),
                            r(a.pred_at_measurement),
                            Emitter::mm(l.working_limit_um())
                        )
                    })
                    .collect();
                calm.extend(self.interval_left());
                all_of(&calm)
            });
            // The zero was not measured (a block search started after it, no tool active or the
            // operator's spindle turning at the reference): nothing to measure against.
            let no_zero = format!("{}==0", r(self.regs.nbl));
            v.extend(self.skip_measurement(gate, [calm, Some(no_zero)], None, gate.rpm, &skip));
            v.extend(self.save_position(gate));
            v.extend(self.probe_in(gate));
            v.extend(self.measure_axes(&what, |k| self.expected(k), |k| self.measured_drift(k)));
            // The error of the part cut since the last gate: on each axis the measured drift at its last
            // cut (the drift since then without cutting, as the model predicts it, taken off) against the
            // correction in force while it was cut.
            for k in 0..self.axes.len() {
                let a = self.reg(k);
                let since_cut = match idle {
                    Some(_) => format!("-({}-{})", r(a.pred), r(a.pred_cut)),
                    None => String::new(),
                };
                v.push(format!(
                    "IF ABS({}{since_cut}-{}{})>{}",
                    r(a.delta),
                    r(a.applied),
                    self.minus_temp_comp(k),
                    Emitter::mm(l.tolerance_um)
                ));
                // The scrap reading is logged before the stop, for the record and for `diagnose`.
                v.extend(self.log_checked(gate.rpm, gate.pass, true));
                let axis = if self.axes.len() > 1 {
                    format!(" on {}", self.axes[k].at.axis.name())
                } else {
                    String::new()
                };
                v.extend(self.abort(
                    &format!(
                        "driftloop: measured error{axis} beyond the tolerance {} um at {what}: part is scrap",
                        number(l.tolerance_um)
                    ),
                    self.profile.registers.alarm_scrap,
                ));
                v.push("ENDIF".into());
            }
            for k in 0..self.axes.len() {
                let a = self.reg(k);
                v.push(format!("{}={}-{}", r(a.eps), r(a.delta), r(a.pred)));
                v.push(format!("{}={}", r(a.pred_at_measurement), r(a.pred)));
            }
            v.extend(self.note_measured());
            // The speed the prediction runs on from here (the targets above), as the unmeasured rows log it.
            v.extend(self.log_checked(gate.rpm, gate.pass, true));
            v.extend(self.give_back(gate));
            v.push(format!("{skip}:"));
        } else {
            v.extend(self.log_checked(gate.rpm, gate.pass, false));
        }
        for k in 0..self.axes.len() {
            let a = self.reg(k);
            v.push(format!("{}={}+{}", r(a.corr), r(a.pred), r(a.eps)));
        }
        v.extend(self.temp_comp_at_gate());
        v.extend(self.apply_correction());
        Emitter::finish(Emitter::in_metric(&gate.before, v))
    }

    /// Before the program ends: the work offset back to its value before the program; with a warm start
    /// the states first brought up to now (the speed of the last gate held till here) and stored. In
    /// metric when `inch` (G70, G700) is in force there: the stored base values are mm.
    pub fn end(&self, rpm: f64, inch: Option<u32>) -> String {
        let mut v =
            vec!["; driftloop: work offset back to its value before the program".to_string()];
        v.extend(inch.map(|_| METRIC.to_string()));
        if self.regs.warm.is_some() {
            v.extend(self.read_timer());
            v.extend(self.update_prediction(rpm, None));
            v.extend(self.warm_store());
        }
        // The stored values only: the program ends here, and may not be running in the offset now.
        v.extend(self.restore_values());
        v.extend(inch.map(|g| format!("G{g}")));
        Emitter::finish(v)
    }
}

/// The conditions joined by AND, each in brackets when there are several: the control's comparisons bind
/// looser than AND (`a<b AND c<d` is `a<(b AND c)<d`).
fn all_of(conditions: &[String]) -> String {
    joined(conditions, " AND ")
}

/// The conditions joined by OR, bracketed as in [`all_of`].
fn any_of(conditions: &[String]) -> String {
    joined(conditions, " OR ")
}

fn joined(conditions: &[String], operator: &str) -> String {
    match conditions {
        [one] => one.clone(),
        _ => conditions
            .iter()
            .map(|c| format!("({c})"))
            .collect::<Vec<_>>()
            .join(operator),
    }
}

/// `reg` raised to `floor` where it is below (NC blocks).
fn at_least(reg: &str, floor: &str) -> [String; 3] {
    [
        format!("IF {reg}<{floor}"),
        format!("{reg}={floor}"),
        "ENDIF".into(),
    ]
}

/// The block that turns the coolant `c` on again (M7, M8, both for 78); nothing when it was off.
fn coolant_on(c: Option<u32>) -> Option<String> {
    match c? {
        c @ (7 | 8) => Some(format!("M{c}")),
        78 => Some("M7 M8".into()),
        _ => None,
    }
}
