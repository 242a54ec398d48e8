//! Any bytes as a measurement CSV: reading never panics; data it accepts have a time axis that does not go
//! back within a run, and every value is finite (or NaN: a channel not measured in that row) and within the
//! reader's ranges.
#![no_main]

use driftloop::data::{Require, read_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(ds) = read_bytes("fuzz.csv", data, Require::InputsOnly) else {
        return;
    };
    assert!(!ds.is_empty());
    for run in ds.runs() {
        let t = &ds.time_min[run];
        assert!(t.windows(2).all(|w| w[0] <= w[1]), "time goes back: {t:?}");
    }
    for c in &ds.columns {
        assert_eq!(c.values.len(), ds.len());
        assert!(c.values.iter().all(|v| v.is_nan() || v.abs() <= 1e9), "{}", c.name);
    }
});
