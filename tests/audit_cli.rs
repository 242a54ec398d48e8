//! `driftloop run --audit`: human and JSON output, exit codes, --original, --profile, --probe-margin,
//! --machine.

mod common;

use std::path::Path;

const FIXTURES: &str = "fixtures/vm/audit";

fn run(args: &[&str]) -> std::process::Output {
    common::run(args)
}

/// `driftloop run --audit ARGS`, with the profile the fixtures are written for (the stored offset G54,
/// `method = "frame"`) unless ARGS name one.
fn audit(args: &[&str]) -> std::process::Output {
    let dir = tempfile::tempdir().unwrap();
    let profile = common::frame_profile_file(dir.path());
    let mut all = vec!["run", "--audit"];
    all.extend_from_slice(args);
    if !args.contains(&"--profile") {
        all.extend_from_slice(&["--profile", profile.to_str().unwrap()]);
    }
    run(&all)
}

fn fixture(name: &str) -> String {
    format!("{FIXTURES}/{name}.mpf")
}

#[test]
fn clean_exits_0_and_findings_exit_1_with_one_line_each() {
    let out = audit(&[&fixture("clean")]);
    assert_eq!(out.status.code(), Some(0), "{}", common::stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with("audit of fixtures/vm/audit/clean.mpf: 0 finding(s); 3 resume point(s)"),
        "{text}"
    );

    let out = audit(&[&fixture("modal_coolant")]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8(out.stdout).unwrap();
    let first = text.lines().next().unwrap();
    assert_eq!(
        first,
        "fixtures/vm/audit/modal_coolant.mpf:36: modal-not-restored: where the original resumes: coolant off \
         (M9) here, M8 in the original [original line 11]"
    );
    assert!(
        text.lines()
            .nth(1)
            .unwrap()
            .contains("1 finding(s) (modal-not-restored 1)")
    );
}

#[test]
fn json_carries_kind_line_message_original_line_and_counts() {
    let out = audit(&[&fixture("tool_preselected"), "--format", "json"]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = &v["findings"][0];
    assert_eq!(f["kind"], "tool-state");
    assert_eq!(f["line"], 37);
    assert_eq!(f["original_line"], 12);
    assert!(
        f["message"]
            .as_str()
            .unwrap()
            .contains("T5 in the original")
    );
    assert_eq!(v["counts"]["tool-state"], 2);
    assert_eq!(v["resume_points"], 3);
}

#[test]
fn original_profile_and_margin_are_taken_from_the_flags() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // An original that is not the transformed program without its ;DL lines.
    let other = dir.path().join("other.mpf");
    std::fs::write(&other, "G0 X1\nM30\n").unwrap();
    let out = audit(&[&fixture("clean"), "--original", other.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("original-changed"));

    // With the clearance plane at Z20 the gate's travel at Z20 is no hazard.
    let profile = dir.path().join("low.toml");
    std::fs::write(
        &profile,
        common::frame_profile_text().replace("clearance = 100.0", "clearance = 20.0"),
    )
    .unwrap();
    let xy = root.join(fixture("xy_below_clearance"));
    let out = audit(&[xy.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let out = audit(&[xy.to_str().unwrap(), "--profile", profile.to_str().unwrap()]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );

    let out = audit(&[&fixture("probe_machined"), "--probe-margin", "1.5"]);
    assert_eq!(out.status.code(), Some(0));
    let out = audit(&[&fixture("probe_machined"), "--probe-margin", "-1"]);
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn a_machine_file_with_probe_faults_stops_the_comparison() {
    let dir = tempfile::tempdir().unwrap();
    let machine = dir.path().join("faulty.toml");
    std::fs::write(
        &machine,
        "[probe]\nfaults = [{ call = 1, kind = \"garbage\" }]\n",
    )
    .unwrap();
    let out = audit(&[&fixture("clean"), "--machine", machine.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with("note: line 27 (inserted) ended the transformed program"),
        "{text}"
    );
}

#[test]
fn a_construct_the_machine_cannot_run_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.mpf");
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(fixture("clean")))
            .unwrap();
    std::fs::write(&p, text.replace("R2=99999 ;DL", "G33 Z-5 K1 ;DL")).unwrap();
    let out = audit(&[p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = common::stderr(&out);
    assert!(err.contains("t.mpf:21: G33"), "{err}");
}

#[test]
fn model_makes_the_machine_drift_as_predicted_and_profiles_go_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let model = root.join("fixtures/omm/model.toml");
    let t = dir.path().join("stepped_t.mpf");
    let out = run(&[
        "transform",
        "--model",
        model.to_str().unwrap(),
        root.join("fixtures/vm/stepped_surface.mpf")
            .to_str()
            .unwrap(),
        "-o",
        t.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", common::stderr(&out));
    // The model predicts 30 µm by the second measurement: on a machine that does not drift that is scrap,
    // and the comparison ends at the alarm.
    let cold = String::from_utf8(run(&["run", "--audit", t.to_str().unwrap()]).stdout).unwrap();
    assert!(cold.contains("note: line"), "{cold}");
    let args = [
        "run",
        "--audit",
        t.to_str().unwrap(),
        "--model",
        model.to_str().unwrap(),
    ];
    let drifting = String::from_utf8(run(&args).stdout).unwrap();
    assert!(!drifting.contains("note:"), "{drifting}");

    let out = audit(&[&fixture("clean"), "--profile", "tool-setter"]);
    // The builtin tool-setter profile's reference reads -310 (machine coordinates): the fixture's gate, written
    // for a surface at 0, takes it for implausible and stops.
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.starts_with("note: line 27 (inserted) ended the transformed program"),
        "{text}"
    );
    let out = audit(&[&fixture("clean"), "--profile", "no-such-profile"]);
    assert_eq!(out.status.code(), Some(2));
}
