//! The demo's production-only route: `diagnose` on the characterisation and the logs the production program
//! wrote (a row at every gate, a reading only where it measured). Whatever it adds must be physical: the
//! truth's ambient gain is +2 µm/°C, and a lag bought by the held input of a sparse log (hundreds of µm/°C)
//! must never reach the refined program.

use driftloop::demo::{Settings, run_demo};

#[test]
fn production_logs_alone_never_buy_an_implausible_ambient_gain() {
    for seed in [6, 11] {
        let dir = tempfile::tempdir().unwrap();
        let settings = Settings {
            seed,
            production_jobs: vec![6, 24],
            ..Settings::default()
        };
        let o = run_demo(&settings, dir.path()).unwrap();
        let compensated = &o.stages[1];
        assert_eq!(o.production.len(), 2);
        for r in &o.production {
            // Two readings a job at least (the zero and one gate), more rows than readings.
            assert!(r.readings >= 2 * r.jobs && r.rows > r.readings, "{r:?}");
            if let Some(g) = r.ambient_gain {
                assert!((1.0..3.0).contains(&g), "seed {seed}: {r:?}");
            }
            assert!(
                r.after.max_error_um <= compensated.max_error_um + 0.5,
                "seed {seed}: {r:?} against {compensated:?}"
            );
        }
        assert!(dir.path().join("production_log.csv").is_file());
    }
}

/// With a tighter tolerance (Δ = 10 µm, δ' = 5 µm) the production program measures twice after the zero; the
/// first reading's row then carries the warmed hall into the second, and three jobs' logs are enough.
#[test]
fn production_logs_find_the_ambient_effect_when_the_program_measures_twice_after_the_zero() {
    for seed in [1, 6, 11] {
        let dir = tempfile::tempdir().unwrap();
        let settings = Settings {
            seed,
            tolerance_um: Some(10.0),
            production_jobs: vec![3],
            ..Settings::default()
        };
        let o = run_demo(&settings, dir.path()).unwrap();
        let compensated = &o.stages[1];
        let r = &o.production[0];
        assert_eq!(r.readings, 3 * r.jobs, "seed {seed}: {r:?}");
        let gain = r.ambient_gain.unwrap_or(f64::NAN);
        assert!((1.0..4.0).contains(&gain), "seed {seed}: {r:?}");
        assert!(
            r.after.max_error_um < compensated.max_error_um,
            "seed {seed}: {r:?} against {compensated:?}"
        );
    }
}
