//! Hazards a QA run of shop-style programs found in the blocks `transform` inserted, each as a minimal
//! program through the binary. `transform` audits its output twice, as the plan runs it and with every gate
//! measuring (the branch a pause takes on the machine), and writes nothing on a finding: each case must be
//! written (exit 0) and carry the right blocks.

mod common;

use std::path::Path;

/// Writes `files` into a new folder and transforms `program` there with `profile`: the run and the folder.
/// The control finds subprograms beside their caller, so `transform` does too, with no flag.
fn transform(
    files: &[(&str, &str)],
    program: &str,
    profile: &str,
) -> (std::process::Output, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/model.toml");
    let o = common::driftloop(
        dir.path(),
        &[
            "transform",
            program,
            "--model",
            &model.display().to_string(),
            "--profile",
            profile,
            "-o",
            "out.mpf",
        ],
        b"",
    );
    (o, dir)
}

/// The output program, which must have been written.
fn transformed(files: &[(&str, &str)], program: &str, profile: &str) -> String {
    let (o, dir) = transform(files, program, profile);
    assert!(o.status.success(), "{}", common::stderr(&o));
    std::fs::read_to_string(dir.path().join("out.mpf")).unwrap()
}

/// The refusal's message: nothing may have been written.
fn refused(files: &[(&str, &str)], program: &str, profile: &str) -> String {
    let (o, dir) = transform(files, program, profile);
    let err = common::stderr(&o);
    assert!(!o.status.success(), "{err}");
    assert!(!dir.path().join("out.mpf").exists());
    err
}

/// The default profile with `unknown_tool = "refuse"`: no gate measures where the program names no tool.
fn refusing_profile() -> String {
    driftloop::omm::DEFAULT_PROFILE
        .replace("unknown_tool = \"runtime\"", "unknown_tool = \"refuse\"")
}

/// The line index of the first line starting with `start`.
fn line_of(out: &str, start: &str) -> usize {
    out.lines()
        .position(|l| l.starts_with(start))
        .unwrap_or_else(|| panic!("no line starting with {start}:\n{out}"))
}

#[test]
fn a_jump_over_a_retract_does_not_make_the_label_a_place_that_restores_rapid() {
    // The fall-through path retracts in G0; the jump arrives in G1 at Z-1. A gate after the label that
    // measured would give back G0 and rapid through the part: it may correct, never measure there.
    let prog = "\
G17 G90 G94 G71
G54
T=\"A\" M6
D1
S4000 M3
G0 X-50 Y-50 Z5
G1 Z-1 F200
G1 X-20
GOTOF WEITER
G0 Z50
WEITER:
M1 ; PASS 2
X-50 Y-40
G0 Z100
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "tool-setter");
    let after = &out[out.find("WEITER:\n").unwrap()..];
    let gate_end = after.find("X-50 Y-40").unwrap();
    assert!(
        !after[..gate_end].contains("DL_SETTER("),
        "{}",
        &after[..gate_end]
    );
}

#[test]
fn a_gauge_gate_after_a_dressing_subprogram_writes_no_feed_back() {
    let dress = "G0 X60 Z140\nG1 X59.96 F5\nG1 Z160 F20\nG1 X40.4 Z-20 F2\nRET\n";
    let prog = "\
G18 G90 G94 G71 DIAMON
G54
T1 D1
S1500 M3
G0 X44 Z-20
G1 X42 F500
G0 X48
DRESS
G0 X44 Z-20 ; PASS finish
G1 X40.0
G0 X48
M5
M30
";
    let out = transformed(
        &[("p.mpf", prog), ("DRESS.SPF", dress)],
        "p.mpf",
        "grinder-gauge",
    );
    assert!(out.contains("DL_GAUGE("), "{out}");
    assert!(
        !out.lines()
            .any(|l| l.ends_with(";DL") && l.contains(" F500")),
        "{out}"
    );
}

#[test]
fn s_in_a_dwell_block_is_revolutions_not_a_speed() {
    let prog = "\
G18 G90 G94 G71 DIAMON
G54
T1 D1
S1500 M3
G0 X44 Z-20
G1 X40.2 F2
G4 S2
G0 X48
G0 X40.4 Z-40 ; PASS 2
G1 X40.0 F1
G0 X48
M5
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "lathe-setter");
    assert!(!out.contains("S2 M3 ;DL"), "{out}");
    assert!(!out.contains("; 2 rpm"), "{out}");
    assert!(out.contains("; 1500 rpm"), "{out}");
}

#[test]
fn coolant_comes_back_before_the_programs_own_tool_change() {
    let prog = "\
G17 G90 G94 G71
G54
T=\"A\" M6
D1
S5000 M3 M8
G0 X-50 Y-50 Z5
G1 Z-1 F200
G1 X-20
G0 Z100
T=\"B\" M6
D1
S4000 M3
G0 X-50 Y-50 Z5
G1 Z-1 F200
G1 X-20
G0 Z100
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    let change = line_of(&out, "T=\"B\" M6\n".trim_end());
    let lines: Vec<&str> = out.lines().collect();
    let gate: Vec<&str> = lines[..change]
        .iter()
        .rev()
        .take_while(|l| l.ends_with(";DL"))
        .copied()
        .collect();
    assert!(gate.contains(&"M8 ;DL"), "{gate:#?}");
}

#[test]
fn the_zero_is_measured_before_cuts_in_a_subprogram_or_a_cycle() {
    let pocket = "G0 X10 Y10 Z2\nG1 Z-3 F300\nG1 X40\nG1 Y40\nG1 X10\nG0 Z50\nM17\n";
    let prog = "\
G17 G90 G94 G71
G54
T=\"EM8\" M6
D1
S5000 M3
G0 X0 Y0 Z50
L100
L100
G0 Z100
M5
M30
";
    let out = transformed(
        &[("p.mpf", prog), ("L100.SPF", pocket)],
        "p.mpf",
        "grinder-gauge",
    );
    assert!(
        line_of(&out, "; driftloop stage 4") < line_of(&out, "L100"),
        "{out}"
    );
    // A drilling cycle driftloop cannot see into may cut: the zero goes before it.
    let drill = "\
G17 G90 G94 G71
G54
T=\"DR5\" M6
D1
S3000 M3
G0 X0 Y0 Z50
G0 Z5
CYCLE81(20,0,2,-10)
G0 Z100
M30
";
    let out = transformed(&[("d.mpf", drill)], "d.mpf", "tool-setter");
    assert!(
        line_of(&out, "; driftloop stage 4") < line_of(&out, "CYCLE81("),
        "{out}"
    );
}

#[test]
fn the_high_speed_settings_cycle_leaves_a_place_to_measure_and_its_path_mode() {
    let prog = "\
G17 G90 G94 G71 G60
T=\"EM12\" M6
D1
S4000 M3
G54
CYCLE832(0.01,_SEMIFIN,1)
G0 X-20 Y0 Z5
G1 Z-1 F500
G1 X60
G0 Z50
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "tool-setter");
    // The gate gives back no path mode of its own over the one CYCLE832 set.
    let after = &out[out.find("CYCLE832(").unwrap()..];
    assert!(
        !after
            .lines()
            .any(|l| l.ends_with(";DL") && l.split_whitespace().any(|w| w == "G60")),
        "{after}"
    );
}

#[test]
fn a_lathe_profile_in_diameters_moves_x_in_radius() {
    let prog = "\
G18 G90 G94 G71 DIAMON
G54
T1 D1
S1500 M3
G0 X44 Z-20
G1 X40.2 F2
G0 X48
G0 Z100
M5
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "lathe-setter");
    // The profile's start point Ø120 and clearance Ø200, moved under DIAMOF (the clearance under the work
    // offset, not under a programmable translation: red-team round 2, T1).
    assert!(out.contains("SUPA X60 ;DL"), "{out}");
    assert!(
        out.contains("IF R62<100-($P_PFRAME[X,TR]+$P_PFRAME[X,FI]) ;DL"),
        "{out}"
    );
}

#[test]
fn the_zero_is_never_inside_the_programs_own_if() {
    // With T12 already in the spindle (a restart) the IF is skipped: a zero inside it would never be
    // measured, and the offset would later be written from a register never set.
    let prog = "\
G17 G90 G94 G71
G54
IF $P_TOOLNO<>12
  T12 M6
ENDIF
D1
S3000 M3
G0 X50 Y50 Z5
G1 Z-2 F300
G1 X80
G0 Z100
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    assert!(
        line_of(&out, "ENDIF") < line_of(&out, "; driftloop stage 1"),
        "{out}"
    );
}

#[test]
fn a_tool_setter_measures_its_zero_with_the_first_tool_loaded() {
    let prog = "\
G18 G90 G95 G71 DIAMON
G54
G0 X200 Z150
T1 D1
G96 S200 LIMS=3000 M4
G0 X44 Z2
G1 X40 F0.2
G1 Z-30
G0 X200 Z150
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "lathe-setter");
    assert!(
        line_of(&out, "T1 D1") < line_of(&out, "; driftloop stage 4"),
        "{out}"
    );
}

#[test]
fn a_gate_after_a_translation_is_cancelled_goes_back_to_where_the_machine_is() {
    // After the bare TRANS the original's programmed X is still the one inside the translation; the gate
    // goes back to the same machine point in the new frame, and the next X is absolute.
    let prog = "\
G17 G90 G94 G71
G54
T=\"FR\" M6
D1
S4000 M3
TRANS X70
G0 X-10 Y10 Z20
G1 Z-3 F400
G1 X40 F1500
G0 Z20
TRANS
G0 Z150
M5
M0
G0 X0 Y-50
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    assert!(out.contains("BL9700("), "{out}");
}

#[test]
fn the_pass_marker_is_a_word_not_a_prefix() {
    let prog = "\
; Passung 40H7
G17 G90 G94 G71
G54
T=\"EM8\" M6
D1
S5000 M3
G0 X0 Y0 Z5
G1 Z-1 F300
G1 X50
G0 Z50
; Passmass pruefen
G0 X0 Y0
G1 Z-2 F300
G1 X50
G0 Z50
; PASS 2
G0 X0 Y0
G1 Z-3 F300
G1 X50
G0 Z50
M30
";
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("p.mpf"), prog).unwrap();
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/model.toml");
    let o = common::driftloop(
        dir.path(),
        &[
            "plan",
            "p.mpf",
            "--model",
            &model.display().to_string(),
            "--format",
            "json",
        ],
        b"",
    );
    let plan: serde_json::Value = serde_json::from_str(&common::stdout(&o)).unwrap();
    // The tool change's pass and the marked one: not the comments that merely start with "Pass".
    let lines: Vec<u64> = plan["passes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["line"].as_u64().unwrap())
        .collect();
    assert_eq!(lines, [4, 16], "{plan}");
}

#[test]
fn a_shopmill_blank_description_is_no_cut() {
    let prog = "\
N1 G17 G90 G60
N2 WORKPIECE(,\"\",,\"BOX\",112,0,-30,-80,-50,-40,100,80)
N3 G54
N4 T=\"PLANFRAESER_D63\" D1 M6
N5 S3200 M3 M8
N6 G0 X-90 Y0 Z50
N7 CYCLE61(50,2,1,0,-50,-40,50,40,1,100,0.1,800,31,0,1,10110)
N8 G0 Z100
N9 M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "tool-setter");
    // The zero after the blank description and the tool load, before the facing cycle.
    let zero = line_of(&out, "; driftloop stage 4");
    assert!(line_of(&out, "N4 T=") < zero, "{out}");
    assert!(zero < line_of(&out, "N7 CYCLE61("), "{out}");
}

/// A machine whose M6 is a shop subprogram (`T3` then `L6`): with the subprogram in the folder, its call
/// is the tool change. Before, the program was refused with "tool unknown" (a spindle probe) or "state not
/// known" (a tool setter).
const L6: &str = "; tool change\nM5 M9\nG0 G53 Z0\nM6\nRET\n";
const L6_PROGRAM: &str = "\
G17 G90 G94 G71
G54
T3
L6
D1
S6000 M3 M8
G0 X0 Y0 Z5
G1 Z-3 F300
G1 X50 F1000
G0 Z50
T8
L6
D1
S4500 M3
G0 X25 Y15 Z5
G1 Z-12 F200
G0 Z50 M9
M30
";

#[test]
fn a_tool_change_subprogram_loads_the_selected_tool() {
    let out = transformed(
        &[("p.mpf", L6_PROGRAM), ("L6.spf", L6)],
        "p.mpf",
        "blum-tc50",
    );
    // The probe is swapped in and back for the tool L6 loaded the way the program changes tools: `T=` and
    // its L6, never a bare M6 the machine may not take outside its macro (QA round 4).
    assert!(out.contains("T=\"BLUM_TC50\" ;DL\nL6 ;DL\n"), "{out}");
    // The zero before the program's first L6 leaves the probe in with T3 preselected: the program's own L6
    // loads it.
    let lines: Vec<&str> = out.lines().collect();
    let zero_end = line_of(&out, "DLSKIP1:");
    assert_eq!(lines[zero_end - 2], "T=3 ;DL", "{out}");
    let next = zero_end
        + lines[zero_end..]
            .iter()
            .position(|l| !l.ends_with(";DL"))
            .unwrap();
    assert_eq!(lines[next], "L6", "{out}");
    assert!(!out.contains(" M6 ;DL"), "{out}");
    // L6 turned the coolant off: no gate after it turns it on before the program does.
    let lines: Vec<&str> = out.lines().collect();
    let second = lines.iter().rposition(|l| *l == "L6").unwrap();
    let program_m8 = line_of(&out, "S6000 M3 M8");
    let first = lines.iter().position(|l| *l == "L6").unwrap();
    for (k, l) in lines.iter().enumerate() {
        let after_a_change = (first < k && k < program_m8) || k > second;
        assert!(
            !(after_a_change && l.contains("M8") && l.ends_with(";DL")),
            "line {k}: {l}\n{out}"
        );
    }
}

#[test]
fn a_tool_setter_measures_its_zero_after_a_tool_change_subprogram() {
    let out = transformed(
        &[("p.mpf", L6_PROGRAM), ("L6.spf", L6)],
        "p.mpf",
        "tool-setter",
    );
    let zero = line_of(&out, "; driftloop stage 4");
    assert!(
        line_of(&out, "L6") < zero && zero < line_of(&out, "G1 Z-3"),
        "{out}"
    );
}

#[test]
fn a_subprogram_that_changes_tools_and_cuts_is_no_tool_change() {
    let cutting = "M5 M9\nG0 G53 Z0\nM6\nG0 X0 Y0 Z2\nG1 Z-1 F100\nG0 Z50\nRET\n";
    let err = refused(
        &[
            ("p.mpf", L6_PROGRAM),
            ("L6.spf", cutting),
            ("refuse.toml", &refusing_profile()),
        ],
        "p.mpf",
        "refuse.toml",
    );
    assert!(err.contains("tool in the spindle is not known"), "{err}");
}

/// A tool setter's zero goes after the tool load and its D, before a retry jump's label or a loop that
/// starts the spindle (before: refused, the only site after the load was inside the jump's range).
#[test]
fn a_tool_setter_measures_its_zero_before_a_retry_loop() {
    let prog = "\
G17 G90 G94 G71
G54
T=\"FR_D20\" M6
D1
R30=0
WDH: G0 X-40 Y0 Z30
S4000 M3 M8
G1 Z10 F2000
STOPRE
R31=$AA_IW[Z]
R30=R30+1
IF (R31>10.01) AND (R30<3) GOTOB WDH
G0 Z2
G1 Z-1 F500
G1 X60 F1800
G0 Z100 M9
M5
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "tool-setter");
    let zero = line_of(&out, "; driftloop stage 4");
    assert!(
        line_of(&out, "D1") < zero && zero < line_of(&out, "WDH:"),
        "{out}"
    );
}

/// QA round 3: an operator's `R1=1` skips the roughing with a GOTOF. A zero (and stage 1) inside what the
/// jump skips would leave the finishing gates correcting from registers never set. With the offset method
/// `active` (nothing at the end needs stage 1) the zero may go there, and no gate goes after the label;
/// with a profile that writes the stored offset back at the end from stage 1's register, it is refused.
#[test]
fn no_gate_runs_without_the_zero_a_jump_skips() {
    let out = transformed(&[("p.mpf", SKIP_ROUGHING)], "p.mpf", "tool-setter");
    assert!(line_of(&out, "IF R1==1 GOTOF") < line_of(&out, "; driftloop stage 1"));
    let after_label = &out[out.find("SCHLICHTEN:").unwrap()..];
    assert!(!after_label.contains("; driftloop gate"), "{out}");
    let profile = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/tool-setter.toml"),
    )
    .unwrap()
    .replace("method = \"active\"", "method = \"frame\"");
    let err = refused(
        &[("p.mpf", SKIP_ROUGHING), ("frame.toml", &profile)],
        "p.mpf",
        "frame.toml",
    );
    assert!(
        err.contains("a jump of the program (GOTOF …) skips"),
        "{err}"
    );
}

const SKIP_ROUGHING: &str = "\
G17 G90 G40 G71 G94
G54
IF R1==1 GOTOF SCHLICHTEN
T=\"SCHRUPP\" M6
D1
S3000 M3 M8
G0 X50 Y50 Z50
G1 Z-1 F500
X100
G0 Z50
M5 M9
SCHLICHTEN:
T=\"SCHLICHT\" M6
D1
G54
S3000 M3
G0 X50 Y50 Z2
G1 Z-1 F300
X100
G0 Z50
M5
M30
";

/// QA round 3: `GOTOS` starts the program again; the work offset is given back before it as before M30,
/// or each run's stage 1 would take the corrected offset as its base.
#[test]
fn the_offset_is_given_back_before_gotos() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"FR_D10\" M6
D1
G54
S4000 M3 M8
G0 X10 Y10 Z50
G1 Z-1 F500
X60
G0 Z50
M9 M5
R1=R1+1
IF R1<3 GOTOS
M30
";
    let frame = common::frame_profile_text();
    let files = [("p.mpf", prog), ("frame.toml", frame.as_str())];
    for (profile, restore) in [
        ("blum-tc50", "$P_IFRAME[Z,TR]=$P_UIFR[$P_UIFRNUM,Z,TR] "),
        ("frame.toml", "$P_UIFR[1,Z,TR]=R"),
    ] {
        let out = transformed(&files, "p.mpf", profile);
        let gotos = line_of(&out, "IF R1<3 GOTOS");
        let lines: Vec<&str> = out.lines().collect();
        assert!(lines[gotos - 1].starts_with(restore), "{out}");
    }
}

/// QA round 3: a CAM post writes CYCLE800 with every angle 0 (and direction, retract feed and mode after
/// them): no swivel, a gate may go under it.
#[test]
fn cycle800_with_every_angle_zero_is_no_swivel() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"FR_D10\" M6
D1
G54
CYCLE800(1,\"TABLE\",200000,57,0,0,0,0,0,0,0,0,0,1,100,1)
S4000 M3 M8
G0 X10 Y10 Z50
G1 Z-1 F500
X60
G0 Z50
M9 M5
CYCLE800()
M30
";
    transformed(&[("p.mpf", prog)], "p.mpf", "tool-setter");
}

/// QA round 3: a workpiece measuring cycle with a result number (S_KNUM, its second parameter) writes a
/// work offset; after the zero it is refused as the program's own frame write (with S_KNUM 0 it only
/// measures).
#[test]
fn a_measuring_cycle_that_sets_a_work_offset_is_a_frame_write() {
    let prog = |knum: u32| {
        format!(
            "\
G17 G90 G40 G71 G94
T=\"FR_D16\" M6
D1
G54
S5000 M3 M8
G0 X-20 Y0 Z2
G1 Z-4 F500
X120 F1500
G0 Z50 M9
M5
M0
T=\"TASTER\" M6
D1
G54
G0 X50 Y40 Z50
CYCLE978(0,{knum},,1,0,5,1,3,2,1,\"\",,0,1.01,1.01,-1.01,0.34,1,0,,1,1)
G0 Z100
T=\"FR_D16\" M6
D1
G54
S5000 M3 M8
G0 X-20 Y0 Z2
G1 Z-4 F500
X120 F1500
G0 Z50 M9 M5
M30
"
        )
    };
    let writes = prog(1);
    let err = refused(&[("p.mpf", &writes)], "p.mpf", "siemens-cycle978");
    assert!(err.contains("writes a frame itself at line 16"), "{err}");
    let measures = prog(0);
    transformed(&[("p.mpf", &measures)], "p.mpf", "siemens-cycle978");
}

/// QA round 3: a subprogram beside the program (where the control and the audit find it) is timed and
/// its R-parameters are left alone without `--subprograms`.
#[test]
fn a_subprogram_beside_the_program_keeps_its_registers() {
    let sub = "R74=1 R75=2 R76=3\nG0 X0 Y0 Z2\nG1 Z-1 F200\nG1 X40\nG0 Z50\nRET\n";
    let prog = "\
G17 G90 G40 G71 G94
T=\"FR_D10\" M6
D1
G54
S4000 M3 M8
KONTUR7
G0 Z100 M9 M5
M30
";
    let out = transformed(
        &[("p.mpf", prog), ("KONTUR7.spf", sub)],
        "p.mpf",
        "blum-tc50",
    );
    for r in ["R74=", "R75=", "R76="] {
        assert!(
            !out.lines().any(|l| l.starts_with(r) && l.ends_with(";DL")),
            "{r}\n{out}"
        );
    }
}

/// QA round 3: an older 5-axis post positions the table itself (`G0 A30 C45`, no CYCLE800): a probe point
/// in work coordinates is then on a turned part, so no gate goes there until the axes are back at 0.
#[test]
fn no_probe_on_a_part_a_rotary_axis_has_turned() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"SF_D10\" M6
D1
G54
S5000 M3 M8
G0 A0 C0
G0 X0 Y0 Z50
G1 Z-1 F500
X40
G0 Z100
G0 A30 C45
G0 X10 Y10 Z50
G1 Z-1 F500
X40
G0 Z100
M1
G0 X10 Y20 Z50
G1 Z-1 F500
X40
G0 Z100
G0 A0 C0
M9 M5
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    let home = out.rfind("G0 A0 C0\n").unwrap();
    let tilted = &out[out.find("G0 A30 C45").unwrap()..home];
    assert!(!tilted.contains("; driftloop gate"), "{tilted}");
    assert!(out[home..].contains("; driftloop gate"), "{out}");
}

/// QA round 3: a program that writes `$P_IFRAME` itself would lose that shift to a gate: refused.
#[test]
fn a_program_that_writes_the_frame_in_force_is_refused() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"FR_D10\" M6
D1
G54
$P_IFRAME[X,TR]=$P_IFRAME[X,TR]+100
S4000 M3 M8
G0 X10 Y10 Z50
G1 Z-1 F500
X60
G0 Z50
M9 M5
M30
";
    let err = refused(&[("p.mpf", prog)], "p.mpf", "tool-setter");
    assert!(
        err.contains("writes the frame in force ($P_IFRAME) itself at line 5"),
        "{err}"
    );
}

/// A rotary axis sent home through a variable last set to 0 (`A=_A_HOME`, as CAM posts write it) is at 0;
/// through one set to anything else, away.
#[test]
fn a_rotary_axis_sent_home_by_a_variable_is_at_zero() {
    let prog = |home: &str| {
        format!(
            "\
DEF REAL _A_HOME
_A_HOME={home}
G17 G90 G40 G71 G94
SUPA A=_A_HOME
T=\"SF_D10\" M6
D1
G54
S5000 M3 M8
G0 X10 Y10 Z50
G1 Z-1 F500
X40
G0 Z100
M9 M5
M30
"
        )
    };
    transformed(&[("p.mpf", &prog("0"))], "p.mpf", "blum-tc50");
    let err = refused(&[("p.mpf", &prog("30"))], "p.mpf", "blum-tc50");
    assert!(
        err.contains("a rotary axis (A, B or C) stands away from 0"),
        "{err}"
    );
}

/// QA round 3: a back counterbore stops the spindle with the tool under the part; a gate measuring there
/// would retract up through the part. No gate measures where no rapid rose in Z since the last cut.
#[test]
fn no_measurement_where_the_tool_stands_in_the_part() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"RUECKSENKER_D18\" M6
D1
G54
G0 X50 Y50 Z50
G0 X48 Y50
G0 Z-25
G0 X50 Y50
S800 M3 M8
G1 Z-18 F60
G4 F1
G1 Z-22 F200
M5 M9
G0 X48 Y50
G0 Z50
M30
";
    for profile in ["blum-tc50", "tool-setter"] {
        let out = transformed(&[("p.mpf", prog)], "p.mpf", profile);
        let stop = line_of(&out, "M5 M9");
        let before_stop: Vec<&str> = out.lines().take(stop).collect();
        let gate_start = before_stop
            .iter()
            .rposition(|l| l.starts_with("; driftloop gate"))
            .unwrap();
        let gate = before_stop[gate_start..].join("\n");
        assert!(
            !gate.contains("BL9700(") && !gate.contains("DL_SETTER("),
            "{gate}"
        );
    }
}

/// QA round 3: a pass marked on a turret's `T1 D1` block (what a refusal suggested) is still the tool
/// change: the lathe setter's zero never comes before the tool is indexed.
#[test]
fn a_pass_marked_on_a_turret_tool_call_is_a_tool_change() {
    let prog = "\
G18 G90 G95 G40 G71 DIAMON
G54
T1 D1 ; PASS
G96 S200 M4 M8
G0 X22 Z0.5
G1 X-1.6 F0.15
G0 X40 Z5
M5 M9
M30
";
    let out = transformed(&[("p.mpf", prog)], "p.mpf", "lathe-setter");
    assert!(
        line_of(&out, "T1 D1") < line_of(&out, "; driftloop stage 4"),
        "{out}"
    );
}

/// QA round 3: M7 (mist) and M8 (flood) on together; a gate that measures gives both back (before, only
/// the last, and the output failed its own audit with every gate measuring).
#[test]
fn both_coolants_come_back_together() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"STUFENBOHRER\" M6
D2
G54
S3000 M4
M7
M8
G0 X50 Y50 Z50
G1 Z-1 F300
X80
G0 Z50
M1
G0 X50 Y60 Z2
G1 Z-1 F300
X80
G0 Z50 M9
M5
M30
";
    let every = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/blum-tc50.toml"),
    )
    .unwrap()
    .replace(
        "# [log]\n# measure_every_gate = true",
        "[log]\nmeasure_every_gate = true",
    );
    let out = transformed(
        &[("p.mpf", prog), ("every.toml", &every)],
        "p.mpf",
        "every.toml",
    );
    assert!(out.contains("\nM7 M8 ;DL\n"), "{out}");
}

/// QA round 3: a sum offset (`DL=2`) is lost by a spindle-probe gate's tool changes, so no such gate
/// measures while one is active; a tool setter, which changes no tool, may.
#[test]
fn no_probe_swap_under_a_sum_offset() {
    let prog = "\
G17 G90 G40 G71 G94
T=\"FR_D16\" M6
D1 DL=2
G54
S3000 M3 M8
G0 X10 Y10 Z50
G1 Z-1 F300
X60
G0 Z50
M9 M5
M30
";
    let err = refused(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    assert!(err.contains("a sum offset (DL=) is active"), "{err}");
    transformed(&[("p.mpf", prog)], "p.mpf", "tool-setter");
}

/// A program in the ISO dialect (Fanuc-style: G291, or G43 H tool lengths, G28, G81 cycles) is refused:
/// its mode reads driftloop's Siemens blocks otherwise, and a gate's tool change would come back without
/// the G43 H length compensation, every later Z then off by the tool's length. It was written before, with
/// an incomplete audit.
#[test]
fn a_program_in_the_iso_dialect_is_refused() {
    for (first, word) in [
        ("G291", "line 1: G291"),
        ("G17 G90 G54 G43 H1 Z100", "line 1: G43"),
        ("G17 G90 G54\nG28 G91 Z0", "line 2: G28"),
    ] {
        let prog = format!(
            "{first}\nT1 M6\nS3000 M3\nG0 X0 Y0 Z2\nG1 Z-1 F200\nX40\nG0 Z50\nG81 X10 Y10 Z-5 R2 F100\nG80\nM30\n"
        );
        let err = refused(&[("p.mpf", &prog)], "p.mpf", "tool-setter");
        assert!(err.contains(word) && err.contains("ISO dialect"), "{err}");
    }
}

/// A spindle-probe profile needs the tool the program changes to; a shop's tool-change subprogram not found
/// leaves it unknown, and the refusal says which call to give the file of.
#[test]
fn a_tool_change_subprogram_not_found_is_named_in_the_refusal() {
    let prog =
        "G17 G90 G94 G54\nT1\nL6\nD1\nS3000 M3\nG0 X10 Y10 Z2\nG1 Z-1 F200\nX40\nG0 Z50\nM30\n";
    let err = refused(
        &[("p.mpf", prog), ("refuse.toml", &refusing_profile())],
        "p.mpf",
        "refuse.toml",
    );
    assert!(
        err.contains("if L6 (line 3) changes the tool, put its file beside the program"),
        "{err}"
    );
    // Reading the tool at run time does not help before L6: the probe would be swapped for the previous
    // program's tool with a bare M6 where this machine changes tools in L6 (QA round 8).
    let err = refused(&[("p.mpf", prog)], "p.mpf", "blum-tc50");
    assert!(err.contains("if L6 (line 3) changes the tool"), "{err}");
    transformed(
        &[("p.mpf", prog), ("L6.SPF", "PROC L6\nM6\nRET\n")],
        "p.mpf",
        "blum-tc50",
    );
}
