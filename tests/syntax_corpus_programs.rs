//! The real Sinumerik programs in ../shared/corpus are valid, so they must parse without error diagnostics.
//! (The sublime-s840d syntax-highlighting tests are left out on purpose: they exist to hold invalid lines and
//! snippets with undefined labels. Their round trip is checked with the rest of the corpus elsewhere.)

mod shared_data;

mod syntax_support;

use std::path::{Path, PathBuf};

use driftloop::parse;
use syntax_support::errors;

fn nc_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = entry.path();
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if path.is_dir() {
            nc_files(&path, out);
        } else if matches!(ext.as_deref(), Some("mpf" | "spf" | "arc" | "nc" | "def")) {
            out.push(path);
        }
    }
}

#[test]
fn real_programs_have_no_error_diagnostics() {
    let Some(corpus) = shared_data::path("corpus") else {
        return;
    };
    let mut files = Vec::new();
    for project in [
        "nc-gcode-interpreter-examples",
        "sinumerik-840d-sl-cas-package",
        "syil-x7-warmup-routines",
    ] {
        nc_files(&corpus.join(project), &mut files);
    }
    assert!(!files.is_empty(), "the corpus holds real programs");
    let dirty: Vec<(String, Vec<String>)> = files
        .iter()
        .map(|f| {
            (
                f.display().to_string(),
                errors(&parse(&std::fs::read(f).unwrap())),
            )
        })
        .filter(|(_, errors)| !errors.is_empty())
        .collect();
    assert!(dirty.is_empty(), "{dirty:#?}");
}
