//! The audit on what `transform` writes today: the hand-written part's findings are recorded (they show
//! what the emitter has to fix; the snapshot changes when it is fixed), and every program the transform
//! accepts runs through the audit without the virtual machine giving up.

mod shared_data;

use std::path::Path;

use driftloop::model::DriftModel;
use driftloop::omm::{ModelRef, Profile, transform};
use driftloop::vm::Config;
use driftloop::vm::audit::{Audit, AuditSettings, Kind, audit};

fn transformed(src: &[u8]) -> Option<Vec<u8>> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    let model = DriftModel::read(path.as_ref()).unwrap();
    let reference = ModelRef {
        model: &model,
        sha256: "0123456789abcdef",
    };
    transform(
        &driftloop::parse(src),
        reference,
        &Profile::default_profile(),
        false,
    )
    .ok()
    .map(|t| t.bytes)
}

fn audited(path: &Path) -> Option<Audit> {
    let original = std::fs::read(path).unwrap();
    let t = transformed(&original)?;
    let settings = AuditSettings {
        dir: path.parent().map(Path::to_path_buf),
        ..AuditSettings::from_profile(&Profile::default_profile())
    };
    Some(
        audit(&original, &t, &settings, &Config::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
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

#[test]
fn every_transformed_fixture_runs_through_the_audit_in_step() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut audited_files = 0;
    for dir in ["omm", "vm"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path
                .extension()
                .is_none_or(|e| !e.eq_ignore_ascii_case("mpf"))
            {
                continue;
            }
            let Some(a) = audited(&path) else { continue };
            audited_files += 1;
            let broken: Vec<_> = a
                .findings
                .iter()
                .filter(|f| matches!(f.kind, Kind::FlowChanged | Kind::OriginalChanged))
                .collect();
            assert!(broken.is_empty(), "{}: {broken:#?}", path.display());
            assert!(
                a.resume_points > 0 && a.stopped.is_none(),
                "{}",
                path.display()
            );
        }
    }
    assert!(audited_files >= 8, "{audited_files}");
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
