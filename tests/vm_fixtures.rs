//! Hand-written fixtures in fixtures/vm/: control structures, jumps, subprograms, frames, timing, and the
//! measurement module's validity logic against a fake probe.

use std::path::Path;

use driftloop::vm::{
    Config, End, ProbeFault, Run, SimpleMachine, SpindleHistory, run_file, run_source,
};

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new("fixtures/vm").join(name)
}

fn run(name: &str, cfg: &Config, machine: &mut SimpleMachine) -> Run {
    run_file(&fixture(name), cfg, machine).unwrap_or_else(|e| panic!("{e}"))
}

/// A program given as text, on a machine that does not drift.
fn run_text(src: &str) -> Run {
    run_source(
        "t.mpf",
        src.as_bytes(),
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap()
}

fn last_machine(run: &Run) -> Vec<f64> {
    run.trace.last().unwrap().machine[..3].to_vec()
}

fn messages(run: &Run) -> Vec<&str> {
    run.messages.iter().map(|m| m.text.as_str()).collect()
}

#[test]
fn loops_case_and_int_rounding() {
    let r = run("loops.mpf", &Config::default(), &mut SimpleMachine::cold());
    assert_eq!(
        messages(&r),
        ["four", "rounded", "SUM=55 I=-1 J=4 A=4.5"],
        "FOR sums 1..10, WHILE counts to 5, REPEAT steps to -1, LOOP leaves at 4, 7/2 rounds to INT 4"
    );
    assert_eq!(last_machine(&r), [55.0, -1.0, 4.0]);
    assert_eq!(r.end, End::ProgramEnd { code: "M30".into() });
}

#[test]
fn jumps_search_in_their_direction() {
    let r = run("jumps.mpf", &Config::default(), &mut SimpleMachine::cold());
    assert_eq!(last_machine(&r)[..2], [3.0, 1.0]);
    let lines: Vec<usize> = r.trace.iter().map(|t| t.line).collect();
    for skipped in [5, 9, 14] {
        assert!(
            !lines.contains(&skipped),
            "line {skipped} must be jumped over: {lines:?}"
        );
    }
    assert_eq!(
        lines.iter().filter(|&&l| l == 6).count(),
        3,
        "TWICE runs three times"
    );
}

/// A label defined twice: each jump lands on the nearest one in its direction, in the dry run as in the
/// structure check (both resolve through `structure::Targets`).
#[test]
fn duplicate_labels_take_the_nearest_in_the_search_direction() {
    let src = b"N10 R1=0 R2=0 R3=0
TOP: R1=R1+1          ; the first TOP
N20 GOTOF TOP         ; the next TOP, not the one before
N30 R2=100
TOP: R2=R2+1          ; the second TOP
N40 IF R2<3 GOTOB TOP ; the nearest TOP before: the second (R1 stays 1)
N50 GOTO MID          ; forward first
MID: R3=R3+1
N60 IF R3==1 GOTOB MID
N70 GOTOF END_
MID: R3=100
END_: X=R1 Y=R2 Z=R3
M30
";
    let program = driftloop::parse(src);
    assert!(!program.has_errors(), "labels defined twice are no error");
    let checked: Vec<(usize, Option<usize>)> = driftloop::analyze(&program)
        .jumps
        .iter()
        .map(|j| (j.from, j.to))
        .collect();
    assert_eq!(
        checked,
        vec![
            (2, Some(4)),
            (5, Some(4)),
            (6, Some(7)),
            (8, Some(7)),
            (9, Some(11))
        ]
    );
    let r = run_source(
        "dup.mpf",
        src,
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(last_machine(&r), [1.0, 3.0, 2.0]);
    let lines: Vec<usize> = r.trace.iter().map(|t| t.line).collect();
    assert!(!lines.contains(&4) && !lines.contains(&11), "{lines:?}");
}

#[test]
fn a_jump_without_a_target_in_its_direction_stops_with_alarm_14080() {
    let src = b"AHEAD: X1\nGOTOF AHEAD\nM30\n";
    let program = driftloop::parse(src);
    assert_eq!(
        program.diagnostics()[0].message,
        "GOTOF searches forward, but AHEAD is on line 1"
    );
    let err = run_source(
        "miss.mpf",
        src,
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .expect_err("the dry run stops");
    assert_eq!(err.line, 2);
    assert!(err.message.contains("alarm 14080"), "{err}");
}

#[test]
fn subprograms_with_parameters_repetitions_save_and_var() {
    let r = run(
        "subprograms.mpf",
        &Config::default(),
        &mut SimpleMachine::cold(),
    );
    assert_eq!(last_machine(&r), [10.5, 3.0, 1.0]);
    assert_eq!(
        r.trace.last().unwrap().machine[3],
        7.0,
        "VAR parameters doubled R30 and Q"
    );
    let l100 = r
        .trace
        .iter()
        .filter(|t| &*t.file == "L100.spf" && t.line == 3)
        .count();
    assert_eq!(l100, 3, "L100 P3 runs the subprogram three times");
}

#[test]
fn settable_frames_act_when_selected_and_trans_replaces_atrans_adds() {
    let cfg = Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        ..Config::default()
    };
    let r = run("frames.mpf", &cfg, &mut SimpleMachine::cold());
    let at = |line: usize| {
        r.trace
            .iter()
            .find(|t| t.line == line)
            .unwrap()
            .machine
            .clone()
    };
    assert_eq!(at(3)[2], 10.0);
    assert_eq!(at(5)[2], -90.0);
    assert_eq!(
        at(7)[2],
        -95.0,
        "the written frame is not active before G54 is selected again"
    );
    assert!((at(9)[2] + 94.98).abs() < 1e-9);
    assert_eq!(at(12)[0], 110.0);
    assert_eq!(at(14)[0], 115.0);
    assert_eq!(at(16)[0], 10.0);
    assert_eq!(r.corrections.len(), 1);
    assert!((r.corrections[0].new_mm - r.corrections[0].old_mm - 0.02).abs() < 1e-12);
}

#[test]
fn time_follows_path_length_feed_rapid_dwell_and_tool_change() {
    let r = run("timing.mpf", &Config::default(), &mut SimpleMachine::cold());
    let expected =
        100.0 / 10_000.0 + 100.0 / 1000.0 + 50.0 * std::f64::consts::PI / 500.0 + 0.5 + 0.1;
    assert!(
        (r.time_min - expected).abs() < 1e-9,
        "{} vs {expected}",
        r.time_min
    );
}

#[test]
fn unsupported_constructs_and_runaway_loops_name_the_line() {
    let cfg = Config::default();
    let err = |src: &str, cfg: &Config| {
        run_source(
            "t.mpf",
            src.as_bytes(),
            None,
            cfg,
            &mut SimpleMachine::cold(),
        )
        .unwrap_err()
    };
    let e = err("G1 X1 F100\nG33 Z-5 K1\n", &cfg);
    assert_eq!((e.line, e.file.as_str()), (2, "t.mpf"));
    assert!(e.message.contains("G33"), "{e}");
    let e = err("ROT A45\n", &cfg);
    assert!(e.to_string().starts_with("t.mpf:1: ROT"), "{e}");
    let e = err("R1=1\nGOTOF NOWHERE\n", &cfg);
    assert!(e.message.contains("14080") && e.line == 2, "{e}");
    let e = err("G1 X10\n", &cfg);
    assert!(e.message.contains("feed"), "{e}");
    let e = err("X=UNDECLARED\n", &cfg);
    assert!(e.message.contains("UNDECLARED"), "{e}");
    let e = err("N10 MYCYCLE(1)\n", &cfg);
    assert!(e.message.contains("MYCYCLE"), "{e}");
    let limited = Config {
        max_blocks: 1000,
        ..Config::default()
    };
    let e = err("LBL: R1=R1+1\nGOTOB LBL\n", &limited);
    assert!(e.message.contains("1002 executed blocks (1000 more"), "{e}");
}

// ---- the measurement module against a fake probe ----

/// A spindle-driven first-order lag: the drift of Z approaches `um_per_krpm · rpm / 1000` with time constant
/// `tau_min`, exactly integrated over the piecewise-constant spindle history.
fn lag(um_per_krpm: f64, tau_min: f64) -> impl FnMut(&str, f64, &SpindleHistory) -> f64 {
    move |axis, t, spindle| {
        if axis != "Z" {
            return 0.0;
        }
        spindle.intervals(t).fold(0.0, |x, (a, b, rpm)| {
            let target = um_per_krpm * rpm / 1000.0;
            target + (x - target) * (-(b - a) / tau_min).exp()
        })
    }
}

fn omm_config() -> Config {
    Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        probe_surface_mm: -100.0,
        ..Config::default()
    }
}

fn omm(machine: &mut SimpleMachine) -> Run {
    run("omm/omm_main.mpf", &omm_config(), machine)
}

#[test]
fn valid_measurements_correct_the_work_offset() {
    let r = omm(&mut SimpleMachine::with_drift(lag(8.0, 30.0)));
    assert_eq!(r.end, End::ProgramEnd { code: "M30".into() });
    assert!(r.alarms.is_empty());
    assert_eq!(
        r.measurements.len(),
        6,
        "zero and one measurement, three agreeing values each"
    );
    assert_eq!(r.corrections.len(), 1);
    let c = &r.corrections[0];
    let seen = r.measurements[4].true_drift_um - r.measurements[1].true_drift_um;
    assert!(
        ((c.new_mm - c.old_mm) * 1000.0 - seen).abs() < 0.2,
        "correction cancels the drift seen"
    );
    assert_eq!(r.passes.len(), 2);
    let uncorrected = r.passes[1].drift_um;
    assert!(uncorrected > 10.0, "the machine did heat: {uncorrected}");
    assert!((r.totals.max_abs_drift_um - uncorrected).abs() < 1e-12);
    assert!(r.passes[1].error_um.abs() < 1.0, "{:?}", r.passes[1]);
    assert_eq!(r.files["DL_LOG"].lines().count(), 6);
}

#[test]
fn implausible_values_are_repeated_and_never_reach_the_correction() {
    let mut m = SimpleMachine::with_drift(lag(8.0, 30.0))
        .fault(2, ProbeFault::Garbage)
        .fault(5, ProbeFault::Nan)
        .fault(6, ProbeFault::Nothing);
    let r = omm(&mut m);
    assert!(r.alarms.is_empty());
    assert_eq!(r.measurements.len(), 9, "each bad value is repeated");
    assert_eq!(
        r.files["DL_LOG"].lines().count(),
        6,
        "only valid values are logged"
    );
    let c = &r.corrections[0];
    assert!(
        (c.new_mm - c.old_mm).abs() < 0.05,
        "no garbage in the correction: {c:?}"
    );
    assert!(r.passes[1].error_um.abs() < 1.0);
}

#[test]
fn too_few_valid_values_stop_with_an_alarm_and_no_correction() {
    let mut m = SimpleMachine::with_drift(lag(8.0, 30.0));
    for call in 4..=8 {
        m = m.fault(call, ProbeFault::Garbage);
    }
    let r = omm(&mut m);
    assert_eq!(r.end, End::Alarm { number: 65001 });
    assert_eq!(r.measurements.len(), 8, "five attempts, then the stop");
    assert!(r.corrections.is_empty());
    assert_eq!(r.passes.len(), 1, "the finishing pass is not cut");
    assert!(messages(&r)[0].starts_with("PROBE: fewer than 3"));
}

#[test]
fn drift_beyond_the_tolerance_stops_as_scrap() {
    let r = omm(&mut SimpleMachine::with_drift(lag(20.0, 10.0)));
    assert_eq!(r.end, End::Alarm { number: 65002 });
    assert!(r.corrections.is_empty());
    let msg = messages(&r)[0];
    assert!(
        msg.starts_with("SCRAP: drift 6") && msg.ends_with("before pass 2"),
        "{msg}"
    );
}

#[test]
fn probe_noise_is_reproducible_per_seed() {
    let values = |seed| {
        let mut m = SimpleMachine::with_drift(lag(8.0, 30.0)).noise(0.5, seed);
        omm(&mut m)
            .measurements
            .iter()
            .map(|m| m.value_mm)
            .collect::<Vec<f64>>()
    };
    assert_eq!(values(3), values(3));
    assert_ne!(values(3), values(4));
}

#[test]
fn human_report_snapshot() {
    let r = omm(&mut SimpleMachine::with_drift(lag(8.0, 30.0)));
    insta::assert_snapshot!(r.human());
}

#[test]
fn uncompensated_stepped_surface_is_cut_off_by_the_true_drift() {
    let text = std::fs::read_to_string("fixtures/vm/machines/model_truth.toml").unwrap();
    let (cfg, spec) = driftloop::vm::parse_machine_file(
        &text,
        Path::new("fixtures/vm/machines"),
        Config::default(),
    )
    .unwrap();
    let r = run("stepped_surface.mpf", &cfg, &mut spec.build(1));
    let z: Vec<f64> = r.passes.iter().map(|p| p.nominal_z_mm).collect();
    assert_eq!(z, [0.0, -0.5, -1.0, -1.5, -2.0, -2.5]);
    let on = r.spindle.steps.iter().find(|s| s.1 == 4000.0).unwrap().0;
    // The truth of model_truth.toml: two lags at 4000 rpm (14 µm, 12 min; 26 µm, 95 min) + 2 µm / 240 min.
    let truth = |t: f64| {
        14.0 * (1.0 - (-(t - on) / 12.0).exp())
            + 26.0 * (1.0 - (-(t - on) / 95.0).exp())
            + 2.0 * t / 240.0
    };
    for p in &r.passes {
        let mid = (p.start_min + p.end_min) / 2.0;
        assert!(
            (p.error_um - truth(mid)).abs() < 0.1,
            "{p:?} vs {}",
            truth(mid)
        );
    }
    let last = &r.passes[5];
    assert!((239.0..242.0).contains(&last.start_min), "{last:?}");
    let flat = run("stepped_surface_flat.mpf", &cfg, &mut spec.build(1));
    assert_eq!(flat.passes.len(), 6);
    for (a, b) in r.passes.iter().zip(&flat.passes) {
        assert_eq!((a.nominal_z_mm, a.start_min), (b.nominal_z_mm, b.start_min));
        assert!(
            (a.error_um - b.error_um).abs() < 1e-12,
            "the unrolled program cuts the same"
        );
    }
    assert!((r.totals.max_abs_error_um - last.error_um).abs() < 1e-12);
    assert!(r.totals.rms_error_um < r.totals.max_abs_error_um);
}

#[test]
fn section_repetitions() {
    let r = run(
        "sections.mpf",
        &Config::default(),
        &mut SimpleMachine::cold(),
    );
    assert_eq!(last_machine(&r), [3.0, 600.0, 5.0]);
}

#[test]
fn functions_and_string_conversion() {
    let src = br#"DEF STRING[20] S = "12.5"
DEF CHAR C = "A"
MSG(ROUND(2.5) << " " << TRUNC(-2.7) << " " << MINVAL(3, -1) << " " << MAXVAL(3, -1) << " " << BOUND(0, 10, 12))
MSG(POT(2, 3) << " " << POT(3) << " " << STRLEN(S) << " " << NUMBER(S) * 2 << " " << ATAN2(1, 1) << " " << ABS(-4))
MSG(TOUPPER("ab") << (C == "A") << EXP(0) << LN(1) << SQRT(16) << " " << 'H1F' << " " << 'B101' << " " << 5 B_XOR 1)
M30
"#;
    let r = run_source(
        "f.mpf",
        src,
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap();
    assert_eq!(
        messages(&r),
        ["3 -2 -1 3 10", "8 9 4 25 45 4", "AB1104 31 5 4"]
    );
    let e = run_source(
        "f.mpf",
        b"R1 = SQRT(-1)\n",
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    );
    assert!(e.unwrap_err().message.contains("SQRT"));
}

#[test]
fn ambient_signal_drives_the_truth_and_is_readable_as_an_analog_input() {
    let text = std::fs::read_to_string("fixtures/vm/machines/ambient_machine.toml").unwrap();
    let dir = Path::new("fixtures/vm/machines");
    let (cfg, spec) = driftloop::vm::parse_machine_file(&text, dir, Config::default()).unwrap();
    // Spindle stopped: only the ambient term acts.
    let src = b"G54\nG4 F3600\nMSG(\"T=\" << $A_INA[1])\nBL9700()\nM30\n";
    let r = run_source("a.mpf", src, None, &cfg, &mut spec.build(1)).unwrap();
    assert_eq!(
        messages(&r),
        ["T=22"],
        "the sensor reads the signal at 60 min"
    );
    let m = &r.measurements[0];
    assert!((m.at.time_min - 60.0).abs() < 1e-9);
    // u(t) = 20 + t/30 °C: the lag of a ramp, 2 µm/°C · (1/30)·(t − τ(1 − e^(−t/τ))), sampled per minute.
    let tau: f64 = 30.0;
    let ramp = 2.0 / 30.0 * (60.0 - tau * (1.0 - (-60.0 / tau).exp()));
    assert!(
        (m.true_drift_um - ramp).abs() < 0.05,
        "{} vs {ramp}",
        m.true_drift_um
    );
    let e = run_source("a.mpf", b"R1 = $A_INA[2]\n", None, &cfg, &mut spec.build(1));
    assert!(e.unwrap_err().message.contains("$A_INA[2]"));
}

#[test]
fn probe_result_in_the_measuring_cycle_array() {
    let cfg = Config {
        probe_result: driftloop::vm::ProbeTarget::Array("_OVR".into(), 4),
        ..Config::default()
    };
    let src =
        b"G4 F60\nCYCLE978(100,10001,,1,0,1,3)\nR1 = _OVR[4] * 1000\nMSG(\"R1=\" << R1)\nM30\n";
    let mut m = SimpleMachine::with_drift(|_, t, _| 2.0 * t);
    let r = run_source("c.mpf", src, None, &cfg, &mut m).unwrap();
    assert_eq!(
        messages(&r),
        ["R1=2"],
        "surface 0 + 2 µm of drift after 1 min, in mm × 1000"
    );
    assert_eq!(r.measurements[0].value_mm, 0.002);
}

#[test]
fn splines_are_timed_along_their_programmed_points() {
    let src = b"G90 G94 F600\nBSPLINE SD=3 X30 Y40 PW=2\nX30 Y0\nG1 X0 Y0\nM30\n";
    let r = run_source(
        "s.mpf",
        src,
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap();
    assert!(
        (r.time_min - (50.0 + 40.0 + 30.0) / 600.0).abs() < 1e-12,
        "{}",
        r.time_min
    );
    assert_eq!(last_machine(&r), [0.0, 0.0, 0.0]);
}

#[test]
fn archive_units_call_each_other() {
    let r = run(
        "archive.arc",
        &Config::default(),
        &mut SimpleMachine::cold(),
    );
    assert_eq!(last_machine(&r)[0], 12.0, "SUB_A twice: 5 + 0, then 5 + 2");
    let sub_rows = r
        .trace
        .iter()
        .filter(|t| t.file.ends_with("[SUB_A]"))
        .count();
    assert_eq!(
        sub_rows,
        2 * 4,
        "$PATH, PROC, R1=…, M17 per call; the header is not run"
    );
    assert_eq!(r.end, End::ProgramEnd { code: "M30".into() });
}

#[test]
fn feed_per_revolution_other_planes_and_inch() {
    let time = |src: &str| run_text(src).time_min;
    // G95: 0.1 mm/rev at 1000 rpm = 100 mm/min.
    assert!((time("S1000 M3\nG95 G1 X10 F0.1\nM30\n") - 0.1).abs() < 1e-12);
    // G18 half circle in Z-X around centre I10 (X) K0 (Z): radius 10.
    let half = std::f64::consts::PI * 10.0 / 1000.0;
    assert!((time("G18 G94 G2 X20 Z0 I10 K0 F1000\nM30\n") - half).abs() < 1e-12);
    // G700: 10 inch at 10 inch/min is one minute whatever the unit.
    assert!((time("G700 G94 G1 X10 F10\nM30\n") - 1.0).abs() < 1e-12);
    // G70: lengths in inch, feed in mm/min: 254 mm at 254 mm/min.
    assert!((time("G70 G94 G1 X10 F254\nM30\n") - 1.0).abs() < 1e-12);
    let e = run_source(
        "t.mpf",
        b"G95 G1 X10 F0.1\n",
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    );
    assert!(e.unwrap_err().message.contains("G95"));
}

#[test]
fn auxiliary_functions_are_counted_not_skipped() {
    let src = b"M8 H2 H=3\nG=1 X10 F100 M101\nH2\nM30\n";
    let r = run_source(
        "a.mpf",
        src,
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap();
    let aux: Vec<(&str, u64)> = r
        .aux_functions
        .iter()
        .map(|(k, n)| (k.as_str(), *n))
        .collect();
    assert_eq!(aux, [("H2", 2), ("H3", 1), ("M101", 1), ("M8", 1)]);
    assert!(
        (r.time_min - 0.1).abs() < 1e-12,
        "G=1 selects linear interpolation"
    );
}

// Rotation, scale and mirror of the programmable frame place the geometry axes; inverse-time feed times a
// block by its F; swivel cycles and transformations run (recorded, not modelled).

fn assert_near(got: Vec<f64>, want: [f64; 3]) {
    for k in 0..3 {
        assert!((got[k] - want[k]).abs() < 1e-9, "{got:?} vs {want:?}");
    }
}

/// Each program's machine X, Y, Z after its last block.
fn assert_placed(cases: &[(&str, [f64; 3])]) {
    for (src, want) in cases {
        assert_near(last_machine(&run_text(src)), *want);
    }
}

#[test]
fn rot_turns_the_programmed_contour_about_the_origin() {
    assert_placed(&[
        ("ROT Z90\nG0 X10 Y0 Z5\n", [0.0, 10.0, 5.0]),
        // RPL turns in the working plane: G18 turns about Y, from Z towards X.
        ("G18\nROT RPL=90\nG0 X0 Y0 Z10\n", [10.0, 0.0, 0.0]),
        // TRANS first, then the rotation about the shifted origin; ATRANS after it shifts along the turned axis.
        ("TRANS X100\nAROT Z90\nG0 X10 Y0 Z0\n", [100.0, 10.0, 0.0]),
        ("ROT Z90\nATRANS X5\nG0 X0 Y0 Z0\n", [0.0, 5.0, 0.0]),
        // RPY: Z first, then the new Y. X programmed lands on -Z after Z90 then Y90.
        ("ROT Z90 Y90\nG0 X10 Y0 Z0\n", [0.0, 0.0, -10.0]),
        // A bare ROT deletes the programmable frame.
        ("ROT Z90\nROT\nG0 X10 Y0 Z0\n", [10.0, 0.0, 0.0]),
    ]);
}

#[test]
fn scale_and_mirror_act_on_their_axes_and_chain() {
    assert_placed(&[
        ("SCALE X2 Y3\nG0 X1 Y1 Z1\n", [2.0, 3.0, 1.0]),
        ("MIRROR X0\nG0 X4 Y1 Z1\n", [-4.0, 1.0, 1.0]),
        ("MIRROR X0\nAMIRROR X0\nG0 X4 Y1 Z1\n", [4.0, 1.0, 1.0]),
        // ATRANS after SCALE is scaled too.
        ("SCALE X2\nATRANS X5\nG0 X0 Y0 Z0\n", [10.0, 0.0, 0.0]),
    ]);
}

#[test]
fn inverse_time_feed_takes_one_over_f_minutes() {
    let r = run_text("G93 G1 X100 F4\nG1 X0 F0.5\n");
    assert!((r.time_min - 2.25).abs() < 1e-9, "{}", r.time_min);
}

#[test]
fn swivels_and_transformations_run() {
    let r = run_text(
        "CYCLE800(1,\"TC1\",0,57,0,0,0,30,0,0,0,0,0,-1,100,1)\nG0 X1\nCYCLE800()\nTRAORI\nG0 X2\nTRAFOOF\nTRACYL(40)\nTRAFOOF\nTRANSMIT\nTRAFOOF\n",
    );
    assert_eq!(r.trace.len(), 10);
}

#[test]
fn a_turret_loads_with_t_and_the_probe_reports_in_its_frame() {
    let run_with = |cfg: &Config, src: &str| {
        let mut machine = SimpleMachine::with_drift(|_, _, _| 10.0);
        let r = run_source("t.mpf", src.as_bytes(), None, cfg, &mut machine).unwrap();
        messages(&r)
            .iter()
            .map(|m| m.to_string())
            .collect::<Vec<_>>()
    };
    let tools = "T3\nMSG(\"\"<<$P_TOOLNO)\nM6\nMSG(\"\"<<$P_TOOLNO)\n";
    assert_eq!(run_with(&Config::default(), tools), ["0", "3"], "M6 loads");
    let turret = Config {
        tool_change_on_t: true,
        ..Config::default()
    };
    assert_eq!(run_with(&turret, tools), ["3", "3"], "T loads at once");

    let probe = "G54\nBL9700(1)\nMSG(\"\"<<R2)\n";
    let at = |machine_frame, diameter| Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        probe_surface_mm: -50.0,
        probe_machine_frame: machine_frame,
        probe_diameter: diameter,
        ..Config::default()
    };
    // Work coordinates: the surface less the offset; machine coordinates: the surface; a diameter: twice the
    // drift of 10 µm.
    assert_eq!(run_with(&at(false, false), probe), ["50.01"]);
    assert_eq!(run_with(&at(true, false), probe), ["-49.99"]);
    assert_eq!(run_with(&at(true, true), probe), ["-49.98"]);
}
