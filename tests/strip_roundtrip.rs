//! `strip(transform(x)) == x` byte for byte: for the fixtures and every corpus program that transforms with
//! any builtin profile (each with and without `reset_selects`), each also with CRLF, lone CR and without
//! its final newline, and for random programs with mixed line endings.

mod common;
mod shared_data;

use std::path::{Path, PathBuf};

use driftloop::model::DriftModel;
use driftloop::omm::{ModelRef, Profile, transform};
use driftloop::strip::strip;
use proptest::prelude::*;

fn model() -> DriftModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    DriftModel::read(path.as_ref()).unwrap()
}

/// The transformed program, or `None` when the transform refuses it.
/// The default profile on a control whose reset selects G54: programs that select no work offset
/// transform too, so more of them are stripped back.
fn profile() -> Profile {
    let mut p = Profile::default_profile();
    p.offset.reset_selects = true;
    p
}

/// Every builtin profile as shipped and on a control whose reset selects its offset.
fn every_profile() -> Vec<(String, Profile)> {
    let mut all = Vec::new();
    for (name, _, _) in driftloop::omm::profile::BUILTIN {
        let shipped = Profile::builtin(name).unwrap();
        let mut selecting = shipped.clone();
        selecting.offset.reset_selects = true;
        all.push((name.to_string(), shipped));
        all.push((format!("{name} reset_selects"), selecting));
    }
    all
}

fn transformed(src: &[u8], model: &DriftModel, profile: &Profile) -> Option<Vec<u8>> {
    let program = driftloop::parse(src);
    let reference = ModelRef {
        model,
        sha256: "0123456789abcdef",
    };
    transform(&program, reference, profile, false)
        .ok()
        .map(|t| t.bytes)
}

/// The program with every line ending replaced by `eol`.
fn with_endings(src: &[u8], eol: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(src.len() + src.len() / 16);
    for line in driftloop::source::raw_lines(src) {
        out.extend_from_slice(line.content().slice(src));
        if line.end > line.content_end {
            out.extend_from_slice(eol);
        }
    }
    out
}

/// The program and its variants: CRLF, lone CR, LF, and without the final line ending.
fn variants(src: &[u8]) -> Vec<(&'static str, Vec<u8>)> {
    let mut no_final = src.to_vec();
    while matches!(no_final.last(), Some(b'\n' | b'\r')) {
        no_final.pop();
    }
    vec![
        ("as is", src.to_vec()),
        ("CRLF", with_endings(src, b"\r\n")),
        ("CR", with_endings(src, b"\r")),
        ("LF", with_endings(src, b"\n")),
        ("no final newline", no_final),
    ]
}

/// Checks the round trip of every variant of `src`; returns whether the transform accepted the program.
fn round_trips(name: &str, src: &[u8], model: &DriftModel, profile: &Profile) -> bool {
    let mut accepted = false;
    for (variant, x) in variants(src) {
        let Some(t) = transformed(&x, model, profile) else {
            continue;
        };
        accepted = true;
        let s = strip(&t);
        assert!(s.header.is_some(), "{name} ({variant}): no header found");
        assert!(
            s.bytes == x,
            "{name} ({variant}): strip(transform(x)) differs from x at byte {}",
            s.bytes.iter().zip(&x).take_while(|(a, b)| a == b).count()
        );
        let inserted = t.len() - x.len();
        assert!(inserted > 0 && !s.removed.is_empty());
    }
    accepted
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    driftloop::walk::expand(&[dir])
        .unwrap()
        .into_iter()
        .filter_map(|i| match i {
            driftloop::walk::Input::File(p) => Some(p),
            driftloop::walk::Input::Stdin => None,
        })
        .collect()
}

/// The files of `files` that transform with `profile`, each checked to strip back.
fn accepted<'f>(files: &'f [PathBuf], model: &DriftModel, profile: &Profile) -> Vec<&'f PathBuf> {
    files
        .iter()
        .filter(|f| {
            let src = std::fs::read(f).unwrap();
            round_trips(&f.display().to_string(), &src, model, profile)
        })
        .collect()
}

#[test]
fn fixtures_strip_back_to_the_original() {
    let model = model();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let mut files = Vec::new();
    for dir in ["omm", "vm"] {
        files.extend(files_in(&root.join(dir)).into_iter().filter(|f| {
            f.extension().is_some_and(|e| e.eq_ignore_ascii_case("mpf"))
                && f.parent() == Some(&root.join(dir))
        }));
    }
    for (name, profile) in every_profile() {
        let accepted = accepted(&files, &model, &profile);
        if name == "blum-tc50 reset_selects" {
            // The hand-written part and its line-ending variants are certainly among them.
            assert!(accepted.iter().any(|f| f.ends_with("omm/handwritten.mpf")));
            assert!(accepted.iter().any(|f| f.ends_with("omm/crlf.mpf")));
            assert!(accepted.len() >= 7, "{accepted:?}");
        }
    }
}

#[test]
fn corpus_programs_strip_back_to_the_original() {
    let Some(corpus) = shared_data::path("corpus") else {
        return;
    };
    let model = model();
    let files = files_in(&corpus);
    let mut covered = std::collections::BTreeSet::new();
    for (name, profile) in every_profile() {
        let accepted = accepted(&files, &model, &profile);
        eprintln!(
            "corpus, {name}: {} of {} files transform and strip back",
            accepted.len(),
            files.len()
        );
        covered.extend(accepted);
    }
    eprintln!(
        "corpus: {} of {} files transform with some builtin profile (the others have no pass, syntax errors, no move or another offset)",
        covered.len(),
        files.len()
    );
    // The real CAM program (tool names, SUPA, CYCLE800()) is one of them.
    assert!(
        covered.iter().any(|f| f.ends_with("CAM TEST.MPF")),
        "{covered:?}"
    );
}

#[test]
fn a_bom_and_a_header_block_survive() {
    let (model, profile) = (model(), profile());
    let src = b"\xEF\xBB\xBF%_N_PART_MPF\n;$PATH=/_N_WKS_DIR/_N_PART_WPD\nG54\nT1 M6\nS2000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG1 X50\nG0 Z50\nM30";
    assert!(round_trips("bom", src, &model, &profile));
}

const PIECES: &[&str] = &[
    "T=\"END_MILL\" M6",
    "S4000 M3",
    "G0 X0 Y0 Z20",
    "G1 Z-2 F120",
    "G1 X80 Y15",
    "G0 Z30",
    "M5",
    "; a comment ending in DL",
    "R7=R7+1",
    "",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn random_programs_with_mixed_endings_strip_back(
        picks in prop::collection::vec((0..PIECES.len(), 0..3usize), 0..40),
        final_newline: bool,
        bom: bool,
        end: bool,
    ) {
        let endings: [&[u8]; 3] = [b"\n", b"\r\n", b"\r"];
        let mut x = Vec::new();
        if bom {
            x.extend_from_slice(b"\xEF\xBB\xBF");
        }
        x.extend_from_slice(b"G54\nT1 M6\nS2000 M3\nG0 X0 Y0 Z50\n");
        for &(p, e) in &picks {
            x.extend_from_slice(PIECES[p].as_bytes());
            x.extend_from_slice(endings[e]);
        }
        // Without M30 the restore block goes after the last line, which then may have no line ending.
        x.extend_from_slice(if end { b"M30" } else { b"G0 Z50" });
        if final_newline {
            x.extend_from_slice(endings[picks.len() % 3]);
        }
        let (model, profile) = (model(), profile());
        let t = transformed(&x, &model, &profile);
        prop_assert!(t.is_some(), "a tool change and a move: the transform accepts every such program");
        prop_assert_eq!(strip(&t.unwrap()).bytes, x);
    }
}

#[test]
fn cli_strips_checks_and_leaves_plain_programs_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (model, profile) = (model(), profile());
    let original =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/omm/handwritten.mpf"))
            .unwrap();
    let t = transformed(&original, &model, &profile).unwrap();
    let tp = dir.path().join("t.mpf");
    std::fs::write(&tp, &t).unwrap();
    let plain = dir.path().join("plain.mpf");
    std::fs::write(&plain, &original).unwrap();

    let out = common::driftloop(dir.path(), &["strip", "t.mpf", "-o", "back.mpf"], b"");
    assert!(out.status.success(), "{}", common::stderr(&out));
    assert_eq!(
        std::fs::read(dir.path().join("back.mpf")).unwrap(),
        original
    );
    assert!(common::stderr(&out).contains("inserted line(s) removed"));

    let out = common::driftloop(dir.path(), &["strip", "-"], &t);
    assert_eq!(out.stdout, original);

    let out = common::driftloop(dir.path(), &["strip", "--check", "t.mpf", "plain.mpf"], b"");
    assert_eq!(out.status.code(), Some(1));
    let out = common::driftloop(dir.path(), &["strip", "--check", "plain.mpf"], b"");
    assert_eq!(out.status.code(), Some(0));
    assert!(common::stderr(&out).contains("no driftloop header, nothing to strip"));

    let out = common::driftloop(
        dir.path(),
        &["strip", "--in-place", "t.mpf", "plain.mpf"],
        b"",
    );
    assert!(out.status.success(), "{}", common::stderr(&out));
    assert_eq!(std::fs::read(&tp).unwrap(), original);
    assert_eq!(std::fs::read(&plain).unwrap(), original);

    let out = common::driftloop(dir.path(), &["strip", "t.mpf", "plain.mpf"], b"");
    assert_eq!(out.status.code(), Some(2));
    assert!(common::stderr(&out).contains("--in-place or --check"));
}
