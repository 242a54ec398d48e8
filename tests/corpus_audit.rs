//! Every real program of ../shared/corpus that transforms, with every builtin profile (as shipped, and on a
//! control whose reset selects the profile's work offset), runs side by side with its original on the
//! virtual machine. `transform` refuses any output with a hazard its blocks caused; this test shows which
//! ones it refuses that way and why: only a position the gate cannot give back after a programmable
//! translation (TRANS/ATRANS) the program's next incremental move still has to traverse. The counts are
//! printed (`cargo test --test corpus_audit -- --nocapture`) and stated in docs/results.md.

mod common;
mod shared_data;

use std::path::{Path, PathBuf};

use driftloop::model::DriftModel;
use driftloop::omm::profile::BUILTIN;
use driftloop::omm::{ModelRef, Profile, transform};
use driftloop::vm::audit::{AuditSettings, Kind, audit};

#[test]
fn every_transformed_corpus_program_passes_the_audit() {
    let Some(corpus) = shared_data::path("corpus") else {
        return;
    };
    let model = DriftModel::read(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/model.toml"),
    )
    .unwrap();
    let files = common::files_under(&corpus, &["mpf", "arc"]);
    assert!(files.len() >= 40, "{}", files.len());
    let mut total = 0;
    for (name, _, _) in BUILTIN {
        // As shipped, on a control whose reset selects the offset, with every gate measuring (the branch a
        // pause takes on the machine, which `transform` audits too), and that on a machine whose work
        // offsets are not 0 (`AuditSettings::shifted_offsets`) and a tool is in force (as `transform` audits it).
        for (reset, every, shifted) in [
            (false, false, false),
            (true, false, false),
            (false, true, false),
            (false, true, true),
        ] {
            let mut profile = Profile::builtin(name).unwrap();
            profile.offset.reset_selects = reset;
            profile.log.measure_every_gate = every;
            let settings = AuditSettings::from_profile(&profile)
                .drifting_as(&model)
                .unwrap();
            let cfg = driftloop::vm::Config {
                offsets: if shifted {
                    settings.shifted_offsets()
                } else {
                    Vec::new()
                },
                // As `transform` audits it: gates that read the tool at run time swap the probe for it.
                start_tool: shifted.then(driftloop::vm::audit::hand_loaded_tool),
                ..driftloop::vm::Config::default()
            };
            let (mut transformed, mut complete, mut warned) = (0, 0, 0);
            let mut refused = Vec::new();
            for f in &files {
                let src = std::fs::read(f).unwrap();
                let program = driftloop::parse(&src);
                let m = ModelRef {
                    model: &model,
                    sha256: "corpus",
                };
                let Ok(t) = transform(&program, m, &profile, false) else {
                    continue;
                };
                transformed += 1;
                let mut s = settings.clone();
                s.dir = f.parent().map(Path::to_path_buf);
                let Ok(found) = audit(&src, &t.bytes, &s, &cfg) else {
                    continue;
                };
                let hazards: Vec<_> = found
                    .findings
                    .iter()
                    .filter(|x| !x.kind.is_probe_point_warning())
                    .collect();
                if !hazards.is_empty() {
                    let translated = String::from_utf8_lossy(&src).contains("TRANS");
                    assert!(
                        translated && hazards.iter().all(|h| h.kind == Kind::PositionNotRestored),
                        "{name} (reset_selects {reset}, every gate measuring {every}, offsets shifted {shifted}), {}: {hazards:#?}",
                        f.display()
                    );
                    refused.push(f.file_name().unwrap().to_string_lossy().into_owned());
                    continue;
                }
                complete += usize::from(found.stopped.is_none());
                warned += usize::from(!found.findings.is_empty());
            }
            println!(
                "{name:<17} reset_selects={reset:<5} every_gate={every:<5} shifted={shifted:<5}: {} of {} programs pass the audit ({complete} run to the end, {warned} with the probe point in the cut); refused by the audit: {refused:?}",
                transformed - refused.len(),
                files.len()
            );
            total += transformed;
        }
    }
    assert!(total > 0);
}

/// The README's command over the corpus, as a user runs it (no subprogram folder given: the warm-up
/// routines find theirs in `../subroutines`): how many programs each profile transforms, audit on.
#[test]
fn the_readme_command_transforms_what_the_readme_says() {
    let Some(corpus) = shared_data::path("corpus") else {
        return;
    };
    let model = common::fixture("omm/model.toml");
    let corpus = corpus.display().to_string();
    for (profile, checked) in [
        ("blum-tc50", 36),
        ("siemens-cycle978", 36),
        ("tool-setter", 37),
        ("grinder-gauge", 36),
        ("lathe-setter", 29),
    ] {
        let args = [
            "transform",
            "--check",
            &corpus,
            "--model",
            &model,
            "--profile",
            profile,
            "--keep-going",
        ];
        let o = common::run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        let summary = format!("the other {checked} checked");
        assert!(
            err.contains(&summary),
            "{profile}: {}",
            err.lines().last().unwrap_or("")
        );
    }
}
