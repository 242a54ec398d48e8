//! The validity logic of issue 6 exercised on the blocks `transform` emits (not hand-written ones): the
//! demo's stepped surface, transformed with the truth's own spindle model, run with a faulty probe.

use driftloop::demo::transform_program;
use driftloop::model::DriftModel;
use driftloop::omm::Profile;
use driftloop::vm::{Config, End, ProbeFault, Run, SimpleMachine, SpindleHistory, run_source};

/// 30 µm at 4000 rpm through a 40 min lag (the demo truth's spindle part).
const MODEL: &str = include_str!("../fixtures/omm/spindle_40min.toml");

fn profile() -> Profile {
    Profile::default_profile()
}

fn config() -> Config {
    Config {
        offsets: vec![(1, "Z".into(), -100.0)],
        probe_surface_mm: -100.0,
        ..Config::default()
    }
}

/// The model's drift exactly (µm), plus `jump_um` from minute 30 on: a crash the model cannot know.
fn truth(jump_um: f64) -> impl FnMut(&str, f64, &SpindleHistory) -> f64 {
    move |axis, t, spindle| {
        if axis != "Z" {
            return 0.0;
        }
        let lag = spindle.intervals(t).fold(0.0, |x, (a, b, rpm)| {
            let target = 30.0 * rpm / 4000.0;
            target + (x - target) * (-(b - a) / 40.0).exp()
        });
        lag + if t >= 30.0 { jump_um } else { 0.0 }
    }
}

fn run(machine: &mut SimpleMachine) -> Run {
    let model = DriftModel::from_toml(MODEL, "model.toml").unwrap();
    let bytes = transform_program(&model, &profile()).unwrap();
    run_source("stepped.mpf", &bytes, None, &config(), machine).unwrap()
}

fn offset_moves_um(r: &Run) -> Vec<f64> {
    r.corrections
        .iter()
        .map(|c| (c.new_mm - c.old_mm) * 1000.0)
        .collect()
}

#[test]
fn the_transformed_program_compensates_a_drift_its_model_knows() {
    let r = run(&mut SimpleMachine::with_drift(truth(0.0)));
    assert_eq!(r.end, End::ProgramEnd { code: "M30".into() });
    assert!(r.alarms.is_empty());
    assert_eq!(r.passes.len(), 6);
    assert!(r.totals.max_abs_drift_um > 25.0, "{:?}", r.totals);
    assert!(r.totals.max_abs_error_um < 1.0, "{:?}", r.totals);
}

#[test]
fn garbage_and_nan_are_repeated_and_never_reach_a_correction() {
    bad_values_are_repeated(&[
        (2, ProbeFault::Garbage),
        (3, ProbeFault::Nan),
        (5, ProbeFault::Garbage),
    ]);
}

#[test]
fn a_probe_that_returns_nothing_is_measured_again() {
    bad_values_are_repeated(&[(2, ProbeFault::Nothing)]);
}

fn bad_values_are_repeated(faults: &[(usize, ProbeFault)]) {
    let clean = run(&mut SimpleMachine::with_drift(truth(0.0)));
    let mut m = SimpleMachine::with_drift(truth(0.0));
    for &(call, fault) in faults {
        m = m.fault(call, fault);
    }
    let r = run(&mut m);
    assert_eq!(r.end, End::ProgramEnd { code: "M30".into() });
    assert!(r.alarms.is_empty());
    assert_eq!(
        r.measurements.len(),
        clean.measurements.len() + faults.len(),
        "each bad value is measured again"
    );
    for (bad, good) in offset_moves_um(&r).iter().zip(offset_moves_um(&clean)) {
        assert!((bad - good).abs() < 1e-6, "{bad} vs {good}");
    }
    assert!(r.totals.max_abs_error_um < 1.0, "{:?}", r.totals);
}

#[test]
fn too_few_agreeing_values_stop_with_the_alarm_before_cutting() {
    let p = profile();
    let mut m = SimpleMachine::with_drift(truth(0.0));
    for call in 1..=p.limits.max_attempts as usize {
        m = m.fault(call, ProbeFault::Garbage);
    }
    let r = run(&mut m);
    assert_eq!(
        r.end,
        End::Alarm {
            number: i64::from(p.registers.alarm_implausible)
        }
    );
    assert_eq!(r.measurements.len(), p.limits.max_attempts as usize);
    assert!(r.passes.is_empty(), "nothing is cut: {:?}", r.passes);
    assert!(
        offset_moves_um(&r).iter().all(|d| d.abs() < 1e-9),
        "{:?}",
        r.corrections
    );
}

#[test]
fn a_measured_error_beyond_the_tolerance_stops_as_scrap() {
    let p = profile();
    let r = run(&mut SimpleMachine::with_drift(truth(80.0)));
    assert_eq!(
        r.end,
        End::Alarm {
            number: i64::from(p.registers.alarm_scrap)
        }
    );
    assert!(r.passes.len() < 6, "machining stops: {:?}", r.passes);
    let gate_time = r.measurements.last().unwrap().at.time_min;
    assert!(
        r.passes.iter().all(|p| p.start_min < gate_time),
        "nothing is cut after the measurement that saw the jump"
    );
    assert!(
        r.messages.iter().any(|m| m.text.contains("part is scrap")),
        "{:?}",
        r.messages
    );
}
