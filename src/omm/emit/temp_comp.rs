//! Continuous compensation (`[continuous] mode = "temp_comp"`): the blocks that apply the prediction through
//! the control's position-independent temperature compensation, setting data SD43900
//! `$SA_TEMP_COMP_ABS_VALUE[axis]` (mm), between the gates.
//!
//! The arithmetic, per measured axis, with `applied` the work-offset correction in force and `tc` driftloop's
//! part of SD43900 in force (both mm, in the sign of the correction):
//! - the correction in force is `applied + tc`, never one of them twice: a probe reading, the value a reading
//!   is expected at and the scrap decision count both;
//! - a refresh moves `tc` towards `pred + eps − applied` (the prediction less the residual `eps` the last
//!   measurement found, less what the offset already takes) by at most `max_step_um`;
//! - a gate computes the full correction `corr = pred + eps`, refreshes `tc` towards `corr − applied` the
//!   same way and gives the work offset the rest, `corr − tc`: after a gate the correction in force is `corr`
//!   exactly, as without continuous compensation.
//!
//! SD43900 = its value at the start + `sign`·`tc`; the start value comes back at the end and before every
//! alarm, as the work offset does.

use super::{Emitter, r};
use crate::omm::nc::number;
use crate::omm::plan::Gate;

/// SD43900, indexed by the axis name.
const SD: &str = "$SA_TEMP_COMP_ABS_VALUE";
/// MD32750: bit 0 switches on the position-independent temperature compensation of an axis.
const MD: &str = "$MA_TEMP_COMP_TYPE";

/// The R-parameters of continuous compensation.
#[derive(Debug, Clone)]
pub(super) struct TempCompRegisters {
    /// Scratch: the change one refresh makes.
    change: u32,
    /// Per measured axis: SD43900 at the start, and driftloop's part of it in force.
    base: Vec<u32>,
    value: Vec<u32>,
}

impl TempCompRegisters {
    pub(super) fn count(axes: usize) -> usize {
        1 + 2 * axes
    }

    pub(super) fn take(axes: usize, next: &mut impl FnMut() -> u32) -> TempCompRegisters {
        TempCompRegisters {
            change: next(),
            base: (0..axes).map(|_| next()).collect(),
            value: (0..axes).map(|_| next()).collect(),
        }
    }

    pub(super) fn all(&self) -> impl Iterator<Item = u32> + '_ {
        std::iter::once(self.change)
            .chain(self.base.iter().copied())
            .chain(self.value.iter().copied())
    }
}

impl Emitter<'_> {
    fn axis_name(&self, k: usize) -> &'static str {
        self.axes[k].at.axis.name()
    }

    /// `-Rtc` for axis `k`: what the compensation takes off a reading; empty when continuous compensation
    /// is off.
    pub(super) fn minus_temp_comp(&self, k: usize) -> String {
        self.regs
            .temp_comp
            .as_ref()
            .map_or(String::new(), |t| format!("-{}", r(t.value[k])))
    }

    /// `+Rtc` for axis `k`.
    pub(super) fn plus_temp_comp(&self, k: usize) -> String {
        self.regs
            .temp_comp
            .as_ref()
            .map_or(String::new(), |t| format!("+{}", r(t.value[k])))
    }

    /// Before anything else: stop when MD32750 bit 0 is not set on a compensated axis (nothing has been
    /// changed yet, so there is nothing to give back); then keep SD43900 as it is at the start.
    pub(super) fn temp_comp_start(&self) -> Vec<String> {
        let Some(t) = &self.regs.temp_comp else {
            return Vec::new();
        };
        let names: Vec<&str> = (0..self.axes.len()).map(|k| self.axis_name(k)).collect();
        let off: Vec<String> = names
            .iter()
            .map(|a| format!("(({MD}[{a}] B_AND 1)==0)"))
            .collect();
        let mut v = vec![
            format!("IF {}", off.join(" OR ")),
            format!(
                "MSG(\"driftloop: temperature compensation off (MD32750 TEMP_COMP_TYPE bit 0 on {}): stopped\")",
                names.join(", ")
            ),
            format!("SETAL({})", self.profile.continuous.alarm),
            "M0".into(),
            "M30".into(),
            "ENDIF".into(),
        ];
        for (k, name) in names.iter().enumerate() {
            v.push(format!("{}={SD}[{name}]", r(t.base[k])));
            v.push(format!("{}=0", r(t.value[k])));
        }
        v
    }

    /// SD43900 back to its value at the start, after the look-ahead stop: the program ends or stops here.
    pub(super) fn temp_comp_restore(&self) -> Vec<String> {
        let Some(t) = &self.regs.temp_comp else {
            return Vec::new();
        };
        let mut v = vec!["STOPRE".to_string()];
        for k in 0..self.axes.len() {
            v.push(format!("{SD}[{}]={}", self.axis_name(k), r(t.base[k])));
        }
        v
    }

    /// Moves driftloop's part of SD43900 towards `wanted(k)` (NC expression, mm) by at most the profile's
    /// step, then writes it after a look-ahead stop: the value must not act on blocks the control has
    /// prepared before it. Nothing when continuous compensation is off.
    pub(super) fn temp_comp_refresh(&self, wanted: impl Fn(usize) -> String) -> Vec<String> {
        let Some(t) = &self.regs.temp_comp else {
            return Vec::new();
        };
        let c = &self.profile.continuous;
        let (change, step) = (r(t.change), Emitter::mm(c.max_step_um));
        let mut v = Vec::new();
        for k in 0..self.axes.len() {
            let value = r(t.value[k]);
            v.extend([
                format!("{change}={}-{value}", wanted(k)),
                format!("IF {change}>{step}"),
                format!("{change}={step}"),
                "ENDIF".into(),
                format!("IF {change}<-{step}"),
                format!("{change}=-{step}"),
                "ENDIF".into(),
                format!("{value}={value}+{change}"),
            ]);
        }
        v.push("STOPRE".into());
        let sign = if c.sign < 0 { "-" } else { "+" };
        for k in 0..self.axes.len() {
            v.push(format!(
                "{SD}[{}]={}{sign}{}",
                self.axis_name(k),
                r(t.base[k]),
                r(t.value[k])
            ));
        }
        v
    }

    /// At a gate, after `corr = pred + eps`: the compensation takes what it can of the correction, the work
    /// offset keeps the rest (`corr` becomes the offset's part).
    pub(super) fn temp_comp_at_gate(&self) -> Vec<String> {
        let Some(t) = &self.regs.temp_comp else {
            return Vec::new();
        };
        let mut v = self.temp_comp_refresh(|k| {
            let a = self.reg(k);
            format!("{}-{}", r(a.corr), r(a.applied))
        });
        for k in 0..self.axes.len() {
            let corr = r(self.reg(k).corr);
            v.push(format!("{corr}={corr}-{}", r(t.value[k])));
        }
        v
    }

    /// A refresh between gates: the prediction brought up to now and the compensation moved towards it
    /// less the residual of the last measurement. Nothing moves, nothing is measured or logged.
    pub fn refresh(&self, gate: &Gate) -> String {
        let mut v = vec![format!(
            "; driftloop refresh {} (pass {}): temperature compensation, predicted {} um",
            gate.number,
            gate.pass,
            number((gate.predicted_um * 10.0).round() / 10.0)
        )];
        v.extend(self.read_timer());
        v.extend(self.correction_in_force());
        v.extend(self.update_prediction(gate.rpm, None));
        v.extend(self.temp_comp_refresh(|k| {
            let a = self.reg(k);
            format!("{}+{}-{}", r(a.pred), r(a.eps), r(a.applied))
        }));
        Emitter::finish(Emitter::in_metric(&gate.before, v))
    }
}
