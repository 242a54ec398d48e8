//! `driftloop check`: exit codes, the JSON report, stdin, directories, I/O errors and the human rendering.

mod common;

use std::fs;
use std::path::Path;

use common::{driftloop, stderr};
use serde_json::Value;

const CLEAN: &[u8] = b"N10 G90 G0 X0 Y0\nN20 G1 X10 F500\nN30 M30\n";
/// Two errors the parser must find: the IF on line 2 is never closed (structure, with the program end as a
/// related place) and the parenthesis on line 3 is never closed (syntax, at the end of the line).
const BROKEN: &[u8] = b"N10 G0 X0\nN20 IF R1>0\nN30 G1 X=(R1+ F100\nN40 M30\n";

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    let path = dir.join(name);
    fs::create_dir_all(path.parent().unwrap()).unwrap();
    fs::write(path, bytes).unwrap();
}

/// One JSON object per line of stdout.
fn json_lines(stdout: &[u8]) -> Vec<Value> {
    String::from_utf8(stdout.to_vec())
        .unwrap()
        .lines()
        .map(|line| serde_json::from_str(line).unwrap())
        .collect()
}

#[test]
fn clean_program_exits_0_with_a_summary_line() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "clean.mpf", CLEAN);
    let output = driftloop(dir.path(), &["check", "clean.mpf"], b"");
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    assert_eq!(
        stderr(&output),
        "checked 1 file: 0 errors, 0 warnings, 0 notes\n"
    );
    assert!(output.stdout.is_empty());
}

#[test]
fn error_exits_1_and_json_gives_line_column_severity_message() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "broken.mpf", BROKEN);
    let output = driftloop(
        dir.path(),
        &["check", "--format", "json", "broken.mpf"],
        b"",
    );
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    let files = json_lines(&output.stdout);
    assert_eq!(files.len(), 1);
    assert_eq!(files[0]["path"], "broken.mpf");
    let diagnostics = files[0]["diagnostics"].as_array().unwrap();
    assert_eq!(diagnostics.len(), 2, "{diagnostics:?}");
    let unclosed_if = &diagnostics[0];
    assert_eq!(
        (&unclosed_if["line"], &unclosed_if["column"]),
        (&Value::from(2), &Value::from(5))
    );
    assert_eq!(unclosed_if["severity"], "error");
    assert_eq!(unclosed_if["related"][0]["line"], 4, "{unclosed_if}");
    let unclosed_paren = &diagnostics[1];
    assert_eq!(
        (&unclosed_paren["line"], &unclosed_paren["column"]),
        (&Value::from(3), &Value::from(19))
    );
    for d in diagnostics {
        assert!(!d["message"].as_str().unwrap().is_empty(), "{d}");
        assert!(d["help"].is_string() || d["help"].is_null(), "{d}");
    }
}

#[test]
fn stdin_is_checked_under_the_name_dash() {
    let dir = tempfile::tempdir().unwrap();
    let output = driftloop(dir.path(), &["check", "--format", "json", "-"], CLEAN);
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
    let files = json_lines(&output.stdout);
    assert_eq!(files.len(), 1);
    assert_eq!(files[0]["path"], "-");
    assert_eq!(files[0]["diagnostics"], Value::Array(vec![]));
}

#[test]
fn directories_are_walked_in_sorted_order_for_nc_extensions_only() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "progs/b.MPF", CLEAN);
    write(dir.path(), "progs/a/sub.spf", BROKEN);
    write(dir.path(), "progs/notes.txt", b"not a program = (\n");
    let output = driftloop(dir.path(), &["check", "--format", "json", "progs"], b"");
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    let paths: Vec<Value> = json_lines(&output.stdout)
        .iter()
        .map(|f| f["path"].clone())
        .collect();
    assert_eq!(paths, ["progs/a/sub.spf", "progs/b.MPF"]);
}

#[test]
fn missing_path_exits_2_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "clean.mpf", CLEAN);
    let output = driftloop(dir.path(), &["check", "clean.mpf", "gone.mpf"], b"");
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("gone.mpf"), "{}", stderr(&output));
}

/// A file that exists but cannot be read: the others are still checked, the failure is named, exit 2.
/// (`/proc/self/mem` fails to read at offset 0 even for root, who can read any file with no permissions.)
#[cfg(target_os = "linux")]
#[test]
fn unreadable_file_exits_2_and_is_reported_beside_the_others() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "broken.mpf", BROKEN);
    let output = driftloop(
        dir.path(),
        &["check", "--format", "json", "broken.mpf", "/proc/self/mem"],
        b"",
    );
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let files = json_lines(&output.stdout);
    assert_eq!(files.len(), 2);
    assert_eq!(files[0]["diagnostics"].as_array().unwrap().len(), 2);
    assert_eq!(files[1]["path"], "/proc/self/mem");
    assert!(
        files[1]["error"]
            .as_str()
            .unwrap()
            .contains("/proc/self/mem")
    );
    assert!(
        stderr(&output).contains("cannot read /proc/self/mem"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn no_path_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let output = driftloop(dir.path(), &["check"], b"");
    assert_eq!(output.status.code(), Some(2));
}

#[test]
fn colour_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "broken.mpf", BROKEN);
    let always = driftloop(
        dir.path(),
        &["--color", "always", "check", "broken.mpf"],
        b"",
    );
    assert!(stderr(&always).contains("\x1b["), "{}", stderr(&always));
    let never = driftloop(
        dir.path(),
        &["check", "--color", "never", "broken.mpf"],
        b"",
    );
    assert!(!stderr(&never).contains('\x1b'));
}

#[test]
fn human_rendering_shows_the_snippet() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "broken.mpf", BROKEN);
    let output = driftloop(
        dir.path(),
        &["check", "--color", "never", "broken.mpf"],
        b"",
    );
    assert_eq!(output.status.code(), Some(1));
    insta::assert_snapshot!(stderr(&output));
}
