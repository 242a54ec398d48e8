//! The timeline of a whole file: an archive's units each through the pipeline ([`super::unit`]), those
//! that others call first, so that a call adds the time of what it runs; subprograms in the folders the
//! profile names (`[timeline] subprograms`, `--subprograms DIR`) are timed when first called.

use std::collections::{BTreeSet, HashMap};
use std::path::PathBuf;
use std::rc::Rc;

use crate::omm::profile::Profile;
use crate::syntax::structure::Jump;
use crate::syntax::{NodeKind, Program, flag};

use super::fold::Callees;
use super::moves::Moves;
use super::read::section_call_labels;
use super::record::Timeline;
use super::unit::build_unit;

/// The timeline of the program's first unit: of the whole file, or of the main program of an archive. The
/// archive's other units are timed on their own, so that a call of one of its subprograms (`%_N_NAME_SPF`)
/// adds that subprogram's time, as often as `P` says; the R-parameters, labels and work offsets they use
/// count as used. So does a call of a subprogram in the profile's folders, with the R-parameters it uses.
pub fn build(program: &Program, profile: &Profile) -> Timeline {
    build_with(program, None, profile, &mut Folders::new(profile))
}

/// [`build`] for a program parsed with [`parse_timed`](super::parse_timed): the runs of moves the parser
/// timed are folded without reading their blocks again. The timeline is the one [`build`] makes.
pub fn build_with_moves(program: &Program, moves: &Moves, profile: &Profile) -> Timeline {
    build_with(program, Some(moves), profile, &mut Folders::new(profile))
}

fn build_with(
    program: &Program,
    moves: Option<&Moves>,
    profile: &Profile,
    folders: &mut Folders,
) -> Timeline {
    let mut units = units(program);
    // The main program first: an archive may open with a subprogram or a definition file.
    if let Some(h) = program.later_main_header()
        && let Some(m) = units.iter().position(|u| u.start == h)
    {
        let main = units.remove(m);
        units.insert(0, main);
    }
    let jumps = program.jumps();
    let names: Vec<Option<String>> = units[1..]
        .iter()
        .map(|u| subprogram_name(program, u.start))
        .collect();
    let mut callees = Found {
        archive: HashMap::new(),
        folders,
        profile,
        sections: Sections {
            program,
            moves,
            jumps,
            main: units[0].clone(),
            open: BTreeSet::new(),
        },
    };
    // Each subprogram on its own first, for the names it calls; then each again after those it calls (a
    // recursive call stays untimed), unless it calls none of the archive's subprograms.
    let mut alone: Vec<Option<(Timeline, BTreeSet<String>)>> = units[1..]
        .iter()
        .map(|u| {
            Some(build_unit(
                program,
                moves,
                u.clone(),
                jumps,
                profile,
                &mut callees,
            ))
        })
        .collect();
    let calls: Vec<&BTreeSet<String>> = alone.iter().flatten().map(|(_, c)| c).collect();
    let order = callees_first(&names, &calls);
    let mut others = Vec::new();
    for k in order {
        let (first, called) = alone[k].take().expect("each unit once");
        let t = if called
            .iter()
            .any(|c| names.iter().flatten().any(|n| n == c))
        {
            let unit = units[k + 1].clone();
            build_unit(program, moves, unit, jumps, profile, &mut callees).0
        } else {
            first
        };
        let t = Rc::new(t);
        if let Some(name) = &names[k] {
            callees.archive.insert(name.clone(), t.clone());
        }
        others.push(t);
    }
    let mut t = build_unit(
        program,
        moves,
        units[0].clone(),
        jumps,
        profile,
        &mut callees,
    )
    .0;
    for other in others {
        t.used_r.extend(&other.used_r);
        t.labels.extend(other.labels.iter().cloned());
        t.computed_r_lines.extend(&other.computed_r_lines);
        t.offsets.extend(&other.offsets);
    }
    t.computed_r_lines.sort_unstable();
    t.unit_end = units[0].end;
    t
}

/// The units (by index into `names`) ordered so that each comes after the units it calls, when they do not
/// call it back.
fn callees_first(names: &[Option<String>], calls: &[&BTreeSet<String>]) -> Vec<usize> {
    let index: HashMap<&str, usize> = names
        .iter()
        .enumerate()
        .filter_map(|(k, n)| Some((n.as_deref()?, k)))
        .collect();
    let mut seen = vec![false; names.len()];
    let mut order = Vec::with_capacity(names.len());
    for root in 0..names.len() {
        if seen[root] {
            continue;
        }
        seen[root] = true;
        // Depth first, iteratively: (unit, its callees still to visit).
        let mut stack = vec![(root, calls[root].iter())];
        while let Some((k, callees)) = stack.last_mut() {
            let k = *k;
            match callees.find_map(|c| index.get(c.as_str()).copied().filter(|&j| !seen[j])) {
                Some(j) => {
                    seen[j] = true;
                    stack.push((j, calls[j].iter()));
                }
                None => {
                    order.push(k);
                    stack.pop();
                }
            }
        }
    }
    order
}

/// The block ranges of the program's units: a new one starts at each `%` header after the first block.
fn units(program: &Program) -> Vec<std::ops::Range<usize>> {
    let count = program.block_count();
    let src = program.source();
    // Comments and blank lines before the first header belong to its unit (a title above `%_N_…_MPF`).
    let only_comments = |blocks: std::ops::Range<usize>| {
        blocks.into_iter().all(|i| {
            let text = program.content_span(i).slice(src).trim_ascii();
            text.is_empty() || text.starts_with(b";")
        })
    };
    let mut starts = vec![0];
    starts.extend(
        program
            .header_blocks()
            .iter()
            .filter(|&&h| h > 0 && !only_comments(0..h)),
    );
    starts.push(count);
    starts.windows(2).map(|w| w[0]..w[1]).collect()
}

/// `NAME` of a unit headed `%_N_NAME_SPF` (as it is called: `NAME`, `CALL "NAME"`, `L123` for `L123`), or
/// `%_N_NAME_MPF`: a main program may be called as a subprogram, as the dry run finds it too.
fn subprogram_name(program: &Program, block: usize) -> Option<String> {
    let (name, kind) = program.section(block)?;
    matches!(kind.as_str(), "SPF" | "MPF").then_some(name)
}

/// The subprograms a unit's calls may run: the archive's units timed so far, the main program's sections
/// a `CALL BLOCK` runs, and the profile's folders.
struct Found<'f> {
    archive: HashMap<String, Rc<Timeline>>,
    folders: &'f mut Folders,
    profile: &'f Profile,
    sections: Sections<'f>,
}

impl Callees for Found<'_> {
    fn timeline(&mut self, name: &str) -> Option<(Rc<Timeline>, bool)> {
        if let Some(t) = self.archive.get(name) {
            return Some((t.clone(), false));
        }
        if let Some((start, end)) = section_call_labels(name) {
            let t = self.section(name, start, end)?;
            return Some((t, false));
        }
        Some((self.folders.timeline(name, self.profile)?, true))
    }
}

/// What a `CALL BLOCK` section is read from: the main program's blocks.
struct Sections<'f> {
    program: &'f Program,
    moves: Option<&'f Moves>,
    jumps: &'f [Jump],
    main: std::ops::Range<usize>,
    /// Sections being read: one that calls itself stays untimed.
    open: BTreeSet<String>,
}

impl Found<'_> {
    /// The timeline of the main program's blocks from label `start` to label `end` (a CAM post's
    /// operations, written after M30 and run with `CALL BLOCK`), read as a subprogram is: its time, its
    /// cuts and the state it leaves. `None` (an untimed call, as before) when the start label is not
    /// defined exactly once (which one runs would depend on where the call stands) or no end follows it.
    fn section(&mut self, name: &str, start: &str, end: &str) -> Option<Rc<Timeline>> {
        if self.sections.open.contains(name) {
            return None;
        }
        let labelled = |label: &str| -> Vec<usize> {
            let program = self.sections.program;
            self.sections
                .main
                .clone()
                .filter(|&i| program.block_flags(i) & flag::LABEL != 0)
                .filter(|&i| {
                    let block = program.block(i);
                    block
                        .root
                        .find(NodeKind::Label)
                        .and_then(|l| l.find(NodeKind::Name))
                        .is_some_and(|n| block.text(n).eq_ignore_ascii_case(label.as_bytes()))
                })
                .collect()
        };
        let [first] = labelled(start)[..] else {
            return None;
        };
        let last = if end == start {
            first
        } else {
            labelled(end).into_iter().find(|&b| b > first)?
        };
        let Sections {
            program,
            moves,
            jumps,
            ..
        } = self.sections;
        self.sections.open.insert(name.to_string());
        let t = build_unit(program, moves, first..last + 1, jumps, self.profile, self).0;
        self.sections.open.remove(name);
        let t = Rc::new(t);
        self.archive.insert(name.to_string(), t.clone());
        Some(t)
    }
}

/// The subprogram files a program's calls may run, and the timelines built of them so far.
struct Folders {
    files: HashMap<String, PathBuf>,
    /// `None`: the file could not be read.
    timed: HashMap<String, Option<Rc<Timeline>>>,
    /// Subprograms being timed: a call back to one of them stays untimed.
    open: BTreeSet<String>,
}

impl Folders {
    fn new(profile: &Profile) -> Folders {
        let mut files = HashMap::new();
        for dir in &profile.timeline.subprograms {
            for (name, path) in crate::walk::programs_by_name(dir) {
                files.entry(name).or_insert(path);
            }
        }
        Folders {
            files,
            timed: HashMap::new(),
            open: BTreeSet::new(),
        }
    }

    /// The timeline of subprogram `name` from its file (built once, with the subprograms it calls in turn);
    /// `None` when no folder holds it, its file cannot be read, or it is being timed (a recursive call).
    fn timeline(&mut self, name: &str, profile: &Profile) -> Option<Rc<Timeline>> {
        if let Some(t) = self.timed.get(name) {
            return t.clone();
        }
        if self.open.contains(name) {
            return None;
        }
        let path = self.files.get(name)?;
        let Ok(src) = std::fs::read(path) else {
            self.timed.insert(name.to_string(), None);
            return None;
        };
        let program = crate::parse_owned(src);
        self.open.insert(name.to_string());
        let t = Rc::new(build_with(&program, None, profile, self));
        self.open.remove(name);
        self.timed.insert(name.to_string(), Some(t.clone()));
        Some(t)
    }
}
