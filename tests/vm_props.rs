//! Properties of straight-line programs: time is the sum of path length over feed, positions land where
//! programmed, and an incremental (G91) version of the same path takes the same time and ends at the same point.

use driftloop::vm::{Config, SimpleMachine, run_source};
use proptest::prelude::*;

fn moves() -> impl Strategy<Value = Vec<(f64, f64, f64, f64)>> {
    prop::collection::vec(
        (-500i32..500, -500i32..500, -200i32..200, 10u32..20_000).prop_map(|(x, y, z, f)| {
            (
                f64::from(x) / 4.0,
                f64::from(y) / 4.0,
                f64::from(z) / 4.0,
                f64::from(f),
            )
        }),
        1..40,
    )
}

proptest! {
    #[test]
    fn feed_time_is_length_over_feed(path in moves()) {
        let mut abs = String::from("G90 G94\n");
        let mut inc = String::from("G91 G94\n");
        let mut at = (0.0, 0.0, 0.0);
        let mut expected = 0.0;
        for &(x, y, z, f) in &path {
            abs.push_str(&format!("G1 X{x} Y{y} Z{z} F{f}\n"));
            inc.push_str(&format!("G1 X{} Y{} Z{} F{f}\n", x - at.0, y - at.1, z - at.2));
            let d = ((x - at.0).powi(2) + (y - at.1).powi(2) + (z - at.2).powi(2)).sqrt();
            expected += d / f;
            at = (x, y, z);
        }
        let cfg = Config::default();
        for src in [abs, inc] {
            let run = run_source("p.mpf", src.as_bytes(), None, &cfg, &mut SimpleMachine::cold()).unwrap();
            prop_assert!((run.time_min - expected).abs() < 1e-9 * (1.0 + expected));
            let last = &run.trace.last().unwrap().machine;
            prop_assert!((last[0] - at.0).abs() < 1e-9 && (last[1] - at.1).abs() < 1e-9 && (last[2] - at.2).abs() < 1e-9);
        }
    }
}
