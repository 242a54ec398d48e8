//! What Linux's `/proc/self` tells about this process: peak resident memory and CPU time over all its threads
//! (no unsafe, no extra crate). Elsewhere the numbers are simply unavailable and the benchmark says so.

use std::fs;
use std::time::Duration;

/// Peak resident set size (`VmHWM`) in bytes since start or the last [`reset_peak`].
pub fn peak_rss() -> Option<u64> {
    status_kib("VmHWM:").map(|kib| kib * 1024)
}

/// Resets the peak to the current size (Linux `clear_refs` value 5), so the next phase is measured alone.
pub fn reset_peak() -> bool {
    fs::write("/proc/self/clear_refs", b"5").is_ok()
}

/// CPU time used so far by all live threads of the process (nanosecond `schedstat` counters). Worker
/// threads of the rayon pool live as long as the process, so differences of two readings are exact.
pub fn cpu_time() -> Option<Duration> {
    let mut total = 0u64;
    for task in fs::read_dir("/proc/self/task").ok()?.flatten() {
        // A thread that ends between the listing and the read is simply no longer live.
        let Ok(schedstat) = fs::read_to_string(task.path().join("schedstat")) else {
            continue;
        };
        total += schedstat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(Duration::from_nanos(total))
}

fn status_kib(field: &str) -> Option<u64> {
    let status = fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(field))?;
    line[field.len()..]
        .trim()
        .strip_suffix("kB")?
        .trim()
        .parse()
        .ok()
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn peak_grows_with_a_touched_allocation() {
        let before = peak_rss().unwrap();
        let block = vec![1u8; 64 << 20];
        let after = peak_rss().unwrap();
        assert!(after >= before + (60 << 20), "{before} -> {after}");
        std::hint::black_box(&block);
    }

    #[test]
    fn cpu_time_advances_with_busy_work() {
        // Busy until the counter shows 20 ms more; a counter that does not move runs into the wall-clock
        // limit. The sum covers live threads only, and other tests' threads end meanwhile, so it may first
        // fall below `before`: that only lengthens the wait.
        let before = cpu_time().unwrap();
        let started = std::time::Instant::now();
        let mut x = 0u64;
        while cpu_time().unwrap().saturating_sub(before) < Duration::from_millis(20) {
            assert!(
                started.elapsed() < Duration::from_secs(10),
                "CPU time did not advance"
            );
            for _ in 0..100_000 {
                x = std::hint::black_box(x.wrapping_add(1));
            }
        }
    }
}
