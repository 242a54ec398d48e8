//! Runs the built `driftloop` binary for the CLI tests.
// Every test file compiles this module on its own and uses only some of it.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Runs `driftloop ARGS` in `dir`, feeding `stdin`, with colour off unless the test asks for it.
pub fn driftloop(dir: &Path, args: &[&str], stdin: &[u8]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_driftloop"))
        .args(args)
        .current_dir(dir)
        .env_remove("NO_COLOR")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the driftloop binary runs");
    // A command that fails on its arguments exits without reading stdin; that is not the test's concern.
    if let Err(err) = child.stdin.take().unwrap().write_all(stdin) {
        assert_eq!(err.kind(), std::io::ErrorKind::BrokenPipe, "{err}");
    }
    child.wait_with_output().unwrap()
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Runs `driftloop ARGS` from the crate root with empty stdin, so relative fixture paths work.
pub fn run(args: &[&str]) -> Output {
    driftloop(Path::new(env!("CARGO_MANIFEST_DIR")), args, b"")
}

/// The stdout of a run that must have succeeded (its stderr in the failure message).
pub fn stdout(output: &Output) -> String {
    assert!(output.status.success(), "failed: {}", stderr(output));
    String::from_utf8(output.stdout.clone()).unwrap()
}

/// The files under `dir` (recursively, in name order) whose extension is one of `extensions` (any case).
pub fn files_under(dir: &Path, extensions: &[&str]) -> Vec<PathBuf> {
    fn walk(dir: &Path, extensions: &[&str], out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, extensions, out);
            } else if p
                .extension()
                .and_then(|e| e.to_str())
                .is_some_and(|e| extensions.iter().any(|x| e.eq_ignore_ascii_case(x)))
            {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, extensions, &mut out);
    out
}

/// A milling part of six face passes, each after 20 minutes of spindle heating at 4000 rpm: `select`
/// starts the program (a work offset, or nothing) and, with `every_pass`, each pass too; `surface` is the
/// part's top in work coordinates, each pass 0.5 mm deeper.
pub fn facing_passes(select: &str, every_pass: bool, surface: f64) -> String {
    let mut s = format!("G17 G90 G94 {select}\nT=\"MILL\" M6\nD1\nS4000 M3\n");
    let top = surface + 50.0;
    for k in 0..6 {
        if every_pass {
            s.push_str(&format!("{select}\n"));
        }
        s.push_str(&format!(
            "G0 X100 Y100 Z{top}\nG4 F1200\n; PASS {k}\nG0 Z{}\nG1 Z{:.1} F300\nG1 X300 F1200\nG1 Y120\nG1 X100\nG0 Z{top}\n",
            surface + 2.0,
            surface - 0.5 * f64::from(k + 1)
        ));
    }
    s.push_str("M5\nM30\n");
    s
}

/// Runs `program` on the virtual machine the machine file `machine` describes, with `files` (name, text)
/// written beside it (the models it names, the subprograms it calls).
pub fn run_on_machine(
    machine: &str,
    files: &[(&str, String)],
    program: &str,
) -> driftloop::vm::Run {
    try_run_on_machine(machine, files, program).unwrap()
}

/// [`run_on_machine`], where the dry run may stop with an error (what a control stops with an alarm).
pub fn try_run_on_machine(
    machine: &str,
    files: &[(&str, String)],
    program: &str,
) -> Result<driftloop::vm::Run, driftloop::vm::VmError> {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let (cfg, spec) =
        driftloop::vm::parse_machine_file(machine, dir.path(), driftloop::vm::Config::default())
            .unwrap();
    let mut m = spec.build(1);
    driftloop::vm::run_source(
        "part.mpf",
        program.as_bytes(),
        Some(dir.path()),
        &cfg,
        &mut m,
    )
}

/// Audits `transformed` against `original` on the virtual machine `settings` describe and asserts that the
/// audit ran to the end with no hazard (a probe point in the cut is the profile's warning, not a hazard).
pub fn assert_audit_clean(
    original: &str,
    transformed: &str,
    settings: &driftloop::vm::audit::AuditSettings,
) {
    use driftloop::vm::audit::audit;
    let report = audit(
        original.as_bytes(),
        transformed.as_bytes(),
        settings,
        &driftloop::vm::Config::default(),
    )
    .unwrap();
    let hazards: Vec<_> = report
        .findings
        .iter()
        .filter(|f| !f.kind.is_probe_point_warning())
        .collect();
    assert!(hazards.is_empty(), "{hazards:#?}");
    assert!(report.stopped.is_none(), "{:?}", report.stopped);
}

/// The default profile with the stored-offset method (`method = "frame"`: `$P_UIFR[1]`, G54 selected
/// again after each correction) instead of its `active` method: the hand-written audit fixtures and the
/// tests of that method are written for it.
pub fn frame_profile_text() -> String {
    let text = driftloop::omm::DEFAULT_PROFILE.replace("method = \"active\"", "method = \"frame\"");
    assert_ne!(
        text,
        driftloop::omm::DEFAULT_PROFILE,
        "the default profile's method"
    );
    text
}

/// [`frame_profile_text`] loaded.
pub fn frame_profile() -> driftloop::omm::Profile {
    driftloop::omm::Profile::from_toml(&frame_profile_text(), "frame.toml").unwrap()
}

/// [`frame_profile_text`] written to `dir/frame.toml`, for `--profile`.
pub fn frame_profile_file(dir: &Path) -> PathBuf {
    let path = dir.join("frame.toml");
    std::fs::write(&path, frame_profile_text()).unwrap();
    path
}

/// `name` under the crate's fixtures folder, as a path that works from any folder.
pub fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
        .display()
        .to_string()
}

/// Writes `files` into a new folder and runs `driftloop ARGS` there: the run and the folder.
pub fn run_in(files: &[(&str, &str)], args: &[&str]) -> (Output, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let o = driftloop(dir.path(), args, b"");
    (o, dir)
}

/// `driftloop transform PROGRAM --profile PROFILE -o out.mpf` with the fixture model, beside `files`: the
/// run (a refusal's message in its stderr) and the folder.
pub fn transform_in(
    files: &[(&str, &str)],
    program: &str,
    profile: &str,
) -> (Output, tempfile::TempDir) {
    let model = fixture("omm/model.toml");
    let args = [
        "transform",
        program,
        "--model",
        &model,
        "--profile",
        profile,
        "-o",
        "out.mpf",
    ];
    run_in(files, &args)
}

/// `program` transformed with `profile` (a builtin or a file among `files`) and the fixture model, beside
/// `files`: the output, which must have been written (the command's own audits passed).
pub fn transformed_in(files: &[(&str, &str)], program: &str, profile: &str) -> String {
    let (o, dir) = transform_in(files, program, profile);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    // The inserted blocks are well formed: no syntax error the original does not have (an ENDIF without
    // its IF stops the control before the first block; the dry run does not see it).
    let original = files.iter().find(|(name, _)| *name == program).map(|f| f.1);
    let errors = |text: &str| syntax_errors(text.as_bytes());
    assert_eq!(
        errors(&out),
        original.map_or_else(Vec::new, errors),
        "the output has syntax errors the original does not:\n{out}"
    );
    out
}

/// The messages of the syntax errors in `src`.
pub fn syntax_errors(src: &[u8]) -> Vec<String> {
    driftloop::parse(src)
        .diagnostics()
        .iter()
        .filter(|d| d.severity == driftloop::Severity::Error)
        .map(|d| d.message.clone())
        .collect()
}

/// The default profile's text with every gate measuring (`[log] measure_every_gate = true`).
pub fn measuring_default_profile() -> String {
    format!(
        "{}\n[log]\nmeasure_every_gate = true\n",
        driftloop::omm::DEFAULT_PROFILE
    )
}

/// The builtin profile `name` (`driftloop profiles NAME`) measuring at every gate that can (the branch a
/// pause takes on the machine), as a profile file's text.
pub fn measuring_builtin(name: &str) -> String {
    let o = run(&["profiles", name]);
    stdout(&o) + "[log]\nmeasure_every_gate = true\n"
}

/// `p.mpf` (among `files`) transformed with the builtin `profile` measuring at every gate that can: the
/// output, which the command's own audits passed.
pub fn every_gate_transformed(profile: &str, files: &[(&str, &str)]) -> String {
    let every = measuring_builtin(profile);
    let mut all = files.to_vec();
    all.push(("every.toml", &every));
    transformed_in(&all, "p.mpf", "every.toml")
}

/// The builtin profiles whose gates move a milling machine (all but the gauge's, which moves nothing,
/// and the lathe's, which refuses the milling plane).
pub const MILLING_PROFILES: [&str; 3] = ["blum-tc50", "siemens-cycle978", "tool-setter"];

/// The index of the first of `lines` that starts with `at`.
pub fn line_starting(lines: &[&str], at: &str) -> usize {
    lines
        .iter()
        .position(|l| l.starts_with(at))
        .unwrap_or_else(|| panic!("no `{at}` in\n{}", lines.join("\n")))
}

/// `fixtures/SET/FILE` as `p.mpf`, with the subprograms `subs` of `fixtures/SET/subs` beside it, transformed
/// with the builtin `profile` measuring at every gate that can: the output.
pub fn set_every_gate(set: &str, profile: &str, file: &str, subs: &[&str]) -> String {
    let read = |name: &str| std::fs::read_to_string(fixture(&format!("{set}/{name}"))).unwrap();
    let texts: Vec<(String, String)> = subs
        .iter()
        .map(|s| (s.to_string(), read(&format!("subs/{s}"))))
        .collect();
    let src = read(file);
    let mut files = vec![("p.mpf", src.as_str())];
    files.extend(texts.iter().map(|(n, t)| (n.as_str(), t.as_str())));
    every_gate_transformed(profile, &files)
}

/// The program's own blocks (by their first word, `N…`) right before which a gate measures.
pub fn measured_before(out: &str) -> Vec<String> {
    let lines: Vec<&str> = out.lines().collect();
    let (mut gate_start, mut found) = (0, Vec::new());
    for (k, line) in lines.iter().enumerate() {
        if line.ends_with(";DL") {
            continue;
        }
        if gate_measures(&lines[gate_start..k]) {
            found.push(line.split_whitespace().next().unwrap_or("").to_string());
        }
        gate_start = k + 1;
    }
    found
}

/// The lines of `out` from the first that starts with `from` up to the next after it that starts with `to`
/// (excluded).
pub fn lines_between<'a>(out: &'a str, from: &str, to: &str) -> Vec<&'a str> {
    let lines: Vec<&str> = out.lines().collect();
    let a = line_starting(&lines, from);
    let b = a + 1 + line_starting(&lines[a + 1..], to);
    lines[a..b].to_vec()
}

/// The lines driftloop inserted right before the first line of `out` that starts with `at`: the gate there.
pub fn gate_before<'a>(out: &'a str, at: &str) -> Vec<&'a str> {
    let lines: Vec<&str> = out.lines().collect();
    let end = line_starting(&lines, at);
    let start = lines[..end]
        .iter()
        .rposition(|l| !l.ends_with(";DL"))
        .map_or(0, |k| k + 1);
    lines[start..end].to_vec()
}

/// Whether the gate `lines` (see [`gate_before`]) measures: the zero, or a gate planned to measure.
pub fn gate_measures(lines: &[&str]) -> bool {
    lines
        .iter()
        .any(|l| l.contains("stage 4") || l.contains("planned: measure"))
}
