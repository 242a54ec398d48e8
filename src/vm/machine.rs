//! The virtual machine the interpreter runs against: where the tool centre point really is (thermal drift) and
//! what a probe cycle returns. The interpreter owns time and the spindle schedule; a [`Machine`] only answers.

use serde::Serialize;

use crate::model::synth::Rng;

/// Spindle speed over time, piecewise constant: `(from_min, rpm)` in time order, starting at 0 min with 0 rpm.
/// This is the schedule the thermal side integrates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpindleHistory {
    pub steps: Vec<(f64, f64)>,
}

impl Default for SpindleHistory {
    fn default() -> Self {
        SpindleHistory {
            steps: vec![(0.0, 0.0)],
        }
    }
}

impl SpindleHistory {
    /// Records that the speed is `rpm` from `t_min` on.
    pub fn set(&mut self, t_min: f64, rpm: f64) {
        match self.steps.last_mut() {
            Some(last) if last.1 == rpm => {}
            Some(last) if last.0 == t_min => last.1 = rpm,
            _ => self.steps.push((t_min, rpm)),
        }
    }

    pub fn speed_at(&self, t_min: f64) -> f64 {
        // The steps come in time order: a bisection, as the drift asks for the speed at every step.
        match self.steps.partition_point(|(t, _)| *t <= t_min) {
            0 => 0.0,
            k => self.steps[k - 1].1,
        }
    }

    /// Constant-speed intervals `(start, end, rpm)` up to `t_min`.
    pub fn intervals(&self, t_min: f64) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        self.steps
            .iter()
            .enumerate()
            .take_while(move |(_, s)| s.0 < t_min)
            .map(move |(i, &(start, rpm))| {
                let end = self.steps.get(i + 1).map_or(t_min, |n| n.0.min(t_min));
                (start, end, rpm)
            })
    }
}

/// What a probe cycle call hands back to the program.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "value")]
pub enum ProbeResult {
    /// The drift of the probed axis the probe saw, µm (true drift plus noise); the interpreter turns it into the
    /// measured position it writes into the result parameter.
    Drift(f64),
    /// A value written into the result parameter as it is (garbage, NaN): a faulty probe.
    Raw(f64),
    /// The cycle returned without writing the result parameter (no contact).
    Nothing,
}

/// One probe cycle call as the machine sees it.
#[derive(Debug, Clone)]
pub struct ProbeCall<'a> {
    /// Upper-cased cycle name, e.g. `BL9700`.
    pub cycle: &'a str,
    /// Numeric arguments as evaluated (missing ones are `None`).
    pub args: &'a [Option<f64>],
    pub axis: &'a str,
    pub t_min: f64,
    pub spindle: &'a SpindleHistory,
}

/// A machine the interpreter runs against.
pub trait Machine {
    /// Thermal drift along `axis` at `t_min` (µm): commanded minus actual tool centre point position. A
    /// positive Z drift is a spindle grown towards the part: the tool cuts deeper, and a probe meets the surface
    /// that much higher (the transform's convention: δ > 0 is corrected by adding δ to the Z offset).
    fn drift_um(&mut self, axis: &str, t_min: f64, spindle: &SpindleHistory) -> f64;

    /// Answers a probe cycle call. The default: the true drift of the probed axis, no noise.
    fn probe(&mut self, call: &ProbeCall<'_>) -> ProbeResult {
        ProbeResult::Drift(self.drift_um(call.axis, call.t_min, call.spindle))
    }

    /// Analog input `n` (`$A_INA[n]`, e.g. a temperature sensor) at `t_min`; `None`: not connected.
    fn analog_input(&self, _n: usize, _t_min: f64) -> Option<f64> {
        None
    }
}

/// A machine running a later job: its thermal state carries the spindle history of the jobs and pauses
/// before (`before`, ending at `start_min`), and a drift is counted from the job's start, as the job's zero
/// measures it. The job's own time and spindle schedule start at 0.
pub struct LaterJob<'m> {
    pub machine: &'m mut dyn Machine,
    pub before: SpindleHistory,
    pub start_min: f64,
}

impl LaterJob<'_> {
    /// The whole history: the jobs before, then this one's schedule from `start_min` on.
    fn history(&self, spindle: &SpindleHistory) -> SpindleHistory {
        let mut h = self.before.clone();
        for &(t, rpm) in &spindle.steps {
            h.set(self.start_min + t, rpm);
        }
        h
    }
}

impl Machine for LaterJob<'_> {
    fn drift_um(&mut self, axis: &str, t_min: f64, spindle: &SpindleHistory) -> f64 {
        let h = self.history(spindle);
        let at_start = self.machine.drift_um(axis, self.start_min, &self.before);
        self.machine.drift_um(axis, self.start_min + t_min, &h) - at_start
    }

    fn probe(&mut self, call: &ProbeCall<'_>) -> ProbeResult {
        let h = self.history(call.spindle);
        let at_start = self
            .machine
            .drift_um(call.axis, self.start_min, &self.before);
        match self.machine.probe(&ProbeCall {
            t_min: self.start_min + call.t_min,
            spindle: &h,
            ..call.clone()
        }) {
            ProbeResult::Drift(d) => ProbeResult::Drift(d - at_start),
            other => other,
        }
    }

    fn analog_input(&self, n: usize, t_min: f64) -> Option<f64> {
        self.machine.analog_input(n, self.start_min + t_min)
    }
}

/// Linear interpolation through `(t, value)` points in time order, held flat outside them (0 without points).
pub fn piecewise_linear(points: &[(f64, f64)], t: f64) -> f64 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    if t <= first.0 {
        return first.1;
    }
    for w in points.windows(2) {
        let ((t0, v0), (t1, v1)) = (w[0], w[1]);
        if t <= t1 {
            return v0 + (v1 - v0) * (t - t0) / (t1 - t0);
        }
    }
    points.last().map_or(0.0, |p| p.1)
}

/// How a probe call may be made to fail, for testing the program's validity logic.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ProbeFault {
    /// NaN in the result parameter.
    Nan,
    /// A value orders of magnitude off (1e6 mm).
    Garbage,
    /// The result parameter is not written.
    Nothing,
}

type DriftFn = dyn FnMut(&str, f64, &SpindleHistory) -> f64;

/// A machine whose drift is a function (or zero), with Gaussian probe noise and injected probe faults.
pub struct SimpleMachine {
    drift: Box<DriftFn>,
    noise_um: f64,
    rng: Rng,
    /// Probe calls (1-based) that fail, and how.
    faults: Vec<(usize, ProbeFault)>,
    calls: usize,
    /// Analog inputs: number → signal over time.
    analog: Vec<(usize, Vec<(f64, f64)>)>,
}

impl SimpleMachine {
    /// No drift, exact probe.
    pub fn cold() -> Self {
        Self::with_drift(|_, _, _| 0.0)
    }

    pub fn with_drift(drift: impl FnMut(&str, f64, &SpindleHistory) -> f64 + 'static) -> Self {
        SimpleMachine {
            drift: Box::new(drift),
            noise_um: 0.0,
            rng: Rng::new(1),
            faults: Vec::new(),
            calls: 0,
            analog: Vec::new(),
        }
    }

    /// Connects analog input `n` (`$A_INA[n]`) to a signal given as `(minutes, value)` points.
    pub fn analog(mut self, n: usize, points: Vec<(f64, f64)>) -> Self {
        self.analog.push((n, points));
        self
    }

    /// Gaussian probe noise with standard deviation `sigma_um`, reproducible from `seed`.
    pub fn noise(mut self, sigma_um: f64, seed: u64) -> Self {
        self.noise_um = sigma_um;
        self.rng = Rng::new(seed);
        self
    }

    /// Makes probe call number `call` (1-based) fail with `fault`.
    pub fn fault(mut self, call: usize, fault: ProbeFault) -> Self {
        self.faults.push((call, fault));
        self
    }
}

impl Machine for SimpleMachine {
    fn analog_input(&self, n: usize, t_min: f64) -> Option<f64> {
        self.analog
            .iter()
            .find(|a| a.0 == n)
            .map(|a| piecewise_linear(&a.1, t_min))
    }

    fn drift_um(&mut self, axis: &str, t_min: f64, spindle: &SpindleHistory) -> f64 {
        (self.drift)(axis, t_min, spindle)
    }

    fn probe(&mut self, call: &ProbeCall<'_>) -> ProbeResult {
        self.calls += 1;
        match self.faults.iter().find(|f| f.0 == self.calls).map(|f| f.1) {
            Some(ProbeFault::Nan) => ProbeResult::Raw(f64::NAN),
            Some(ProbeFault::Garbage) => ProbeResult::Raw(1.0e6),
            Some(ProbeFault::Nothing) => ProbeResult::Nothing,
            None => {
                let noise = if self.noise_um > 0.0 {
                    self.noise_um * self.rng.normal()
                } else {
                    0.0
                };
                ProbeResult::Drift(self.drift_um(call.axis, call.t_min, call.spindle) + noise)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spindle_history_merges_repeats_and_reports_intervals() {
        let mut h = SpindleHistory::default();
        h.set(0.0, 1000.0);
        h.set(5.0, 1000.0);
        h.set(10.0, 0.0);
        assert_eq!(h.steps, vec![(0.0, 1000.0), (10.0, 0.0)]);
        assert_eq!(h.speed_at(9.9), 1000.0);
        assert_eq!(h.speed_at(10.0), 0.0);
        let iv: Vec<_> = h.intervals(12.0).collect();
        assert_eq!(iv, vec![(0.0, 10.0, 1000.0), (10.0, 12.0, 0.0)]);
    }

    #[test]
    fn faults_hit_the_chosen_call_only() {
        let mut m = SimpleMachine::with_drift(|_, t, _| t).fault(2, ProbeFault::Nothing);
        let h = SpindleHistory::default();
        let call = |t| ProbeCall {
            cycle: "BL9700",
            args: &[],
            axis: "Z",
            t_min: t,
            spindle: &h,
        };
        assert_eq!(m.probe(&call(3.0)), ProbeResult::Drift(3.0));
        assert_eq!(m.probe(&call(4.0)), ProbeResult::Nothing);
        assert_eq!(m.probe(&call(5.0)), ProbeResult::Drift(5.0));
    }
}
