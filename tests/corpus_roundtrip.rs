//! Every file of the shared corpus (real Sinumerik programs plus their licences and CSVs: the invariant holds
//! for any bytes) prints back byte for byte and never panics the parser. Prints how many NC programs parse
//! without error diagnostics; run with `--nocapture` to see the list.

mod shared_data;

use std::fs;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use driftloop::{LineIndex, Severity, parse};

fn all_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            all_files(&path, out);
        } else {
            out.push(path);
        }
    }
}

/// Where two byte strings first differ, for a readable failure.
fn first_difference(a: &[u8], b: &[u8]) -> usize {
    a.iter()
        .zip(b)
        .position(|(x, y)| x != y)
        .unwrap_or(a.len().min(b.len()))
}

#[test]
fn every_corpus_file_round_trips_byte_exact() {
    let Some(corpus) = shared_data::path("corpus") else {
        return;
    };
    let mut files = Vec::new();
    all_files(&corpus, &mut files);
    assert!(!files.is_empty(), "corpus folder is empty");

    let mut failures = Vec::new();
    let mut programs = 0;
    let mut with_errors = Vec::new();
    for path in &files {
        let name = path.strip_prefix(&corpus).unwrap().display().to_string();
        let bytes = fs::read(path).unwrap();
        let Ok(program) = catch_unwind(AssertUnwindSafe(|| parse(&bytes))) else {
            failures.push(format!("{name}: parser panicked"));
            continue;
        };
        let printed = program.to_bytes();
        if printed != bytes {
            failures.push(format!(
                "{name}: printed {} bytes for {}, first difference at byte {}",
                printed.len(),
                bytes.len(),
                first_difference(&printed, &bytes)
            ));
        }
        if driftloop::walk::is_program_file(path) {
            programs += 1;
            let errors: Vec<_> = program
                .diagnostics()
                .iter()
                .filter(|d| d.severity == Severity::Error)
                .collect();
            if let Some(first) = errors.first() {
                let (line, column) = LineIndex::new(&bytes).line_col(first.span.start);
                with_errors.push(format!(
                    "{name}: {} errors, first at {line}:{column}: {}",
                    errors.len(),
                    first.message
                ));
            }
        }
    }
    println!(
        "corpus: {} files round-tripped; NC programs without error diagnostics: {}/{programs}",
        files.len(),
        programs - with_errors.len()
    );
    for line in &with_errors {
        println!("  with errors: {line}");
    }
    assert!(programs > 0, "no NC programs found in the corpus");
    assert!(
        failures.is_empty(),
        "round trip failed:\n{}",
        failures.join("\n")
    );
}
