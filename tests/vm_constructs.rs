//! Constructs of shop programs the dry run once stopped at, so that the safety audit covered a program only
//! up to the first of them: each now runs, and the audit goes on past it and finds a hazard planted after
//! it. Where the construct is state that matters to safety (a positioned spindle, a sum offset, a
//! toolholder, a second spindle, speed limits, …) the planted blocks break exactly that state.

mod common;

use std::path::Path;

use driftloop::omm::Profile;
use driftloop::vm::audit::{Audit, AuditSettings, Kind, audit};
use driftloop::vm::{Config, Run, SimpleMachine, run_source};

/// A milling program with `construct` on line 9, between two cuts; line 10 is where the original resumes
/// after blocks inserted after the construct.
fn program(construct: &str) -> String {
    format!(
        "G17 G90 G94 G54\nT=\"MILL\" M6\nD1\nS3000 M3 M8\nG0 X0 Y0 Z5\nG1 Z-1 F200\nG1 X50\nG0 Z50\n\
         {construct}\nG0 X10 Y10 Z5\nG1 Z-1 F200\nG1 X60\nG0 Z50\nM30\n"
    )
}

/// `original` with driftloop's header and the `planted` lines (marked `;DL`) after line 9.
fn planted(original: &str, planted: &[&str]) -> String {
    planted_after(original, 9, planted)
}

/// `original` with driftloop's header and the `planted` lines (marked `;DL`) after line `line`.
fn planted_after(original: &str, line: usize, planted: &[&str]) -> String {
    let mut lines: Vec<String> = vec!["; driftloop-omm ;DL".into()];
    for (k, text) in original.lines().enumerate() {
        lines.push(text.to_string());
        if k + 1 == line {
            lines.extend(planted.iter().map(|p| format!("{p} ;DL")));
        }
    }
    lines.join("\n") + "\n"
}

fn audited(original: &str, transformed: &str, dir: Option<&Path>) -> Audit {
    let mut settings = AuditSettings::from_profile(&Profile::default_profile());
    settings.dir = dir.map(Path::to_path_buf);
    audit(
        original.as_bytes(),
        transformed.as_bytes(),
        &settings,
        &Config::default(),
    )
    .unwrap_or_else(|e| panic!("the dry run stopped: {e}"))
}

/// The audit of `construct` with `plant` after it ran to the end and found `kind` saying `text`.
fn finds(construct: &str, plant: &[&str], kind: Kind, text: &str) -> Audit {
    let original = program(construct);
    let found = audited(&original, &planted(&original, plant), None);
    assert_eq!(found.stopped, None, "{construct}");
    assert!(
        found
            .findings
            .iter()
            .any(|f| f.kind == kind && f.message.contains(text)),
        "{construct} with {plant:?}: no {} saying `{text}` in {:#?}",
        kind.name(),
        found.findings
    );
    found
}

/// A dry run of `src` on a machine that does not drift.
fn dry_run(src: &[u8], cfg: &Config) -> Run {
    run_source("p.mpf", src, None, cfg, &mut SimpleMachine::cold())
        .unwrap_or_else(|e| panic!("the dry run stopped: {e}"))
}

/// The message the dry run of `src` stops with.
fn dry_run_error(src: &[u8], cfg: &Config) -> String {
    match run_source("p.mpf", src, None, cfg, &mut SimpleMachine::cold()) {
        Ok(_) => panic!("the dry run ran {}", String::from_utf8_lossy(src)),
        Err(e) => e.message,
    }
}

/// Whether the audit noted something containing `text`.
fn noted(found: &Audit, text: &str) -> bool {
    found.notes.iter().any(|n| n.contains(text))
}

/// `driftloop transform PROGRAM --profile tool-setter -o out.mpf` in `dir`: its stderr. It must have
/// written the output with the audit run to the end.
fn transformed_and_audited(dir: &Path, program: &str) -> String {
    transformed_and_audited_with(dir, program, "tool-setter")
}

fn transformed_and_audited_with(dir: &Path, program: &str, profile: &str) -> String {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/model.toml");
    let args = [
        "transform",
        program,
        "--model",
        &model.display().to_string(),
        "--profile",
        profile,
        "-o",
        "out.mpf",
    ];
    let o = common::driftloop(dir, &args, b"");
    let err = common::stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("audit incomplete"), "{err}");
    err
}

#[test]
fn a_positioned_spindle_started_again_by_a_gate_is_found() {
    for (construct, angle) in [
        ("SPOS=0", "SPOS=0"),
        ("SPOSA=0", "SPOS=0"),
        ("SPOS[1]=90", "SPOS=90"),
        ("SPOS=DC(0)", "SPOS=0"),
        ("SPOS=ACP(450)", "SPOS=90"),
        ("M19", "SPOS"),
    ] {
        let message = format!("spindle S3000 M3 here, S3000 M5 {angle} in the original");
        finds(construct, &["S3000 M3"], Kind::ModalNotRestored, &message);
        // A tool change turns the spindle to the changer's angle: the program's orientation is lost.
        let message = format!("spindle S3000 M5 here, S3000 M5 {angle} in the original");
        finds(
            construct,
            &["T=\"PROBE\" M6", "T=\"MILL\" M6", "D1"],
            Kind::ModalNotRestored,
            &message,
        );
    }
}

#[test]
fn a_sum_offset_a_gate_drops_is_a_tool_state_finding() {
    let found = finds(
        "D1 DL=2",
        &["T=\"PROBE\" M6", "T=\"MILL\" M6", "D1"],
        Kind::ToolState,
        "sum offset (the tool's length) DL=0 here, DL=2 in the original",
    );
    assert!(
        found
            .findings
            .iter()
            .filter(|f| f.kind == Kind::ToolState)
            .all(|f| f.original_line == Some(10))
    );
    // A new cutting edge brings MD20272's sum offset: with 2 there, the gate's D1 gives DL=2 back.
    let original = program("D1 DL=2");
    let cfg = Config {
        sumcorr_default: 2.0,
        ..Config::default()
    };
    let settings = AuditSettings::from_profile(&Profile::default_profile());
    let transformed = planted(&original, &["T=\"MILL\" M6", "D1"]);
    let found = audit(original.as_bytes(), transformed.as_bytes(), &settings, &cfg).unwrap();
    assert!(
        found.findings.iter().all(|f| f.kind != Kind::ToolState),
        "{:#?}",
        found.findings
    );
}

#[test]
fn an_orientable_toolholder_is_a_transformation_and_state() {
    finds(
        "TCARR=1 TCOABS",
        &["STOPRE"],
        Kind::MeasureUnderTransform,
        "STOPRE runs while the orientable toolholder TCARR=1 is active",
    );
    finds(
        "TCARR=2 TCOFR",
        &["TCARR=0"],
        Kind::ModalNotRestored,
        "toolholder TCARR=0 here, TCARR=2 in the original",
    );
    finds(
        "TCOFR",
        &["TCOABS"],
        Kind::ModalNotRestored,
        "toolholder orientation (G group 42) TCOABS here, TCOFR in the original",
    );
}

#[test]
fn the_other_spindles_and_the_speed_limits_are_compared() {
    finds(
        "S2=1000 M2=3",
        &["M2=5"],
        Kind::ModalNotRestored,
        "spindle 2 S1000 M5 here, S1000 M3 in the original",
    );
    finds(
        "G25 S4000",
        &["G25 S0"],
        Kind::ModalNotRestored,
        "spindle speed limits G25 S0, G26 none here, G25 S4000, G26 none in the original",
    );
    finds(
        "G26 S6000",
        &["G26 S8000"],
        Kind::ModalNotRestored,
        "spindle speed limits G25 none, G26 S8000 here, G25 none, G26 S6000 in the original",
    );
}

#[test]
fn g26_clamps_the_speed_and_its_axis_values_are_no_move() {
    let src = b"G26 S2000 X500\nS3000 M3\nG4 F60\nG25 S1500\nS1000\nG4 F60\nM30\n";
    let run = dry_run(src, &Config::default());
    let speeds: Vec<f64> = run.spindle.steps.iter().map(|s| s.1).collect();
    assert_eq!(speeds, [2000.0, 1500.0, 0.0], "{:?}", run.spindle);
    assert!(run.trace.iter().all(|r| r.programmed[0] == 0.0));
}

#[test]
fn the_circle_constant_is_a_value() {
    // A dresser macro's speed from the wheel's diameter (QA round 13: the dry run stopped at `$PI`).
    let run = dry_run(
        b"R1=60000/($PI*400)\nS=R1 M3\nG4 F1\nM30\n",
        &Config::default(),
    );
    let rpm = run.spindle.steps[0].1;
    assert!((rpm - 47.746_482_9).abs() < 1e-6, "{:?}", run.spindle);
    finds(
        "R9=$PI",
        &["G91"],
        Kind::ModalNotRestored,
        "dimensions G91 here, G90 in the original",
    );
}

#[test]
fn a_measuring_cycles_parameters_are_data_of_the_cycle_package() {
    // A CAM post's probing operation sets the measuring cycle's parameters (GUD of the cycle package) and
    // calls the cycle without arguments (QA round 14: the dry run stopped at `_TSA`, "not defined").
    finds(
        "_TSA=1 _PRNUM=001 _VMS=0 _NMSP=1 _FA=5 _MVAR=100 _SETVAL=0 _SETV[0]=40 _KNUM=1 _TNAME=\"T1\"",
        &["G91"],
        Kind::ModalNotRestored,
        "dimensions G91 here, G90 in the original",
    );
}

#[test]
fn indirect_g_codes_select_as_the_g_code_would() {
    finds(
        "G[8]=2",
        &["G500"],
        Kind::ModalNotRestored,
        "work offset G500 here, G54 in the original",
    );
    finds(
        "G[18]=2",
        &["G450"],
        Kind::ModalNotRestored,
        "corner behaviour (G group 18) G450 here, G451 in the original",
    );
    let cfg = Config {
        offsets: vec![(2, "Z".into(), -100.0)],
        ..Config::default()
    };
    let run = dry_run(b"G[8]=3\nG0 Z5\nM30\n", &cfg);
    assert_eq!(run.trace[1].machine[2], -95.0, "G[8]=3 is G55");
}

#[test]
fn path_settings_are_kept_as_state() {
    for (construct, other, text) in [
        (
            "COMPCAD",
            "COMPOF",
            "compressor (G group 59) COMPOF here, COMPCAD",
        ),
        (
            "UPATH",
            "SPATH",
            "path reference (G group 45) SPATH here, UPATH",
        ),
        (
            "SPATH",
            "UPATH",
            "path reference (G group 45) UPATH here, SPATH",
        ),
        (
            "ORIMKS",
            "ORIWKS",
            "orientation reference (G group 25) ORIWKS here, ORIMKS",
        ),
        (
            "ORIWKS",
            "ORIMKS",
            "orientation reference (G group 25) ORIMKS here, ORIWKS",
        ),
        (
            "CUT2DF",
            "CUT2D",
            "tool compensation type (G group 22) CUT2D here, CUT2DF",
        ),
        (
            "CUT2D",
            "CUT3DC",
            "tool compensation type (G group 22) CUT3DC here, CUT2D",
        ),
        (
            "G451",
            "G450",
            "corner behaviour (G group 18) G450 here, G451",
        ),
        (
            "G450",
            "G451",
            "corner behaviour (G group 18) G451 here, G450",
        ),
        (
            "WALIMOF",
            "WALIMON",
            "working area limitation (G group 28) WALIMON here, WALIMOF",
        ),
        (
            "WALIMON",
            "WALIMOF",
            "working area limitation (G group 28) WALIMOF here, WALIMON",
        ),
        ("OFFN=0.1", "OFFN=0", "contour offset OFFN=0 here, OFFN=0.1"),
    ] {
        finds(construct, &[other], Kind::ModalNotRestored, text);
    }
}

#[test]
fn dynamics_and_rotary_positioning_run_on() {
    // How fast, not where: accepted; the audit goes on and finds the coolant a block switched off.
    for construct in [
        "ACC[X]=50",
        "FA[X]=100",
        "FGROUP(X,Y,Z)",
        "G641 ADIS=0.1",
        "G0 A=DC(0)",
        "G0 C=ACN(270)",
    ] {
        finds(
            construct,
            &["M9"],
            Kind::ModalNotRestored,
            "coolant off (M9) here, M8 in the original",
        );
    }
    finds(
        "G0 A=DC(30)",
        &["G0 A=DC(0)"],
        Kind::PositionNotRestored,
        "A 0 here, 30 in the original",
    );
}

#[test]
fn axis_procedures_the_online_tool_offset_and_compsurf_run_on() {
    // Acceleration per axis, waiting for positioning axes, the online tool length offset (which no gate
    // measures under) and the surface compressor: accepted, also by a dry run that skips no call; before,
    // it took the axis names for values or COMPSURF for a subprogram.
    for construct in [
        "SOFTA(X,Y,Z)",
        "BRISKA(X,Y,Z)",
        "DRIVEA(Z)",
        "JERKA(X,Y)",
        "WAITP(X)",
        "TOFFON(Z,0.1)",
        "TOFFOF(Z)",
        "COMPSURF",
    ] {
        dry_run(program(construct).as_bytes(), &Config::default());
        finds(
            construct,
            &["M9"],
            Kind::ModalNotRestored,
            "coolant off (M9) here, M8 in the original",
        );
    }
}

#[test]
fn values_the_dry_run_cannot_know_are_read_from_the_machine_file_or_noted() {
    for (construct, key) in [
        ("R10=$TC_DP1[1,1]", "$TC_DP1[1,1]"),
        ("IF $A_IN[1]==1 GOTOF SKIP", "$A_IN[1]"),
        ("R5=$AC_TIME", "$AC_TIME"),
        ("R6=_OVR[16]", "_OVR[16]"),
    ] {
        let found = finds(
            construct,
            &["M9"],
            Kind::ModalNotRestored,
            "coolant off (M9) here",
        );
        assert!(
            noted(&found, &format!("{key} read as 0")),
            "{construct}: {:?}",
            found.notes
        );
    }
    // The machine file's value steers the flow: input 1 set, the jump skips the second cut.
    let src = "IF $A_IN[1]==1 GOTOF SKIP\nG0 X10\nSKIP:\nG0 Y10\nM30\n";
    let run_with = |text: &str| {
        let (cfg, _) =
            driftloop::vm::parse_machine_file(text, Path::new("."), Config::default()).unwrap();
        dry_run(src.as_bytes(), &cfg)
    };
    let set = run_with("[variables]\n\"$a_in[ 1 ]\" = 1\n");
    assert_eq!(set.trace.last().unwrap().programmed[0], 0.0, "X10 skipped");
    assert!(set.assumptions.is_empty(), "{:?}", set.assumptions);
    let unset = run_with("");
    assert_eq!(unset.trace.last().unwrap().programmed[0], 10.0);
    assert_eq!(unset.assumptions.len(), 1, "{:?}", unset.assumptions);
    // What the program writes it reads back, with no note.
    let wrote = dry_run(
        b"$TC_DP3[1,1]=120.5\nR1=$TC_DP3[1,1]\n_OVR[4]=0.5\nR2=_OVR[4]\nM30\n",
        &Config::default(),
    );
    assert_eq!(&wrote.r_final[1..3], &[120.5, 0.5]);
    assert!(wrote.assumptions.is_empty(), "{:?}", wrote.assumptions);
}

#[test]
fn synchronized_actions_are_recorded_not_run_and_said_so() {
    let found = finds(
        "ID=1 WHENEVER $AA_IM[Z]<-100 DO $AC_OVR=0",
        &["CANCEL(1)"],
        Kind::ModalNotRestored,
        "synchronized actions none here, ID=1 in the original",
    );
    assert!(noted(&found, "WHENEVER … DO, ID=1"), "{:?}", found.notes);
    let found = finds(
        "WHEN $AA_IW[Z]<0 DO M8",
        &["M9"],
        Kind::ModalNotRestored,
        "coolant off (M9) here, M8 in the original",
    );
    assert!(
        noted(&found, "for the next block that moves"),
        "{:?}",
        found.notes
    );
    // An inserted move under a modal action: the note says the dry run did not check it.
    let found = finds(
        "IDS=2 EVERY $A_IN[1]==1 DO POS[X]=100",
        &["G0 Z60", "M9"],
        Kind::ModalNotRestored,
        "coolant off (M9) here",
    );
    assert!(
        noted(
            &found,
            "synchronized action IDS=2 of line 10 is active while inserted blocks move"
        ),
        "{:?}",
        found.notes
    );
}

#[test]
fn extcall_and_pcall_run_the_program_they_name() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("PART1.SPF"), "G0 X30 Y30\nM17\n").unwrap();
    for construct in [
        "EXTCALL \"PART1\"",
        "PCALL PART1",
        "PCALL /_N_WKS_DIR/_N_SHAFT_WPD/_N_PART1_SPF",
    ] {
        let original = program(construct);
        let found = audited(&original, &planted(&original, &["M9"]), Some(dir.path()));
        assert_eq!(found.stopped, None);
        assert_eq!(
            found.original_blocks, 16,
            "{construct}: the called program's two blocks ran"
        );
        assert!(
            found
                .findings
                .iter()
                .any(|f| f.kind == Kind::ModalNotRestored),
            "{construct}: {:#?}",
            found.findings
        );
    }
}

/// `L200 P3` of a subprogram neither run can find is skipped alike, its repetitions with it.
#[test]
fn a_missing_subprogram_called_several_times_is_skipped() {
    finds(
        "L200 P3",
        &["M9"],
        Kind::ModalNotRestored,
        "coolant off (M9) here, M8 in the original",
    );
}

/// A program whose last blocks run under TRAORI ends without TRAFOOF: the control's reset ends the
/// transformation, and the offset restore before M30 moves nothing under it.
#[test]
fn an_offset_written_under_a_transformation_is_a_hazard_only_when_the_machine_moves_under_it() {
    let original = "G17 G90 G94 G54\nT=\"MILL\" M6\nD1\nS3000 M3\nG0 X0 Y0 Z50\nTRAORI\nG1 Z-1 F200\n\
                    X50\nG0 Z50\nM30\n";
    let settings = AuditSettings::from_profile(&Profile::default_profile());
    let audit_of = |transformed: String| {
        let transformed = format!("; driftloop-omm ;DL\n{transformed}");
        audit(
            original.as_bytes(),
            transformed.as_bytes(),
            &settings,
            &Config::default(),
        )
        .unwrap()
    };
    let found = audit_of(original.replace("M30\n", "STOPRE ;DL\n$P_UIFR[1,Z,TR]=0 ;DL\nM30\n"));
    assert!(
        found
            .findings
            .iter()
            .all(|f| f.kind != Kind::MeasureUnderTransform),
        "{:#?}",
        found.findings
    );
    // The same blocks before the last cut: the machine then moves under TRAORI.
    let found = audit_of(original.replace("X50\n", "STOPRE ;DL\nX50\n"));
    let under: Vec<_> = found
        .findings
        .iter()
        .filter(|f| f.kind == Kind::MeasureUnderTransform)
        .collect();
    assert_eq!(under.len(), 1, "{:#?}", found.findings);
    assert_eq!(under[0].line, 9);
    assert!(
        under[0]
            .message
            .contains("STOPRE runs while TRAORI is active")
    );
}

/// Through the binary: the same program transforms (the restore before M30 no longer refuses it), and
/// its audit runs to the end.
#[test]
fn a_program_ending_under_traori_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let prog = "G17 G90 G94 G54\nT=\"MILL\" M6\nD1\nS3000 M3 M8\nG0 X0 Y0 Z50\nG1 Z-1 F200\nX50\n\
                G0 Z50\nTRAORI\nG0 X10 Y10 Z5\nG1 Z-1 F200\nX60\nG0 Z50\nM30\n";
    std::fs::write(dir.path().join("p.mpf"), prog).unwrap();
    transformed_and_audited(dir.path(), "p.mpf");
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
    let restore = out
        .find("work offset back to its value before the program")
        .expect("the restore before M30");
    assert!(out[..restore].contains("TRAORI") && !out.contains("TRAFOOF"));
}

/// The shop program that measures its part zero with CYCLE978 and adds `_OVR[16]` to G54: its audit ran
/// only to that line; it now runs to the end, and says which result it took as 0.
#[test]
fn the_probe_setup_shop_program_is_audited_to_its_end() {
    let dir = tempfile::tempdir().unwrap();
    let program = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/shop/10_probe_setup.mpf");
    let err = transformed_and_audited(dir.path(), &program.display().to_string());
    assert!(err.contains("_OVR[16] read as 0"), "{err}");
}

/// fixtures/shop5/20 builds its work offsets with `$P_UIFR[n]=CTRANS(…)` before the first cut: the dry run
/// stopped at that line, so every output was written without an audit. A whole frame written so now takes
/// those translations (0 for what it leaves out, the fine part too), acting at the next selection, and the
/// program transforms with its audit run to the end.
#[test]
fn a_settable_frame_built_with_ctrans_is_run() {
    let src = "G500\n$P_UIFR[1,Y,FI]=0.5\n$P_UIFR[1]=CTRANS(X,-412.35,Z,-611.48)\nG0 X0 Y0 Z0\nG54\nG0 X0 Y0 Z0\nM30\n";
    let run = dry_run(src.as_bytes(), &Config::default());
    let trace = &run.trace;
    let at = |line: usize| {
        trace
            .iter()
            .find(|r| r.line == line)
            .map(|r| r.machine.clone())
            .unwrap()
    };
    assert_eq!(
        at(4)[..3],
        [0.0, 0.0, 0.0],
        "not acting before the selection"
    );
    assert_eq!(at(6)[..3], [-412.35, 0.0, -611.48]);
    let dir = tempfile::tempdir().unwrap();
    let program = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/shop5/20_g500_puifr_frames_before_first_cut.mpf");
    transformed_and_audited(dir.path(), &program.display().to_string());
}

/// The same program probed in work coordinates: the part lies where the offset the program built puts it,
/// not where the offsets at the start would. The dry run placed the surface by the start's offsets, so the
/// zero read hundreds of millimetres off, ended in its alarm and left the rest of the output unaudited.
#[test]
fn a_part_probed_under_an_offset_the_program_built_is_audited_to_its_end() {
    let program = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/shop5/20_g500_puifr_frames_before_first_cut.mpf");
    for profile in ["blum-tc50", "grinder-gauge"] {
        let dir = tempfile::tempdir().unwrap();
        transformed_and_audited_with(dir.path(), &program.display().to_string(), profile);
    }
}

/// The machine position of every axis after the last block of `src` (X Y Z A B C).
fn machine_at_end(src: &str, cfg: &Config) -> Vec<f64> {
    let run = dry_run(src.as_bytes(), cfg);
    run.trace.last().expect("a traced block").machine.clone()
}

fn near(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-9
}

#[test]
fn orientation_under_traori_is_state_the_audit_compares() {
    let direction = "TRAORI ORIWKS A3=0 B3=-0.5 C3=0.866";
    finds(
        direction,
        &["A3=0 B3=0 C3=1"],
        Kind::ModalNotRestored,
        "tool orientation A3=0 B3=0 C3=1 here, A3=0 B3=-0.5 C3=0.866 in the original",
    );
    // A gate that leaves the transformation and selects it again has lost the orientation.
    finds(
        direction,
        &["TRAFOOF", "TRAORI"],
        Kind::ModalNotRestored,
        "tool orientation none here, A3=0 B3=-0.5 C3=0.866 in the original",
    );
    finds(
        "TRAORI LEAD=10 TILT=5",
        &["LEAD=0"],
        Kind::ModalNotRestored,
        "tool orientation LEAD=0 TILT=5 here, LEAD=10 TILT=5 in the original",
    );
    finds(
        "TRAORI ORIRESET(0, 90)",
        &["A2=0 B2=0 C2=0"],
        Kind::ModalNotRestored,
        "tool orientation A2=0 B2=0 C2=0 here, ORIRESET(0, 90) in the original",
    );
    // Orientation words and X Y Z in one block: the positions are the programmed ones.
    let run = dry_run(
        b"G90 G94 G54\nTRAORI\nG1 X-20 Y5 Z-2 A3=0.1 B3=-0.49 C3=0.866 F1500\nM30\n",
        &Config::default(),
    );
    assert_eq!(
        run.trace.last().unwrap().programmed[..3],
        [-20.0, 5.0, -2.0]
    );
    let without = dry_run_error(b"G90 G54\nG1 X1 A3=1 F100\nM30\n", &Config::default());
    assert!(without.contains("without the orientation transformation TRAORI"));
}

#[test]
fn g58_and_g59_replace_the_coarse_and_the_fine_part_of_the_programmable_translation() {
    // The Programming Manual's example: total offset X30 Y20 Z10.
    let end = machine_at_end(
        "G90 G500\nTRANS X10 Y10 Z10\nATRANS X5 Y5\nG58 X20\nG59 X10 Y10\nG0 X0 Y0 Z0\nM30\n",
        &Config::default(),
    );
    assert_eq!(end[..3], [30.0, 20.0, 10.0]);
    // ATRANS after a rotation goes into the fine part along the turned axis; G58 X replaces the coarse X
    // in the frame's own coordinates and keeps the fine part.
    let end = machine_at_end(
        "G90 G17 G500\nTRANS X10\nAROT RPL=90\nATRANS X5\nG58 X20\nG0 X0 Y0 Z0\nM30\n",
        &Config::default(),
    );
    assert!(near(end[0], 20.0) && near(end[1], 5.0), "{end:?}");
    // TRANS deletes both parts; the settable offset stays underneath.
    let cfg = Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        ..Config::default()
    };
    let end = machine_at_end(
        "G90 G54\nG58 Z-5\nG59 Z-0.2\nG0 Z1\nTRANS\nG0 Z1\nM30\n",
        &cfg,
    );
    assert!(near(end[2], -99.0), "{end:?}");
    let end = machine_at_end("G90 G54\nG58 Z-5\nG59 Z-0.2\nG0 Z1\nM30\n", &cfg);
    assert!(near(end[2], -104.2), "{end:?}");
}

#[test]
fn a_gate_that_loses_a_g58_or_g59_offset_is_found() {
    finds(
        "G58 Z-5",
        &["TRANS"],
        Kind::ModalNotRestored,
        "programmable translation Z 0 here, -5 in the original",
    );
    // The same total split otherwise: the next G58 / G59 of the original would act differently.
    finds(
        "G59 Z-0.2",
        &["G59 Z0", "G58 Z-0.2"],
        Kind::ModalNotRestored,
        "fine part of the programmable translation (ATRANS, G59) Z 0 here, -0.2 in the original",
    );
}

#[test]
fn poly_blocks_end_at_the_programmed_points_and_take_the_curve_s_time() {
    // X = p, Y = p² over PL=1 at F1 mm/min: the parabola's length in minutes.
    let parabola = (2.0 * 5f64.sqrt() + 2f64.asinh()) / 4.0;
    for block in [
        "POLY PO[X]=(1) PO[Y]=(1,1)",
        "POLY X=PO(1) Y=PO(1,1)",
        "POLY PO[X]=(1,0,0,0,0) PO[Y]=(1,1,0) PL=1",
    ] {
        let src = format!("G90 G94 G500\nG0 X0 Y0 Z0\nG1 F1\n{block}\nM30\n");
        let run = dry_run(src.as_bytes(), &Config::default());
        let last = run.trace.last().unwrap();
        assert_eq!(last.programmed[..2], [1.0, 1.0], "{block}");
        assert!(
            (run.time_min - parabola).abs() < 1e-3 * parabola,
            "{block}: {} min",
            run.time_min
        );
    }
    // Without POLY, or for the axes POLYPATH leaves out, the end point is reached along the line.
    for src in [
        "G90 G94 G500\nG0 X0 Y0 Z0\nG1 F1\nPO[X]=(1) PO[Y]=(1,1)\nM30\n",
        "G90 G94 G500\nPOLYPATH(\"VECT\")\nG0 X0 Y0 Z0\nG1 F1\nPOLY PO[X]=(1) PO[Y]=(1,1)\nM30\n",
    ] {
        let run = dry_run(src.as_bytes(), &Config::default());
        assert!(
            (run.time_min - 2f64.sqrt()).abs() < 1e-9,
            "{src}: {}",
            run.time_min
        );
    }
    let too_many = dry_run_error(
        b"G94 G1 F1\nPOLY PO[X]=(1,1,1,1,1,1)\nM30\n",
        &Config::default(),
    );
    assert!(too_many.contains("at most the coefficients a2"));
}

#[test]
fn gett_and_the_number_of_a_named_tool_agree() {
    let run = dry_run(
        b"DEF INT TNR\nTNR=GETT(\"EM_D10_FIN\",2)\nR1=TNR\nR2=GETT(\"em_d10_fin\",1)\n\
          T=\"EM_D10_FIN\"\nM6\nR3=$P_TOOLNO\nT=TNR\nM6\nR4=$P_TOOLNO\nM30\n",
        &Config::default(),
    );
    let r = &run.r_final;
    assert!(r[1] >= 1.0 && r[1].fract() == 0.0, "{}", r[1]);
    assert_ne!(r[1], r[2], "the sister tool (duplo 2) is a tool of its own");
    assert_eq!(
        r[2], r[3],
        "$P_TOOLNO of the named tool is its first duplo's number"
    );
    assert_eq!(r[4], r[1]);
}

#[test]
fn a_machine_axis_name_moves_its_axis_in_machine_coordinates() {
    let cfg = Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        ..Config::default()
    };
    let end = machine_at_end("G90 G54\nG0 X5 Z1=-2\nM30\n", &cfg);
    assert_eq!((end[0], end[2]), (5.0, -2.0));
    let end = machine_at_end("G90 G54\nG0 Z1=-2\nG0 Z3\nM30\n", &cfg);
    assert_eq!(
        end[2], -97.0,
        "the channel axis name is in the work offset again"
    );
    // The machine file names them when the machine's names differ (MD10000).
    let (cfg, _) = driftloop::vm::parse_machine_file(
        "[machine_axes]\nZS = \"Z\"\n",
        Path::new("."),
        Config::default(),
    )
    .unwrap();
    assert_eq!(machine_at_end("G90\nG0 ZS=-7\nM30\n", &cfg)[2], -7.0);
    assert!(dry_run_error(b"G0 Z1=-2\nM30\n", &cfg).contains("Z1 is not defined"));
}

/// G74 takes the axes it names to their reference points (MD34100, machine positions): the machine file's
/// value, else 0 with a note; the values written with them are placeholders. It stopped the dry run.
#[test]
fn g74_goes_to_the_reference_point_in_machine_coordinates() {
    let src = "G90 G54\nG0 X5 Y5 Z-3\nG74 Z1=0\nM30\n";
    let cfg = Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        ..Config::default()
    };
    let run = dry_run(src.as_bytes(), &cfg);
    let end = &run.trace.last().unwrap().machine;
    assert_eq!((end[0], end[2]), (5.0, 0.0));
    assert!(
        run.assumptions
            .iter()
            .any(|a| a.text.contains("$MA_REFP_SET_POS[0,Z] read as 0")),
        "{:?}",
        run.assumptions
    );
    let (cfg, _) = driftloop::vm::parse_machine_file(
        "[variables]\n\"$MA_REFP_SET_POS[0,Z]\" = 450\n",
        Path::new("."),
        cfg,
    )
    .unwrap();
    assert_eq!(machine_at_end(src, &cfg)[2], 450.0);
}

/// Siemens cycles and shop cycles address axes through AXIS variables (`DEF AXIS _X`, `_X=$P_AXN1`,
/// `AX[_X]=…`, `$AA_IW[_X]`) and read the active G codes with `$P_GG[group]`: each stopped the dry run.
#[test]
fn axis_variables_indirect_axes_and_the_active_g_codes_run() {
    let src = "DEF AXIS _X,_Z2\nG17 G90 G94 G54\n_X=$P_AXN1\n_Z2=Z\nG0 AX[_X]=10 AX[Z]=5\nG1 AX[_Z2]=-2 F100\n\
               R1=$AA_IW[_X]\nR2=$P_GG[6]*100+$P_GG[14]*10+$P_GG[8]\nR3=$P_GG[15]+$P_MC\n\
               G18 G91 G55\nR4=$P_GG[6]*100+$P_GG[14]*10+$P_GG[8]\nG90\n_X=AXNAME(\"y\")\nG0 AX[_X]=7\nM30\n";
    let run = dry_run(src.as_bytes(), &Config::default());
    assert_eq!(&run.r_final[1..5], &[10.0, 112.0, 2.0, 223.0]);
    assert_eq!(
        &run.trace.last().unwrap().programmed[..3],
        &[10.0, 7.0, -2.0]
    );
    assert!(
        dry_run_error(b"DEF AXIS _X\n_X=5\nM30\n", &Config::default())
            .contains("holds an axis name")
    );
    assert!(
        dry_run_error(
            b"DEF AXIS _X\n_X=\"Q\"\nG0 AX[_X]=1\nM30\n",
            &Config::default()
        )
        .contains("Q is not an axis")
    );
}

#[test]
fn an_axis_variable_takes_an_axis_name_in_brackets() {
    // A builder's axis-calibration macro writes `AXIVAR=(C)`; a declaration may set the axis at once
    // (QA round 13: the dry run stopped, "axis C used as a value").
    let src = "DEF AXIS AV, AW\nDEF AXIS AZ=(Z), AY=Y\nAV=(X)\nAW=((Y))\nG90 G1 AX[AV]=4 AX[AW]=5 F500\n\
               AX[AZ]=-1\nAX[AY]=6\nM30\n";
    let run = dry_run(src.as_bytes(), &Config::default());
    assert_eq!(
        &run.trace.last().unwrap().programmed[..3],
        &[4.0, 6.0, -1.0]
    );
}

/// The shop programs the dry run stopped at (TRAORI orientation words, a machine axis name, GETT, POLY,
/// G58/G59) transform with every profile that writes them, audited to the end.
#[test]
fn the_fixture_programs_with_these_constructs_are_audited_to_the_end() {
    let model = common::fixture("omm/model.toml");
    for program in [
        "shop/23_nx_traori.mpf",
        "shop4/02_hypermill_5x_impeller_cover.mpf",
        "shop5/06_millturn_tracyl_groove_subspindle.mpf",
        "shop5/07_traori_5x_orireset_no_trafooff.mpf",
        "shop5/08_toolmgmt_gett_duplo_sister.mpf",
        "shop6/09_poly_finishing_nurbs_post.mpf",
        "shop6/10_g58_g59_stacked_frames.mpf",
    ] {
        let path = common::fixture(program);
        let subs = Path::new(&path).parent().unwrap().join("subs");
        let subs = subs.display().to_string();
        for profile in ["blum-tc50", "tool-setter", "lathe-setter", "grinder-gauge"] {
            let dir = tempfile::tempdir().unwrap();
            let args = [
                "transform",
                &path,
                "--model",
                &model,
                "--profile",
                profile,
                "--subprograms",
                &subs,
                "-o",
                "out.mpf",
            ];
            let o = common::driftloop(dir.path(), &args, b"");
            let err = common::stderr(&o);
            assert!(
                !err.contains("audit incomplete"),
                "{program} {profile}: {err}"
            );
            assert!(
                !err.contains("audit findings"),
                "{program} {profile}: {err}"
            );
        }
    }
}

/// `TOWSTD`/`TOWWCS` (which frame the tool length acts in) are Siemens commands, not calls: the dry run
/// stopped at them as unknown, so the Pittler lathe program (fixtures/shop8/10) was written without an
/// audit from there on.
#[test]
fn the_tool_length_frame_commands_are_run() {
    let dir = tempfile::tempdir().unwrap();
    let program = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/shop8/10_pittler_pv_vertical_lathe_wzw.mpf");
    transformed_and_audited_with(dir.path(), &program.display().to_string(), "grinder-gauge");
}

/// SETMS makes another spindle the master: a feed per revolution then runs by its speed (a lathe's main
/// spindle 4 with `S4=… M4=3`), and SETMS alone gives the master back to spindle 1. The dry run took every
/// G95 feed by spindle 1, so DMG lathe programs stopped at their first cut ("spindle stopped").
#[test]
fn a_feed_per_revolution_runs_by_the_master_spindle_setms_selects() {
    let src = "G18 G90 G95\nSETMS(4)\nS4=1000 M4=3\nG1 Z-10 F0.1\nM30\n";
    let run = dry_run(src.as_bytes(), &Config::default());
    // 10 mm at 0.1 mm per revolution of 1000 rpm: 0.1 min.
    assert!((run.time_min - 0.1).abs() < 1e-6, "{}", run.time_min);
    let back = "G18 G90 G95\nSETMS(4)\nS4=1000 M4=3\nSETMS\nG1 Z-10 F0.1\nM30\n";
    assert!(
        dry_run_error(back.as_bytes(), &Config::default()).contains("spindle stopped"),
        "spindle 1 is the master again, and it stands"
    );
    // Under SETMS(2) S and M3 without an extension turn spindle 2, the master; spindle 1 stands. They
    // went to spindle 1, and the feed per revolution then found the master standing (QA round 9, `07`).
    let unextended = "G18 G90 G95\nSETMS(2)\nS1000 M3\nG1 Z-10 F0.1\nSETMS\nG1 Z-20 F0.1\nM30\n";
    assert!(
        dry_run_error(unextended.as_bytes(), &Config::default()).contains("spindle stopped"),
        "spindle 1 never started"
    );
    let first = dry_run(
        b"G18 G90 G95\nSETMS(2)\nS1000 M3\nG1 Z-10 F0.1\nM30\n",
        &Config::default(),
    );
    assert!((first.time_min - 0.1).abs() < 1e-6, "{}", first.time_min);
    // A chamfer or rounding at the corner leaves the points where they are.
    let chamfer = "G18 G90 G95\nSETMS(4)\nS4=1000 M4=3\nG1 Z-10 F0.1 CHR=0.5\nX20 RND=1\nM30\n";
    dry_run(chamfer.as_bytes(), &Config::default());
    for program in [
        "fixtures/shop8/01_dmg_ctx_main_spindle_tc1.mpf",
        "fixtures/shop8/15_dmg_ctx_counter_spindle_setms3.mpf",
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(program);
        transformed_and_audited_with(dir.path(), &path.display().to_string(), "grinder-gauge");
    }
}

/// A dry run of `src` as `p.mpf` beside `files` in a new folder.
fn dry_run_beside(src: &str, files: &[(&str, &str)]) -> Run {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    run_source(
        "p.mpf",
        src.as_bytes(),
        Some(dir.path()),
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap_or_else(|e| panic!("the dry run stopped: {e}"))
}

#[test]
fn mcall_runs_its_subprogram_after_each_move_of_the_program_that_set_it() {
    // `MCALL DRILL` runs DRILL after every later block of this program that moves (not after the moves of
    // DRILL itself), with `$P_MC` = 1 inside it, until `MCALL` alone. Before, the dry run skipped modal
    // calls: a subprogram's state after them was not the machine's (its feed, say) and the audit compared
    // gates against a run that never drilled.
    let drill = "IF $P_MC<>1\nSETAL(65010)\nENDIF\nG1 Z-3 F100\nG0 Z5\nM17\n";
    let program = |construct: &str| {
        format!(
            "G17 G90 G94 G54\nT=\"DR\" M6\nD1\nS3000 M3\nG0 X0 Y0 Z5\n{construct}G0 X30 Y30\nG0 Z50\nM30\n"
        )
    };
    let plain = dry_run_beside(&program(""), &[("DRILL.SPF", drill)]);
    let modal = dry_run_beside(
        &program("MCALL DRILL\nX10\nX20 Y10\nMCALL\n"),
        &[("DRILL.SPF", drill)],
    );
    assert!(modal.alarms.is_empty(), "{:?}", modal.alarms);
    // Four blocks of the program's own, and DRILL's four (IF, G1, G0, M17: the IF jumps past SETAL and
    // ENDIF) after each of its two moves.
    assert_eq!(modal.blocks_executed, plain.blocks_executed + 4 + 2 * 4);
    // Outside a modal call `$P_MC` is 0.
    let direct = dry_run_beside(&program("DRILL\n"), &[("DRILL.SPF", drill)]);
    assert_eq!(
        direct.alarms.iter().map(|a| a.number).collect::<Vec<_>>(),
        [65010]
    );
}

#[test]
fn tc_tp2_names_a_tool_the_program_selected_by_name() {
    // A gate that finds no tool named where it stands reads `$P_TOOLNO` and loads `$TC_TP2[that]` again
    // after the probe: the dry run stopped there ("expected a number, found the string …") unless the
    // machine file named the start tool.
    let src = "G17 G90 G54\nT=\"EM10\" M6\nD1\nR1=$P_TOOLNO\nT=\"PROBE\" M6\n\
               IF $TC_TP2[R1]<>\"EM10\"\nSETAL(65010)\nENDIF\nT=$TC_TP2[R1] M6\nM30\n";
    let run = dry_run(src.as_bytes(), &Config::default());
    assert!(run.alarms.is_empty(), "{:?}", run.alarms);
}

#[test]
fn a_tool_change_subprogram_after_a_gate_is_judged_at_its_return() {
    // A gate before the program's own tool change (here its `L6`) leaves the probe in the spindle with the
    // program's next tool preselected; the change inside `L6` loads that tool from wherever the gate left
    // the machine. The audit compared the states at the call and found the probe "in the spindle where the
    // original resumes". A call that changes no tool is still judged at its first block that acts: a gate
    // that left G91 before a part subprogram moving without G90 is found.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("L6.SPF"),
        "G0 G153 Z0 D0\nM5\nM9\nM6\nM17\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("PART.SPF"), "X10 Y10\nG90 G0 Z50\nM17\n").unwrap();
    let original = "G17 G90 G94 G54\nT=\"MILL\"\nL6\nD1\nS3000 M3 M8\nG0 X0 Y0 Z5\nG1 Z-1 F200\n\
                    G1 X50\nG0 Z50\nT=\"DRILL\"\nL6\nD1\nS2000 M3\nG0 X10 Y10 Z5\nG1 Z-5 F100\n\
                    G0 Z50\nM30\n";
    let gate = [
        "M5",
        "M9",
        "T=\"PROBE\"",
        "L6",
        "D1",
        "G0 Z100",
        "G0 X0 Y0",
        "T=\"DRILL\"",
    ];
    let mut settings = AuditSettings::from_profile(&Profile::default_profile());
    settings.dir = Some(dir.path().to_path_buf());
    common::assert_audit_clean(original, &planted_after(original, 10, &gate), &settings);
    let part = original.replace("T=\"DRILL\"\nL6\n", "PART\nT=\"DRILL\"\nL6\n");
    let found = audited(&part, &planted_after(&part, 9, &["G91"]), Some(dir.path()));
    assert!(
        found
            .findings
            .iter()
            .any(|f| f.kind == Kind::ModalNotRestored && f.message.contains("G91")),
        "{:#?}",
        found.findings
    );
}
