//! Unit tests that read `../shared` (real programs and data beside the checkout) find it here and skip with a
//! notice when it is absent — written past the test harness's capture, as the integration tests' is.

use std::io::Write;
use std::path::PathBuf;

/// `../shared/<rel>` if it exists; otherwise prints the skip notice and gives `None`.
pub fn path(rel: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared")
        .join(rel);
    if path.exists() {
        return Some(path);
    }
    let _ = writeln!(
        std::io::stderr(),
        "note: test skipped, {} is absent",
        path.display()
    );
    None
}
