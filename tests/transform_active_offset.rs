//! `[offset] method = "active"`: the correction goes into the work offset in force (`$P_IFRAME`), so a
//! program that selects no work offset (it runs in the control's reset offset, G500) can be compensated,
//! and a program that selects its offset again between passes keeps the correction, as driftloop applies it
//! again after each selection. On a virtual machine drifting as the model says both cut closer than the
//! originals, and the safety audit finds nothing.

mod common;

use driftloop::model::DriftModel;
use driftloop::omm::profile::OffsetMethod;
use driftloop::omm::{ModelRef, Profile};
use driftloop::vm::audit::AuditSettings;

/// Z: 30 µm at 4000 rpm through τ = 20 min.
fn model() -> DriftModel {
    DriftModel::from_modes(
        "drift_z_um",
        vec![1000.0, 4000.0],
        &[(20.0, vec![7.5, 30.0])],
        0.0,
    )
}

/// Six face-milling passes, each after 20 minutes of spindle heating; `select` starts the program and
/// every pass (empty: the program selects no work offset); `surface` is the part's top in work coordinates.
fn program(select: &str, surface: f64) -> String {
    common::facing_passes(select, !select.is_empty(), surface)
}

/// The default spindle-probe profile correcting the offset in force, measuring at every gate, the probe
/// point over the surface at `surface` (work coordinates).
fn profile(method: OffsetMethod, surface: f64) -> Profile {
    let mut p = Profile::default_profile();
    p.offset.method = method;
    p.log.measure_every_gate = true;
    p.position.nominal = surface;
    p.position.z = surface + 10.0;
    p.position.clearance = surface + 100.0;
    p
}

fn transformed(src: &str, p: &Profile) -> Result<String, String> {
    let model = model();
    let parsed = driftloop::parse(src.as_bytes());
    let reference = ModelRef {
        model: &model,
        sha256: "zzzzzzzzzzzzzzzz",
    };
    driftloop::omm::transform(&parsed, reference, p, false)
        .map(|t| String::from_utf8(t.bytes).unwrap())
        .map_err(|e| e.to_string())
}

/// A machine drifting on Z as the model says, the probed surface at machine Z −100, G54 = Z −100.
fn run(program: &str) -> driftloop::vm::Run {
    let machine = "[probe]\nsurface_mm = -100\n[offsets]\nG54 = { Z = -100.0 }\n[models]\nZ = { file = \"z.toml\" }\n";
    common::run_on_machine(machine, &[("z.toml", model().to_toml())], program)
}

/// The transformed program cuts with less than a third of the original's error, ends normally, and its
/// inserted blocks pass the audit.
fn compensates(original: &str, out: &str, p: &Profile) {
    let (before, after) = (run(original), run(out));
    assert!(
        matches!(after.end, driftloop::vm::End::ProgramEnd { .. }),
        "{:?}",
        after.alarms
    );
    let (b, a) = (&before.cutting_error["Z"], &after.cutting_error["Z"]);
    assert!(b.max_abs_um > 10.0, "{b:?}");
    assert!(
        a.max_abs_um < 0.35 * b.max_abs_um,
        "{:.2} µm compensated against {:.2} µm",
        a.max_abs_um,
        b.max_abs_um
    );
    let settings = AuditSettings::from_profile(p)
        .drifting_as_axes(&[&model()])
        .unwrap();
    common::assert_audit_clean(original, out, &settings);
}

#[test]
fn a_program_in_the_reset_offset_is_refused_by_frame_and_compensated_by_active() {
    // No selection: the program runs in G500, the part's top at machine Z −100.
    let src = program("", -100.0);
    let err = transformed(&src, &profile(OffsetMethod::Frame, -100.0)).unwrap_err();
    assert!(err.contains("method = \"active\""), "{err}");
    let p = profile(OffsetMethod::Active, -100.0);
    let out = transformed(&src, &p).unwrap();
    // The offset in force is corrected; nothing selects or writes a stored offset.
    assert!(
        out.contains("$P_IFRAME[Z,TR]=$P_UIFR[$P_UIFRNUM,Z,TR]+R"),
        "{out}"
    );
    let inserted = || out.lines().filter(|l| l.ends_with(";DL"));
    assert!(!inserted().any(|l| l.starts_with("$P_UIFR[")), "{out}");
    assert!(!inserted().any(|l| l.starts_with("G54")), "{out}");
    compensates(&src, &out, &p);
}

#[test]
fn a_program_that_selects_its_offset_before_every_pass_keeps_the_correction() {
    let src = program("G54", 0.0);
    let p = profile(OffsetMethod::Active, 0.0);
    let out = transformed(&src, &p).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    let selects = |l: &str| !l.ends_with(";DL") && l.split_whitespace().any(|w| w == "G54");
    // Each of the program's seven selections is followed by the correction applied again.
    let reapplied = lines
        .windows(3)
        .filter(|w| selects(w[0]) && w[2].starts_with("$P_IFRAME[Z,TR]="))
        .count();
    assert_eq!(reapplied, 7, "{out}");
    compensates(&src, &out, &p);
    // Without the blocks after the selections, each selection drops the correction, and the next gate,
    // reading back the correction in force instead of assuming it, finds the part cut since then scrap.
    let dropped: String = lines
        .iter()
        .enumerate()
        .filter(|(k, l)| {
            let after_selection = *k >= 2 && selects(lines[k - 2]);
            !(after_selection && l.starts_with("$P_IFRAME[Z,TR]="))
        })
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let lost = run(&dropped);
    assert!(
        lost.alarms.iter().any(|a| a.number == 65001),
        "{:?}",
        lost.alarms
    );
}
