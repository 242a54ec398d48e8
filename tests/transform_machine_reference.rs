//! A gate measuring at a reference fixed on the machine (tool setter, lathe setter arm) approaches its start
//! point with SUPA, in machine coordinates, while the clearance height is in work coordinates: under a work
//! offset on the retract axis the clearance can lie below the start point. Through the binary: the audit
//! started with such offsets shows the old way (across at the clearance, then down after measuring) as a
//! hazard, the gates rise to the start point instead and pass, `position.retract_max` stops a gate that
//! would have to rise beyond the machine's top before it moves, and a program in inch gets its gates in
//! metric (the offsets made the unit mix-up visible).

mod common;

use std::path::Path;

use common::{fixture, run_in, transformed_in};

/// `run --audit` of `out` against `original` on a machine whose work offsets `offsets` gives (the body of
/// `[offsets]`): exit code and the report.
fn audit(out: &str, original: &str, profile: &str, offsets: &str) -> (bool, String) {
    let original = std::fs::read_to_string(original).unwrap();
    let machine = format!("[offsets]\n{offsets}\n");
    let model = fixture("omm/model.toml");
    let (o, _dir) = run_in(
        &[
            ("out.mpf", out),
            ("orig.mpf", &original),
            ("m.toml", &machine),
        ],
        &[
            "run",
            "--audit",
            "out.mpf",
            "--original",
            "orig.mpf",
            "--model",
            &model,
            "--profile",
            profile,
            "--machine",
            "m.toml",
        ],
    );
    let text = String::from_utf8_lossy(&o.stdout).into_owned() + &common::stderr(&o);
    (o.status.success(), text)
}

/// The output without the blocks that raise the travel height to the reference: the gate as it was.
fn without_the_rise(out: &str) -> String {
    let lines: Vec<&str> = out.lines().collect();
    let mut kept = Vec::new();
    let mut k = 0;
    while k < lines.len() {
        if lines[k].contains("$P_ACTFRAME") && lines[k].starts_with("IF ") {
            k += 3;
            continue;
        }
        kept.push(lines[k]);
        k += 1;
    }
    kept.join("\n") + "\n"
}

/// The audit of `out` is clean and complete under each of `offsets`.
fn clean_under(out: &str, program: &str, profile: &str, offsets: &[&str]) {
    for offsets in offsets {
        let (clean, report) = audit(out, program, profile, offsets);
        assert!(clean, "{offsets}: {report}");
        assert!(report.contains("0 finding(s)"), "{offsets}: {report}");
        assert!(
            !report.contains("ended the transformed program"),
            "{offsets}: {report}"
        );
    }
}

/// The audit's report on `out` without its rise to the reference, under `offsets`: it must find hazards.
fn hazard_without_the_rise(out: &str, program: &str, profile: &str, offsets: &str) -> String {
    let (clean, report) = audit(&without_the_rise(out), program, profile, offsets);
    assert!(!clean, "{report}");
    report
}

#[test]
fn a_milling_gate_rises_to_the_setters_start_point_under_a_low_work_offset() {
    let program = fixture("programs/single_tool.mpf");
    let out = transformed_in(&[], &program, "tool-setter");
    // Clearance Z100 in G54, which lies at Z-500: the setter's start point Z-300 (machine) is 100 mm
    // higher. Each gate travels at Z-300 - offset, never at the clearance below it.
    assert!(
        out.contains("IF R62<-300-($P_ACTFRAME[Z,TR]+$P_ACTFRAME[Z,FI]) ;DL"),
        "{out}"
    );
    assert!(
        !out.contains("$AA_IM"),
        "the guard that stopped the machine is gone"
    );
    clean_under(
        &out,
        &program,
        "tool-setter",
        &[
            "G54 = { Z = -500.0 }",
            "G54 = { Z = -380.0 }",
            "G54 = { Z = 0.0 }",
        ],
    );
    // The gate as it was travels across 100 mm below the start point and moves down after measuring.
    let report = hazard_without_the_rise(&out, &program, "tool-setter", "G54 = { Z = -500.0 }");
    assert!(
        report.contains("at Z-400 (machine coordinates) below the reference's start point Z-300"),
        "{report}"
    );
    assert!(
        report.contains("the move out of the probe point"),
        "{report}"
    );
}

#[test]
fn a_lathe_gate_rises_in_x_to_the_arms_start_diameter_under_an_x_offset() {
    let program = fixture("programs/lathe.mpf");
    let out = transformed_in(&[], &program, "lathe-setter");
    // X in radius inside the gate: the start diameter 120 is 60, the clearance diameter 200 is 100.
    assert!(
        out.contains("IF R62<60-($P_ACTFRAME[X,TR]+$P_ACTFRAME[X,FI]) ;DL"),
        "{out}"
    );
    clean_under(
        &out,
        &program,
        "lathe-setter",
        &["G54 = { X = -50.0, Z = -300.0 }", "G54 = { X = 20.0 }"],
    );
    let report = hazard_without_the_rise(
        &out,
        &program,
        "lathe-setter",
        "G54 = { X = -50.0, Z = -300.0 }",
    );
    assert!(
        report.contains("at X50 (machine coordinates) below the reference's start point X60"),
        "{report}"
    );
}

/// The tool-setter profile with `retract_max` (machine Z).
fn setter_with_retract_max(max: &str) -> String {
    let (o, _dir) = run_in(&[], &["profiles", "tool-setter"]);
    common::stdout(&o).replace(
        "clearance = 100.0\n",
        &format!("clearance = 100.0\nretract_max = {max}\n"),
    )
}

#[test]
fn retract_max_is_validated_and_stops_a_gate_that_would_rise_beyond_it_before_it_moves() {
    let program = std::fs::read_to_string(fixture("programs/single_tool.mpf")).unwrap();
    let model = fixture("omm/model.toml");
    // Below the setter's start point: no gate could reach the setter.
    let (o, _dir) = run_in(
        &[
            ("p.mpf", &program),
            ("s.toml", &setter_with_retract_max("-350.0")),
        ],
        &["plan", "p.mpf", "--model", &model, "--profile", "s.toml"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(
        common::stderr(&o)
            .contains("position.retract_max -350 lies below the probing start point Z-300"),
        "{}",
        common::stderr(&o)
    );
    let profile = setter_with_retract_max("0.0");
    let (o, dir) = run_in(
        &[("p.mpf", &program), ("s.toml", &profile)],
        &[
            "transform",
            "p.mpf",
            "--model",
            &model,
            "--profile",
            "s.toml",
            "--no-audit",
            "-o",
            "out.mpf",
        ],
    );
    assert!(o.status.success(), "{}", common::stderr(&o));
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    let check = "IF (R62>R65) AND (R62+($P_ACTFRAME[Z,TR]+$P_ACTFRAME[Z,FI])>0) ;DL";
    let at = out.lines().position(|l| l == check).expect(check);
    let first_move = out
        .lines()
        .position(|l| l.starts_with("G0 G90 Z=R62"))
        .unwrap();
    assert!(at < first_move, "the check comes before the gate moves");
    let dry_run = |offsets: &str| {
        let machine = format!("[offsets]\n{offsets}\n");
        let (o, _dir) = run_in(
            &[("out.mpf", &out), ("m.toml", &machine)],
            &["run", "out.mpf", "--machine", "m.toml"],
        );
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    // G54 at Z-50: the clearance Z100 is machine Z50, above the top: the alarm, offset given back.
    let high = dry_run("G54 = { Z = -50.0 }");
    assert!(high.contains("stopped by alarm 65000"), "{high}");
    assert!(high.contains("retract_max"), "{high}");
    // G54 at Z-500: the gates rise to the setter's start point, Z-300, below the top.
    let low = dry_run("G54 = { Z = -500.0 }");
    assert!(!low.contains("alarm"), "{low}");
}

#[test]
fn a_program_in_inch_gets_its_gates_in_metric_and_its_unit_and_feed_back() {
    // G70 reads system variables in the basic system (mm) but takes positions in inch: a gate that saved
    // $AA_IW and went back to it, or rose to the clearance 100, moved 25.4 times as far.
    let prog = "\
G17 G90 G94 G54 G700
T1 D1
S3000 M3
G0 X1 Y1 Z2
G1 Z-0.05 F20
G1 X3
G0 Z2 ; PASS 2
G1 Z-0.1 F20
G1 X1
G0 Z2
M30
";
    let out = transformed_in(&[("p.mpf", prog)], "p.mpf", "tool-setter");
    let lines: Vec<&str> = out.lines().collect();
    let gates: Vec<usize> = (0..lines.len())
        .filter(|&k| {
            lines[k].starts_with("; driftloop gate") || lines[k].starts_with("; driftloop stage 1")
        })
        .collect();
    assert!(!gates.is_empty(), "{out}");
    for &g in &gates {
        assert_eq!(lines[g + 1], "G710 ;DL", "{out}");
    }
    // Every switch to metric gives the unit back, after a feed with the program's feed (G700 reads F in
    // inch/min).
    let count = |p: &dyn Fn(&str) -> bool| out.lines().filter(|l| p(l)).count();
    assert_eq!(
        count(&|l| l == "G710 ;DL"),
        count(&|l| l.starts_with("G700") && l.ends_with(";DL")),
        "{out}"
    );
    assert!(out.contains("\nG700 F20 ;DL\nG0 Z2 ; PASS 2\n"), "{out}");
    // The work offset's restore before M30 runs in mm too.
    let end = out.find("; driftloop: work offset back").unwrap();
    assert!(
        out[end..].lines().nth(1) == Some("G710 ;DL"),
        "{}",
        &out[end..]
    );
    let original = Path::new("p.mpf");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(original), prog).unwrap();
    let original = dir.path().join(original).display().to_string();
    let (clean, report) = audit(
        &out,
        &original,
        "tool-setter",
        "G54 = { X = 120.0, Y = 80.0, Z = -450.0 }",
    );
    assert!(clean, "{report}");
}

#[test]
fn a_lathe_gate_does_not_go_where_the_program_mills() {
    // A milling program (G17, X in radius) with the lathe profile: its gate would retract along X to a
    // clearance diameter and travel Z to the arm, dragging the end mill sideways through the part.
    let mill = "G17 G90 G94 G54\nT=\"EM12\" M6\nD1\nS6000 M3 M8\nG0 X-10 Y0 Z20\nG1 Z-2 F500\nX80 F1200\nG0 Z50\nM30\n";
    let (o, _dir) = common::transform_in(&[("mill.mpf", mill)], "mill.mpf", "lathe-setter");
    assert!(!o.status.success());
    assert!(
        common::stderr(&o).contains("the program mills there (the milling plane G17 in force"),
        "{}",
        common::stderr(&o)
    );
    // A lathe drilling on its axis under G17 is measured once the program turns in G18 again.
    let lathe = "G18 G90 G95 G54 DIAMON\nT1 D1\nG96 S180 LIMS=2500 M4 M8\nG0 X52 Z2\nG1 Z-40 F0.2\nG0 X60\nG0 Z2\nG17\nT2 D1\nG97 S1200 M3\nG0 X0 Z5\nG1 Z-20 F0.1\nG0 Z5\nG18\nT1 D1\nG96 S180 M4\nG0 X60 Z2\nG1 X48 F0.2\nG1 Z-40\nG0 X60\nM30\n";
    let out = transformed_in(&[("lathe.mpf", lathe)], "lathe.mpf", "lathe-setter");
    assert!(out.contains("driftloop gate"), "{out}");
    // A lathe program that turns first in the plane it starts in (G18 on a lathe) and selects G17 only
    // for a later milling step keeps its zero before the milling step.
    let turns_first = lathe.replacen("G18 G90", "G90", 1);
    let out = transformed_in(&[("lathe.mpf", &turns_first)], "lathe.mpf", "lathe-setter");
    assert!(out.contains("stage 4: reference measurement"), "{out}");
}

#[test]
fn a_lathe_gate_does_not_go_before_a_milling_programs_g17() {
    // A milling program that selects G17 only after its first blocks (the warm-up routines of
    // ../shared/corpus write `G70 G90 G17` after a declaration) left the places before it with no plane
    // written, and the lathe profile put its zero there: X retracted to a clearance diameter on a mill. The plane the
    // program selects before its first cut is the one it machines in from its start.
    let mill = "G54 G90\nT=\"EM12\" M6\nD1\nS6000 M3 M8\nG17 G94\nG0 X-10 Y0 Z20\nG1 Z-2 F500\nX80 F1200\nG0 Z50\nM30\n";
    let (o, _dir) = common::transform_in(&[("mill.mpf", mill)], "mill.mpf", "lathe-setter");
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("or selected before the program's first cut"),
        "{err}"
    );
}
