//! A call the profile declares (`[calls.NAME]`, see [`crate::omm::declared_calls`]) and driftloop does not
//! read: it cuts nothing, a tool change among them counts as M6, and only the fields it may change stay
//! unsure after it — the user's claim narrows "anything", it never makes a place fitter than the program's
//! own words would.

use std::rc::Rc;
use std::sync::Arc;

use super::Builder;
use crate::omm::declared_calls::{DeclaredCall, Leaves, Loads};
use crate::omm::timeline::modal::{coolant_after, field};
use crate::omm::timeline::read::CallArg;
use crate::omm::timeline::record::Timeline;

/// A call the block after which the tool is known as after M6.
pub(in crate::omm::timeline) enum ToolChangeCall {
    /// A subprogram the timeline read (an `L6` holding the M6).
    Read(Rc<Timeline>),
    /// A call the profile declares with `loads`.
    Declared(DeclaredTool),
}

/// Which tool a declared tool-change call loads at a call site.
pub(in crate::omm::timeline) enum DeclaredTool {
    /// The tool the last `T` selected.
    Preselected,
    /// The tool its argument names.
    Named(Arc<str>),
    /// An argument the timeline cannot evaluate: the tool is not known.
    Unknown,
}

/// The fields of the modal state `what` stands for.
fn fields(what: Leaves) -> &'static [usize] {
    match what {
        // A gate reads where the axes stand from the control; the frames a call writes are handled as the
        // program's own frame writes (see `Builder::declared`).
        Leaves::Position | Leaves::Frames => &[],
        Leaves::Motion => &[field::MOTION],
        Leaves::Feed => &[field::FEED],
        Leaves::FeedMode => &[field::FEED_MODE],
        Leaves::Absolute => &[field::ABSOLUTE],
        Leaves::Plane => &[field::PLANE],
        Leaves::PathMode => &[field::PATH_MODE],
        Leaves::Spindle => &[field::S, field::DIRECTION],
        Leaves::Coolant => &[field::COOLANT, field::MACHINE_COOLANT],
        Leaves::Compensation => &[field::COMP],
        Leaves::Edge => &[field::D],
        Leaves::Offset => &[field::OFFSET],
        Leaves::Diameter => &[field::DIAMETER],
        Leaves::Units => &[field::UNITS],
    }
}

impl Builder<'_> {
    /// The declared call `decl` of `name` at block `i` with the arguments `args`: not timed, cuts
    /// nothing; the fields it may change are unsure after it until the program sets them again; frames it
    /// writes count as the program's own frame writes (the zero after them, none after the zero), and the
    /// correction in force is applied again after it where it may select an offset. Returns the tool a
    /// tool change loads.
    pub(super) fn declared(
        &mut self,
        i: usize,
        name: &str,
        decl: &DeclaredCall,
        args: &[CallArg],
    ) -> Option<DeclaredTool> {
        self.t.untimed_calls.push((i + 1, name.to_string()));
        let leaves = decl.leaves();
        let mut unsure = [false; field::COUNT];
        for f in leaves.iter().flat_map(|l| fields(*l)) {
            unsure[*f] = true;
        }
        if leaves.contains(&Leaves::Frames) {
            self.t.frame_writes.push(i);
            unsure[field::FRAMES] = false;
            self.touched[field::FRAMES] = true;
            if self.t.first_cut.is_none() {
                self.t.setup_end = i + 1;
            }
            for pending in &mut self.frame_pending {
                pending.get_or_insert(i);
            }
        }
        if (leaves.contains(&Leaves::Frames) || leaves.contains(&Leaves::Offset))
            && self.state.unfit().is_none()
        {
            self.t.offset_selections.push(i);
        }
        if leaves.contains(&Leaves::Position) {
            // The call moved: the rapid after it is no longer the one right after a retract.
            self.last_was_z_retract = false;
            self.position_doubt = true;
        }
        for (mine, its) in self.touched.iter_mut().zip(unsure) {
            *mine |= its;
        }
        self.leave_to_call(i, &mut unsure);
        self.unsure_after(i, name, Some(unsure));
        if decl.coolant_off {
            let before = self.state.clone();
            self.state.coolant = coolant_after(self.state.coolant, 9);
            self.state.machine_coolant = self.profile.coolant.after(self.state.machine_coolant, 9);
            self.touched[field::COOLANT] = true;
            let mut set = [false; field::COUNT];
            set[field::COOLANT] = true;
            set[field::MACHINE_COOLANT] = self.profile.coolant.follows(9);
            self.mark_written(i + 1, set);
            if before.coolant != self.state.coolant {
                self.changed[field::COOLANT] = i + 1;
            }
        }
        let n = match decl.loads? {
            Loads::Preselected => return Some(DeclaredTool::Preselected),
            Loads::Arg(n) => n,
        };
        Some(match args.get(n - 1) {
            Some(CallArg::Literal(tool)) => DeclaredTool::Named(tool.clone()),
            Some(CallArg::Other) => DeclaredTool::Unknown,
            None | Some(CallArg::Empty) => {
                self.bad_declaration(
                    i,
                    format!(
                        "{name} is declared to load the tool its argument {n} gives ([calls.{name}] loads = \"arg {n}\"), and this call gives no argument {n}: the declaration does not fit the program, so the tool after it is not known; correct the declaration or the call"
                    ),
                );
                DeclaredTool::Unknown
            }
        })
    }

    /// The G codes a gate writes back only where the program set them (plane, feed type, path mode): after
    /// a call that may change them they are the call's, which a gate then leaves as they are (as after
    /// CYCLE832), so they are not unsure.
    fn leave_to_call(&mut self, i: usize, unsure: &mut [bool; field::COUNT]) {
        let st = &mut self.state;
        let mut left = [false; field::COUNT];
        for (f, value) in [
            (field::PLANE, &mut st.plane),
            (field::FEED_MODE, &mut st.feed_mode),
            (field::PATH_MODE, &mut st.path_mode),
        ] {
            if unsure[f] {
                unsure[f] = false;
                if value.take().is_some() {
                    self.changed[f] = i + 1;
                }
                left[f] = true;
            }
        }
        self.mark_written(i + 1, left);
    }

    /// The block after a declared tool change at block `i`: the tool (and with `Named` its selection) set
    /// by it, the spindle stopped as the timeline has it after M6, and the change's time.
    pub(super) fn after_declared_change(&mut self, i: usize, named: bool) {
        let mut set = [false; field::COUNT];
        set[field::TOOL] = true;
        set[field::DIRECTION] = true;
        set[field::SELECTED] = named;
        self.touched[field::TOOL] = true;
        self.touched[field::SELECTED] |= named;
        self.mark_written(i + 1, set);
        self.add_minutes(self.profile.timeline.tool_change_s / 60.0);
    }

    /// A declaration that does not fit the program at block `i`: the transform refuses the program (the
    /// first one is reported).
    pub(super) fn bad_declaration(&mut self, i: usize, why: String) {
        self.t.bad_declaration.get_or_insert((i + 1, why));
    }
}
