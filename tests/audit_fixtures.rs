//! The audit on hand-written "transformed" programs (fixtures/vm/audit): each hazard file shows one kind of
//! finding at the lines it is expected, its clean counterpart (or clean.mpf, for the hazards in the base
//! program) shows none.

mod common;

use std::path::{Path, PathBuf};

use driftloop::strip::strip;
use driftloop::vm::audit::{Audit, AuditSettings, Kind, audit};
use driftloop::vm::{Config, MachineSpec, ProbeFault};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/vm/audit")
        .join(format!("{name}.mpf"))
}

/// The fixtures correct the stored offset G54 (`method = "frame"`).
fn settings() -> AuditSettings {
    AuditSettings::from_profile(&common::frame_profile())
}

fn audited_with(name: &str, settings: &AuditSettings) -> Audit {
    let transformed = std::fs::read(fixture(name)).unwrap();
    let original = strip(&transformed).bytes;
    audit(&original, &transformed, settings, &Config::default()).unwrap()
}

/// Fixture `name` with `from` replaced by `to`, audited against itself without its `;DL` lines.
fn audited_edited(name: &str, from: &str, to: &str) -> Result<Audit, driftloop::vm::VmError> {
    let transformed = std::fs::read_to_string(fixture(name))
        .unwrap()
        .replace(from, to);
    let original = strip(transformed.as_bytes()).bytes;
    audit(
        &original,
        transformed.as_bytes(),
        &settings(),
        &Config::default(),
    )
}

fn audited(name: &str) -> Audit {
    audited_with(name, &settings())
}

/// (kind, line) of every finding, in the order the runs met them.
fn found(a: &Audit) -> Vec<(Kind, usize)> {
    a.findings.iter().map(|f| (f.kind, f.line)).collect()
}

fn messages(a: &Audit) -> String {
    a.findings
        .iter()
        .map(|f| f.message.as_str())
        .collect::<Vec<_>>()
        .join("\n")
}

/// Audits fixture `name`, checks its findings' kinds and lines and that their messages say each of `says`.
fn expect(name: &str, expected: &[(Kind, usize)], says: &[&str]) -> Audit {
    let a = audited(name);
    assert_eq!(found(&a), expected, "{name}");
    let m = messages(&a);
    for text in says {
        assert!(m.contains(text), "{name}: {m}");
    }
    a
}

#[test]
fn clean_counterparts_have_no_finding() {
    for name in [
        "clean",
        "flow_changed_clean",
        "measure_g41_clean",
        "measure_swivel_clean",
        "modal_g95_clean",
        "offset_abort_clean",
        "stopre_contour_clean",
        "tool_preselected_clean",
    ] {
        let a = audited(name);
        assert!(a.findings.is_empty(), "{name}: {:#?}", a.findings);
        assert!(a.resume_points >= 2, "{name}: the gates were compared");
    }
    // The clean gate's abort paths were followed: NaN and 1e6 reach the alarm, the scrap drift (no scrap
    // check in this gate) is written as a correction and the program goes on.
    let a = audited("clean");
    assert_eq!((a.abort_runs, a.aborts_reached), (3, 2));
}

#[test]
fn xy_travel_below_the_clearance_plane() {
    expect(
        "xy_below_clearance",
        &[(Kind::XyBelowClearance, 19)],
        &["travel from X80 Y50 to X0 Y0 at Z20 below the clearance height Z100"],
    );
}

#[test]
fn a_move_out_of_the_probe_point_that_is_not_straight_up() {
    expect(
        "probe_exit",
        &[(Kind::XyBelowClearance, 24)],
        &["not straight up the tool axis"],
    );
}

#[test]
fn the_probe_left_in_the_spindle() {
    // At the gate's resume point, and again before M30 (the end block restores the offset only).
    expect(
        "tool_state",
        &[(Kind::ToolState, 35), (Kind::ToolState, 44)],
        &["spindle tool T=\"BLUM_TC50\" here, T1 in the original"],
    );
}

#[test]
fn a_preselected_tool_the_gate_replaces() {
    expect(
        "tool_preselected",
        &[(Kind::ToolState, 37), (Kind::ToolState, 49)],
        &[
            "preselected tool (the next M6 loads it) T1 here, T5 in the original",
            // The bare M6 after the gate then loads T1 instead of T5: at the end the wrong tool is in the
            // spindle.
            "spindle tool T1 here, T5 in the original",
        ],
    );
}

#[test]
fn probing_under_a_swivel_and_under_cutter_compensation() {
    // STOPRE, probe call, STOPRE, offset write.
    let lines = [14, 23, 24, 30].map(|l| (Kind::MeasureUnderTransform, l));
    expect("measure_swivel", &lines, &["swivel CYCLE800 A0 B30 C0"]);
    expect("measure_g41", &lines, &["cutter radius compensation G41"]);
}

#[test]
fn coolant_and_feed_type_not_restored() {
    expect(
        "modal_coolant",
        &[(Kind::ModalNotRestored, 36)],
        &["coolant off (M9) here, M8 in the original"],
    );
    expect(
        "modal_g95",
        &[(Kind::ModalNotRestored, 36), (Kind::ModalNotRestored, 45)],
        &[
            "feed type G94 here, G95 in the original",
            "feed F2000 here, F0.1 in the original",
        ],
    );
}

#[test]
fn position_not_brought_back() {
    expect(
        "position",
        &[(Kind::PositionNotRestored, 35)],
        &["X 0 here, 80 in the original; Y 0 here, 50 in the original"],
    );
}

#[test]
fn stopre_inside_a_continuous_path_contour() {
    expect("stopre_contour", &[(Kind::StopreInContour, 12)], &["(G64)"]);
}

#[test]
fn an_alarm_that_leaves_the_work_offset_shifted() {
    let a = expect(
        "offset_abort",
        &[(Kind::OffsetLeftOnAbort, 29)],
        &["alarm 65000 stops the program with $P_UIFR[1,Z,TR] = NaN mm"],
    );
    assert_eq!(
        a.findings[0].times, 2,
        "both the NaN and the 1e6 probe reach it"
    );
}

#[test]
fn a_faulty_probe_value_that_reaches_the_offset() {
    expect(
        "fault_offset",
        &[(Kind::FaultReachesOffset, 29)],
        &["a probe that returns NaN"],
    );
}

#[test]
fn the_original_cuts_where_the_probe_touches() {
    let a = expect(
        "probe_machined",
        &[(Kind::ProbeInMachinedVolume, 10)],
        &["[position] x, y"],
    );
    assert_eq!(a.findings[0].original_line, Some(9));
    // The cut runs along Y2, 2 mm from the probe point: a margin below that lets it pass.
    let narrow = AuditSettings {
        probe_margin_mm: 1.5,
        ..settings()
    };
    assert!(audited_with("probe_machined", &narrow).findings.is_empty());
}

#[test]
fn a_face_milling_cycle_over_the_probe_point() {
    // QA round 9, shop9 F4: the dry run skips the cycle, so no move of it passed the point before.
    let a = expect(
        "cycle_face_probe",
        &[(Kind::ProbeInMachinedVolume, 8)],
        &["CYCLE61 machines X-10…130 Y-10…90 Z0…1", "[position] x, y"],
    );
    assert_eq!(a.findings[0].original_line, Some(7));
}

#[test]
fn a_face_milling_cycle_clear_of_the_probe_point() {
    let a = audited("cycle_face_clear");
    assert!(a.findings.is_empty(), "{:#?}", a.findings);
    assert!(a.resume_points >= 2, "the gate was compared");
}

#[test]
fn a_cycle_region_moves_with_the_programmable_frame() {
    // The clear face (X20…150 Y20…110) called under TRANS X-50 Y-50 runs over X-30…100 Y-30…60 of G54.
    let call = "CYCLE61(50,1,2,0,20,20,130,90,3,40,0.2,1000,31,0,1,10100)";
    let a = audited_edited(
        "cycle_face_clear",
        call,
        &format!("TRANS X-50 Y-50\n{call}\nTRANS"),
    )
    .unwrap();
    machined_once(&a, 9, "CYCLE61 machines X-30…100 Y-30…60 Z0…1");
}

/// `a` found the probe point in the machined volume once, at `line`, saying `what`.
fn machined_once(a: &Audit, line: usize, what: &str) {
    assert_eq!(found(a), [(Kind::ProbeInMachinedVolume, line)]);
    assert!(
        a.findings[0].message.contains(what),
        "{}",
        a.findings[0].message
    );
}

#[test]
fn a_pocket_cycle_around_the_probe_point() {
    expect(
        "cycle_pocket_probe",
        &[(Kind::ProbeInMachinedVolume, 8)],
        &["POCKET3 machines X-15…35 Y-10…20 Z-8…0"],
    );
}

#[test]
fn a_turned_pocket_counts_by_the_box_that_holds_it() {
    expect(
        "cycle_pocket_turned",
        &[(Kind::ProbeInMachinedVolume, 8)],
        &["POCKET3 machines X2.322"],
    );
    // The same pocket not turned runs along Y15…25, 15 mm from the point.
    let a = audited_edited("cycle_pocket_turned", ",20,20,45,", ",20,20,0,").unwrap();
    assert!(a.findings.is_empty(), "{:#?}", a.findings);
}

#[test]
fn a_cycle_whose_machined_region_is_not_known() {
    // Once per cycle: the second CYCLE72 (line 10) is not reported again.
    expect(
        "cycle_unknown",
        &[
            (Kind::MachinedVolumeUnknown, 8),
            (Kind::MachinedVolumeUnknown, 9),
        ],
        &[
            "the region CYCLE61 machines is not known here (its parameter 7 (corner X1) is a value the dry run \
             cannot evaluate): the probe point (X0 Y0 at Z0) is not checked against it",
            "the region CYCLE72 machines is not known here (it mills along a contour defined elsewhere)",
        ],
    );
    // A probe that does not touch the part (a tool setter) is not measuring on a face the cycle mills.
    let setter = AuditSettings {
        spindle_probe: false,
        ..settings()
    };
    assert!(audited_with("cycle_unknown", &setter).findings.is_empty());
}

#[test]
fn an_inserted_jump_over_an_original_block() {
    expect(
        "flow_changed",
        &[(Kind::FlowChanged, 15)],
        &["runs original line 12 next where the original runs original line 11"],
    );
}

#[test]
fn an_original_line_changed_by_the_transform() {
    let transformed = std::fs::read(fixture("clean")).unwrap();
    let mut original = strip(&transformed).bytes;
    // Original line 6 is `G0 X50 Y50 Z50`; make it X51.
    let at = original.windows(3).position(|w| w == b"X50").unwrap();
    original[at + 2] = b'1';
    let a = audit(&original, &transformed, &settings(), &Config::default()).unwrap();
    assert_eq!(found(&a), [(Kind::OriginalChanged, 7)]);
    assert_eq!(a.findings[0].original_line, Some(6));
}

#[test]
fn a_machine_whose_probe_fails_ends_the_comparison_without_a_finding() {
    let faulty = AuditSettings {
        machine: MachineSpec {
            faults: vec![(1, ProbeFault::Nan)],
            ..MachineSpec::default()
        },
        ..settings()
    };
    let a = audited_with("clean", &faulty);
    assert!(a.findings.is_empty(), "{:#?}", a.findings);
    let stopped = a.stopped.unwrap();
    assert!(
        stopped.starts_with("line 27 (inserted) ended the transformed program"),
        "{stopped}"
    );
}

#[test]
fn a_construct_the_machine_cannot_run_is_an_error_naming_the_line() {
    let e = audited_edited("clean", "R2=99999 ;DL", "G33 Z-5 K1 ;DL").unwrap_err();
    assert_eq!((e.file.as_str(), e.line), ("transformed", 21));
    assert!(e.message.contains("G33"), "{e}");
}

#[test]
fn probing_under_a_rotation_or_a_kinematic_transformation() {
    let clean = std::fs::read_to_string(fixture("clean")).unwrap();
    for (on, off, named) in [
        ("ROT Z30", "ROT", "rotation/scale/mirror frame"),
        ("MIRROR X0", "MIRROR", "rotation/scale/mirror frame"),
        ("TRAORI", "TRAFOOF", "TRAORI"),
        ("TRANSMIT", "TRAFOOF", "TRANSMIT"),
        ("TRACYL(40)", "TRAFOOF", "TRACYL"),
    ] {
        // Switched on by the original before the gate, off again after it.
        let t = clean
            .replacen(
                "G0 Z50\n; driftloop gate",
                &format!("G0 Z50\n{on}\n; driftloop gate"),
                1,
            )
            .replacen("G0 X50 Y60\n", &format!("{off}\nG0 X50 Y60\n"), 1);
        let original = strip(t.as_bytes()).bytes;
        let a = audit(&original, t.as_bytes(), &settings(), &Config::default()).unwrap();
        let kinds: Vec<Kind> = a.findings.iter().map(|f| f.kind).collect();
        assert!(
            !kinds.is_empty() && kinds.iter().all(|k| *k == Kind::MeasureUnderTransform),
            "{on}: {:#?}",
            a.findings
        );
        assert!(messages(&a).contains(named), "{on}: {}", messages(&a));
    }
}

#[test]
fn a_hole_a_modal_drilling_cycle_drills_at_the_probe_point() {
    // `MCALL CYCLE81` drills after each move; the dry run skips the cycle, so the hole at X2 Y1 (the
    // probe point X0 Y0 within the margin) was no cut it saw. Holes clear of it are no finding.
    let call = "CYCLE61(50,1,2,0,20,20,130,90,3,40,0.2,1000,31,0,1,10100)";
    let drill = |holes: &str| {
        audited_edited(
            "cycle_face_clear",
            call,
            &format!("MCALL CYCLE81(50,1,2,-10,)\n{holes}MCALL"),
        )
        .unwrap()
    };
    machined_once(
        &drill("X60 Y60\nX2 Y1\n"),
        10,
        "CYCLE81 machines X2…2 Y1…1 Z-10…1",
    );
    assert!(found(&drill("X60 Y60\nX90 Y60\n")).is_empty());
}

#[test]
fn a_hole_pattern_under_a_modal_drilling_cycle_drills_at_its_positions() {
    // `HOLES2` moves to each hole of its circle and calls the modal cycle there: the dry run skips the
    // pattern, so its holes were no cut it saw — a circle about the probe point went unchecked.
    let call = "CYCLE61(50,1,2,0,20,20,130,90,3,40,0.2,1000,31,0,1,10100)";
    let pattern = |modal: &str, holes: &str| {
        audited_edited(
            "cycle_face_clear",
            call,
            &format!("G0 X60 Y60\n{modal}\n{holes}\nMCALL"),
        )
        .unwrap()
    };
    let drill = "MCALL CYCLE81(50,1,2,-10,)";
    machined_once(
        &pattern(drill, "HOLES2(0,0,3,0,0,4)"),
        10,
        "HOLES2 machines X3…3 Y0…0 Z-10…1",
    );
    machined_once(
        &pattern(drill, "HOLES1(-30,2,0,10,10,4)"),
        10,
        "HOLES1 machines X0…0 Y2…2",
    );
    machined_once(
        &pattern(drill, "CYCLE801(-10,-10,0,10,10,3,3)"),
        10,
        "CYCLE801 machines X0…0 Y0…0",
    );
    // Holes clear of the point are no finding, also on a circle about it; without a modal call a pattern
    // only positions the tool.
    assert!(found(&pattern(drill, "HOLES2(60,60,20,0,0,6)")).is_empty());
    assert!(found(&pattern(drill, "HOLES2(0,0,40,0,0,6)")).is_empty());
    assert!(found(&pattern("", "HOLES2(0,0,3,0,0,4)")).is_empty());
    // A modal subprogram or milling cycle at each position is a region the dry run does not know.
    let a = pattern("MCALL POCKET4(50,1,2,-5,4,0,0)", "HOLES2(0,0,30,0,0,4)");
    assert_eq!(found(&a), [(Kind::MachinedVolumeUnknown, 10)]);
    assert!(
        messages(&a).contains("it calls POCKET4, made modal by MCALL, at each of its positions"),
        "{}",
        messages(&a)
    );
}
