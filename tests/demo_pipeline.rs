//! `driftloop demo` as a test: the structural claims of the replayed experiment, and its printed table.

use driftloop::demo::{Outcome, Settings, run_demo};

fn demo() -> Outcome {
    let dir = tempfile::tempdir().unwrap();
    let outcome = run_demo(&Settings::default(), dir.path()).unwrap();
    for artefact in [
        "model.toml",
        "stepped_surface_model.mpf",
        "stepped_surface_model_refined.mpf",
        "run_original.txt",
        "run_model.txt",
        "run_model_refined.txt",
        "probe_log.csv",
        "diagnose.html",
        "model_refined.toml",
    ] {
        assert!(dir.path().join(artefact).is_file(), "{artefact} written");
    }
    outcome
}

#[test]
fn compensation_cuts_the_error_the_truth_causes() {
    let o = demo();
    let [uncompensated, compensated, dense, after] = &o.stages[..] else {
        panic!("four stages: {:?}", o.stages);
    };
    // Without correction the part carries the truth's drift: 30 µm spindle + 8 µm ambient, near steady
    // state after 240 min.
    assert!((uncompensated.max_error_um - o.truth_drift_um).abs() < 1e-9);
    assert!(
        (35.0..41.0).contains(&uncompensated.max_error_um),
        "{uncompensated:?}"
    );
    assert_eq!(uncompensated.measurements, 0);
    assert!(compensated.measurements > 0 && compensated.corrections > 0);
    assert!(
        compensated.max_error_um < uncompensated.max_error_um / 5.0,
        "{compensated:?}"
    );
    // Measuring at every gate costs probe calls and catches what the model misses between gates.
    assert!(dense.measurements > compensated.measurements, "{dense:?}");
    assert!(dense.max_error_um < compensated.max_error_um, "{dense:?}");
    assert!(
        [compensated, dense, after]
            .iter()
            .all(|st| st.end.starts_with("ProgramEnd"))
    );
    insta::assert_snapshot!(o.table());
}

#[test]
#[ignore = "not met yet: measured at every gate the program logs 12 rows per job (zero, passes, dwells), still too \
            sparse for diagnose to find the ambient lag (notes/demo.md)"]
fn diagnose_finds_the_ambient_effect_and_does_not_make_things_worse() {
    let o = demo();
    assert!(
        o.diagnosis
            .effects_added
            .iter()
            .any(|a| a.effect.signal.as_deref() == Some("ambient_c")),
        "{:?}",
        o.effects
    );
    assert!(
        o.stages[3].max_error_um <= o.stages[1].max_error_um,
        "{:?}",
        o.stages
    );
}
