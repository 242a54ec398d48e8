//! One program unit through the pipeline: its blocks read in chunks ([`super::read`]), those the parser
//! timed taken from their runs ([`super::moves`]), and the chunks folded in order ([`super::fold`]).
//! Reading a block does not depend on the blocks before it, folding does: helper threads read chunks
//! ahead while this one folds.

use std::collections::BTreeSet;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};

use crate::omm::profile::Profile;
use crate::syntax::Program;
use crate::syntax::structure::Jump;

use super::fold::{Builder, Callees};
use super::moves::{Moves, RunRef};
use super::read::{CHUNK_BLOCKS, Chunk, scan_chunk};
use super::record::Timeline;

/// A chunk read, with the runs of timed moves that start in it.
type Scanned<'m> = (Chunk, Vec<RunRef<'m>>);

/// The timeline of the unit of `program` that spans `blocks`, with the names it calls; `jumps` are the
/// whole program's (its structure, analysed once for all its units).
pub(super) fn build_unit<'m>(
    program: &Program,
    moves: Option<&'m Moves>,
    blocks: std::ops::Range<usize>,
    jumps: &[Jump],
    profile: &Profile,
    callees: &mut dyn Callees,
) -> (Timeline, BTreeSet<String>) {
    let marker = profile.passes.marker.to_ascii_uppercase();
    let mut b = Builder::new(profile, callees);
    let (first, count) = (blocks.start, blocks.end);
    for jump in jumps.iter().filter(|j| blocks.contains(&j.from)) {
        if let Some(to) = jump.to {
            b.jumps.entry(jump.from).or_default().push(to);
        }
    }
    let chunks = (count - first).div_ceil(CHUNK_BLOCKS);
    let scan = |k: usize| -> Scanned<'m> {
        let from = first + k * CHUNK_BLOCKS;
        let blocks = from..count.min(from + CHUNK_BLOCKS);
        let (runs, covered) = moves.map_or_else(Default::default, |m| m.in_chunk(blocks.clone()));
        (scan_chunk(program, blocks, &marker, covered), runs)
    };
    let read = |blocks: std::ops::Range<usize>| scan_chunk(program, blocks, &marker, Vec::new());
    let helpers = rayon::current_num_threads().saturating_sub(1);
    if chunks <= 1 || helpers == 0 {
        for k in 0..chunks {
            let (chunk, runs) = scan(k);
            b.fold(&chunk, &runs, &read);
        }
        return b.finish();
    }
    // Reading the blocks is independent line by line, the fold is not. Helpers read chunks in order of a
    // shared counter, at most AHEAD chunks past the fold (so the records never hold the whole program);
    // this thread folds them in order and, while the next one is not ready, reads chunks itself.
    const AHEAD: usize = 8;
    let next = AtomicUsize::new(0);
    let ready: Mutex<(Vec<Option<Scanned<'m>>>, usize)> =
        Mutex::new(((0..chunks).map(|_| None).collect(), 0));
    let changed = Condvar::new();
    let put = |k: usize, chunk: Scanned<'m>| {
        ready.lock().expect("no panic while held").0[k] = Some(chunk);
        changed.notify_all();
    };
    std::thread::scope(|threads| {
        for _ in 0..helpers {
            threads.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    if k >= chunks {
                        return;
                    }
                    let mut slots = ready.lock().expect("no panic while held");
                    while k > slots.1 + AHEAD {
                        slots = changed.wait(slots).expect("no panic while held");
                    }
                    drop(slots);
                    put(k, scan(k));
                }
            });
        }
        for k in 0..chunks {
            let (chunk, runs) = loop {
                let mut slots = ready.lock().expect("no panic while held");
                if let Some(chunk) = slots.0[k].take() {
                    break chunk;
                }
                drop(slots);
                let j = next.fetch_add(1, Ordering::Relaxed);
                if j < chunks {
                    put(j, scan(j));
                    continue;
                }
                let mut slots = ready.lock().expect("no panic while held");
                while slots.0[k].is_none() {
                    slots = changed.wait(slots).expect("no panic while held");
                }
            };
            b.fold(&chunk, &runs, &read);
            ready.lock().expect("no panic while held").1 = k + 1;
            changed.notify_all();
        }
    });
    b.finish()
}
