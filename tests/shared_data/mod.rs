//! Where the tests (integration and, through `#[path]`, the library's unit tests) find the real programs
//! and data of `../shared`.

use std::io::Write;
use std::path::PathBuf;

/// `../shared/<rel>` beside the checkout (real programs and data, never copied into the repo), or `None`
/// after a notice that the calling test is skipped. The notice is written to the process's stderr itself,
/// not through `eprintln!`, so the test harness's output capture does not swallow it.
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
