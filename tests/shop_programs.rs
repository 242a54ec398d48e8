//! 26 shop-style programs written for a QA run (CAM posts for 840D with swivels, high-speed settings and
//! drilling cycles, hand-written programs with loops, labels and frames, lathe and grinder programs, CRLF,
//! Latin-1, an archive; subprograms in fixtures/shop/subs) through `transform` with every builtin profile.
//! Each output is audited by `transform` itself (as planned and with every gate measuring); here every
//! written program must give its original back through `strip`, and the counts of what transforms are held
//! (a change that refuses more, or writes what it refused, shows here).

mod common;

use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn shop_programs_transform_with_every_builtin_profile_and_strip_back() {
    let expected = [
        ("blum-tc50", 18),
        ("siemens-cycle978", 18),
        ("tool-setter", 23),
        ("grinder-gauge", 23),
        ("lathe-setter", 23),
    ];
    for (profile, count) in expected {
        let out = tempfile::tempdir().unwrap();
        let o = common::run(&[
            "transform",
            "fixtures/shop",
            "--model",
            "fixtures/omm/model.toml",
            "--profile",
            profile,
            "--subprograms",
            "fixtures/shop/subs",
            "--keep-going",
            "-o",
            &out.path().display().to_string(),
        ]);
        let err = common::stderr(&o);
        assert!(
            err.contains(&format!("{count} of 26 programs transform")),
            "{profile}: {err}"
        );
        assert!(
            !err.contains("panicked") && !err.contains("internal error"),
            "{err}"
        );
        let written = common::files_under(out.path(), &["mpf", "arc"]);
        assert_eq!(written.len(), count, "{profile}");
        for file in written {
            let name = file.file_name().unwrap();
            let original = std::fs::read(root().join("fixtures/shop").join(name)).unwrap();
            let stripped = common::run(&["strip", &file.display().to_string()]);
            assert!(stripped.status.success(), "{}", common::stderr(&stripped));
            assert!(
                stripped.stdout == original,
                "{profile}: {} does not strip back",
                name.to_string_lossy()
            );
        }
    }
}
