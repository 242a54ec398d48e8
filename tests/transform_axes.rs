//! Drift measured and corrected on two axes at once: a profile that also measures X (`[[position.also]]`),
//! one model per axis, every measuring gate probing Z and X and correcting both components of G54. On a
//! virtual machine that drifts on both axes as the models say, the compensated program cuts with a smaller
//! error on each axis than the original, and the safety audit finds nothing.

mod common;

use driftloop::model::DriftModel;
use driftloop::omm::profile::{AlsoMeasured, Axis};
use driftloop::omm::{ModelRef, Profile, prepare};

/// Z: 30 µm at 4000 rpm through τ = 20 min; X: 12 µm through τ = 45 min.
fn models() -> (DriftModel, DriftModel) {
    let z = DriftModel::from_modes(
        "drift_z_um",
        vec![1000.0, 4000.0],
        &[(20.0, vec![7.5, 30.0])],
        0.0,
    );
    let x = DriftModel::from_modes(
        "drift_x_um",
        vec![1000.0, 4000.0],
        &[(45.0, vec![3.0, 12.0])],
        0.0,
    );
    (z, x)
}

/// The default profile, also measuring a side face at X 50 from X 60, measuring at every gate.
fn profile() -> Profile {
    let mut p = sparse_profile();
    p.log.measure_every_gate = true;
    p
}

/// The same, measuring where the prediction asks for it (the Cycle_in decision).
fn sparse_profile() -> Profile {
    let mut p = Profile::default_profile();
    p.position.also.push(AlsoMeasured {
        axis: Axis::X,
        nominal: 50.0,
        x: 60.0,
        y: 0.0,
        z: -5.0,
        channel: "drift_x_um".into(),
    });
    p
}

/// Six passes of face milling, each after 20 minutes of spindle heating.
fn program() -> String {
    common::facing_passes("G54", false, 0.0)
}

fn transformed() -> String {
    transformed_with(&profile())
}

fn transformed_with(p: &Profile) -> String {
    let (z, x) = models();
    let src = program();
    let parsed = driftloop::parse(src.as_bytes());
    let refs = [
        ModelRef {
            model: &x,
            sha256: "xxxxxxxxxxxxxxxx",
        },
        ModelRef {
            model: &z,
            sha256: "zzzzzzzzzzzzzzzz",
        },
    ];
    // The models come in any order: each axis takes the one of its channel.
    let prepared = driftloop::omm::prepare_timed(
        &parsed,
        &driftloop::omm::parse_timed(src.as_bytes().to_vec()).1,
        &refs,
        p,
        false,
    )
    .unwrap();
    let mut out = Vec::new();
    prepared.write_to(&mut out).unwrap();
    String::from_utf8(out).unwrap()
}

/// A machine drifting on Z and X as the models say; the probe's second argument names the axis.
fn run(program: &str) -> driftloop::vm::Run {
    let (z, x) = models();
    let machine = "[probe]\nsurface_mm = -100\naxis_arg = 2\nsurfaces = { X = 50.0 }\n[offsets]\nG54 = { Z = -100.0 }\n[models]\nZ = { file = \"z.toml\" }\nX = { file = \"x.toml\" }\n";
    common::run_on_machine(
        machine,
        &[("z.toml", z.to_toml()), ("x.toml", x.to_toml())],
        program,
    )
}

#[test]
fn every_measuring_gate_probes_both_axes_and_corrects_both() {
    let out = transformed();
    assert!(
        out.contains("BL9700(1,3,0,") && out.contains("BL9700(1,1,50,"),
        "{out}"
    );
    assert!(
        out.contains("$P_IFRAME[X,TR]=$P_UIFR[$P_UIFRNUM,X,TR]+R")
            && out.contains("$P_IFRAME[Z,TR]=$P_UIFR[$P_UIFRNUM,Z,TR]+R"),
        "{out}"
    );
    assert!(out.contains(",drift_z_um,drift_x_um,pass,run"), "{out}");
    // Cycle_in waits for either axis, each comparison in brackets: on the control AND binds tighter than
    // `<`, and `ABS(a)<d AND ABS(b)<d` would compare ABS(a) with `d AND ABS(b)`, never skipping.
    let sparse = transformed_with(&sparse_profile());
    assert!(
        sparse
            .lines()
            .any(|l| l.starts_with("IF ((ABS(R") && l.contains(") AND (ABS(R")),
        "{sparse}"
    );
    let mut every = sparse_profile();
    every.log.measure_every_gate = true;
    let (planned, all) = (run(&sparse), run(&transformed_with(&every)));
    assert!(
        planned.measurements.len() < all.measurements.len(),
        "{} probings as planned, {} with every gate measuring",
        planned.measurements.len(),
        all.measurements.len()
    );
    // The header names both models.
    assert!(out.contains("model drift_z_um sha256 zzzz") && out.contains("model drift_x_um"));
    let (z, _) = models();
    let one = ModelRef {
        model: &z,
        sha256: "z",
    };
    let err = prepare(
        &driftloop::parse(program().as_bytes()),
        one,
        &profile(),
        false,
    )
    .err()
    .expect("one model for two measured axes is refused");
    assert!(err.to_string().contains("drift_x_um"), "{err}");
}

#[test]
fn the_virtual_machine_cuts_closer_on_both_axes_and_the_audit_finds_nothing() {
    let before = run(&program());
    let after = run(&transformed());
    assert!(
        matches!(after.end, driftloop::vm::End::ProgramEnd { .. }),
        "{:?}",
        after.alarms
    );
    for axis in ["X", "Z"] {
        let (b, a) = (&before.cutting_error[axis], &after.cutting_error[axis]);
        assert!(b.max_abs_um > 5.0, "{axis}: {b:?}");
        assert!(
            a.max_abs_um < 0.35 * b.max_abs_um,
            "{axis}: {:.2} µm compensated against {:.2} µm",
            a.max_abs_um,
            b.max_abs_um
        );
    }
    assert_eq!(after.cutting_error["Y"].max_abs_um, 0.0);
    let (z, x) = models();
    let settings = driftloop::vm::audit::AuditSettings::from_profile(&profile())
        .drifting_as_axes(&[&z, &x])
        .unwrap();
    common::assert_audit_clean(&program(), &transformed(), &settings);
}

#[test]
fn a_two_axis_gate() {
    let out = transformed();
    let gate: Vec<&str> = out
        .lines()
        .skip_while(|l| !l.starts_with("; driftloop gate 4"))
        .take_while(|l| l.ends_with(";DL"))
        .collect();
    insta::assert_snapshot!(gate.join("\n"));
}
