//! The sites of a timeline in the order the program runs them: the sites in the body of a loop the
//! timeline counted (see [`Loop`]) come once more for each further run of the loop, at that run's time.

use super::timeline::Timeline;
// The loop record is the timeline's, which counts the loops as it reads the program.
pub use super::timeline::Loop;

/// Sites listed at most, loops counted in: a loop of a million runs is still timed, but the sites of its
/// further runs are not all listed (see [`Runs::complete`]).
pub const MAX_SITE_RUNS: usize = 200_000;

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
