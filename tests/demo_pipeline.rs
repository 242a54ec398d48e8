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

/// The claim, over several seeds (probe noise, characterisation noise and ambient courses all
/// change): one diagnose round on the probe logs finds the undeclared ambient effect, and the program
/// transformed with the refined model keeps the machined error within 3 µm at 0.5 µm probe noise.
#[test]
fn diagnose_finds_the_ambient_effect_and_meets_the_target() {
    for seed in [1, 6, 11] {
        let dir = tempfile::tempdir().unwrap();
        let settings = Settings {
            seed,
            ..Settings::default()
        };
        let o = run_demo(&settings, dir.path()).unwrap();
        assert!(
            o.diagnosis
                .effects_added
                .iter()
                .any(|a| a.effect.signal.as_deref() == Some("ambient_c")),
            "seed {seed}: {:?}",
            o.effects
        );
        let [_, compensated, _, after] = &o.stages[..] else {
            panic!("four stages: {:?}", o.stages);
        };
        assert!(
            after.max_error_um <= compensated.max_error_um,
            "seed {seed}: {after:?}"
        );
        assert!(after.max_error_um <= 3.0, "seed {seed}: {after:?}");
    }
}
