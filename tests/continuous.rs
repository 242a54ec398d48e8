//! Continuous compensation through the control's temperature compensation (`[continuous] mode =
//! "temp_comp"`): the emitted blocks, the machined error with and without it on the virtual machine, the
//! start check of MD32750, and the audit of the SD43900 restore.

mod common;

use std::path::Path;

use common::{run, stderr, stdout};
use driftloop::omm::{ModelRef, Profile, transform};
use driftloop::vm::{Config, parse_machine_file, run_source};

const MODEL: &str = "fixtures/omm/model.toml";
const PROGRAM: &str = "fixtures/omm/long_facing.mpf";

/// The default profile with the probe point beside the part.
fn gates_profile() -> String {
    driftloop::omm::profile::DEFAULT_PROFILE
        .replace("\nx = 0.0\n", "\nx = -50.0\n")
        .replace("\ny = 0.0\n", "\ny = -50.0\n")
}

fn continuous_profile(extra: &str) -> String {
    format!(
        "{}\n[continuous]\nmode = \"temp_comp\"\n{extra}",
        gates_profile()
    )
}

fn model() -> driftloop::model::DriftModel {
    driftloop::model::DriftModel::read(Path::new(MODEL)).unwrap()
}

fn transformed(program: &[u8], profile: &str) -> Vec<u8> {
    let profile = Profile::from_toml(profile, "p.toml").unwrap();
    let model = model();
    let model = ModelRef {
        model: &model,
        sha256: "0000000000000000",
    };
    transform(&driftloop::parse(program), model, &profile, false)
        .unwrap()
        .bytes
}

/// A machine that drifts as the model says, with 0.5 µm probe noise; `extra` adds to the machine file.
fn dry_run(program: &[u8], extra: &str) -> driftloop::vm::Run {
    let text =
        format!("[probe]\nnoise_um = 0.5\n[models]\nZ = {{ file = \"model.toml\" }}\n{extra}");
    let (cfg, spec) =
        parse_machine_file(&text, Path::new("fixtures/omm"), Config::default()).unwrap();
    run_source("p.mpf", program, None, &cfg, &mut spec.build(1)).unwrap()
}

#[test]
fn continuous_compensation_cuts_the_error_between_gates() {
    let original = std::fs::read(PROGRAM).unwrap();
    let gates = dry_run(&transformed(&original, &gates_profile()), "");
    let continuous = dry_run(&transformed(&original, &continuous_profile("")), "");
    let none = dry_run(&original, "");
    let (g, c, n) = (&gates.totals, &continuous.totals, &none.totals);
    println!(
        "machined error (µm), max / RMS: none {:.2} / {:.2}, gates only {:.2} / {:.2}, gates + continuous {:.2} / {:.2}",
        n.max_abs_error_um,
        n.rms_error_um,
        g.max_abs_error_um,
        g.rms_error_um,
        c.max_abs_error_um,
        c.rms_error_um
    );
    assert_eq!(gates.measurements.len(), continuous.measurements.len());
    assert!(c.rms_error_um < g.rms_error_um / 2.0, "{c:?} vs {g:?}");
    assert!(c.max_abs_error_um < g.max_abs_error_um, "{c:?} vs {g:?}");
    // Applied twice, the error would be the drift with the other sign: never larger than the drift here.
    assert!(c.max_abs_error_um < n.max_abs_drift_um / 2.0);
    // SD43900 is refreshed between the gates and back to its start value at the end.
    assert!(continuous.temp_comp_writes.len() > 10);
    assert_eq!(continuous.temp_comp_writes.last().unwrap().new_mm, 0.0);
    assert!(gates.temp_comp_writes.is_empty());
}

#[test]
fn continuous_compensation_works_with_the_offset_in_force_too() {
    // `method = "active"`: the refreshes read the correction in force back from the offset, as the gates do.
    let active = |p: String| p.replace("method = \"frame\"", "method = \"active\"");
    let original = std::fs::read(PROGRAM).unwrap();
    let gates = dry_run(&transformed(&original, &active(gates_profile())), "");
    let text = transformed(&original, &active(continuous_profile("")));
    let out = String::from_utf8_lossy(&text);
    assert!(
        out.contains("$P_IFRAME[Z,TR]=$P_UIFR[$P_UIFRNUM,Z,TR]+R"),
        "{out}"
    );
    let continuous = dry_run(&text, "");
    let (g, c) = (&gates.totals, &continuous.totals);
    assert!(
        matches!(continuous.end, driftloop::vm::End::ProgramEnd { .. }),
        "{:?}",
        continuous.alarms
    );
    assert!(c.rms_error_um < g.rms_error_um / 2.0, "{c:?} vs {g:?}");
    assert_eq!(continuous.temp_comp_writes.last().unwrap().new_mm, 0.0);
}

#[test]
fn a_refresh_step_never_exceeds_the_profile_step_and_a_start_value_comes_back() {
    let original = std::fs::read(PROGRAM).unwrap();
    let t = transformed(&original, &continuous_profile("max_step_um = 2\n"));
    let run = dry_run(&t, "[machine_data]\ntemp_comp_abs_value = { Z = 0.004 }\n");
    let writes = &run.temp_comp_writes;
    let (restore, refreshes) = writes.split_last().unwrap();
    for w in refreshes {
        assert!(
            (w.new_mm - w.old_mm).abs() <= 0.002 + 1e-12,
            "{w:?}: more than the 2 µm step"
        );
    }
    assert_eq!(restore.new_mm, 0.004, "the value at the start comes back");
    // A small step lags the prediction: the error grows against the unlimited default, but stays below
    // the uncompensated drift.
    assert!(run.totals.max_abs_error_um < run.totals.max_abs_drift_um);
}

#[test]
fn without_md32750_bit_0_the_program_stops_before_anything_moves() {
    let original = std::fs::read(PROGRAM).unwrap();
    let t = transformed(&original, &continuous_profile(""));
    let run = dry_run(&t, "[machine_data]\ntemp_comp_type = { Z = 2 }\n");
    assert_eq!(
        run.end,
        driftloop::vm::End::Alarm { number: 65002 },
        "{:?}",
        run.messages
    );
    assert!(
        run.messages[0].text.contains("MD32750"),
        "{:?}",
        run.messages
    );
    assert!(run.temp_comp_writes.is_empty());
    // The program's G54 is followed by the correction in force, still none.
    assert!(
        run.corrections.iter().all(|c| c.new_mm == c.old_mm),
        "{:?}",
        run.corrections
    );
    assert!(run.passes.is_empty(), "nothing was cut");
}

/// A short program whose one long stroke has retracts in it, refreshed every minute.
const SHORT: &str = "G17 G90 G94 G54\nT1 M6 D1\nS4000 M3\n; PASS one\nG0 X20 Y20\nG0 Z2\nG1 Z0 F300\nG1 X220 F150\nG0 Z5\nG0 X20 Y30\nG0 Z2\nG1 Z0 F300\nG1 X220 F150\nG0 Z5\nM5\nM30\n";

#[test]
fn emitted_blocks_with_continuous_compensation() {
    let t = transformed(SHORT.as_bytes(), &continuous_profile("interval_min = 1\n"));
    let text = String::from_utf8(t).unwrap();
    assert!(text.contains("; driftloop refresh"), "{text}");
    insta::assert_snapshot!(text);
}

#[test]
fn the_audit_finds_sd43900_left_shifted() {
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("cont.toml");
    std::fs::write(&profile, continuous_profile("")).unwrap();
    let out = dir.path().join("t.mpf");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (model, program) = (root.join(MODEL), root.join(PROGRAM));
    let args = |extra: &[&str]| {
        let mut v: Vec<String> = [
            "transform",
            "--model",
            model.to_str().unwrap(),
            program.to_str().unwrap(),
            "--profile",
            profile.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let a = args(&["-o", out.to_str().unwrap()]);
    let o = run(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let audit = |file: &Path| {
        run(&[
            "run",
            "--audit",
            file.to_str().unwrap(),
            "--original",
            program.to_str().unwrap(),
            "--model",
            model.to_str().unwrap(),
            "--profile",
            profile.to_str().unwrap(),
        ])
    };
    let clean = audit(&out);
    assert!(stdout(&clean).contains("0 finding(s)"));
    // Without the restore at the end and before the alarms, SD43900 stays shifted.
    let text = std::fs::read_to_string(&out).unwrap();
    let broken: String = text
        .lines()
        .filter(|l| !l.starts_with("$SA_TEMP_COMP_ABS_VALUE[Z]=R") || l.contains('+'))
        .map(|l| format!("{l}\n"))
        .collect();
    assert_ne!(broken, text);
    let bad = dir.path().join("bad.mpf");
    std::fs::write(&bad, broken).unwrap();
    let found = audit(&bad);
    assert_eq!(found.status.code(), Some(1), "{}", stderr(&found));
    let report = String::from_utf8(found.stdout).unwrap();
    assert!(
        report.contains("alarm 65000 stops the program with $SA_TEMP_COMP_ABS_VALUE[Z]"),
        "{report}"
    );
    assert!(
        report.contains("the program ends with $SA_TEMP_COMP_ABS_VALUE[Z]"),
        "{report}"
    );
}

#[test]
fn a_bad_continuous_key_names_its_line_and_column() {
    let text = continuous_profile("sign = 0\n");
    let err = Profile::from_toml(&text, "p.toml").unwrap_err().to_string();
    let line = text.lines().position(|l| l == "sign = 0").unwrap() + 1;
    assert!(
        err.starts_with(&format!("p.toml:{line}:8: continuous.sign must be 1 or -1")),
        "{err}"
    );
    let diameter = Profile::builtin("lathe-setter").unwrap();
    let lathe = format!(
        "{}\n[continuous]\nmode = \"temp_comp\"\n",
        toml::to_string(&diameter).unwrap()
    );
    let err = Profile::from_toml(&lathe, "l.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("not supported with position.diameter"),
        "{err}"
    );
}

/// Two jobs 30 min apart with continuous compensation, the second started warm or cold.
fn second_job(profile_extra: &str, model: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let profile = dir.path().join("p.toml");
    std::fs::write(&profile, continuous_profile(profile_extra)).unwrap();
    let machine = dir.path().join("m.toml");
    let truth = root.join(MODEL);
    std::fs::write(
        &machine,
        format!(
            "[probe]\nnoise_um = 0.5\n[models]\nZ = {{ file = {:?} }}\n",
            truth.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = dir.path().join("t.mpf");
    let model = root.join(model);
    let o = run(&[
        "transform",
        "--model",
        model.to_str().unwrap(),
        root.join(PROGRAM).to_str().unwrap(),
        "--profile",
        profile.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&run(&[
        "run",
        out.to_str().unwrap(),
        "--machine",
        machine.to_str().unwrap(),
        "--jobs",
        "2",
        "--pause",
        "30",
    ]));
    let job2 = text.split("job 2 of 2").nth(1).unwrap();
    job2.lines().nth(1).unwrap().to_string()
}

fn rms(line: &str) -> f64 {
    let at = line.find("RMS ").unwrap() + 4;
    line[at..].split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn a_warm_start_predicts_the_second_job_of_a_warm_machine() {
    let cold = second_job("", MODEL);
    let warm = second_job("[warm_start]\nr_first = 900\n", MODEL);
    println!("job 2, cold start: {cold}\njob 2, warm start: {warm}");
    assert!(rms(&warm) < rms(&cold) / 2.0, "{warm} vs {cold}");
}

#[test]
fn the_store_is_written_and_a_program_using_it_is_refused() {
    let t = transformed(
        std::fs::read(PROGRAM).unwrap().as_slice(),
        &continuous_profile("[warm_start]\nr_first = 900\n"),
    );
    let text = String::from_utf8(t).unwrap();
    // The marker goes last, after the stamp and the states.
    let store: Vec<&str> = text.lines().filter(|l| l.starts_with("R90")).collect();
    assert!(
        store.iter().any(|l| l.starts_with("R900=271828")),
        "{store:?}"
    );
    assert!(text.contains("IF (R900==271828) AND (R901=="), "{text}");
    let program = "G17 G90 G94 G54\nR902=1\nT1 M6 D1\nS4000 M3\nG0 X20 Y20\nG0 Z2\nG1 Z0 F300\nG1 X220 F150\nG0 Z5\nM30\n";
    let profile = Profile::from_toml(
        &continuous_profile("[warm_start]\nr_first = 900\n"),
        "p.toml",
    )
    .unwrap();
    let model = model();
    let err = transform(
        &driftloop::parse(program.as_bytes()),
        ModelRef {
            model: &model,
            sha256: "00",
        },
        &profile,
        false,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("R902, which lies in the warm-start store"),
        "{err}"
    );
}
