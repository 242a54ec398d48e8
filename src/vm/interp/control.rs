//! Control structures, jumps, CASE and section repetition.

use super::*;
use crate::structure::Search;

impl Interp<'_> {
    pub(super) fn block(&mut self, u: &Rc<Unit>, i: usize) -> Result<Flow, String> {
        let root = u.root(i);
        let kind = u.program.block_kind(i);
        if kind == BlockKind::Plain {
            return self.plain(u, i, &root);
        }
        let partner = |map: &HashMap<usize, usize>| {
            map.get(&i).copied().ok_or_else(|| {
                format!(
                    "this control keyword has no partner: {}",
                    first_message(u, i).unwrap_or("unbalanced structure".into())
                )
            })
        };
        let stmt = root
            .significant()
            .find(|c| {
                !matches!(
                    c.kind,
                    NodeKind::BlockNumber | NodeKind::Label | NodeKind::Skip
                )
            })
            .ok_or("control block without statement")?;
        match kind {
            BlockKind::If => {
                let cond = self.condition(u, stmt)?;
                if cond {
                    Ok(Flow::Next)
                } else {
                    let to = partner(&u.forward)?;
                    // IF → ELSE: continue after the ELSE; IF → ENDIF: after the ENDIF.
                    Ok(Flow::Jump(to + 1))
                }
            }
            BlockKind::Else => Ok(Flow::Jump(partner(&u.forward)? + 1)),
            BlockKind::EndIf | BlockKind::Repeat | BlockKind::Loop => Ok(Flow::Next),
            BlockKind::While => {
                if self.condition(u, stmt)? {
                    Ok(Flow::Next)
                } else {
                    Ok(Flow::Jump(partner(&u.forward)? + 1))
                }
            }
            BlockKind::EndWhile => Ok(Flow::Jump(partner(&u.backward)?)),
            BlockKind::Until => {
                if self.condition(u, stmt)? {
                    Ok(Flow::Next)
                } else {
                    Ok(Flow::Jump(partner(&u.backward)? + 1))
                }
            }
            BlockKind::EndLoop => Ok(Flow::Jump(partner(&u.backward)? + 1)),
            BlockKind::For => {
                let parts: Vec<&Node> = stmt.significant().collect();
                // FOR target = start TO end
                let [_, target, _, start, _, end] = parts[..] else {
                    return Err("FOR needs `FOR variable = start TO end`".into());
                };
                let (start, end) = (self.num(u, start)?, self.num(u, end)?);
                self.store(u, target, Value::Num(start), &mut Words::default())?;
                self.top().for_ends.insert(i, end);
                if start <= end {
                    Ok(Flow::Next)
                } else {
                    Ok(Flow::Jump(partner(&u.forward)? + 1))
                }
            }
            BlockKind::EndFor => {
                let open = partner(&u.backward)?;
                let opener = u.root(open);
                let parts: Vec<&Node> = opener
                    .significant()
                    .find(|c| c.kind == NodeKind::For)
                    .map(|f| f.significant().collect())
                    .unwrap_or_default();
                let target = parts.get(1).ok_or("FOR without variable")?;
                let end = *self
                    .top()
                    .for_ends
                    .get(&open)
                    .ok_or("ENDFOR reached without running its FOR")?;
                let next = self.num(u, target)? + 1.0;
                self.store(u, target, Value::Num(next), &mut Words::default())?;
                if next <= end {
                    Ok(Flow::Jump(open + 1))
                } else {
                    Ok(Flow::Next)
                }
            }
            BlockKind::Plain | BlockKind::Header => Ok(Flow::Next),
        }
    }

    /// The expression after IF / WHILE / UNTIL.
    pub(super) fn condition(&mut self, u: &Unit, stmt: &Node) -> Result<bool, String> {
        let expr = stmt.significant().nth(1).ok_or("condition missing")?;
        self.eval(u, expr)?.truth()
    }

    pub(super) fn jump_target(&self, u: &Unit, node: &Node) -> Result<JumpTarget, String> {
        match node.kind {
            NodeKind::Var if node.find(NodeKind::Index).is_none() => {
                Ok(JumpTarget::named(&u.upper(node)))
            }
            NodeKind::Number => Ok(JumpTarget::Number(
                u.upper(node).parse().map_err(|_| "bad block number")?,
            )),
            _ => match self.eval(u, node)? {
                Value::Str(s) => Ok(JumpTarget::named(&s)),
                Value::Num(n) if n >= 0.0 && n.fract() == 0.0 => Ok(JumpTarget::Number(n as u64)),
                Value::Num(n) => Err(format!("jump target {n} is not a block number")),
            },
        }
    }

    /// Resolves a `Goto` node to the block to continue at (`None`: GOTOC without target, fall through).
    pub(super) fn goto(&self, u: &Unit, i: usize, node: &Node) -> Result<Option<usize>, String> {
        let parts: Vec<&Node> = node.significant().collect();
        let keyword = u.upper(parts[0]);
        let Some(search) = Search::of_jump(&keyword) else {
            // GOTOS: the restart happens only on a PLC request; without one the control carries on.
            return Ok(None);
        };
        let target = self.jump_target(u, parts.get(1).ok_or("jump without target")?)?;
        match u.search(i, &target, search) {
            Some(to) => Ok(Some(to)),
            None if keyword == "GOTOC" => Ok(None),
            None => Err(format!(
                "{keyword} {target}: jump target not found (alarm 14080)"
            )),
        }
    }

    /// `REPEAT start [end]` (from the start label to the end label, or to the block before the REPEAT) and
    /// `REPEATB label` (that one block); the labels are found as [`Unit::section_labels`] says.
    pub(super) fn section(
        &self,
        u: &Unit,
        i: usize,
        node: &Node,
    ) -> Result<(usize, usize), String> {
        let parts: Vec<&Node> = node.significant().collect();
        let keyword = u.upper(parts[0]);
        let names: Vec<String> = parts[1..].iter().map(|n| u.upper(n)).collect();
        let first = names.first().ok_or("REPEAT without a label")?;
        let end_name = names.get(1).filter(|_| keyword != "REPEATB");
        let (start, end) = u.section_labels(i, first, end_name.map(String::as_str));
        let start =
            start.ok_or_else(|| format!("{keyword}: label {first} not found (alarm 14080)"))?;
        let end = match (keyword.as_str(), end_name) {
            ("REPEATB", _) => start,
            (_, Some(name)) => {
                end.ok_or_else(|| format!("{keyword}: end label {name} not found after {first}"))?
            }
            (_, None) => i
                .checked_sub(1)
                .filter(|&e| e >= start)
                .ok_or("REPEAT section is empty")?,
        };
        if (start..=end).contains(&i) {
            return Err(format!("{keyword} would repeat itself"));
        }
        Ok((start, end))
    }

    pub(super) fn case(&self, u: &Unit, i: usize, node: &Node) -> Result<Option<usize>, String> {
        let mut parts = node.significant();
        parts.next(); // CASE
        let selector = self.eval(u, parts.next().ok_or("CASE without expression")?)?;
        for arm in parts.filter(|p| p.kind == NodeKind::CaseArm) {
            let items: Vec<&Node> = arm.significant().collect();
            let (Some(head), Some(goto)) = (items.first(), items.last()) else {
                continue;
            };
            let hit = head.kind == NodeKind::Keyword
                || eval::binary("==", selector.clone(), self.eval(u, head)?)?.truth()?;
            if hit {
                return self.goto(u, i, goto);
            }
        }
        Ok(None)
    }
}
