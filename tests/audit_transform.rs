//! The audit on what `transform` writes today: the hand-written part's findings are recorded (they show
//! what the emitter has to fix; the snapshot changes when it is fixed), and every program the transform
//! accepts runs through the audit without the virtual machine giving up.

mod shared_data;

use std::path::{Path, PathBuf};

use driftloop::model::DriftModel;
use driftloop::omm::profile::BUILTIN;
use driftloop::omm::{ModelRef, Profile, transform};
use driftloop::vm::Config;
use driftloop::vm::audit::{Audit, AuditSettings, Kind, audit};

fn model() -> DriftModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    DriftModel::read(path.as_ref()).unwrap()
}

fn transformed(src: &[u8], profile: &Profile) -> Option<Vec<u8>> {
    let model = model();
    let reference = ModelRef {
        model: &model,
        sha256: "0123456789abcdef",
    };
    transform(&driftloop::parse(src), reference, profile, false)
        .ok()
        .map(|t| t.bytes)
}

/// The audit of `path` as transformed with `profile`, on a machine that drifts as the model predicts (so
/// no scrap alarm cuts the comparison short); `None` when the transform refuses the program.
fn audited_with(path: &Path, profile: &Profile) -> Option<Audit> {
    let original = std::fs::read(path).unwrap();
    let t = transformed(&original, profile)?;
    let settings = AuditSettings {
        dir: path.parent().map(Path::to_path_buf),
        ..AuditSettings::from_profile(profile)
    }
    .drifting_as(&model())
    .unwrap();
    Some(
        audit(&original, &t, &settings, &Config::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
}

fn audited(path: &Path) -> Option<Audit> {
    audited_with(path, &Profile::default_profile())
}

/// The programs of fixtures/omm, fixtures/vm and the turning job of fixtures/vm/audit.
fn programs() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut files: Vec<PathBuf> = ["omm", "vm"]
        .iter()
        .flat_map(|dir| std::fs::read_dir(root.join(dir)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("mpf")))
        .collect();
    files.push(root.join("vm/audit/lathe_original.mpf"));
    files.sort();
    files
}

#[test]
fn the_hand_written_part_as_transformed_today() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/handwritten.mpf");
    let a = audited(&path).unwrap();
    insta::assert_snapshot!(
        "audit_handwritten",
        a.human("handwritten.mpf (transformed)")
    );
}

/// Every builtin profile on every fixture program it transforms: the runs stay in step (no flow change, no
/// alarm on a machine that drifts as predicted), and what the audit finds is recorded per profile and
/// program — what the emitter still leaves for the lead to fix shows here.
#[test]
fn every_builtin_profile_on_every_fixture_runs_through_the_audit_in_step() {
    let mut table = String::new();
    for (name, _, _) in BUILTIN {
        let profile = Profile::builtin(name).unwrap();
        for path in programs() {
            let Some(a) = audited_with(&path, &profile) else {
                continue;
            };
            let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
            let file = path.strip_prefix(&root).unwrap().display().to_string();
            let broken: Vec<_> = a
                .findings
                .iter()
                .filter(|f| matches!(f.kind, Kind::FlowChanged | Kind::OriginalChanged))
                .collect();
            assert!(broken.is_empty(), "{name} {file}: {broken:#?}");
            assert!(a.resume_points > 0, "{name} {file}");
            assert_eq!(a.stopped, None, "{name} {file}");
            let kinds: Vec<String> = a.counts.iter().map(|(k, n)| format!("{k} {n}")).collect();
            let found = if kinds.is_empty() {
                "clean".to_string()
            } else {
                kinds.join(", ")
            };
            table.push_str(&format!("{name:18} {file:30} {found}\n"));
        }
    }
    insta::assert_snapshot!("audit_builtin_profiles", table);
}

#[test]
fn a_probe_point_on_the_face_a_siemens_cycle_mills_is_reported() {
    // QA round 9 (fixtures/shop9/REPORT.md, F4): `CYCLE61` faces X-10…130 Y-10…90 from Z1 down to Z0 over
    // the default profile's probe point X0 Y0 Z0. The dry run does not run the cycle; its region does.
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/shop9/09_828d_shopmill_gcode_cycles.mpf");
    let a = audited(&path).unwrap();
    let f = a
        .findings
        .iter()
        .find(|f| f.kind == Kind::ProbeInMachinedVolume)
        .unwrap_or_else(|| panic!("{:#?}", a.findings));
    assert!(f.message.starts_with("CYCLE61 machines"), "{}", f.message);
    assert_eq!(f.original_line, Some(9));
}

#[test]
fn the_corpus_cam_program_runs_through_the_audit() {
    let Some(cam) =
        shared_data::path("corpus/sinumerik-840d-sl-cas-package/Approach A/CAM TEST.MPF")
    else {
        return;
    };
    let a = audited(&cam).unwrap();
    assert_eq!(a.original_blocks, 996);
    assert!(a.findings.iter().all(|f| f.kind != Kind::FlowChanged));
}
