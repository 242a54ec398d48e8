//! What QA round 7 found in the gates the run-time tool read admitted (`[probe] unknown_tool = "runtime"`):
//! programs that never carried a spindle-probe gate before (fixtures/shop7, its README lists them), each
//! through the binary.

mod common;

/// fixtures/shop7/`name` transformed with `profile`: the run (a refusal's message in its stderr) and the
/// output when one was written.
fn transform_fixture(name: &str, profile: &str) -> (std::process::Output, Option<String>) {
    let prog = std::fs::read_to_string(common::fixture(&format!("shop7/{name}"))).unwrap();
    let (o, dir) = common::transform_in(&[("p.mpf", &prog)], "p.mpf", profile);
    let out = std::fs::read_to_string(dir.path().join("out.mpf")).ok();
    (o, out)
}

/// `name` is refused with `profile`, and the message says `why`.
fn refused_because(name: &str, profile: &str, why: &str) {
    let (o, out) = transform_fixture(name, profile);
    assert_eq!(o.status.code(), Some(2), "{name} {profile}: {out:?}");
    let err = common::stderr(&o);
    assert!(err.contains(why), "{name} {profile}: {err}");
}

/// A machine that does not drift, with T3 (`EM_D80`, D1) in force at the start.
const TOOL_LOADED: &str = "[tool]\nnumber = 3\nname = \"EM_D80\"\nd = 1\n";

/// The same machine with the spindle turning as the operator started it in MDA (`S2000 M3`).
fn mda_spindle() -> String {
    format!("{TOOL_LOADED}[spindle]\nrpm = 2000\ndirection = 3\n")
}

/// The speed of each pass the run cut (rpm).
fn pass_speeds(run: &driftloop::vm::Run) -> Vec<f64> {
    run.passes.iter().map(|p| p.spindle_rpm).collect()
}

/// `out`, transformed from `original`, run with the operator's spindle turning (`S2000 M3` in MDA): no
/// measurement, no M5, every pass at that speed as in the original; and with it standing: measured (no
/// speed given back: there was none).
fn measures_only_where_the_spindle_stands(
    profile: &str,
    files: &[(&str, String)],
    original: &str,
    out: &str,
) {
    let plain = common::run_on_machine(&mda_spindle(), files, original);
    let turning = common::run_on_machine(&mda_spindle(), files, out);
    assert!(
        matches!(turning.end, driftloop::vm::End::ProgramEnd { .. }),
        "{profile}: {:?}",
        turning.end
    );
    assert!(turning.alarms.is_empty(), "{profile}: {:?}", turning.alarms);
    assert!(turning.measurements.is_empty(), "{profile}: measured");
    assert_eq!(pass_speeds(&turning), pass_speeds(&plain), "{profile}");
    assert!(!plain.passes.is_empty() && pass_speeds(&turning).iter().all(|&n| n == 2000.0));
    let standing = common::run_on_machine(TOOL_LOADED, files, out);
    assert!(!standing.measurements.is_empty(), "{profile}: not measured");
}

#[test]
fn a_gate_before_the_programs_spindle_measures_only_where_the_spindle_stands() {
    // 01: the program has no S/M3 (the operator started the spindle in MDA). The zero's `M5` stopped it for
    // the probe and nothing started it again: N40 `G1 Z-0.5 F600` fed the cutter into the part standing
    // still. Now the zero reads the actual speed after its STOPRE and goes around the probe where the
    // spindle turns.
    let prog = std::fs::read_to_string(common::fixture("shop7/01_mda_spindle_face.mpf")).unwrap();
    for profile in common::MILLING_PROFILES {
        let (o, out) = transform_fixture("01_mda_spindle_face.mpf", profile);
        let out = out.unwrap_or_else(|| panic!("{profile}: {}", common::stderr(&o)));
        let check = out.find("$AA_S[1]<>0").expect("the spindle check");
        assert!(check < out.find("N40 ").unwrap(), "{profile}: {out}");
        assert!(out[..check].contains("STOPRE"), "{profile}: {out}");
        let first_m5 = out
            .find("M5 ;DL")
            .expect("the gate stops a standing spindle");
        assert!(check < first_m5, "{profile}: {out}");
        // The tool setters' cycles are the profile's own, which the dry run knows only in the transform's
        // audit (it ran with the spindle turning there too, or nothing was written).
        if !profile.starts_with("blum") && !profile.starts_with("siemens") {
            continue;
        }
        measures_only_where_the_spindle_stands(profile, &[], &prog, &out);
    }
    // A gauge moves nothing and stops nothing: no check.
    let (o, out) = transform_fixture("01_mda_spindle_face.mpf", "grinder-gauge");
    assert!(o.status.success(), "{}", common::stderr(&o));
    assert!(!out.unwrap().contains("$AA_S"));
}

/// A face whose cuts are in a shop subprogram that is not beside the program when it is transformed.
const SHOP_SUB_MAIN: &str = "; FACING IN A SHOP SUBPROGRAM - SPINDLE STARTED IN MDA\nN10 G17 G90 G94 G71\n\
N20 G54 D1\nN30 G0 X-50 Y0 Z20\nN40 FACE_PASS\nN50 G0 Z100\nN60 M30\n";
const SHOP_SUB: &str = "PROC FACE_PASS\nG1 Z-0.5 F600\nX250 F1600\nY60\nX-50\nG0 Z20\nRET\n";

#[test]
fn a_shop_subprogram_that_cuts_with_the_operators_spindle_gets_no_gate_that_stops_it() {
    // The first cut is a call of a shop subprogram with no spindle word. Unread, it is refused (no zero
    // before a call that may set up the tool, QA round 8); read from beside the program, the zero before
    // it checks the operator's spindle at run time, and FACE_PASS cuts at the speed the operator set.
    let sub = [("FACE_PASS.SPF", SHOP_SUB.to_string())];
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let (o, _) = common::transform_in(&[("p.mpf", SHOP_SUB_MAIN)], "p.mpf", profile);
        assert_eq!(o.status.code(), Some(2), "{profile}");
        assert!(common::stderr(&o).contains("FACE_PASS"), "{profile}");
        let (o, dir) = common::transform_in(
            &[("p.mpf", SHOP_SUB_MAIN), ("FACE_PASS.SPF", SHOP_SUB)],
            "p.mpf",
            profile,
        );
        assert!(o.status.success(), "{profile}: {}", common::stderr(&o));
        let out = std::fs::read_to_string(dir.path().join("out.mpf")).unwrap();
        let check = out.find("$AA_S[1]<>0").expect("the spindle check");
        assert!(
            check < out.find("N40 FACE_PASS").unwrap(),
            "{profile}: {out}"
        );
        measures_only_where_the_spindle_stands(profile, &sub, SHOP_SUB_MAIN, &out);
    }
}

#[test]
fn a_gate_without_the_spindle_check_is_caught_with_a_turning_start_spindle() {
    // The same output with the check taken out stops the operator's spindle for good: on the machine the
    // passes are cut with a standing spindle, and `run --audit` on a machine whose spindle turns at the
    // start finds it.
    let (o, out) = transform_fixture("01_mda_spindle_face.mpf", "blum-tc50");
    let out = out.unwrap_or_else(|| panic!("{}", common::stderr(&o)));
    let planted = out.replace(" OR ($AA_S[1]<>0)", "");
    assert_ne!(planted, out, "the check as written");
    let run = common::run_on_machine(&mda_spindle(), &[], &planted);
    assert!(!run.measurements.is_empty());
    assert!(
        pass_speeds(&run).iter().all(|&n| n == 0.0),
        "{:?}",
        pass_speeds(&run)
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.toml"), mda_spindle()).unwrap();
    // Both report the profile's probe point in the cut (a warning: exit 1); only the planted gate leaves
    // the spindle stopped where the original resumes.
    for (name, text, clean) in [("planted.mpf", &planted, false), ("out.mpf", &out, true)] {
        std::fs::write(dir.path().join(name), text).unwrap();
        let args = [
            "run",
            name,
            "--machine",
            "m.toml",
            "--audit",
            "--profile",
            "blum-tc50",
        ];
        let o = common::driftloop(dir.path(), &args, b"");
        let report = String::from_utf8_lossy(&o.stdout);
        let stopped = "modal-not-restored: where the original resumes: spindle S2000 M5 here, S2000 M3 in the original";
        assert_eq!(
            report.contains(stopped),
            !clean,
            "{name}: {report}{}",
            common::stderr(&o)
        );
    }
}

#[test]
fn a_program_that_starts_its_spindle_itself_keeps_its_gates() {
    // 04: the same job with `S2000 M3 M8` of its own: a gate may stop the spindle, since it gives back the
    // program's speed, direction and coolant after the tool comes back.
    let (o, out) = transform_fixture("04_single_tool_sets_spindle.mpf", "blum-tc50");
    let out = out.unwrap_or_else(|| panic!("{}", common::stderr(&o)));
    assert!(out.contains("R79=$P_TOOLNO ;DL"), "{out}");
    let back = out
        .rfind("T=$TC_TP2[R79] M6 ;DL")
        .expect("the tool loaded again");
    let rest = &out[back..];
    assert!(
        rest.contains("S2000 M3 ;DL") && rest.contains("M8 ;DL"),
        "{rest}"
    );
}

#[test]
fn no_spindle_probe_swap_on_a_lathe_or_grinder_that_names_no_m6_tool() {
    // 02: a turret lathe selects its tools with `T="…" D1` alone. The gate read the turret's tool, retracted
    // along Z only and wrote `T="BLUM_TC50" M6`: the turret indexes on T where X stands (beside the part),
    // then `X0 Y0` on a lathe without Y. 03: a grinder's wheel (T1 D1) is not changed by M6 at all.
    let why = "the program turns or grinds (X in diameters or constant cutting speed";
    for profile in ["blum-tc50", "siemens-cycle978"] {
        refused_because("02_lathe_turret_no_m6.mpf", profile, why);
        refused_because("03_grinder_wheel_t1.mpf", profile, why);
    }
    // The lathe's and the grinder's own profiles measure them.
    for (name, profile) in [
        ("02_lathe_turret_no_m6.mpf", "lathe-setter"),
        ("03_grinder_wheel_t1.mpf", "grinder-gauge"),
    ] {
        let (o, _) = transform_fixture(name, profile);
        assert!(o.status.success(), "{name}: {}", common::stderr(&o));
    }
}

#[test]
fn every_gate_before_the_programs_spindle_checks_it_not_only_the_zero() {
    // With a measurement at every gate the face gets two gates before any spindle word of its own (the
    // zero and the one at M1): both check the operator's spindle, and measure only where it stands.
    let prog = std::fs::read_to_string(common::fixture("shop7/01_mda_spindle_face.mpf")).unwrap();
    let every = common::measuring_default_profile();
    let out = common::transformed_in(
        &[("p.mpf", &prog), ("every.toml", &every)],
        "p.mpf",
        "every.toml",
    );
    let checks = out
        .lines()
        .filter(|l| l.contains("($AA_S[1]<>0)") && l.contains("GOTOF DLSKIP"))
        .count();
    assert_eq!(checks, 2, "{out}");
    measures_only_where_the_spindle_stands("every", &[], &prog, &out);
    let standing = common::run_on_machine(TOOL_LOADED, &[], &out);
    // Each gate has its own probe call: one line per gate that measured.
    let gates_measured = standing
        .measurements
        .iter()
        .map(|m| m.at.line)
        .collect::<std::collections::BTreeSet<_>>();
    assert_eq!(gates_measured.len(), 2, "{:?}", standing.measurements);
}
