//! `driftloop run` through the binary: exit codes, JSON, machine file, trace CSV.

mod common;

const MACHINE: &str = r#"
[probe]
surface_mm = -100
[offsets]
G54 = { Z = -100.0 }
[drift]
Z = [[0, 0], [20, 70]]
"#;

#[test]
fn alarm_stop_exits_1_and_json_carries_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("hot.toml");
    std::fs::write(&machine, MACHINE).unwrap();
    let out = common::run(&[
        "run",
        "fixtures/vm/omm/omm_main.mpf",
        "--machine",
        machine.to_str().unwrap(),
        "--format",
        "json",
    ]);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["end"]["kind"], "alarm");
    assert_eq!(
        v["end"]["number"], 65002,
        "70 µm after 20 min exceeds the 50 µm tolerance"
    );
    assert!(v["corrections"].as_array().unwrap().is_empty());
}

#[test]
fn clean_run_exits_0_and_writes_the_trace() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace.csv");
    let out = common::run(&[
        "run",
        "fixtures/vm/timing.mpf",
        "--trace",
        trace.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0));
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(stdout.contains("program end (M30)"), "{stdout}");
    let csv = std::fs::read_to_string(trace).unwrap();
    assert!(csv.starts_with("file,line,n,time_min,spindle_rpm,X_prog,X_mach"));
    assert_eq!(csv.lines().count(), 1 + 9, "a row per executed block");
}

#[test]
fn unsupported_construct_exits_2_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.mpf");
    // Rotation about a rotary axis is not modelled (the geometry axes X, Y, Z are).
    std::fs::write(&p, "G1 X1 F100\nAROT A45\n").unwrap();
    let out = common::run(&["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("bad.mpf:2: AROT"), "{err}");
    // A predefined command the dry run does not model is named as such, not searched for as a subprogram.
    std::fs::write(&p, "G1 X1 F100\nCIP\n").unwrap();
    let out = common::run(&["run", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("bad.mpf:2: CIP is not supported by the dry run"),
        "{err}"
    );
}

#[test]
fn machine_file_with_a_model_drives_the_truth() {
    let out = common::run(&[
        "run",
        "fixtures/vm/omm/omm_main.mpf",
        "--machine",
        "fixtures/vm/machines/model_truth.toml",
        "--probe-noise",
        "0",
        "--format",
        "json",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let m = &v["measurements"][3];
    let on = v["spindle"]["steps"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| s[1] == 4000.0)
        .map(|s| s[0].as_f64().unwrap())
        .unwrap();
    let t_abs = m["at"]["time_min"].as_f64().unwrap();
    let t = t_abs - on;
    // Two lags at 4000 rpm from cold (14 µm, 12 min; 26 µm, 95 min) plus the creep of 2 µm per 240 min.
    let expected =
        14.0 * (1.0 - (-t / 12.0).exp()) + 26.0 * (1.0 - (-t / 95.0).exp()) + 2.0 * t_abs / 240.0;
    let got = m["true_drift_um"].as_f64().unwrap();
    assert!(
        (got - expected).abs() < 1e-9,
        "{got} vs {expected} at {t_abs} min"
    );
    assert_eq!(
        m["result"]["value"].as_f64().unwrap(),
        got,
        "no noise asked for"
    );
}

#[test]
fn program_from_stdin() {
    let out = common::driftloop(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")),
        &["run", "-", "--format", "json"],
        b"G1 X100 F1000\nM30\n",
    );
    assert_eq!(out.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["program"], "<stdin>");
    assert!((v["time_min"].as_f64().unwrap() - 0.1).abs() < 1e-12);
}
