//! Peak resident memory of this process, from Linux's `/proc/self/status` (no unsafe, no extra crate).
//! Elsewhere the numbers are simply unavailable and the benchmark says so.

use std::fs;

/// Peak resident set size (`VmHWM`) in bytes since start or the last [`reset_peak`].
pub fn peak_rss() -> Option<u64> {
    status_kib("VmHWM:").map(|kib| kib * 1024)
}

/// Resets the peak to the current size (Linux `clear_refs` value 5), so the next phase is measured alone.
pub fn reset_peak() -> bool {
    fs::write("/proc/self/clear_refs", b"5").is_ok()
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
}
