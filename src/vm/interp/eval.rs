//! Expressions, variables and system variables.

use crate::syntax::{Node, NodeKind};

use crate::vm::motion::{FRAMES, Tool};
use crate::vm::unit::Unit;
use crate::vm::value::{Value, VarType, Variable};

use super::{Interp, PLANES, external};

pub use crate::vm::config::R_COUNT;

/// The expressions of an index `[a, b]`.
pub fn index_nodes(index: &Node) -> Vec<&Node> {
    index
        .significant()
        .filter(|c| c.kind != NodeKind::Punct)
        .collect()
}

/// A number as written: digits, point, and the exponent `EX` (`1.5EX3`), any case.
pub fn parse_number(text: &str) -> Result<f64, String> {
    let parsed = if text.bytes().any(|b| b.eq_ignore_ascii_case(&b'x')) {
        text.to_ascii_uppercase().replace("EX", "E").parse()
    } else {
        text.parse()
    };
    parsed.map_err(|_| format!("`{text}` is not a number"))
}

fn deg(f: fn(f64) -> f64) -> impl Fn(f64) -> f64 {
    move |x| f(x.to_radians())
}

impl Interp<'_> {
    pub(super) fn eval(&self, u: &Unit, n: &Node) -> Result<Value, String> {
        match n.kind {
            NodeKind::Number => Ok(Value::Num(parse_number(&String::from_utf8_lossy(
                u.text(n),
            ))?)),
            NodeKind::Str => {
                let t = u.text(n);
                Ok(Value::Str(
                    String::from_utf8_lossy(&t[1..t.len() - 1]).into_owned(),
                ))
            }
            NodeKind::BitLiteral => {
                let t = u.upper(n);
                let body = &t[2..t.len() - 1];
                let radix = if t.as_bytes()[1] == b'H' { 16 } else { 2 };
                i64::from_str_radix(body, radix)
                    .map(|v| Value::Num(v as f64))
                    .map_err(|_| format!("bad bit literal {t}"))
            }
            NodeKind::Paren => {
                let inner = n
                    .significant()
                    .find(|c| c.kind != NodeKind::Punct)
                    .ok_or("empty parentheses")?;
                self.eval(u, inner)
            }
            NodeKind::Unary => {
                let parts: Vec<&Node> = n.significant().collect();
                let v = self.eval(u, parts[parts.len() - 1])?;
                match u.upper(parts[0]).as_str() {
                    "-" => Ok(Value::Num(-v.num()?)),
                    "+" => Ok(Value::Num(v.num()?)),
                    "NOT" => Ok(Value::Num(f64::from(!v.truth()?))),
                    "B_NOT" => Ok(Value::Num(!(v.num()? as i64) as f64)),
                    // `<<R1`: the value as a string.
                    "<<" => Ok(Value::Str(v.text())),
                    op => Err(format!("unknown operator {op}")),
                }
            }
            NodeKind::Binary => {
                let parts: Vec<&Node> = n.significant().collect();
                let op = u.upper(parts[1]);
                let l = self.eval(u, parts[0])?;
                let r = self.eval(u, parts[2])?;
                binary(&op, l, r)
            }
            NodeKind::FnCall => self.function(u, n),
            NodeKind::RParam => Ok(Value::Num(self.r[self.r_index(u, n)?])),
            NodeKind::SysVar => self.sysvar(u, n),
            NodeKind::Var => self.read_var(u, n),
            k => Err(format!("{} cannot be evaluated here", k.name())),
        }
    }

    pub(super) fn num(&self, u: &Unit, n: &Node) -> Result<f64, String> {
        self.eval(u, n)?.num()
    }

    pub(super) fn r_index(&self, u: &Unit, n: &Node) -> Result<usize, String> {
        let name = u.upper(n.find(NodeKind::Name).ok_or("R parameter without name")?);
        let i = match n.find(NodeKind::Index) {
            Some(ix) => {
                let [e] = index_nodes(ix)[..] else {
                    return Err("R[…] takes one index".into());
                };
                let v = self.num(u, e)?;
                if v < 0.0 || v.fract() != 0.0 {
                    return Err(format!("R parameter number {v} is not a whole number ≥ 0"));
                }
                v as usize
            }
            None => name[1..]
                .parse()
                .map_err(|_| format!("bad R parameter {name}"))?,
        };
        if i >= R_COUNT {
            return Err(format!("R{i} is beyond R{} (alarm 12140)", R_COUNT - 1));
        }
        Ok(i)
    }

    /// Index values of an indexed user variable.
    pub(super) fn indices(&self, u: &Unit, n: &Node) -> Result<Vec<usize>, String> {
        let Some(ix) = n.find(NodeKind::Index) else {
            return Ok(Vec::new());
        };
        index_nodes(ix)
            .into_iter()
            .map(|e| {
                let v = self.num(u, e)?;
                if v < 0.0 {
                    return Err(format!("negative index {v}"));
                }
                Ok(v.round() as usize)
            })
            .collect()
    }

    /// A variable of the running program, or a global one (the probe's result array).
    pub(super) fn variable(&self, name: &str) -> Option<&Variable> {
        self.stack
            .last()
            .and_then(|f| f.vars.get(name))
            .or_else(|| self.globals.get(name))
    }

    fn read_var(&self, u: &Unit, n: &Node) -> Result<Value, String> {
        let name = u.upper(n.find(NodeKind::Name).ok_or("variable without name")?);
        match name.as_str() {
            "TRUE" => return Ok(Value::Num(1.0)),
            "FALSE" => return Ok(Value::Num(0.0)),
            _ => {}
        }
        if let Some(v) = self.variable(&name) {
            return v.get(&self.indices(u, n)?);
        }
        if self.axis_index(&name).is_some() {
            return Err(format!("axis {name} used as a value"));
        }
        if external::is_cycle_result(&name) {
            let index = n.find(NodeKind::Index).map(index_nodes).unwrap_or_default();
            return Ok(Value::Num(
                self.external(self.external_key(u, &name, &index)?),
            ));
        }
        Err(format!("variable {name} is not defined (alarm 12550)"))
    }

    /// The active G code of `group` (the groups [`crate::views::indirect_g`] knows). G710 reads as G71:
    /// the dry run keeps whether the feed is in inch, not whether a metric G710 was written.
    fn active_g(&self, group: u32) -> Option<u32> {
        let m = &self.motion.modal;
        Some(match group {
            1 => m.motion,
            6 => 17 + PLANES.iter().position(|p| self.plane(*p) == m.plane)? as u32,
            7 => m.compensation,
            8 => match self.motion.frames.selected {
                0 => 500,
                s @ 1..=4 => 53 + s as u32,
                s => 500 + s as u32,
            },
            10 => m.path,
            12 => m.exact_stop,
            13 => match (m.inch, m.inch_feed) {
                (true, true) => 700,
                (true, false) => 70,
                (false, _) => 71,
            },
            14 => {
                if m.absolute {
                    90
                } else {
                    91
                }
            }
            15 if m.css => 96,
            15 => m.feed_mode.g(),
            _ => return None,
        })
    }

    pub(super) fn axis_index(&self, name: &str) -> Option<usize> {
        self.cfg.axes.iter().position(|a| a == name)
    }

    /// An axis named in an index (`$AA_IM[Z]`, `AX[Z]`), or held by an AXIS variable (`$AA_IM[_X]`).
    pub(super) fn axis_arg(&self, u: &Unit, n: &Node) -> Result<usize, String> {
        let mut name = u.upper(n);
        if self.axis_index(&name).is_none()
            && let Some(var) = self.variable(&name).filter(|v| v.ty == VarType::Axis)
        {
            name = var.get(&[])?.text();
        }
        self.axis_index(&name)
            .ok_or_else(|| format!("{name} is not an axis of this machine"))
    }

    fn sysvar(&self, u: &Unit, n: &Node) -> Result<Value, String> {
        let name = u.upper(
            n.find(NodeKind::Name)
                .ok_or("system variable without name")?,
        );
        let idx: Vec<&Node> = n.find(NodeKind::Index).map(index_nodes).unwrap_or_default();
        // The names of the geometry axes 1 to 3 (for an AXIS variable).
        if let Some(k) = ["$P_AXN1", "$P_AXN2", "$P_AXN3"]
            .iter()
            .position(|n| *n == name)
            .filter(|_| idx.is_empty())
        {
            let axis = self.motion.frames.geo[k]
                .ok_or_else(|| format!("{name}: no geometry axis {}", k + 1))?;
            return Ok(Value::Str(self.cfg.axes[axis].clone()));
        }
        if let ("$TC_TP2", [t]) = (name.as_str(), idx.as_slice()) {
            let number = self.num(u, t)?;
            let named = || {
                let mut names = self.named_tools.iter();
                names.find(|n| Tool::Name((*n).clone()).number() == number)
            };
            if let Some(name) = self.cfg.tool_name(number).or_else(|| named().map(|n| &**n)) {
                return Ok(Value::Str(name.to_string()));
            }
        }
        let m = &self.motion;
        let v = match (name.as_str(), idx.as_slice()) {
            ("$P_UIFR", [frame, axis, tr]) => {
                let (f, a, fine) = self.uifr_address(u, frame, axis, tr)?;
                if fine {
                    m.frames.fine[f][a]
                } else {
                    m.frames.table[f][a]
                }
            }
            ("$AA_IM", [axis]) => m.machine[self.axis_arg(u, axis)?],
            ("$AA_IW", [axis]) => m.work_position(self.axis_arg(u, axis)?),
            ("$P_EP", [axis]) => m.local[self.axis_arg(u, axis)?],
            ("$P_UIFRNUM", []) => m.frames.selected as f64,
            // Whether the running program was called modally (MCALL).
            ("$P_MC", []) => f64::from(u8::from(
                self.stack.last().is_some_and(|f| f.called_modally),
            )),
            // The master spindle (SETMS).
            ("$AC_MSNUM", []) => m.master as f64,
            ("$P_GG", [group]) => {
                let group = self.num(u, group)?;
                let g = (group.fract() == 0.0 && group >= 1.0)
                    .then(|| self.active_g(group as u32))
                    .flatten();
                let position = g.and_then(|g| crate::views::g_position(group as u32, g));
                f64::from(position.ok_or_else(|| {
                    format!("$P_GG[{group}]: that G group is not modelled by the dry run")
                })?)
            }
            ("$P_IFRAME", [axis, part]) => {
                let (a, f) = (self.axis_arg(u, axis)?, m.frames.selected);
                if Interp::fine_part(u, part)? {
                    m.frames.active[a] - m.frames.table[f][a]
                } else {
                    m.frames.active[a] - m.frames.fine[f][a]
                }
            }
            // The complete frame: the settable offset in force and the programmable translation, all
            // in the coarse part (a chain keeps no fine part of its own here).
            ("$P_ACTFRAME", [axis, part]) => {
                let a = self.axis_arg(u, axis)?;
                if Interp::fine_part(u, part)? {
                    0.0
                } else {
                    m.frames.offset(a)
                }
            }
            // The programmable frame's translation: TRANS and G58 write the coarse part, ATRANS and G59
            // the fine one.
            ("$P_PFRAME", [axis, part]) => {
                let (a, t) = (self.axis_arg(u, axis)?, &m.frames);
                if Interp::fine_part(u, part)? {
                    t.trans_fine[a]
                } else {
                    t.trans[a] - t.trans_fine[a]
                }
            }
            // The circle constant, which cycles and shop macros use for cutting speeds.
            ("$PI", []) => std::f64::consts::PI,
            ("$AN_POWERON_TIME" | "$AN_SETUP_TIME", []) => self.time_min,
            ("$AC_CYCLE_TIME" | "$AC_OPERATING_TIME", []) => self.time_min * 60.0,
            ("$P_F", []) => m.modal.feed.unwrap_or(0.0),
            ("$AA_S", [_] | []) => m.spindle_rpm(),
            // The dry run machines in automatic mode; the machine file may set these to run a program
            // as a block search, a program test or a simulation would.
            ("$P_SEARCH" | "$P_SEARCHL" | "$P_ISTEST" | "$P_SIM" | "$P_DRYRUN", []) => {
                self.cfg.variables.get(&name).copied().unwrap_or(0.0)
            }
            ("$P_TOOLNO", []) => m.tool.as_ref().map_or(0.0, |t| self.cfg.tool_number(t)),
            // The tool programmed last (T, the preselection), which the next M6 loads.
            ("$P_TOOLP", []) => m
                .preselected
                .as_ref()
                .map_or(0.0, |t| self.cfg.tool_number(t)),
            ("$A_INA", [n]) => {
                let n = self.num(u, n)?;
                self.machine_input(n as usize).ok_or_else(|| {
                    format!("analog input $A_INA[{n}] is not connected on this machine")
                })?
            }
            ("$P_TOOL", []) => m.d,
            ("$A_YEAR" | "$A_MONTH" | "$A_DAY" | "$A_HOUR" | "$A_MINUTE" | "$A_SECOND", []) => {
                clock_field(&name, self.cfg.clock_start_min + self.time_min)
            }
            ("$MA_TEMP_COMP_TYPE", [axis]) => f64::from(
                self.cfg
                    .temp_comp_type(&self.cfg.axes[self.axis_arg(u, axis)?]),
            ),
            ("$SA_TEMP_COMP_ABS_VALUE", [axis]) => m.temp_comp[self.axis_arg(u, axis)?],
            _ if external::is_system(&name) => self.external(self.external_key(u, &name, &idx)?),
            _ => {
                return Err(format!(
                    "system variable {name} with {} index value(s) is not supported by the dry run",
                    idx.len()
                ));
            }
        };
        Ok(Value::Num(v))
    }

    /// `$P_UIFR[n, axis, TR | FI]` → (frame, axis index, fine).
    pub(super) fn uifr_address(
        &self,
        u: &Unit,
        frame: &Node,
        axis: &Node,
        part: &Node,
    ) -> Result<(usize, usize, bool), String> {
        Ok((
            self.uifr_number(u, frame)?,
            self.axis_arg(u, axis)?,
            Interp::fine_part(u, part)?,
        ))
    }

    /// The frame number `n` of `$P_UIFR[n, …]`.
    pub(super) fn uifr_number(&self, u: &Unit, frame: &Node) -> Result<usize, String> {
        let f = self.num(u, frame)?;
        if !(0.0..FRAMES as f64).contains(&f) || f.fract() != 0.0 {
            return Err(format!("$P_UIFR frame number {f} out of range 0…99"));
        }
        Ok(f as usize)
    }

    /// A frame component: `TR` (coarse translation, false) or `FI` (fine, true).
    pub(super) fn fine_part(u: &Unit, part: &Node) -> Result<bool, String> {
        match u.upper(part).as_str() {
            "TR" => Ok(false),
            "FI" => Ok(true),
            other => Err(format!(
                "frame component {other} is not supported (translations TR and FI only)"
            )),
        }
    }

    fn function(&self, u: &Unit, n: &Node) -> Result<Value, String> {
        let name = u.upper(&n.children[0]);
        let args = n.call_arguments();
        let mut vals = Vec::with_capacity(args.len());
        for a in &args {
            vals.push(match a {
                Some(a) => self.eval(u, a)?,
                None => return Err(format!("{name}: empty argument")),
            });
        }
        let nums = || {
            vals.iter()
                .map(Value::num)
                .collect::<Result<Vec<f64>, String>>()
        };
        let one = |f: &dyn Fn(f64) -> f64| -> Result<Value, String> {
            match nums()?[..] {
                [x] => Ok(Value::Num(f(x))),
                _ => Err(format!("{name} takes one argument")),
            }
        };
        let checked = |v: f64| {
            if v.is_finite() {
                Ok(Value::Num(v))
            } else {
                Err(format!("{name}: argument out of range"))
            }
        };
        match name.as_str() {
            "SIN" => one(&deg(f64::sin)),
            "COS" => one(&deg(f64::cos)),
            "TAN" => one(&deg(f64::tan)),
            "ASIN" => checked(one(&|x| x.asin().to_degrees())?.num()?),
            "ACOS" => checked(one(&|x| x.acos().to_degrees())?.num()?),
            "ATAN2" => match nums()?[..] {
                [y, x] => Ok(Value::Num(y.atan2(x).to_degrees())),
                _ => Err("ATAN2 takes two arguments".into()),
            },
            "ABS" => one(&f64::abs),
            "SQRT" => checked(one(&f64::sqrt)?.num()?),
            "POT" => match nums()?[..] {
                [x] => Ok(Value::Num(x * x)),
                [x, y] => checked(x.powf(y)),
                _ => Err("POT takes one or two arguments".into()),
            },
            "EXP" => one(&f64::exp),
            "LN" => checked(one(&f64::ln)?.num()?),
            "TRUNC" => one(&f64::trunc),
            "ROUND" => one(&f64::round),
            "ROUNDUP" => one(&f64::ceil),
            "MINVAL" | "MAXVAL" => match nums()?[..] {
                [a, b] => Ok(Value::Num(if name == "MINVAL" {
                    a.min(b)
                } else {
                    a.max(b)
                })),
                _ => Err(format!("{name} takes two arguments")),
            },
            "BOUND" => match nums()?[..] {
                [lo, hi, x] => Ok(Value::Num(x.clamp(lo.min(hi), hi.max(lo)))),
                _ => Err("BOUND takes three arguments (min, max, value)".into()),
            },
            "STRLEN" => match &vals[..] {
                [Value::Str(s)] => Ok(Value::Num(s.chars().count() as f64)),
                _ => Err("STRLEN takes one string".into()),
            },
            "NUMBER" => match &vals[..] {
                [Value::Str(s)] => parse_number(s.trim()).map(Value::Num),
                _ => Err("NUMBER takes one string".into()),
            },
            "TOUPPER" | "TOLOWER" => match &vals[..] {
                [Value::Str(s)] => Ok(Value::Str(if name == "TOUPPER" {
                    s.to_uppercase()
                } else {
                    s.to_lowercase()
                })),
                _ => Err(format!("{name} takes one string")),
            },
            // Every named tool exists for the dry run (no tool table), so it never answers -1 (not found).
            "GETT" => match &vals[..] {
                [Value::Str(tool), duplo] => {
                    let duplo = duplo.num()?;
                    if duplo < 1.0 || duplo.fract() != 0.0 {
                        return Err(format!(
                            "GETT: duplo number {duplo} is not a whole number ≥ 1"
                        ));
                    }
                    // The first duplo is the tool `T="name"` selects, the start tool's number included.
                    Ok(Value::Num(if duplo == 1.0 {
                        self.cfg.tool_number(&Tool::Name(tool.as_str().into()))
                    } else {
                        crate::vm::tool_numbers::internal_number(tool, duplo as u32)
                    }))
                }
                _ => Err("GETT takes a tool name and a duplo number".into()),
            },
            // The axis a string names, for an AXIS variable.
            "AXNAME" => match &vals[..] {
                [Value::Str(s)] => Ok(Value::Str(s.trim().to_ascii_uppercase())),
                _ => Err("AXNAME takes a string".into()),
            },
            "IC" | "AC" | "ACP" | "ACN" | "DC" => {
                Err(format!("{name}() is only allowed as an axis value"))
            }
            _ => Err(format!("function {name} is not supported by the dry run")),
        }
    }
}

/// A field of the control's clock at `minutes` since 1970-01-01 00:00 (whole seconds, as the control has
/// them).
fn clock_field(name: &str, minutes: f64) -> f64 {
    let seconds = (minutes * 60.0).floor() as i64;
    let (days, in_day) = (seconds.div_euclid(86_400), seconds.rem_euclid(86_400));
    // Days since 1970-01-01 to the civil date (proleptic Gregorian calendar).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    (match name {
        "$A_YEAR" => year,
        "$A_MONTH" => month,
        "$A_DAY" => day,
        "$A_HOUR" => in_day / 3600,
        "$A_MINUTE" => in_day / 60 % 60,
        _ => in_day % 60,
    }) as f64
}

/// Applies a binary operator.
pub fn binary(op: &str, l: Value, r: Value) -> Result<Value, String> {
    if op == "<<" {
        return Ok(Value::Str(l.text() + &r.text()));
    }
    if let (Value::Str(a), Value::Str(b)) = (&l, &r) {
        return match op {
            "==" => Ok(Value::Num(f64::from(a == b))),
            "<>" => Ok(Value::Num(f64::from(a != b))),
            _ => Err(format!("operator {op} does not apply to strings")),
        };
    }
    let (a, b) = (l.num()?, r.num()?);
    let bool_num = |v: bool| Value::Num(f64::from(v));
    let int = |v: f64| v as i64;
    Ok(match op {
        "+" => Value::Num(a + b),
        "-" => Value::Num(a - b),
        "*" => Value::Num(a * b),
        "/" | "DIV" | "MOD" if b == 0.0 => return Err("division by zero".into()),
        "/" => Value::Num(a / b),
        "DIV" => Value::Num((a / b).trunc()),
        "MOD" => Value::Num(a % b),
        "==" => bool_num(a == b),
        "<>" => bool_num(a != b),
        "<" => bool_num(a < b),
        ">" => bool_num(a > b),
        "<=" => bool_num(a <= b),
        ">=" => bool_num(a >= b),
        "AND" => bool_num(a != 0.0 && b != 0.0),
        "OR" => bool_num(a != 0.0 || b != 0.0),
        "XOR" => bool_num((a != 0.0) != (b != 0.0)),
        "B_AND" => Value::Num((int(a) & int(b)) as f64),
        "B_OR" => Value::Num((int(a) | int(b)) as f64),
        "B_XOR" => Value::Num((int(a) ^ int(b)) as f64),
        _ => return Err(format!("operator {op} is not supported by the dry run")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_crosses_month_and_year_ends_and_leap_days() {
        let at = |days: f64, minutes: f64| {
            [
                "$A_YEAR",
                "$A_MONTH",
                "$A_DAY",
                "$A_HOUR",
                "$A_MINUTE",
                "$A_SECOND",
            ]
            .map(|f| clock_field(f, days * 1440.0 + minutes))
        };
        assert_eq!(at(0.0, 0.0), [1970.0, 1.0, 1.0, 0.0, 0.0, 0.0]);
        // 2024-02-29 is day 19 782; 2024-12-31 23:59:30 is the minute before day 20 089.
        assert_eq!(at(19_782.0, 61.5), [2024.0, 2.0, 29.0, 1.0, 1.0, 30.0]);
        assert_eq!(at(20_089.0, -0.5), [2024.0, 12.0, 31.0, 23.0, 59.0, 30.0]);
        assert_eq!(at(20_094.0, 360.0), [2025.0, 1.0, 6.0, 6.0, 0.0, 0.0]);
    }

    #[test]
    fn div_truncates_and_mod_keeps_the_fraction() {
        let n = |v| Value::Num(v);
        assert_eq!(binary("DIV", n(7.0), n(4.1)), Ok(n(1.0)));
        assert_eq!(binary("DIV", n(7.0), n(0.4)), Ok(n(17.0)));
        let m = binary("MOD", n(7.0), n(4.1)).unwrap().num().unwrap();
        assert!((m - 2.9).abs() < 1e-12);
        assert!(binary("/", n(1.0), n(0.0)).is_err());
    }

    #[test]
    fn logic_bits_and_strings() {
        let n = |v| Value::Num(v);
        assert_eq!(binary("XOR", n(1.0), n(1.0)), Ok(n(0.0)));
        assert_eq!(binary("B_AND", n(6.0), n(3.0)), Ok(n(2.0)));
        assert_eq!(binary("B_OR", n(4.0), n(1.0)), Ok(n(5.0)));
        assert_eq!(
            binary("<<", Value::Str("R=".into()), n(1.5)),
            Ok(Value::Str("R=1.5".into()))
        );
        assert_eq!(
            binary("==", Value::Str("A".into()), Value::Str("A".into())),
            Ok(n(1.0))
        );
        assert!(binary("<", Value::Str("A".into()), n(1.0)).is_err());
    }
}
