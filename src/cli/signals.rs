//! Temporary files that must not outlive the process: an `--in-place` write registers its temporary file
//! here while it exists, and an interrupt, termination or hang-up signal (Ctrl-C, `kill`, a closed terminal)
//! removes it before the process exits with 128 + the signal's number, as a shell reports it. (`kill -9`
//! cannot be caught by any program; the input file is intact then too, as the rename never happened.)

use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Keeps `path` registered until the guard is dropped.
pub struct Registered(PathBuf);

/// Creates a temporary file with `create` and registers it, both under the lock the signal handler takes:
/// a signal can never find a file created but not yet registered, and once the handler runs no new file
/// is created (it keeps the lock until the process exits). The file is removed should the process be
/// interrupted or terminated before the guard is dropped.
pub fn create_registered<T>(
    create: impl FnOnce() -> std::io::Result<T>,
    path_of: impl Fn(&T) -> &Path,
) -> std::io::Result<(T, Registered)> {
    install();
    let mut pending = pending();
    let made = create()?;
    let path = path_of(&made).to_path_buf();
    pending.push(path.clone());
    Ok((made, Registered(path)))
}

impl Drop for Registered {
    fn drop(&mut self) {
        let mut pending = pending();
        if let Some(i) = pending.iter().position(|p| *p == self.0) {
            pending.swap_remove(i);
        }
    }
}

fn pending() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(PoisonError::into_inner)
}

#[cfg(unix)]
fn install() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            if let Some(signal) = signals.forever().next() {
                // Held until the exit: no writer creates or registers a file after this point.
                let mut pending = pending();
                for path in pending.drain(..) {
                    let _ = std::fs::remove_file(path);
                }
                std::process::exit(128 + signal);
            }
        });
    });
}

#[cfg(not(unix))]
fn install() {}
