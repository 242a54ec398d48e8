//! Hostile and broken input through the built binary (issue J): every case refuses with a message that
//! names the file (and line and column where there is one), exits 2, and writes nothing a machine would run.
//! Sections follow the issue's items: what reaches NC, aborts and panics, bounded work, files, honest
//! success.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

fn fixture(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(rel)
}

fn text_of(rel: &str) -> String {
    std::fs::read_to_string(fixture(rel)).unwrap()
}

/// The fixture `rel` with `from` replaced by `to` (which must occur), written to `dir/name`.
fn edited(dir: &Path, rel: &str, from: &str, to: &str, name: &str) -> String {
    let text = text_of(rel);
    assert!(text.contains(from), "{rel} has no `{from}`");
    let path = dir.join(name);
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
    path.display().to_string()
}

/// Rows of `from | to | where | what`: a replacement in a fixture and what its refusal must say.
fn cases(table: &str) -> Vec<[&str; 4]> {
    table
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| {
            let cells: Vec<&str> = l.split(" | ").collect();
            cells.try_into().expect("four cells a row")
        })
        .collect()
}

fn code(o: &Output) -> i32 {
    o.status.code().expect("exited, not killed by a signal")
}

fn err(o: &Output) -> String {
    common::stderr(o)
}

/// Runs `driftloop ARGS` in `dir` with empty stdin.
fn run_in(dir: &Path, args: &[&str]) -> Output {
    common::driftloop(dir, args, b"")
}

/// A failure: exit 2, no panic, stderr holds every `needle` (and not one of `absent`).
fn assert_failed(o: &Output, needles: &[&str], absent: &[&str]) {
    let e = err(o);
    assert_eq!(code(o), 2, "{e}");
    assert!(!e.contains("panicked"), "{e}");
    for n in needles {
        assert!(e.contains(n), "`{n}` not in: {e}");
    }
    for n in absent {
        assert!(!e.contains(n), "`{n}` in: {e}");
    }
}

/// A refusal: a failure that wrote nothing on stdout.
fn assert_refused(o: &Output, needles: &[&str]) {
    assert_failed(o, needles, &[]);
    assert!(o.stdout.is_empty(), "wrote {} bytes", o.stdout.len());
}

/// `transform handwritten.mpf --model MODEL --profile PROFILE -o dir/out.mpf`: refused, and no output file.
fn transform_refused(dir: &Path, model: &str, profile: &str, needles: &[&str]) {
    let program = fixture("omm/handwritten.mpf").display().to_string();
    let o = run_in(
        dir,
        &[
            "transform",
            &program,
            "--model",
            model,
            "--profile",
            profile,
            "-o",
            "out.mpf",
        ],
    );
    assert_refused(&o, needles);
    assert!(!dir.join("out.mpf").exists(), "a refused transform wrote");
}

/// Each row of `table` (see [`cases`]) edits the model (`omm/model.toml`, saved as m.toml) or the profile
/// (saved as p.toml) fixture, and `transform` refuses the edited file saying where and what.
fn edits_refused(rel: &str, table: &str) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let is_model = rel == "omm/model.toml";
    for [from, to, at, what] in cases(table) {
        let file = edited(d, rel, from, to, if is_model { "m.toml" } else { "p.toml" });
        let (model, profile) = if is_model {
            (file, default_profile())
        } else {
            (default_model(), file)
        };
        transform_refused(d, &model, &profile, &[at, what]);
    }
}

fn default_model() -> String {
    fixture("omm/model.toml").display().to_string()
}

fn default_profile() -> String {
    fixture("omm/blum-tc50.toml").display().to_string()
}

/// The hand-written fixture program transformed with the fixture model, written to `path`.
fn transformed_fixture(path: &Path) -> Vec<u8> {
    let made = common::run(&[
        "transform",
        "fixtures/omm/handwritten.mpf",
        "--model",
        "fixtures/omm/model.toml",
        "--no-audit",
        "-o",
        &path.display().to_string(),
    ]);
    assert!(made.status.success(), "{}", err(&made));
    std::fs::read(path).unwrap()
}

// ---- 1. Never into NC: absurd numbers and block-breaking strings are refused where they are read ----

#[test]
fn model_values_that_would_write_absurd_nc_are_refused_with_line_and_column() {
    // τ → 0 would be written as EXP(-R/0); a channel name is written into the log's header and a
    // comment, where a line break injects a block; syntax and type errors carry their place too.
    edits_refused(
        "omm/model.toml",
        r#"
        tau_min = 12.0 | tau_min = 1e-300 | m.toml:13:11 | tau_min
        tau_min = 12.0 | tau_min = 1e300 | m.toml:13:11 | tau_min
        tau_min = 12.0 | tau_min = nan | m.toml:13:11 | tau_min
        tau_min = 12.0 | tau_min = -inf | m.toml:13:11 | tau_min
        [2.0, 4.5 | [1e308, 4.5 | m.toml:14:12 | gain_um[0]
        offset_um = 0.0 | offset_um = inf | m.toml:5:13 | offset_um
        5000.0] | 5e200] | m.toml:8: | grid_rpm[4]
        channel = "drift_z_um" | channel = "drift_z_um\nM30" | m.toml:4:11 | column name
        channel = "drift_z_um" | channel = "a\"b" | m.toml:4:11 | column name
        tau_min = 12.0 | tau_min = 12.0.0 | m.toml:13: | not a valid model file
        tau_min = 12.0 | tau_min = "x" | m.toml:13:11 | not a valid model file
        "#,
    );
}

#[test]
fn a_model_with_modes_and_no_speed_grid_is_refused_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = text_of("omm/model.toml")
        .replace("[1000.0, 2000.0, 3000.0, 4000.0, 5000.0]", "[]")
        .replace("[2.0, 4.5, 7.0, 9.5, 12.0]", "[]")
        .replace("[5.0, 10.0, 16.0, 22.0, 28.0]", "[]");
    std::fs::write(d.join("m.toml"), text).unwrap();
    transform_refused(
        d,
        "m.toml",
        &default_profile(),
        &["m.toml:8:12", "grid_rpm"],
    );
    for args in [
        &["predict", "m.toml", "--schedule", "3000:60"][..],
        &["plan", "x.mpf", "--model", "m.toml"][..],
    ] {
        std::fs::write(d.join("x.mpf"), "G54\nT1 M6\nS1000 M3\nG1 X10 F100\nM30\n").unwrap();
        assert_refused(&run_in(d, args), &["m.toml:8:12"]);
    }
}

#[test]
fn profile_values_that_would_break_or_misdirect_nc_are_refused_with_line_and_column() {
    // Texts with a line break or quote would inject `M30` into a comment or block; numbers: a travel
    // height below the probe, frames out of range, absurd limits; then syntax and type errors.
    edits_refused(
        "omm/blum-tc50.toml",
        r#"
        name = "blum-tc50" | name = "x\nM30" | p.toml:5:8 | printable ASCII
        name = "blum-tc50" | name = "x\rM30" | p.toml:5:8 | printable ASCII
        result = "R2" | result = "R2\nM30" | p.toml: | probe.result
        cycle = "BL9700( | cycle = "M30\nBL9700( | p.toml: | probe.cycle
        log_file = "DRIFTLOG" | log_file = "DRIFT\nLOG" | p.toml: | registers.log_file
        timer = "$AN_SETUP_TIME" | timer = "$AN_SETUP_TIME\nM30" | p.toml: | registers.timer
        select = "G54" | select = "G54\nM30" | p.toml: | offset.select
        clearance = 100.0 | clearance = -5.0 | p.toml:52:13 | position.clearance
        tolerance_um = 20.0 | tolerance_um = 1e300 | p.toml:78:16 | limits.tolerance_um
        tolerance_um = 20.0 | tolerance_um = nan | p.toml:78:16 | limits.tolerance_um
        z = 10.0 | z = 1e308 | p.toml: | position.z
        measure_s = 3.0 | measure_s = 1e300 | p.toml: | probe.measure_s
        tool_offset = 1 | tool_offset = 0 | p.toml: | probe.tool_offset
        r_last = 99 | r_last = 4000000000 | p.toml: | registers.r_last
        max_attempts = 8 | max_attempts = 4000000000 | p.toml: | limits.max_attempts
        tolerance_um = 20.0 | tolerance_um = 20.0.0 | p.toml:78: | not a valid machine profile
        tolerance_um = 20.0 | tolerance_um = "x" | p.toml:78:16 | expected f64
        "#,
    );
    // The stored-offset method writes a frame that exists, the one of the offset it selects again.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.toml");
    for (frame, what) in [("100000", "offset.frame"), ("2", "another work offset")] {
        let text = common::frame_profile_text().replace("frame = 1", &format!("frame = {frame}"));
        std::fs::write(&p, text).unwrap();
        transform_refused(
            dir.path(),
            &default_model(),
            p.to_str().unwrap(),
            &["p.toml:74:9", what],
        );
    }
}

#[test]
fn program_values_out_of_the_writable_range_refuse_the_transform() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let program = text_of("omm/handwritten.mpf");
    assert!(program.contains("S5000 M3"));
    let path = d.join("huge_s.mpf");
    std::fs::write(&path, program.replacen("S5000 M3", "S5EX15 M3", 1)).unwrap();
    let o = run_in(
        d,
        &[
            "transform",
            "huge_s.mpf",
            "--model",
            &default_model(),
            "--no-audit",
            "-o",
            "out.mpf",
        ],
    );
    assert_refused(&o, &["huge_s.mpf"]);
    assert!(!d.join("out.mpf").exists());
}

// ---- 2. No abort or panic: a full or closed stdout is an error of every command ----

/// Runs `driftloop ARGS` from the crate root with stdout on `/dev/full`.
#[cfg(target_os = "linux")]
fn to_full_disk(args: &[&str]) -> Output {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    std::process::Command::new(env!("CARGO_BIN_EXE_driftloop"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(std::process::Stdio::null())
        .stdout(full)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap()
}

#[cfg(target_os = "linux")]
#[test]
fn every_command_that_writes_stdout_fails_on_a_full_disk_without_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    transformed_fixture(&dir.path().join("t.mpf"));
    let transformed = dir.path().join("t.mpf").display().to_string();
    let (m, p, csv) = (
        "fixtures/omm/model.toml",
        "fixtures/omm/handwritten.mpf",
        "fixtures/data/characterisation.csv",
    );
    let commands: Vec<Vec<&str>> = vec![
        vec!["transform", p, "--model", m, "--no-audit", "-o", "-"],
        vec!["transform", p, "--model", m, "--no-audit", "--diff"],
        vec![
            "transform",
            p,
            "--model",
            m,
            "--no-audit",
            "--check",
            "--format",
            "json",
        ],
        vec!["check", "fixtures/nc/errors.mpf", "--format", "json"],
        vec!["parse", "fixtures/nc/cam.mpf"],
        vec!["strip", &transformed],
        vec!["plan", p, "--model", m],
        vec!["run", p],
        vec!["run", p, "--format", "json"],
        vec!["run", p, "--trace", "-"],
        vec!["predict", m, "--schedule", "3000:60"],
        vec!["fit", csv, "--channel", "drift_z_um", "--modes", "1"],
        vec!["profiles"],
        vec!["profiles", "blum-tc50"],
        vec!["positioning", "fixtures/positioning/paper_row.csv"],
        vec!["log", "merge", csv],
        vec!["diagnose", m, csv, "--max-effects", "0"],
        vec!["forward", csv, "--until", "100", "--format", "json"],
        vec!["bench", "--size-mb", "1", "--runs", "1"],
        vec!["--help"],
        vec!["transform", "--help"],
    ];
    for args in &commands {
        assert_failed(
            &to_full_disk(args),
            &["cannot write to standard output"],
            &[],
        );
    }
}

#[test]
fn a_program_cut_short_by_a_closed_pipe_is_no_success() {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_driftloop"))
        .args([
            "transform",
            "fixtures/omm/handwritten.mpf",
            "--model",
            "fixtures/omm/model.toml",
            "--no-audit",
            "-o",
            "-",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert_eq!(code(&o), 2, "{}", err(&o));
    assert!(err(&o).contains("not written completely"), "{}", err(&o));
}

#[test]
fn pass_markers_at_the_end_of_a_file_without_newline_plan_and_transform() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = default_model();
    std::fs::write(d.join("only.mpf"), "; PASS 1").unwrap();
    for cmd in ["plan", "transform"] {
        let o = run_in(d, &[cmd, "only.mpf", "--model", &model]);
        assert_refused(&o, &["only.mpf", "moves no axis"]);
    }
    std::fs::write(
        d.join("last.mpf"),
        "G54\nT1 M6\nS1000 M3\nG1 X10 F100\n; PASS 1",
    )
    .unwrap();
    let plan = run_in(d, &["plan", "last.mpf", "--model", &model]);
    assert_eq!(code(&plan), 0, "{}", err(&plan));
    let o = run_in(
        d,
        &["transform", "last.mpf", "--model", &model, "--no-audit"],
    );
    assert_eq!(code(&o), 0, "{}", err(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("; PASS 1\n"));
}

// ---- 3. No hang, bounded memory: work beyond a named limit is refused before it starts ----

#[test]
fn requests_for_unbounded_series_are_refused_with_the_limit_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let model = default_model();
    let sim = d.join("sim").display().to_string();
    let cases: Vec<(Vec<&str>, &[&str])> = vec![
        (
            vec!["predict", &model, "--schedule", "3000:60", "--step", "1e-9"],
            &["6.000e10 rows", "10000000", "--step"],
        ),
        (
            vec!["predict", &model, "--schedule", "3000:1e300"],
            &["rows", "10000000"],
        ),
        (
            vec!["predict", &model, "--schedule", "1e200:60"],
            &["faster than 1000000 rpm"],
        ),
        (
            vec!["simulate-data", &sim, "--minutes", "1e12"],
            &["3.333e11 rows", "10000000"],
        ),
        (
            vec!["simulate-data", &sim, "--step", "1e-6"],
            &["rows", "10000000"],
        ),
        (
            vec!["simulate-data", &sim, "--noise", "1e308"],
            &["--noise"],
        ),
        (
            vec!["simulate-data", &sim, "--theta", "1e300"],
            &["--theta"],
        ),
    ];
    for (args, needles) in cases {
        assert_refused(&run_in(d, &args), needles);
    }
    assert!(!d.join("sim").exists(), "a refused simulation wrote");
}

#[test]
fn measurement_figures_beyond_any_machine_are_refused_where_they_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let csv = text_of("data/characterisation.csv");
    let mut lines: Vec<String> = csv.lines().map(str::to_string).collect();
    assert_eq!(lines[0], "time_min,run,spindle_rpm,drift_z_um");
    let row = lines[1].clone();
    for (column, value, needle) in [
        (2, "1e200", "spindle_rpm`: 1e200 is beyond ±1000000 rpm"),
        (3, "1e306", "drift_z_um`: 1e306 is beyond ±1000000 µm"),
        (0, "1e300", "time_min`: 1e300 is beyond ±1000000000"),
    ] {
        let mut cells: Vec<&str> = row.split(',').collect();
        cells[column] = value;
        lines[1] = cells.join(",");
        std::fs::write(d.join("bad.csv"), lines.join("\n") + "\n").unwrap();
        let at = format!("bad.csv:2:{}", column + 1);
        for args in [
            &["fit", "bad.csv", "--channel", "drift_z_um"][..],
            &["diagnose", &default_model(), "bad.csv"][..],
            &["predict", &default_model(), "--data", "bad.csv"][..],
        ] {
            assert_refused(&run_in(d, args), &[&at, needle]);
        }
    }
    let rows = text_of("positioning/paper_row.csv").replacen("X,0,+,1,2", "X,0,+,1,1e16", 1);
    std::fs::write(d.join("pos.csv"), rows).unwrap();
    assert_refused(
        &run_in(d, &["positioning", "pos.csv"]),
        &["pos.csv:2:5", "within ±1e6", "1e16"],
    );
    let paper = fixture("positioning/paper_row.csv").display().to_string();
    for grid in ["0:1e-300:100", "-1e300:1:1e300"] {
        let flag = format!("--grid={grid}");
        assert_refused(
            &run_in(d, &["positioning", &paper, &flag]),
            &["more than the 100000 allowed"],
        );
    }
}

// ---- 5. Files: no output over an input, atomic in-place writes, walks that report what they cannot read ----

#[test]
fn an_output_that_is_an_input_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(fixture("data/characterisation.csv"), d.join("data.csv")).unwrap();
    std::fs::copy(fixture("omm/model.toml"), d.join("m.toml")).unwrap();
    std::fs::copy(fixture("omm/handwritten.mpf"), d.join("p.mpf")).unwrap();
    let before: Vec<Vec<u8>> = ["data.csv", "m.toml", "p.mpf"]
        .iter()
        .map(|f| std::fs::read(d.join(f)).unwrap())
        .collect();
    let cases: Vec<Vec<&str>> = vec![
        vec![
            "fit",
            "data.csv",
            "--channel",
            "drift_z_um",
            "-o",
            "./data.csv",
        ],
        vec!["diagnose", "m.toml", "data.csv", "--report", "data.csv"],
        vec!["diagnose", "m.toml", "data.csv", "-o", "m.toml"],
        vec!["transform", "p.mpf", "--model", "m.toml", "-o", "p.mpf"],
        vec!["transform", "p.mpf", "--model", "m.toml", "-o", "m.toml"],
        vec!["predict", "m.toml", "--data", "data.csv", "-o", "data.csv"],
        vec!["sensors", "data.csv", "-o", "data.csv"],
        vec!["sensors", "data.csv", "--report", "./data.csv"],
        vec!["log", "merge", "data.csv", "-o", "data.csv"],
        vec!["strip", "p.mpf", "-o", "p.mpf"],
        vec!["run", "p.mpf", "--trace", "p.mpf"],
    ];
    for args in &cases {
        assert_refused(&run_in(d, args), &["is the input", "would destroy"]);
    }
    for (f, b) in ["data.csv", "m.toml", "p.mpf"].iter().zip(&before) {
        assert_eq!(&std::fs::read(d.join(f)).unwrap(), b, "{f} changed");
    }
}

#[cfg(unix)]
#[test]
fn in_place_keeps_the_mode_and_leaves_no_temporary_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = d.join("p.mpf");
    std::fs::copy(fixture("omm/handwritten.mpf"), &p).unwrap();
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
    let o = run_in(
        d,
        &[
            "transform",
            "p.mpf",
            "--model",
            &default_model(),
            "--no-audit",
            "--in-place",
        ],
    );
    assert_eq!(code(&o), 0, "{}", err(&o));
    let meta = std::fs::metadata(&p).unwrap();
    assert_eq!(meta.permissions().mode() & 0o777, 0o640);
    assert!(std::fs::read(&p).unwrap().starts_with(b"; driftloop-omm"));
    let names: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["p.mpf".to_string()]);
}

/// Files in `dir` whose names mark them as driftloop's temporary files.
#[cfg(unix)]
fn temporary_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".driftloop.tmp"))
        .collect()
}

#[cfg(unix)]
#[test]
fn a_terminated_in_place_write_leaves_no_temporary_file_and_whole_programs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let transformed = transformed_fixture(&d.join("t.mpf"));
    let original = std::fs::read(fixture("omm/handwritten.mpf")).unwrap();
    let progs = d.join("progs");
    std::fs::create_dir(&progs).unwrap();
    // Enough files that the writing takes a while; the signal lands while one is being written.
    for i in 0..400 {
        std::fs::write(progs.join(format!("p{i:03}.mpf")), &transformed).unwrap();
    }
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_driftloop"))
        .args(["strip", "--in-place", "progs"])
        .current_dir(d)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while temporary_files(&progs).is_empty()
        && child.try_wait().unwrap().is_none()
        && started.elapsed().as_secs() < 60
    {
        std::thread::yield_now();
    }
    // SIGTERM, as `kill` sends it.
    let _ = std::process::Command::new("kill")
        .arg(child.id().to_string())
        .status();
    let status = child.wait().unwrap();
    assert_eq!(temporary_files(&progs), Vec::<String>::new(), "{status:?}");
    for e in std::fs::read_dir(&progs).unwrap() {
        let bytes = std::fs::read(e.unwrap().path()).unwrap();
        assert!(
            bytes == original || bytes == transformed,
            "a half-written program"
        );
    }
}

#[cfg(unix)]
#[test]
fn walks_report_dangling_links_and_unreadable_entries_and_go_on() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tree = d.join("tree");
    std::fs::create_dir(&tree).unwrap();
    std::fs::copy(fixture("nc/errors.mpf"), tree.join("a.mpf")).unwrap();
    std::os::unix::fs::symlink("nowhere.mpf", tree.join("b.mpf")).unwrap();
    for args in [
        &["check", "tree", "missing.mpf"][..],
        &["strip", "--check", "tree", "missing.mpf"][..],
    ] {
        // The readable program is still worked on.
        assert_failed(
            &run_in(d, args),
            &[
                "tree/b.mpf: dangling symbolic link",
                "missing.mpf",
                "tree/a.mpf",
            ],
            &[],
        );
    }
    let o = run_in(
        d,
        &[
            "transform",
            "tree",
            "--model",
            &default_model(),
            "--check",
            "--format",
            "json",
        ],
    );
    assert_eq!(code(&o), 2);
    let json = String::from_utf8_lossy(&o.stdout);
    assert!(json.contains("dangling symbolic link"), "{json}");
}

#[test]
fn binary_and_utf16_files_get_their_own_diagnostic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let utf16: Vec<u8> = "\u{feff}G54\r\nG0 X1\r\nM30\r\n"
        .encode_utf16()
        .flat_map(u16::to_le_bytes)
        .collect();
    std::fs::write(d.join("u.mpf"), utf16).unwrap();
    let binary: Vec<u8> = (0..=255u8).cycle().take(3000).collect();
    std::fs::write(d.join("b.mpf"), binary).unwrap();
    for (file, needle) in [("u.mpf", "UTF-16"), ("b.mpf", "binary file")] {
        for args in [
            &["check", file][..],
            &["transform", file, "--model", &default_model()][..],
            &["plan", file, "--model", &default_model()][..],
        ] {
            assert_failed(&run_in(d, args), &[file, needle], &["PC-format archive"]);
        }
    }
}

/// Data, model, profile and machine files that are UTF-16, binary or Latin-1 were refused with the CSV
/// tokeniser's `invalid utf-8 … byte index 0` or serde's `stream did not contain valid UTF-8`.
#[test]
fn binary_utf16_and_latin1_data_and_toml_files_say_what_they_hold() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let utf16 = |text: &str| -> Vec<u8> {
        let mut bytes = vec![0xFF, 0xFE];
        bytes.extend(text.encode_utf16().flat_map(u16::to_le_bytes));
        bytes
    };
    std::fs::write(
        d.join("u.csv"),
        utf16(&text_of("data/characterisation.csv")),
    )
    .unwrap();
    std::fs::write(d.join("u.toml"), utf16(&text_of("omm/model.toml"))).unwrap();
    let binary: Vec<u8> = (0..=255u8).cycle().take(3000).collect();
    std::fs::write(d.join("b.csv"), &binary).unwrap();
    std::fs::write(d.join("b.toml"), &binary).unwrap();
    std::fs::write(
        d.join("l.csv"),
        b"time_min,spindle_rpm,z_um,hall_\xB0c\n0,1000,0.1,20\n",
    )
    .unwrap();
    let mut latin = std::fs::read(fixture("omm/model.toml")).unwrap();
    latin.extend(b"\n# Fr\xE4se\n");
    std::fs::write(d.join("l.toml"), latin).unwrap();
    let m = default_model();
    let p = fixture("omm/handwritten.mpf").display().to_string();
    let csv_cases: [(&str, &[&str]); 3] = [
        ("u.csv", &["u.csv: UTF-16 text: save it as UTF-8"]),
        ("b.csv", &["b.csv: a binary file, not a CSV file"]),
        (
            "l.csv",
            &["l.csv:1: column 4: a cell that is not UTF-8 text; save it as UTF-8"],
        ),
    ];
    for (file, needles) in csv_cases {
        for args in [
            vec!["fit", file],
            vec!["forward", file, "--until", "1h"],
            vec!["sensors", file],
            vec!["diagnose", &m, file],
            vec!["log", "merge", file],
            vec!["predict", &m, "--data", file],
        ] {
            assert_refused(&run_in(d, &args), needles);
        }
    }
    for (file, needle) in [("u.csv", "UTF-16 text"), ("b.csv", "a binary file")] {
        assert_refused(&run_in(d, &["positioning", file]), &[file, needle]);
    }
    let toml_cases: [(&str, &str); 3] = [
        (
            "u.toml",
            "u.toml: cannot read: UTF-16 text: save it as UTF-8",
        ),
        (
            "b.toml",
            "b.toml: cannot read: a binary file, not a TOML file",
        ),
        (
            "l.toml",
            "l.toml: cannot read: line 20, column 5: byte 0xE4 is not UTF-8 text",
        ),
    ];
    for (file, needle) in toml_cases {
        for args in [
            vec!["predict", file, "--schedule", "1000:10"],
            vec!["plan", &p, "--model", file],
            vec!["plan", &p, "--model", &m, "--profile", file],
        ] {
            assert_refused(&run_in(d, &args), &[needle]);
        }
        assert_failed(
            &run_in(d, &["run", &p, "--machine", file]),
            &[file, needle.split(": cannot read: ").nth(1).unwrap()],
            &[],
        );
    }
}

/// `plan` and `transform` said only "the program has 1 syntax error(s)"; the user had to run `check` to
/// learn where. And the message showed an unclosed quote as `\"hello`, Rust's escape.
#[test]
fn a_refusal_for_syntax_errors_names_the_first_one_where_it_is() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.mpf"), "G0 X0\nMSG(\"hello\nG1 X10 F100\nM30\n").unwrap();
    std::fs::write(d.join("i.mpf"), "R1=1\nIF R1==1\nG0 X0\nM30\n").unwrap();
    let m = default_model();
    for (file, needle) in [
        (
            "s.mpf",
            "s.mpf: the program has 1 syntax error(s), the first at line 2, column 5: expected a closed string, found `\"hello`; fix them (`driftloop check` shows each with a hint) or pass --force",
        ),
        (
            "i.mpf",
            "i.mpf: the program has 1 syntax error(s), the first at line 2, column 1: IF on line 2 has no ENDIF",
        ),
    ] {
        assert_refused(&run_in(d, &["plan", file, "--model", &m]), &[needle]);
        assert_refused(
            &run_in(d, &["transform", file, "--model", &m, "-o", "out.mpf"]),
            &[needle],
        );
        assert!(!d.join("out.mpf").exists());
    }
    let o = run_in(d, &["check", "s.mpf"]);
    assert_eq!(code(&o), 1);
    assert!(err(&o).contains("found `\"hello`"), "{}", err(&o));
}

/// CSVs a logger or a spreadsheet gets wrong: each refusal names the file, where there is one the line, and
/// what to do. A fit of rows that span no time said "20 samples …; the model needs at least 3", and the
/// errors of a fit or diagnosis that cannot start named no file.
#[test]
fn measurement_files_that_cannot_be_fitted_say_which_and_why() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let head = "time_min,spindle_rpm,drift_z_um\n";
    let rows = |times: &[u32]| -> String {
        times
            .iter()
            .map(|t| format!("{t},3000,{}\n", f64::from(*t) * 0.01))
            .collect()
    };
    std::fs::write(d.join("header.csv"), head).unwrap();
    std::fs::write(d.join("ragged.csv"), format!("{head}0,1000,0.1\n5,1000\n")).unwrap();
    std::fs::write(
        d.join("back.csv"),
        format!("{head}{}", rows(&[0, 10, 5, 15])),
    )
    .unwrap();
    std::fs::write(d.join("few.csv"), format!("{head}{}", rows(&[0, 5, 5, 10]))).unwrap();
    std::fs::write(d.join("same.csv"), format!("{head}{}", rows(&[7; 20]))).unwrap();
    let m = default_model();
    for (file, needles) in [
        (
            "header.csv",
            &["header.csv: no data rows after the header"][..],
        ),
        (
            "ragged.csv",
            &["ragged.csv:3: 2 fields, but the header has 3: every row needs one value per column"],
        ),
        (
            "back.csv",
            &["back.csv:4:1: time goes backwards within run 1: 5 after 10"],
        ),
        (
            "few.csv",
            &[
                "few.csv: 4 samples in the fitted rows; the model needs at least",
                "measure longer",
            ],
        ),
        (
            "same.csv",
            &[
                "same.csv: the fitted rows span no time",
                "check the time column",
            ],
        ),
    ] {
        assert_refused(&run_in(d, &["fit", file]), needles);
    }
    assert_refused(
        &run_in(d, &["forward", "few.csv", "--until", "8"]),
        &["few.csv: drift_z_um: 3 samples in the fitted rows"],
    );
    assert_refused(
        &run_in(d, &["diagnose", &m, "few.csv"]),
        &["few.csv: only", "rows before the holdout", "--holdout-from"],
    );
}

/// An output that cannot be written (its folder is a file) names the output, and nothing half-written is
/// left; `transform` and `strip` said only "cannot create h.mpf: File exists".
#[test]
fn an_output_that_cannot_be_written_is_named_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(fixture("omm/handwritten.mpf"), d.join("p.mpf")).unwrap();
    std::fs::copy(fixture("data/characterisation.csv"), d.join("data.csv")).unwrap();
    let m = default_model();
    let cases: [(&[&str], &str); 5] = [
        (
            &["transform", "p.mpf", "--model", &m, "-o", "p.mpf/x.mpf"],
            "cannot write p.mpf/x.mpf: cannot create its folder p.mpf",
        ),
        (
            &["strip", "p.mpf", "-o", "p.mpf/x.mpf"],
            "cannot write p.mpf/x.mpf: cannot create its folder p.mpf",
        ),
        (
            &["fit", "data.csv", "-o", "p.mpf/m.toml"],
            "cannot write the model file p.mpf/m.toml",
        ),
        (
            &["log", "merge", "data.csv", "-o", "p.mpf/x.csv"],
            "cannot write p.mpf/x.csv",
        ),
        (
            &["run", "p.mpf", "--trace", "p.mpf/t.csv"],
            "cannot write p.mpf/t.csv",
        ),
    ];
    for (args, needle) in cases {
        assert_failed(&run_in(d, args), &[needle], &[]);
    }
    assert_eq!(
        std::fs::read(d.join("p.mpf")).unwrap(),
        std::fs::read(fixture("omm/handwritten.mpf")).unwrap()
    );
}

#[test]
fn a_closed_or_empty_stdin_is_no_program_and_a_missing_subprogram_folder_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for args in [
        &["check", "-"][..],
        &["transform", "-", "--model", &default_model()][..],
        &["plan", "-", "--model", &default_model()][..],
    ] {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_driftloop"))
            .args(args)
            .current_dir(d)
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap();
        assert_failed(&o, &["standard input is empty or closed"], &[]);
    }
    let program = fixture("omm/handwritten.mpf").display().to_string();
    assert_refused(
        &run_in(d, &["run", &program, "--subprograms", "no-such-folder"]),
        &["no-such-folder", "not a folder"],
    );
}

// ---- 6. Honest success ----

#[test]
fn the_demo_never_calls_a_run_stopped_by_alarms_a_success() {
    let o = common::run(&["demo", "--tolerance", "0"]);
    assert_refused(
        &o,
        &["--tolerance 0", "tolerance_um must be a positive number"],
    );
    // 1 µm: every compensated run stops as scrap at its first measurement.
    let o = common::run(&["demo", "--tolerance", "1"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(code(&o), 1, "{out}");
    assert!(!out.contains("target met"), "{out}");
    assert!(
        out.contains("target NOT met: the run after diagnose stopped"),
        "{out}"
    );
}

#[test]
fn json_output_carries_the_error_record_and_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("p.mpf"), "G54\nT1 M6\nS1000 M3\nG1 X10 F100\nM30\n").unwrap();
    for args in [
        &[
            "transform",
            "p.mpf",
            "--model",
            "nope.toml",
            "--format",
            "json",
        ][..],
        &["plan", "p.mpf", "--model", "nope.toml", "--format=json"][..],
        &["diagnose", "nope.toml", "data.csv", "--format", "json"][..],
        &["fit", "nope.csv", "--format", "json"][..],
    ] {
        let o = run_in(d, args);
        assert_failed(&o, &["nope."], &[]);
        let record: serde_json::Value = serde_json::from_slice(&o.stdout)
            .unwrap_or_else(|e| panic!("{args:?}: {e}: {}", String::from_utf8_lossy(&o.stdout)));
        let message = record["error"].as_str().unwrap();
        assert!(message.contains("nope."), "{args:?}: {message}");
    }
}

#[test]
fn a_file_of_too_many_sensors_is_refused_with_the_limit_named() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let n = 501;
    let mut csv = String::from("time_min,e_um");
    for i in 0..n {
        csv.push_str(&format!(",t{i}_c"));
    }
    csv.push('\n');
    for r in 0..6 {
        csv.push_str(&format!("{r},{}", r % 3));
        for i in 0..n {
            csv.push_str(&format!(",{}", 20 + (i + r) % 5));
        }
        csv.push('\n');
    }
    std::fs::write(d.join("wide.csv"), csv).unwrap();
    assert_refused(
        &run_in(d, &["sensors", "wide.csv"]),
        &["501 temperature columns", "more than the 500"],
    );
}

#[test]
fn a_walk_over_a_deep_expression_and_a_program_over_16_mib_reports_without_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let tree = dir.path().join("tree");
    std::fs::create_dir(&tree).unwrap();
    let deep = format!("R1={}1{}\nM30\n", "(".repeat(100_000), ")".repeat(100_000));
    std::fs::write(tree.join("deep.mpf"), deep).unwrap();
    let line = "G1 X1.5 Y2 Z-3 F100\n";
    let big = line.repeat((17 << 20) / line.len() + 1);
    assert!(big.len() > 16 << 20);
    std::fs::write(tree.join("big.mpf"), big).unwrap();
    let o = run_in(dir.path(), &["check", "tree"]);
    let e = err(&o);
    assert_eq!(code(&o), 1, "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(
        e.contains("tree/deep.mpf:1:") && e.contains("nested deeper"),
        "{e}"
    );
    assert!(e.contains("checked 2 files"), "{e}");
}

#[test]
fn a_fit_window_before_the_files_first_row_says_where_its_clock_starts() {
    // A log that continues an earlier one: its clock starts at 24 h.
    let dir = tempfile::tempdir().unwrap();
    let mut csv = String::from("time_min,spindle_rpm,z_um,ambient_c\n");
    for k in 0..200 {
        let t = 1440 + 5 * k;
        let rpm = if k % 80 < 40 { 3000 } else { 0 };
        csv.push_str(&format!(
            "{t},{rpm},{},{}\n",
            f64::from(k % 80) * 0.1,
            20.0 + 0.01 * f64::from(k)
        ));
    }
    std::fs::write(dir.path().join("later.csv"), csv).unwrap();
    let needle = "no rows before 960 min: the data's first row is at 1440 min of the file's own clock (`--until 2400min` fits the first 960 min of it)";
    for args in [
        vec!["fit", "later.csv", "--until", "16h", "-o", "m.toml"],
        vec![
            "fit",
            "later.csv",
            "--kind",
            "dlag",
            "--until",
            "16h",
            "-o",
            "m.toml",
        ],
        vec!["forward", "later.csv", "--until", "16h"],
    ] {
        assert_refused(&run_in(dir.path(), &args), &[needle]);
    }
}
