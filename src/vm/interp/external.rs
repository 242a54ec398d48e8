//! Values the dry run cannot know: tool and toolholder data, digital and analog I/O, machine and setting data,
//! the PLC's data, synchronized-action variables and the measuring cycles' results (`_OVR`, `_OVI`). A read
//! takes what the program wrote, else the machine file's `[variables]`, else 0 — and then notes it, since a
//! value the dry run made up may steer the program's flow.

use super::*;
use crate::vm::config::variable_key;

/// System variables read and written through [`Interp::external`]: by prefix of their name. Those the dry
/// run models itself (`$AA_IM`, `$P_UIFR`, `$A_INA`, `$MA_TEMP_COMP_TYPE`, …) are matched before.
const SYSTEM_FAMILIES: &[&str] = &[
    "$TC_",
    "$A_IN",
    "$A_OUT",
    "$A_DB",
    "$AC_TIME",
    "$AC_MARKER",
    "$AC_PARAM",
    "$AC_MEA",
    "$MA_",
    "$MC_",
    "$MN_",
    "$SA_",
    "$SC_",
    "$SN_",
];

/// The measuring cycles' data (GUD of the cycle package): their result arrays and the parameters a program
/// sets before calling one without arguments (`_MVAR=100 _SETVAL=0 _KNUM=1` / `CYCLE978`, as CAM posts
/// write a probing operation). Read and written like the system variables above unless the program or the
/// probe result configuration defines them.
const CYCLE_RESULTS: &[&str] = &[
    "_OVR", "_OVI", "_CBIT", "_CHBIT", "_CM", "_CORA", "_CVAL", "_EVMVNUM", "_EVNUM", "_FA", "_ID",
    "_INCA", "_K", "_KB", "_KNUM", "_MA", "_MD", "_MFS", "_MVAR", "_NMSP", "_PRNUM", "_RA",
    "_SETV", "_SETVAL", "_SPEED", "_STA1", "_SZA", "_SZO", "_TDIF", "_TENV", "_TLL", "_TMV",
    "_TNAME", "_TNUM", "_TP", "_TSA", "_TUL", "_TZL", "_VMS", "_WP",
];

/// Whether system variable `name` is one of [`SYSTEM_FAMILIES`].
pub(super) fn is_system(name: &str) -> bool {
    SYSTEM_FAMILIES.iter().any(|f| name.starts_with(f))
}

/// Whether user variable `name`, not defined, is a measuring cycle's result array.
pub(super) fn is_cycle_result(name: &str) -> bool {
    CYCLE_RESULTS.contains(&name)
}

impl Interp<'_> {
    /// The key of `name` with its index (`$TC_DP3[1,1]`): numbers evaluated, axis names as written.
    pub(super) fn external_key(
        &self,
        u: &Unit,
        name: &str,
        index: &[&Node],
    ) -> Result<String, String> {
        let mut text = name.to_string();
        if !index.is_empty() {
            let parts = index
                .iter()
                .map(|n| match n.kind {
                    NodeKind::Var if self.axis_index(&u.upper(n)).is_some() => Ok(u.upper(n)),
                    _ => self.num(u, n).map(crate::vm::value::format_number),
                })
                .collect::<Result<Vec<_>, String>>()?;
            text = format!("{name}[{}]", parts.join(","));
        }
        variable_key(&text).ok_or_else(|| format!("{text} cannot be a variable's name"))
    }

    /// The value of an external variable: written by the program, else from the machine file, else 0 —
    /// noted once the block has run ([`Interp::note_assumed`]).
    pub(super) fn external(&self, key: String) -> f64 {
        if let Some(v) = self
            .written
            .get(&key)
            .or_else(|| self.cfg.variables.get(&key))
        {
            return *v;
        }
        self.assumed.borrow_mut().push(key);
        0.0
    }

    /// Turns the values read as 0 by block `i` into notes of the run, each variable once.
    pub(super) fn note_assumed(&mut self, u: &Unit, i: usize) {
        let keys = std::mem::take(self.assumed.get_mut());
        for key in keys {
            if self.noted.insert(key.clone()) {
                let at = self.at(u, i);
                self.run.assumptions.push(Message {
                    at,
                    text: format!(
                        "{key} read as 0: the dry run cannot know it and the machine file's [variables] does \
                         not give it"
                    ),
                });
            }
        }
    }

    /// Notes something the dry run took without running it (a synchronized action), once per text.
    pub(super) fn note(&mut self, u: &Unit, i: usize, text: String) {
        if self.noted.insert(text.clone()) {
            let at = self.at(u, i);
            self.run.assumptions.push(Message { at, text });
        }
    }
}
