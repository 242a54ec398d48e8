//! 26 shop-style programs written for a QA run (CAM posts for 840D with swivels, high-speed settings and
//! drilling cycles, hand-written programs with loops, labels and frames, lathe and grinder programs, CRLF,
//! Latin-1, an archive; subprograms in fixtures/shop/subs) and 22 with tool changes for QA round 4
//! (fixtures/shop4, its README lists them), 25 in styles neither covers for QA round 5 (fixtures/shop5) and
//! 25 in the styles QA round 6 added (fixtures/shop6: ShopMill step programs, two channels, G331, G93, POLY,
//! G58, G75, ISO, DIAM90, a 10 648-line generated program) and 4 for QA round 7 (fixtures/shop7: a spindle
//! the operator started, a turret lathe and a grinder that name no tool loaded by M6) and 15 for QA round 8
//! (fixtures/shop8: machine builders' dialects — DMG MORI, Monforts, STAMA, Burkhardt+Weber, Pittler,
//! Hermle, INDEX)
//! through `transform` with every builtin profile.
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
    // fixtures/shop (26, QA rounds 1–2), fixtures/shop4 (22 with tool changes, QA round 4) and
    // fixtures/shop5 (25, QA round 5), fixtures/shop6 (25, QA round 6), fixtures/shop7 (4, QA round 7:
    // what the run-time tool read admitted), fixtures/shop8 (15, QA round 8: builders' dialects) and
    // fixtures/shop9 (15, QA round 9: archives, multi-part, mould, TRAORI, IFs, G18/G19).
    let sets = [
        (
            "shop",
            26,
            [
                // 23 (TRAORI) since the zero goes before a transformation (QA round 9); 08 (a LOOP
                // and a FOR over four fixtures, an offset each) since no zero goes inside a loop (QA
                // round 12: it was measured again on every fixture).
                ("blum-tc50", 20),
                ("siemens-cycle978", 20),
                ("tool-setter", 24),
                ("grinder-gauge", 24),
                ("lathe-setter", 4),
            ],
        ),
        (
            "shop4",
            22,
            [
                ("blum-tc50", 20),
                ("siemens-cycle978", 20),
                ("tool-setter", 21),
                ("grinder-gauge", 21),
                ("lathe-setter", 1),
            ],
        ),
        (
            "shop5",
            25,
            [
                ("blum-tc50", 18),
                ("siemens-cycle978", 18),
                ("tool-setter", 25),
                ("grinder-gauge", 25),
                ("lathe-setter", 6),
            ],
        ),
        (
            "shop6",
            25,
            [
                ("blum-tc50", 19),
                ("siemens-cycle978", 19),
                ("tool-setter", 21),
                ("grinder-gauge", 23),
                ("lathe-setter", 2),
            ],
        ),
        (
            "shop7",
            4,
            [
                ("blum-tc50", 2),
                ("siemens-cycle978", 2),
                ("tool-setter", 4),
                ("grinder-gauge", 4),
                ("lathe-setter", 2),
            ],
        ),
        (
            "shop8",
            15,
            [
                // 05 since a subprogram's end state is taken (L_FREI).
                ("blum-tc50", 4),
                ("siemens-cycle978", 4),
                ("tool-setter", 3),
                // 14 since GROUP_BEGIN is known to move nothing.
                ("grinder-gauge", 9),
                ("lathe-setter", 1),
            ],
        ),
        (
            "shop9",
            15,
            [
                ("blum-tc50", 14),
                ("siemens-cycle978", 14),
                ("tool-setter", 15),
                ("grinder-gauge", 15),
                ("lathe-setter", 2),
            ],
        ),
    ];
    // fixtures/cov10 (4, QA round 10's reproductions from public programs; 03 is refused rightly: its
    // subprogram selects the work offset and cuts) and fixtures/shop11 (20, QA round 11: subprograms,
    // MCALL, loops, tool-change subprograms).
    let shop11 = (
        "shop11",
        20,
        [
            ("blum-tc50", 15),
            ("siemens-cycle978", 15),
            ("tool-setter", 19),
            ("grinder-gauge", 20),
            ("lathe-setter", 3),
        ],
    );
    // fixtures/shop12 (QA round 12: reductions of the edits of real programs that lost measurements or
    // put the zero where it ran again).
    let shop12 = (
        "shop12",
        2,
        [
            ("blum-tc50", 2),
            ("siemens-cycle978", 2),
            ("tool-setter", 2),
            ("grinder-gauge", 2),
            ("lathe-setter", 0),
        ],
    );
    // fixtures/shop13 (QA round 13: reductions of public programs; 02 is a grinder, which the spindle
    // probes refuse rightly, 01 a milling program in G17, which the lathe setter refuses rightly; 03
    // changes tools with the builder's M16, which needs `tool_change_m = 16`: every builtin but the gauge
    // refuses it, naming the key).
    let shop13 = (
        "shop13",
        3,
        [
            ("blum-tc50", 1),
            ("siemens-cycle978", 1),
            ("tool-setter", 2),
            ("grinder-gauge", 3),
            ("lathe-setter", 1),
        ],
    );
    // fixtures/shop14 (QA round 14: programs in the exact output forms of public CAM posts; 06 starts with
    // the post's own probing under SPOS, which the milling probes refused until QA round 15 read its strokes
    // as a probe's, and only 03, a mill-turn program, is one for the lathe setter).
    let shop14 = (
        "shop14",
        7,
        [
            ("blum-tc50", 7),
            ("siemens-cycle978", 7),
            ("tool-setter", 7),
            ("grinder-gauge", 7),
            ("lathe-setter", 1),
        ],
    );
    // fixtures/shop15 (QA round 15: 01 a mill-turn program's CYCLE95 with its contour after the call, one
    // for the lathe setter; 02 a milling program that starts with its own probing under SPOS, which the lathe
    // setter refuses rightly; 03 probes mid-program into the work offset (`_KNUM=1` before a bare
    // `CYCLE978`), after the zero: refused by every profile).
    let shop15 = (
        "shop15",
        3,
        [
            ("blum-tc50", 2),
            ("siemens-cycle978", 2),
            ("tool-setter", 2),
            ("grinder-gauge", 2),
            ("lathe-setter", 1),
        ],
    );
    // fixtures/redteam (the red-team round on the modal state at gates; 07 and 08 are lathes, which the
    // spindle probes refuse rightly, the others milling programs in G17, which the lathe setter refuses
    // rightly).
    let redteam = (
        "redteam",
        9,
        [
            ("blum-tc50", 7),
            ("siemens-cycle978", 7),
            ("tool-setter", 9),
            ("grinder-gauge", 9),
            ("lathe-setter", 2),
        ],
    );
    // fixtures/redteam2 (the red-team round on the route of a gate; every program is a mill: the lathe
    // setter refuses the four in G17 and writes the two that select G18 or G19 before their first cut,
    // which it cannot tell from a lathe's plane: choose the profile for the machine).
    let redteam2 = (
        "redteam2",
        6,
        [
            ("blum-tc50", 6),
            ("siemens-cycle978", 6),
            ("tool-setter", 6),
            ("grinder-gauge", 6),
            ("lathe-setter", 2),
        ],
    );
    // fixtures/redteam3 (the red-team round on the places after a drilling cycle; every program is a
    // mill in G17, which the lathe setter refuses rightly).
    let redteam3 = (
        "redteam3",
        14,
        [
            ("blum-tc50", 14),
            ("siemens-cycle978", 14),
            ("tool-setter", 14),
            ("grinder-gauge", 14),
            ("lathe-setter", 0),
        ],
    );
    // fixtures/shop16 (the places after a milling or turning cycle: 03 is a lathe, which the spindle
    // probes refuse rightly, the others mills in G17, which the lathe setter refuses rightly).
    let shop16 = (
        "shop16",
        5,
        [
            ("blum-tc50", 4),
            ("siemens-cycle978", 4),
            ("tool-setter", 5),
            ("grinder-gauge", 5),
            ("lathe-setter", 1),
        ],
    );
    // fixtures/shop17 (predefined procedures read as calls before: SOFTA/BRISKA/…, WAITP, TOFFON, COMPSURF;
    // every program a mill in G17, which the lathe setter refuses rightly; 01 was refused by the spindle
    // probes while BRISKA was its first cut).
    let shop17 = (
        "shop17",
        6,
        [
            ("blum-tc50", 6),
            ("siemens-cycle978", 6),
            ("tool-setter", 6),
            ("grinder-gauge", 6),
            ("lathe-setter", 0),
        ],
    );
    // fixtures/redteam4 (red-team round 4: the spindle after an M6 of the same tool, working-area limits,
    // polar coordinates under G18, RND/CHF/CHR before a gate, a modal synchronized action); the lathe
    // setter takes only the program that selects G18 before its first cut.
    let redteam4 = (
        "redteam4",
        5,
        [
            ("blum-tc50", 5),
            ("siemens-cycle978", 5),
            ("tool-setter", 5),
            ("grinder-gauge", 5),
            ("lathe-setter", 1),
        ],
    );
    // fixtures/redteam5 (red-team round 5: a swivel left at a tool change, the feed after CYCLE63, a
    // spline at a gate, CANCEL(n), G96 on a mill, SPOS in a subprogram, a tailstock under FXS, GEOAX): 07
    // and 08 are a lathe and a grinder in G18, which the spindle probes refuse rightly; the lathe setter
    // takes only those two.
    let redteam5 = (
        "redteam5",
        8,
        [
            ("blum-tc50", 6),
            ("siemens-cycle978", 6),
            ("tool-setter", 8),
            ("grinder-gauge", 8),
            ("lathe-setter", 2),
        ],
    );
    let sets = sets
        .into_iter()
        .chain([
            shop11, shop12, shop13, shop14, shop15, shop16, shop17, redteam, redteam2, redteam3,
            redteam4, redteam5,
        ])
        .chain([(
            "cov10",
            4,
            [
                ("blum-tc50", 3),
                ("siemens-cycle978", 3),
                ("tool-setter", 3),
                // A gauge reads the part itself, not through the work offset the subprogram selects.
                ("grinder-gauge", 4),
                ("lathe-setter", 1),
            ],
        )]);
    // lathe-setter: the lathes, grinders and mill-turn programs only, since its gate (a retract along X to
    // a clearance diameter) goes nowhere the milling plane G17 is in force with X in radius.
    for (set, total, expected) in sets {
        for (profile, count) in expected {
            transforms_and_strips_back(set, total, profile, count);
        }
    }
}

/// Transforms fixtures/`set` (its subprograms in `subs`) with `profile`: `count` of `total` written, each
/// stripping back to its original.
fn transforms_and_strips_back(set: &str, total: usize, profile: &str, count: usize) {
    let dir = format!("fixtures/{set}");
    let subs = format!("{dir}/subs");
    let out = tempfile::tempdir().unwrap();
    let out_dir = out.path().display().to_string();
    let mut args = vec![
        "transform",
        &dir,
        "--model",
        "fixtures/omm/model.toml",
        "--profile",
        profile,
        "--keep-going",
        "-o",
        &out_dir,
    ];
    // A set whose programs call no subprogram has no folder for them.
    if root().join(&subs).is_dir() {
        args.extend(["--subprograms", &subs]);
    }
    let o = common::run(&args);
    let err = common::stderr(&o);
    assert!(
        err.contains(&format!("{count} of {total} programs transform")),
        "{set} {profile}: {err}"
    );
    assert!(
        !err.contains("panicked") && !err.contains("internal error"),
        "{err}"
    );
    let written = common::files_under(out.path(), &["mpf", "arc"]);
    assert_eq!(written.len(), count, "{set} {profile}");
    for file in written {
        let name = file.file_name().unwrap();
        let original = std::fs::read(root().join(&dir).join(name)).unwrap();
        let stripped = common::run(&["strip", &file.display().to_string()]);
        assert!(stripped.status.success(), "{}", common::stderr(&stripped));
        assert!(
            stripped.stdout == original,
            "{set} {profile}: {} does not strip back",
            name.to_string_lossy()
        );
    }
}
