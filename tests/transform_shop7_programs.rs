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

#[test]
fn no_gate_stops_a_spindle_the_operator_started() {
    // 01: the program has no S/M3 (the operator started the spindle in MDA). The zero's `M5` stopped it for
    // the probe and nothing started it again: N40 `G1 Z-0.5 F600` fed the cutter into the part standing
    // still. The audit's machine starts with the spindle off, so it saw nothing.
    for profile in [
        "blum-tc50",
        "siemens-cycle978",
        "tool-setter",
        "lathe-setter",
    ] {
        refused_because(
            "01_mda_spindle_face.mpf",
            profile,
            "at line 4, the program cuts with the spindle as the operator left it",
        );
    }
    // A gauge moves nothing and stops nothing.
    let (o, _) = transform_fixture("01_mda_spindle_face.mpf", "grinder-gauge");
    assert!(o.status.success(), "{}", common::stderr(&o));
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
