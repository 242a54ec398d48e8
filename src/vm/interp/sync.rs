//! Synchronized actions (`[ID=n | IDS=n] [WHEN | WHENEVER | FROM | EVERY] condition DO action`): recorded,
//! never run. The control checks their conditions in the interpolation cycle while the axes move, a time
//! scale the dry run does not have; what it keeps is which modal (`ID`) and static (`IDS`) actions are
//! active, until `CANCEL`, so the audit can compare them and say when inserted blocks move under one.

use super::*;

impl Interp<'_> {
    /// The block from its synchronized-action keyword on; `id` from an `ID=` / `IDS=` before it.
    pub(super) fn sync_action(
        &mut self,
        u: &Unit,
        i: usize,
        condition: &Node,
        id: Option<(u32, bool)>,
    ) -> Result<Flow, String> {
        let keyword = condition
            .significant()
            .next()
            .map(|k| u.upper(k))
            .ok_or("synchronized action without keyword")?;
        let scope = match id {
            Some((n, is_static)) => {
                let actions = &mut self.motion.sync_actions;
                actions.retain(|a| a.0 != n);
                actions.push((n, is_static, i + 1));
                format!(
                    "{}={n}, active until CANCEL({n})",
                    if is_static { "IDS" } else { "ID" }
                )
            }
            None => "for the next block that moves".to_string(),
        };
        self.note(
            u,
            i,
            format!(
                "synchronized action ({keyword} … DO, {scope}) at line {} recorded, not run: the dry run \
                 does not check its condition as the axes move",
                i + 1
            ),
        );
        Ok(Flow::Next)
    }

    /// `CANCEL(n, …)` ends those synchronized actions, `CANCEL()` every one.
    pub(super) fn cancel(&mut self, ids: &[Option<Value>]) -> Result<(), String> {
        let ids = ids
            .iter()
            .flatten()
            .map(|v| v.num().map(|n| n as u32))
            .collect::<Result<Vec<u32>, String>>()?;
        self.motion
            .sync_actions
            .retain(|a| !ids.is_empty() && !ids.contains(&a.0));
        Ok(())
    }
}
