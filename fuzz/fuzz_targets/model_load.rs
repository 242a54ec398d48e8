//! Any text as a model file: loading never panics; a model it accepts predicts finite drifts for a
//! schedule across and above its speed grid, and its time constants are ones an NC program can divide by.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|text: &str| {
    let Ok(model) = driftloop::model::DriftModel::from_toml(text, "fuzz.toml") else {
        return;
    };
    for m in &model.spindle.modes {
        assert!(m.tau_min >= driftloop::model::file::TAU_SHORTEST_MIN, "{}", m.tau_min);
    }
    let schedule: driftloop::model::Schedule = "3000:30,0:10,20000:30".parse().unwrap();
    if let Ok(drift) = model.predict(&schedule.to_dataset(5.0)) {
        assert!(drift.iter().all(|d| d.is_finite()), "{drift:?}");
    }
});
