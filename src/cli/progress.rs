//! `what k/n` on stderr while long work runs, for a person at a terminal; nothing when stderr is a file or
//! a pipe, so logs and tests see only results.

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicUsize, Ordering};

pub struct Progress {
    what: &'static str,
    total: usize,
    done: AtomicUsize,
    shown: bool,
}

impl Progress {
    /// Progress over `total` items, each counted as `what` (`transformed`, `checked`, …) when done; shown only
    /// for more than one item.
    pub fn new(what: &'static str, total: usize) -> Progress {
        Progress {
            what,
            total,
            done: AtomicUsize::new(0),
            shown: total > 1 && std::io::stderr().is_terminal(),
        }
    }

    /// One more item done (from any thread).
    pub fn tick(&self) {
        let n = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if self.shown {
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r{} {n}/{}", self.what, self.total);
            let _ = err.flush();
        }
    }

    /// Ends the progress line, so what follows starts on a line of its own.
    pub fn finish(&self) {
        if self.shown {
            eprintln!();
        }
    }
}
