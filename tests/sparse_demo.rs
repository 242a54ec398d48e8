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
