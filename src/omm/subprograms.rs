//! Subprograms in the folders the profile names (`[timeline] subprograms`, `--subprograms DIR`): a call of
//! one adds its time as a call of an archive's own subprogram does.

use std::collections::{BTreeSet, HashMap};
use std::path::PathBuf;
use std::rc::Rc;

use super::profile::Profile;
use super::timeline::{self, Timeline};

/// The subprogram files a program's calls may run, and the timelines built of them so far.
pub(super) struct Folders {
    files: HashMap<String, PathBuf>,
    /// `None`: the file could not be read.
    timed: HashMap<String, Option<Rc<Timeline>>>,
    /// Subprograms being timed: a call back to one of them stays untimed.
    open: BTreeSet<String>,
}

impl Folders {
    pub(super) fn new(profile: &Profile) -> Folders {
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
    pub(super) fn timeline(&mut self, name: &str, profile: &Profile) -> Option<Rc<Timeline>> {
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
        let t = Rc::new(timeline::build_with(&program, None, profile, self));
        self.open.remove(name);
        self.timed.insert(name.to_string(), Some(t.clone()));
        Some(t)
    }
}
