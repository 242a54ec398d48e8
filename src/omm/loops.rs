//! The program's loops as the timeline counts them. A loop whose count is known before the program runs —
//! `FOR var = a TO b` with literal bounds (or R-parameters last assigned a literal), a section repeat
//! `REPEAT label [label] P=n` / `REPEATB label P=n` — is counted that often: its further runs are added to
//! the program time where they happen, and [`site_runs`] lists the sites of its body once per run. Any
//! other loop (WHILE, LOOP, REPEAT … UNTIL, computed bounds) is counted once, and says so.

use serde::Serialize;

use super::timeline::Timeline;

/// Sites listed at most, loops counted in: a loop of a million runs is still timed, but the sites of its
/// further runs are not all listed (see [`Runs::complete`]).
pub const MAX_SITE_RUNS: usize = 200_000;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum LoopKind {
    For,
    While,
    /// `LOOP … ENDLOOP`: endless unless left by a jump.
    Loop,
    /// `REPEAT … UNTIL condition`.
    RepeatUntil,
    /// `REPEAT label [label] P=n`: a section repeated.
    Repeat,
    /// `REPEATB label P=n`: one block repeated.
    RepeatBlock,
}

impl LoopKind {
    pub fn keyword(self) -> &'static str {
        match self {
            LoopKind::For => "FOR",
            LoopKind::While => "WHILE",
            LoopKind::Loop => "LOOP",
            LoopKind::RepeatUntil => "REPEAT…UNTIL",
            LoopKind::Repeat => "REPEAT",
            LoopKind::RepeatBlock => "REPEATB",
        }
    }
}

/// One loop of the program.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Loop {
    pub kind: LoopKind,
    /// Block of the loop statement (`FOR …`, `WHILE …`, the `REPEAT` statement).
    pub block: usize,
    /// First and last block of the body or repeated section.
    pub body: (usize, usize),
    /// How often the body runs in all (the run in the program's flow included), when known before the
    /// program runs; `None`: counted once.
    pub runs: Option<u64>,
    /// Why the count is not known.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unknown: Option<&'static str>,
    /// Start of the first run and length of one run (min, measurements not included).
    pub start_min: f64,
    pub body_min: f64,
    /// The further runs happen after this block (ENDFOR, the REPEAT statement), from this time on.
    #[serde(skip)]
    pub repeat_block: usize,
    #[serde(skip)]
    pub repeat_min: f64,
}

impl Loop {
    /// The blocks whose gates run again with the body: a gate goes before its block, so the one before a
    /// section's labelled first block stays outside the section.
    pub fn gate_blocks(&self) -> (usize, usize) {
        match self.kind {
            LoopKind::Repeat | LoopKind::RepeatBlock => (self.body.0 + 1, self.body.1),
            _ => self.body,
        }
    }

    /// Runs beyond the one the program's flow makes anyway.
    pub fn further_runs(&self) -> u64 {
        self.runs.map_or(0, |n| n.saturating_sub(1))
    }
}

/// A loop bound or repeat count as written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bound {
    Number(f64),
    R(u32),
    Other,
}

/// What a FOR header or a section repeat statement says about the count.
#[derive(Debug, Clone, PartialEq)]
pub enum Count {
    For {
        from: Bound,
        to: Bound,
    },
    /// `REPEAT a [b] P=n` (`single`: REPEATB). `times` is P (1 when absent).
    Section {
        labels: Vec<String>,
        single: bool,
        times: Bound,
    },
}

/// The runs of a `FOR from TO to` loop (counting up by one), or why they are not known.
pub fn for_runs(from: Option<f64>, to: Option<f64>) -> Result<u64, &'static str> {
    let (Some(a), Some(b)) = (from, to) else {
        return Err("bounds computed at run time");
    };
    if a.fract() != 0.0 || b.fract() != 0.0 {
        return Err("bounds are not whole numbers");
    }
    if b < a {
        return Err("the bounds give no run");
    }
    Ok(((b - a) as u64).saturating_add(1))
}

/// Every site in the order the program runs them, with its time: a counted loop's sites come once more for
/// each further run, at that run's time.
#[derive(Debug, Clone, PartialEq)]
pub struct Runs {
    /// (index into [`Timeline::sites`], time in min).
    pub sites: Vec<(usize, f64)>,
    /// False when [`MAX_SITE_RUNS`] cut the list: the further runs of some loop are timed but their sites
    /// not all listed.
    pub complete: bool,
}

pub fn site_runs(t: &Timeline) -> Runs {
    let mut runs = Runs {
        sites: Vec::with_capacity(t.sites.len()),
        complete: true,
    };
    let last = t.sites.last().map_or(0, |s| s.block);
    let end = t.loops.iter().map(|l| l.repeat_block).max().unwrap_or(0);
    walk(t, (0, last.max(end)), None, 0.0, &mut runs);
    runs
}

/// Lists the sites of blocks `range` (inclusive) shifted by `offset`, and after each loop's repeat block the
/// loop's further runs (loops nested in `range` only, `outer` excluded: it is the one being repeated).
fn walk(t: &Timeline, range: (usize, usize), outer: Option<usize>, offset: f64, runs: &mut Runs) {
    let inner: Vec<usize> = (0..t.loops.len())
        .filter(|&k| {
            let l = &t.loops[k];
            Some(k) != outer
                && l.further_runs() > 0
                && range.0 <= l.body.0
                && l.body.1 <= range.1
                && (range.0..=range.1).contains(&l.repeat_block)
        })
        .collect();
    let first = t.sites.partition_point(|s| s.block < range.0);
    let mut site = first;
    let mut pending = inner.iter().peekable();
    loop {
        let next_site = t.sites.get(site).filter(|s| s.block <= range.1);
        let next_loop = pending.peek().map(|&&k| &t.loops[k]);
        let site_first = match (next_site, next_loop) {
            (Some(s), Some(l)) => s.block <= l.repeat_block,
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => return,
        };
        if site_first {
            if runs.sites.len() == MAX_SITE_RUNS {
                runs.complete = false;
                return;
            }
            runs.sites.push((site, t.sites[site].time_min + offset));
            site += 1;
            continue;
        }
        let k = *pending.next().expect("peeked");
        let l = &t.loops[k];
        // A body without sites adds time but nothing to list (and a million empty runs no work).
        let blocks = l.gate_blocks();
        let body_sites = t.sites.partition_point(|s| s.block <= blocks.1)
            - t.sites.partition_point(|s| s.block < blocks.0);
        if body_sites == 0 {
            continue;
        }
        for run in 0..l.further_runs() {
            if !runs.complete {
                return;
            }
            let shift = l.repeat_min - l.start_min + run as f64 * l.body_min;
            walk(t, blocks, Some(k), offset + shift, runs);
        }
    }
}
