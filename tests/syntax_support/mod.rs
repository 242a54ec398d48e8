//! Helpers shared by the syntax tests.
#![allow(dead_code)]

use std::path::PathBuf;

use driftloop::{Node, NodeKind, Program};

pub fn fixture_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/nc")
}

pub fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(fixture_dir().join(name)).unwrap_or_else(|e| panic!("fixture {name}: {e}"))
}

/// Every fixture as (file name, bytes), sorted by name.
pub fn all_fixtures() -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(fixture_dir())
        .expect("fixtures/nc exists")
        .map(|e| {
            let path = e.expect("readable dir entry").path();
            (
                path.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&path).unwrap(),
            )
        })
        .collect();
    out.sort();
    out
}

/// Kinds of the significant top-level nodes of block `i` (no trivia, comments, newline).
pub fn statement_kinds(program: &Program, i: usize) -> Vec<NodeKind> {
    program
        .block(i)
        .root
        .significant()
        .map(|n| n.kind)
        .collect()
}

/// The first node of `kind` anywhere in block `i`.
pub fn find_in(program: &Program, i: usize, kind: NodeKind) -> Option<Node> {
    let block = program.block(i);
    let mut found = None;
    block.root.walk(&mut |n| {
        if found.is_none() && n.kind == kind {
            found = Some(n.clone());
        }
    });
    found
}

pub fn text(program: &Program, node: &Node) -> String {
    String::from_utf8_lossy(node.span.slice(program.source())).into_owned()
}

/// Error diagnostics as "line:col message".
pub fn errors(program: &Program) -> Vec<String> {
    let index = driftloop::LineIndex::new(program.source());
    program
        .diagnostics()
        .iter()
        .filter(|d| d.severity == driftloop::Severity::Error)
        .map(|d| {
            let (line, col) = index.line_col(d.span.start);
            format!("{line}:{col} {}", d.message)
        })
        .collect()
}

/// The structure check's resolved jumps as "from target to" (blocks 0-based, `-` for no landing block).
pub fn resolved_jumps(program: &Program) -> Vec<String> {
    driftloop::analyze(program)
        .jumps
        .into_iter()
        .map(|j| {
            let to = j.to.map_or("-".to_string(), |t| t.to_string());
            format!("{} {} {to}", j.from, j.target)
        })
        .collect()
}
