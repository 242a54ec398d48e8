//! `driftloop parse`: the source format gives the input back byte for byte, the JSON format is the tree.

mod common;

use std::fs;

use common::{driftloop, stderr};

/// CRLF, a lone CR, Latin-1 in a comment, a BOM and no final newline: everything a printer could lose.
const AWKWARD: &[u8] = b"\xEF\xBB\xBF%_N_PART_MPF\r\nN10 G0 X0 ; Stra\xDFe\r\nN20 G1 X10\rM30";

#[test]
fn source_format_reprints_file_and_stdin_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("part.mpf"), AWKWARD).unwrap();

    let from_file = driftloop(
        dir.path(),
        &["parse", "part.mpf", "--format", "source"],
        b"",
    );
    assert_eq!(from_file.status.code(), Some(0), "{}", stderr(&from_file));
    assert_eq!(from_file.stdout, AWKWARD);

    let from_stdin = driftloop(dir.path(), &["parse", "-", "--format", "source"], AWKWARD);
    assert_eq!(from_stdin.status.code(), Some(0), "{}", stderr(&from_stdin));
    assert_eq!(from_stdin.stdout, AWKWARD);
}

#[test]
fn json_is_the_default_and_holds_one_block_per_line() {
    let dir = tempfile::tempdir().unwrap();
    let output = driftloop(
        dir.path(),
        &["parse", "-"],
        b"N10 G0 X0\nN20 G1 X1 F100\nM30\n",
    );
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    let tree: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let blocks = tree["blocks"].as_array().expect("blocks array");
    assert_eq!(blocks.len(), 3);
    assert_eq!(blocks[1]["tree"]["span"]["start"], 10);
    assert_eq!(blocks[1]["tree"]["span"]["end"], 25);
    assert!(tree["diagnostics"].as_array().unwrap().is_empty());
}

#[test]
fn missing_file_exits_2_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let output = driftloop(dir.path(), &["parse", "no_such_part.mpf"], b"");
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("no_such_part.mpf"),
        "{}",
        stderr(&output)
    );
    assert!(output.stdout.is_empty());
}

#[test]
fn unknown_format_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let output = driftloop(dir.path(), &["parse", "-", "--format", "xml"], b"M30\n");
    assert_eq!(output.status.code(), Some(2));
}
