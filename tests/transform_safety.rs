//! What every inserted gate must do for the operator at the machine: each hazard of the safety review on a
//! program that shows it — the tool and its preselection given back, the return path above the part, no gate
//! under a swivel, transformation, rotated frame or cutter compensation, the modal state restored, the work
//! offset restored before an alarm, the scrap decision against the correction in force at the last cut —
//! plus golden files of the gates around a preselected tool, a swivel, G41 and G95.

mod common;

use std::path::PathBuf;

use driftloop::model::DriftModel;
use driftloop::omm::emit::MARK;
use driftloop::omm::{ModelRef, Profile, TransformError, transform};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn model() -> DriftModel {
    DriftModel::read(&root().join("fixtures/omm/model.toml")).expect("model fixture")
}

/// `p` measuring at every gate that can: every gate shows its measuring blocks.
fn measuring(mut p: Profile) -> Profile {
    p.log.measure_every_gate = true;
    p
}

/// The default profile, measuring at every gate that can.
fn measuring_profile() -> Profile {
    measuring(Profile::default_profile())
}

fn transformed(src: &str, profile: &Profile, model: &DriftModel) -> Result<String, TransformError> {
    let program = driftloop::parse(src.as_bytes());
    let m = ModelRef {
        model,
        sha256: "0123456789abcdef",
    };
    let t = transform(&program, m, profile, false)?;
    Ok(String::from_utf8(t.bytes).unwrap())
}

fn out(src: &str) -> String {
    transformed(src, &measuring_profile(), &model()).expect("transforms")
}

fn inserted(line: &str) -> bool {
    line.ends_with(MARK)
}

/// How many blocks the output inserted between the original lines starting with `from` and `to`.
fn gates_between(out: &str, from: &str, to: &str) -> usize {
    common::lines_between(out, from, to)
        .into_iter()
        .filter(|l| inserted(l))
        .count()
}

/// The inserted blocks right before the original line starting with `before`, without their mark.
fn gate_before<'a>(out: &'a str, before: &str) -> Vec<&'a str> {
    common::gate_before(out, before)
        .into_iter()
        .map(|l| l.trim_end_matches(MARK).trim_end())
        .collect()
}

fn index(gate: &[&str], pred: impl Fn(&str) -> bool, what: &str) -> usize {
    gate.iter()
        .position(|l| pred(l))
        .unwrap_or_else(|| panic!("no {what} in\n{}", gate.join("\n")))
}

fn rindex(gate: &[&str], pred: impl Fn(&str) -> bool, what: &str) -> usize {
    gate.iter()
        .rposition(|l| pred(l))
        .unwrap_or_else(|| panic!("no {what} in\n{}", gate.join("\n")))
}

/// A part cut with one tool, the next one preselected early, retracts between the cuts.
const PRESELECTED: &str = "\
G17 G90 G94 G54
T=\"ROUGH\" M6
D2
T=\"FINISH\"
S5000 M3 M8
G0 X0 Y0 Z50
G0 Z2
G1 Z-5 F200
G1 X400 F200
G1 Y300
G1 X0
G1 Y0
G0 Z50
G0 X10 Y10
G1 Z-5 F200
G1 X400 F150
G0 Z50
M5 M9
M6
D1
S6000 M3
G0 X0 Y0 Z10
G1 Z-6 F300
G1 X400
G0 Z50
M30
";

#[test]
fn the_tool_and_its_preselection_are_given_back_and_the_program_ends_without_the_probe() {
    let o = out(PRESELECTED);
    let gate = gate_before(&o, "G0 X10 Y10");
    let probe = index(&gate, |l| l == "T=\"BLUM_TC50\" M6", "probe change");
    let back = index(&gate, |l| l == "T=\"ROUGH\" M6", "cutting tool back");
    let preselect = index(&gate, |l| l == "T=\"FINISH\"", "preselection again");
    let d = index(&gate, |l| l == "D2", "D number");
    assert!(probe < back && back < preselect && preselect < d);
    // The program's bare M6 later loads FINISH: the last T before it is the program's preselection.
    let lines: Vec<&str> = o.lines().collect();
    let m6 = lines.iter().position(|l| *l == "M6").unwrap();
    let last_t = lines[..m6]
        .iter()
        .rev()
        .find(|l| l.starts_with("T="))
        .unwrap();
    assert_eq!(last_t.trim_end_matches(MARK).trim_end(), "T=\"FINISH\"");
    // Nowhere is the probe left in the spindle: every probe change is followed by a change back, or by the
    // program's own tool change.
    let mut probe_in = false;
    for l in &lines {
        if l.starts_with("T=\"BLUM_TC50\" M6") {
            probe_in = true;
        } else if l.contains("M6") {
            probe_in = false;
        }
        if l.starts_with("M30") && !inserted(l) {
            assert!(
                !probe_in,
                "the program would end with the probe in the spindle"
            );
        }
    }
}

#[test]
fn the_gate_travels_above_the_part_and_comes_back_down_where_the_program_was() {
    let o = out(PRESELECTED);
    let gate = gate_before(&o, "G0 X10 Y10");
    let save = index(&gate, |l| l.contains("=$AA_IW[X]"), "position saved");
    let up = index(&gate, |l| l.starts_with("G0 G90 Z=R"), "retract");
    let change = index(&gate, |l| l.contains("BLUM_TC50"), "probe change");
    let across = index(&gate, |l| l == "X0 Y0", "travel to the probe point");
    let down = index(&gate, |l| l == "Z10", "descent to the start point");
    let cycle = index(&gate, |l| l.starts_with("BL9700("), "probe cycle");
    assert!(save < up && up < change && change < across && across < down && down < cycle);
    // Before any XY travel the tool is up at the travel height, and it goes down only at the end.
    let back_up = rindex(
        &gate,
        |l| l.starts_with("G0 G90 Z=R"),
        "retract before the way back",
    );
    let back_across = index(&gate, |l| l.starts_with("X=R"), "travel back");
    let back_down = rindex(&gate, |l| l.starts_with("Z=R"), "descent back");
    assert!(cycle < back_up && back_up < back_across && back_across < back_down);
    // The travel height is the clearance height or the tool's own, never lower.
    let height = gate[up].trim_start_matches("G0 G90 Z=");
    assert!(
        gate.contains(&format!("IF {height}<100").as_str()),
        "{gate:#?}"
    );
    for l in &gate[up..back_down] {
        let moves_across = l.starts_with('X') || l.contains(" X") || l.contains(" Y");
        assert!(
            !moves_across || l.starts_with("X=R") || *l == "X0 Y0",
            "travel at an unknown height: {l}"
        );
    }
}

#[test]
fn the_modal_state_is_given_back() {
    // G18 plane, feed per revolution, incremental dimensions, continuous path, coolant on.
    let src = "\
G18 G95 G64 G90 G54
T=\"TURN\" M6
D1
S800 M4 M8
G0 X50 Z5
G1 Z-20 F0.2
G0 Z50
G91
; PASS 2
G0 X10
G90
M30
";
    let o = out(src);
    let gate = gate_before(&o, "; PASS 2");
    let coolant_off = index(&gate, |l| l == "M9", "coolant off");
    let probe = index(&gate, |l| l.contains("BLUM_TC50"), "probe change");
    assert!(coolant_off < probe);
    assert!(gate.contains(&"S800 M4"), "{gate:#?}");
    assert!(gate.contains(&"M8"), "{gate:#?}");
    // The correction goes into the offset in force: nothing is selected again.
    assert!(!gate.contains(&"G54"), "{gate:#?}");
    let modal = index(&gate, |l| l.starts_with("G18 "), "modal line");
    assert_eq!(gate[modal], "G18 G95 G64 G0 G91 F0.2");
    // A profile that corrects the stored G54 selects it again as the gate's last block.
    let o = transformed(src, &measuring(common::frame_profile()), &model()).unwrap();
    assert_eq!(*gate_before(&o, "; PASS 2").last().unwrap(), "G54");
}

/// A milling start that swivels the table and cuts under the swivel.
const SWIVELLED_CUT: &str = "\
G17 G90 G94 G54
T=\"MILL\" M6
D1
S6000 M3
G0 X0 Y0 Z50
CYCLE800(1,\"TABLE\",0,57,0,0,0,0,30,0,0,0,0,1,,1)
G0 Z5
G1 Z-1 F500
";

#[test]
fn no_gate_under_a_swivel_a_transformation_a_rotated_frame_or_cutter_compensation() {
    let src = &format!(
        "{SWIVELLED_CUT}\
G1 X100 S4000
G0 Z50
G0 X10
CYCLE800()
G0 Z50
TRAORI
G0 Z5
G1 X100 F500
G0 Z50
G0 X10
TRAFOOF
ROT Z30
G0 Z50
G0 X10 S3000
ROT
G41 D1
G1 X0 Y0 F500
G1 X50 S2000
G0 Z50
G0 X10
G40
M5
M30
"
    );
    let o = out(src);
    assert_eq!(gates_between(&o, "CYCLE800(1", "CYCLE800()"), 0, "{o}");
    assert_eq!(gates_between(&o, "TRAORI", "TRAFOOF"), 0, "{o}");
    assert_eq!(gates_between(&o, "ROT Z30", "ROT"), 0, "{o}");
    assert_eq!(gates_between(&o, "G41", "G40"), 0, "{o}");
    // After each of them is switched off, gates come back.
    assert!(gates_between(&o, "G40", "M30") > 0, "{o}");
}

#[test]
fn every_alarm_restores_the_work_offset_first() {
    // Restore (and re-select the stored offset), message, alarm: SETAL stops the interpreter, nothing
    // after it runs.
    let active = ["$P_IFRAME[Z,TR]=$P_UIFR[$P_UIFRNUM,Z,TR]"];
    let frame = ["$P_UIFR[1,Z,TR]=R", "G54"];
    for (profile, restore) in [
        (measuring_profile(), &active[..]),
        (measuring(common::frame_profile()), &frame[..]),
    ] {
        let o = transformed(PRESELECTED, &profile, &model()).unwrap();
        let lines: Vec<&str> = o.lines().collect();
        let mut alarms = 0;
        for (k, l) in lines.iter().enumerate() {
            if !l.starts_with("SETAL(") {
                continue;
            }
            alarms += 1;
            let n = restore.len();
            let before: Vec<&str> = lines[k - n - 1..k]
                .iter()
                .map(|l| l.trim_end_matches(MARK).trim_end())
                .collect();
            for (line, want) in before.iter().zip(restore) {
                assert!(line.starts_with(want) && !line.contains('+'), "{before:#?}");
            }
            assert!(before[n].starts_with("MSG(\"driftloop: "), "{before:#?}");
        }
        assert!(alarms >= 4, "{alarms}");
    }
}

#[test]
fn the_default_r_parameters_fit_the_default_machine_data_and_the_summary_says_how_many_it_needs() {
    let program = driftloop::parse(PRESELECTED.as_bytes());
    let model = model();
    let m = ModelRef {
        model: &model,
        sha256: "0123456789abcdef",
    };
    let t = transform(&program, m, &Profile::default_profile(), false).unwrap();
    let highest = *t.summary.r_parameters.last().unwrap();
    assert!(
        t.summary.r_parameters[0] >= 50 && highest <= 99,
        "{:?}",
        t.summary.r_parameters
    );
    assert_eq!(t.summary.r_parameters_needed, highest + 1);
}

#[test]
fn a_program_that_never_changes_tools_is_refused_with_a_spindle_probe_and_measured_with_a_tool_setter()
 {
    let src = "G54\nS3000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F200\nG1 X100\nG0 Z50\nG0 X0\nG1 Z-2\nG1 X100\nG0 Z50\nM30\n";
    let mut refusing = Profile::default_profile();
    refusing.probe.unknown_tool = driftloop::omm::profile::UnknownTool::Refuse;
    let err = transformed(src, &refusing, &model()).unwrap_err();
    assert!(err.to_string().contains("--profile tool-setter"), "{err}");
    // As shipped, the spindle probe's gates read the tool in force at run time instead.
    let read = transformed(src, &Profile::default_profile(), &model()).unwrap();
    assert!(read.contains("=$P_TOOLNO ;DL"), "{read}");
    let setter = Profile::builtin("tool-setter").unwrap();
    let o = transformed(src, &setter, &model()).unwrap();
    // No tool change anywhere in the gates; the setter is reached in machine coordinates.
    assert!(!o.lines().any(|l| inserted(l) && l.contains("M6")), "{o}");
    assert!(
        o.contains("SUPA X-250 Y-20 ;DL") && o.contains("SUPA Z-300 ;DL"),
        "{o}"
    );
    assert!(o.contains("DL_SETTER(3,-310) ;DL"), "{o}");
    // The zero comes before the first cut.
    let zero = o.find("DL_SETTER(").unwrap();
    assert!(zero < o.find("G1 Z-1").unwrap());
}

#[test]
fn a_grinder_gate_moves_nothing_and_corrects_x_by_half_the_diameter_change() {
    let src = "\
G18 G90 G95 G54 DIAMON
S1500 M3
G0 X60 Z5
; PASS roughing
G1 X41 F0.05
G0 X60
DRESS
G0 X45
G1 X40.2 F0.02
G0 X60
M30
";
    let mut gauge = Profile::builtin("grinder-gauge").unwrap();
    gauge.log.measure_every_gate = true;
    let o = transformed(src, &gauge, &model()).unwrap();
    for l in o.lines().filter(|l| inserted(l)) {
        let moves = l.starts_with("G0 ") || l.starts_with("X") || l.starts_with("Z=");
        assert!(!moves, "a gauge gate moves: {l}");
    }
    assert!(o.contains("DL_GAUGE(1,40) ;DL"), "{o}");
    // The diameter reading halves into the drift; the X offset is written as a radius.
    assert!(
        o.lines().any(|l| l.contains(")/2+R") && l.ends_with(MARK)),
        "{o}"
    );
    // The builtin gauge profile corrects the offset in force, and selects none.
    assert!(
        o.contains("$P_IFRAME[X,TR]=$P_UIFR[$P_UIFRNUM,X,TR]+R"),
        "{o}"
    );
    assert!(!o.lines().any(|l| l == "G54 ;DL"), "{o}");
    // The dressing call is a place to measure.
    let gate = gate_before(&o, "G0 X45");
    assert!(gate.iter().any(|l| l.starts_with("DL_GAUGE(")), "{gate:#?}");
}

/// A virtual machine whose Z drift is the model itself, probing a surface at machine Z −100.
fn run_on_truth(transformed: &str, model: &DriftModel) -> driftloop::vm::Run {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("truth.toml"), model.to_toml()).unwrap();
    let machine = "[probe]\nsurface_mm = -100\n[offsets]\nG54 = { Z = -100.0 }\n[models]\nZ = { file = \"truth.toml\" }\n";
    let (cfg, spec) =
        driftloop::vm::parse_machine_file(machine, dir.path(), driftloop::vm::Config::default())
            .unwrap();
    let mut m = spec.build(1);
    driftloop::vm::run_source("part.mpf", transformed.as_bytes(), None, &cfg, &mut m).unwrap()
}

/// One mode of 30 µm at 4000 rpm with τ = 20 min: the truth and the model alike.
fn heating_model() -> DriftModel {
    DriftModel::from_modes(
        "drift_z_um",
        vec![1000.0, 4000.0],
        &[(20.0, vec![7.5, 30.0])],
        0.0,
    )
}

fn scrap_alarms(run: &driftloop::vm::Run) -> usize {
    run.alarms.iter().filter(|a| a.number == 65001).count()
}

#[test]
fn drift_during_a_pause_without_cutting_is_no_scrap_but_drift_during_a_long_cut_is() {
    let model = heating_model();
    // 25 min of spindle heating with the tool up (no cut), then the next pass: the part cut before the
    // pause was cut with the right correction; the program must go on.
    let pause = "\
G17 G90 G94 G54
T=\"MILL\" M6
D1
S4000 M3
G0 X0 Y0 Z5
G1 Z-1 F300
G1 X50 F1200
G0 Z50
G4 F1500
; PASS 2
G0 X0 Y0 Z5
G1 Z-1.5 F300
G1 X50 F1200
G0 Z50
M30
";
    let profile = Profile::default_profile();
    let o = transformed(pause, &profile, &model).unwrap();
    let run = run_on_truth(&o, &model);
    assert_eq!(scrap_alarms(&run), 0, "{:?}", run.alarms);
    assert!(run.measurements.len() >= 2, "{:?}", run.measurements);
    // 25 min of cutting in one feed move with the same correction: the part's error grows by ≈ 21 µm,
    // more than Δ = 20 µm. The gate after it stops the program, and the plan warns beforehand.
    let long_cut = pause.replace("G0 Z50\nG4 F1500\n", "G1 X50.001 F0.00004\nG0 Z50\n");
    let program = driftloop::parse(long_cut.as_bytes());
    let timeline = driftloop::omm::timeline::build(&program, &profile);
    let plan = driftloop::omm::plan::plan(&timeline, &[&model], &profile).unwrap();
    assert!(
        plan.warnings.iter().any(|w| w.contains("while cutting")),
        "{:?}",
        plan.warnings
    );
    let o = transformed(&long_cut, &profile, &model).unwrap();
    let run = run_on_truth(&o, &model);
    assert_eq!(scrap_alarms(&run), 1, "{:?}", run.alarms);
    // The alarm left the work offset as it was before the program.
    let last = run.corrections.last().expect("the program corrected");
    assert!((last.new_mm - -100.0).abs() < 1e-12, "{last:?}");
}

#[test]
fn gates_around_a_preselected_tool_a_swivel_g41_and_g95() {
    let swivel_g41_g95 = &format!(
        "{SWIVELLED_CUT}\
G0 Z50
G0 X10
CYCLE800()
G0 Z50
G0 X20
G41 D1
G1 X0 Y0 F500
G40
G0 Z50
G95
G0 X30
G1 Z-1 F0.1
G0 Z50
G0 X40
M30
"
    );
    insta::assert_snapshot!("preselected_tool", out(PRESELECTED));
    insta::assert_snapshot!("swivel_g41_g95", out(swivel_g41_g95));
}

#[test]
fn no_gate_between_a_frame_change_and_the_incremental_move_that_traverses_it() {
    // The incremental X move after TRANS carries the translation's 10 mm (MD42440 = 1): a gate in between
    // would go back to where X is and take the traverse away. After the absolute move gates come back.
    let src = "\
G17 G90 G94 G54
T=\"MILL\" M6
D1
S6000 M3
G0 X0 Y0 Z50
G0 Z5
G1 Z-1 F500
G1 X100
G0 Z50
TRANS X10
G0 Y20
; PASS after the translation
G91 G0 X5
G90
G0 Z5
G1 Z-1 F500
G1 X100 S4000
G0 Z50
; PASS later
G0 X0 Y0
G1 Z-1 F500
G1 X100
G0 Z50
M30
";
    let o = out(src);
    assert_eq!(gates_between(&o, "TRANS X10", "G91 G0 X5"), 0, "{o}");
    assert!(gates_between(&o, "G90", "M30") > 0, "{o}");
}

/// A main program may end with M17 (or RET) instead of M30: the work offset must be put back before it,
/// not after it, where nothing runs — the stored offset (`method = "frame"`) would stay corrected for the
/// next program. Found on real grinder programs that end with M17.
#[test]
fn the_offset_is_put_back_before_an_m17_or_ret_that_ends_the_program() {
    let model = model();
    let body = "G54\nT1 M6\nS2000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG1 X50 F500\nG0 Z50\n";
    for (end, after) in [("M17", ""), ("M17", "G0 X100\n"), ("RET", "")] {
        let src = format!("{body}{end}\n{after}");
        for profile in [Profile::default_profile(), common::frame_profile()] {
            let out = transformed(&src, &profile, &model).unwrap();
            let lines: Vec<&str> = out.lines().collect();
            let at_end = lines.iter().position(|l| *l == end).unwrap();
            let restore = lines
                .iter()
                .position(|l| l.contains("work offset back to its value before the program"))
                .unwrap_or_else(|| panic!("no restore:\n{out}"));
            assert!(restore < at_end, "{end}: the restore after the end:\n{out}");
            assert!(
                lines[at_end..].iter().all(|l| !l.ends_with(MARK)),
                "{end}: blocks inserted after the end:\n{out}"
            );
        }
    }
}

/// After the program's own tool change the new tool has the control's default cutting edge (MD20270,
/// usually D1) unless the block selects one; the timeline kept the last tool's D, so a gate that loaded
/// the new tool again after the probe wrote that D (`D2` where the original cut with D1: the wrong length
/// and radius). The audit refused such outputs; found by random programs. Now a gate writes no D there,
/// and its own M6 gives the same default.
#[test]
fn a_gate_after_a_tool_change_gives_back_the_default_edge_not_the_last_tools() {
    let cut = "G0 Z5\nG1 X0 F500\nG0 Z50\nM1\nG0 Z5\nG1 X10 F500\nG0 Z50\n";
    let src = format!("G54\nT1 M6\nD2\nS2000 M3\n{cut}T2 M6\nS3000 M3\n{cut}M30\n");
    let out = out(&src);
    let lines: Vec<&str> = out.lines().collect();
    let second = lines.iter().position(|l| *l == "T2 M6").unwrap();
    let reload = |tool: &str| format!("T={tool} M6 {MARK}");
    assert!(
        lines[..second].contains(&reload("1").as_str())
            && lines[..second].contains(&format!("D2 {MARK}").as_str()),
        "a gate of the first tool loads it again with its D2:\n{out}"
    );
    assert!(
        lines[second..].contains(&reload("2").as_str()),
        "a gate of the second tool loads it again:\n{out}"
    );
    let after_reload = lines[second..]
        .windows(2)
        .filter(|w| w[0] == reload("2"))
        .map(|w| w[1]);
    for next in after_reload {
        assert!(
            !next.starts_with('D'),
            "a gate after T2 M6 writes the last tool's D ({next}):\n{out}"
        );
    }
}

/// A gate's STOPRE between two feed moves of a contour under continuous path stops the path there: the
/// tool dwells on the contour and marks it. A pass marker or a spindle stop in the middle of a G64 contour
/// gets no gate (the audit refused such outputs; found by random programs); under G60, or once a rapid
/// leaves the contour, it does. A rapid in one branch of an IF does not end the contour the other branch's
/// feed continues.
#[test]
fn no_gate_stops_a_continuous_path_contour_between_two_feed_moves() {
    let head = "G54\nT1 M6\nD1\nS2000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F100\n";
    for (path, contour_gate) in [("G64", false), ("G642", false), ("G60", true)] {
        for middle in [
            "; PASS finish\n",
            "M5\n",
            "IF R1>3\nG0 Z80\nELSE\nR2=1\nENDIF\nM5\n",
        ] {
            let src = format!("{head}{path}\nG1 X50 F500\n{middle}G1 X60 Y10\nG0 Z50\nM30\n");
            let out = out(&src);
            let between = gates_between(&out, "G1 X50 F500", "G1 X60 Y10");
            assert_eq!(
                between > 0,
                contour_gate,
                "{path}, {middle:?}: {between} inserted blocks in the contour:\n{out}"
            );
        }
    }
}

/// The fold runs an IF's body as if it always ran: a gate after ENDIF gave back the speed or feed the body
/// set (S6000 where a run that skips the body turns 2000 rpm), and the audit agreed whenever the dry run
/// took the branch. Now a field any branch sets is unsure after ENDIF until the program sets it again:
/// no gate after it measures (and gives back) with that field, one after it is set again does. QA round 9.
#[test]
fn a_gate_after_an_if_does_not_give_back_what_only_one_branch_set() {
    let cut = "G0 X-60 Y0 Z30\nG0 Z2\nG1 Z0 F800\nG1 X60\nG0 Z30\nM1\nG0 X-60 Y40\nG1 Z0\nG1 X60\nG0 Z30\n";
    // The plunge after M1 runs at the feed in force: F200, or F2500 when the branch ran.
    let plunge = "G0 Z30\nM1\nG0 X60\nG1 Z-5\nG0 Z30\n";
    for (branch, rest) in [
        ("IF R20==0\nS6000\nENDIF\n", cut),
        ("IF R20==0\nS6000\nELSE\nS3000\nENDIF\n", cut),
        (
            "G0 X0 Y0 Z5\nG1 Z0 F200\nIF R20==0\nG1 X40 F2500\nENDIF\n",
            plunge,
        ),
    ] {
        let src = format!("G17 G90 G94 G54\nT1 M6\nD1\nS2000 M3 M8\n{branch}{rest}M5\nM30\n");
        let out = out(&src);
        let endif = out.find("ENDIF\n").map(|k| k + 6).unwrap();
        let after: Vec<&str> = out[endif..].lines().filter(|l| inserted(l)).collect();
        assert!(
            !after
                .iter()
                .any(|l| l.starts_with("S6000") || l.starts_with("S3000") || l.contains("F2500")),
            "{branch:?}: a gate gives back a branch's value:\n{out}"
        );
        assert!(
            !after.iter().any(|l| l.contains("BL9700")),
            "{branch:?}: a gate measures after the IF:\n{out}"
        );
    }
    // The output from the gate at M1 on, of the program with `body` between its start and the cut.
    let from_m1 = |body: &str| {
        let o = out(&format!(
            "G17 G90 G94 G54\nT1 M6\nD1\nS2000 M3 M8\n{body}{cut}M5\nM30\n"
        ));
        let m1 = o.find("\nM1\n").unwrap();
        o[m1..].to_string()
    };
    // A nested IF that ends the program does not end the outer body: S6000 may still follow.
    let o = from_m1("IF R20==0\nIF R21==1\nM30\nENDIF\nS6000\nENDIF\n");
    assert!(!o.contains("S6000 M3 ;DL") && !o.contains("BL9700"), "{o}");
    // A body that ends the program (a piece counter) leaves the state before the IF: its D0 is not the
    // program's after ENDIF, and the gate after M1 measures.
    let o = from_m1("IF R30>=R31\nG0 G53 Z0 D0\nM30\nENDIF\n");
    assert!(o.contains("BL9700") && o.contains("S2000 M3 ;DL"), "{o}");
    // Set again after the ENDIF, the speed is known and the gate after M1 measures.
    let o = from_m1("IF R20==0\nS6000\nENDIF\nS2500\n");
    assert!(o.contains("S2500 M3 ;DL") && o.contains("BL9700"), "{o}");
}

/// TRAORI with orientation vectors turns the rotary axes the kinematics choose, and TRAFOOF leaves them
/// there: a gate before the program sends them home measured X0 Y0 with the head or table tilted (the
/// rule that counted the axes as turned covered only CYCLE800). QA round 9.
#[test]
fn no_measurement_while_an_orientation_left_the_rotary_axes_turned() {
    let head = "G17 G90 G94 G54\nT=\"EM16\" M6\nD1\nS6000 M3\nG0 X-80 Y-60 Z80\nG1 Z60 F2000\nG0 Z80\nTRAORI\n\
                G0 X-80 Y-60 Z40 A3=0 B3=-0.5 C3=0.86603\nG1 Z-8 F3000\nG0 Z40\nTRAFOOF\nG0 SUPA Z0\n";
    let tail = "S4000 M3\nG0 X-30 Y20 Z50\nG1 Z-10 F300\nG0 Z50\nM30\n";
    let before_home = format!("{head}T=\"DR8\"\nM6\nD1\nG0 B0 C0\n{tail}");
    let o = out(&before_home);
    let home = o.find("G0 B0 C0\n").unwrap();
    assert!(
        !o[..home]
            .rsplit("TRAFOOF")
            .next()
            .unwrap()
            .contains("BL9700"),
        "{o}"
    );
    // Once both axes are home the next gate measures.
    let after_home = format!("{head}G0 B0 C0\nT=\"DR8\"\nM6\nD1\n{tail}");
    let o = out(&after_home);
    let home = o.find("G0 B0 C0\n").unwrap();
    assert!(o[home..].contains("BL9700"), "{o}");
}

/// A post may leave G18 or G19 modal after an edge radius. The gate's probe and cycle ran in it: with
/// SD42940 = 0 the probe's length acts along Y or X, and the cycle's measuring axis is the plane's. Now the
/// probing section runs in G17 and the program's plane comes back before the way back. TRAORI is no setup
/// of the work coordinates: the zero goes before it (a one-operation 5-axis program was refused). QA round 9.
#[test]
fn the_probe_works_in_g17_and_the_zero_goes_before_traori() {
    let src = "G54\nT1 M6\nD1\nS3000 M3\nG0 X-5 Y-10 Z5\nG18\nG1 X-5 Z0 F800\nG3 X0 Z-5 I5 K0\nG0 Z30\nM1\nG0 X50\nG1 Z-5 F300\nG0 Z30\nM30\n";
    let o = out(src);
    let m1 = o.find("\nM1\n").unwrap();
    let gate = &o[m1..];
    let pos = |what: &str| gate.find(what).unwrap_or_else(|| panic!("{what}:\n{o}"));
    assert!(
        pos("G17 ;DL") < pos("T=\"BLUM_TC50\" M6") && pos("T=\"BLUM_TC50\" M6") < pos("BL9700"),
        "{o}"
    );
    let back = pos("T=1 M6 ;DL");
    assert!(
        gate[back..].find("G18 ;DL").unwrap() < gate[back..].find("X=R63").unwrap(),
        "{o}"
    );
    let traori = "G17 G90 G40 G94 G71 G60\nT1 M6\nD1\nG54\nS8000 M3\nG0 X0 Y0 Z50\nTRAORI\n\
                  G0 Z5 A3=0 B3=-0.5 C3=0.86603\nG1 Z-2 F1000\nG1 X20\nG0 Z50\nTRAFOOF\nM30\n";
    let o = out(traori);
    assert!(o.find("BL9700").unwrap() < o.find("TRAORI").unwrap(), "{o}");
}
