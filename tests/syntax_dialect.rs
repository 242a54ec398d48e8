//! The dialect as the control accepts it (docs/dialect.md): blanks between address and value, the DOS
//! end-of-file byte, control characters, labels defined twice, full-width punctuation, CASE values without
//! blanks, `<<` as a prefix, ELSE in synchronized actions, one control statement per block.

mod syntax_support;

use driftloop::syntax::{Decimal, Words, parse_owned_with};
use driftloop::views::{BlockFacts, Value, facts};
use driftloop::{BlockKind, LineIndex, NodeKind as K, Program, Severity, analyze, parse};
use proptest::prelude::*;
use syntax_support::{errors, find_in, fixture, resolved_jumps, statement_kinds, text};

/// (line, severity, message) of every diagnostic.
fn diagnostics(p: &Program) -> Vec<(usize, Severity, String)> {
    let index = LineIndex::new(p.source());
    p.diagnostics()
        .iter()
        .map(|d| {
            (
                index.line_col(d.span.start).0,
                d.severity,
                d.message.clone(),
            )
        })
        .collect()
}

/// What the views read off a block, without the spans (which differ between `X10` and `X 10`).
fn values(f: &BlockFacts) -> String {
    let av = |v: &[driftloop::views::AddressValue]| -> Vec<(Option<u32>, Value)> {
        v.iter().map(|a| (a.extension, a.value.clone())).collect()
    };
    let axes: Vec<(String, Value)> = f
        .axes
        .iter()
        .map(|a| (a.axis.clone(), a.value.clone()))
        .collect();
    format!(
        "N{:?} G{:?} motion{:?} axes{axes:?} T{:?} S{:?} M{:?} F{:?} calls{:?}",
        f.block_number,
        f.g_codes,
        f.motion,
        av(&f.tools),
        av(&f.spindle_speeds),
        av(&f.m_codes),
        f.feed.as_ref().map(|a| a.value.clone()),
        f.calls,
    )
}

#[test]
fn blanks_between_address_and_value_give_the_same_words() {
    let spaced = parse(b"N 10 G 1 X 10 Y -2.5 Z .5 S 1000 T 5 F 100 M 3 D 1\nN20 L 100 P 2\n");
    let packed = parse(b"N10 G1 X10 Y-2.5 Z.5 S1000 T5 F100 M3 D1\nN20 L100 P2\n");
    assert_eq!(errors(&spaced), Vec::<String>::new());
    for i in 0..2 {
        assert_eq!(
            statement_kinds(&spaced, i),
            statement_kinds(&packed, i),
            "line {}",
            i + 1
        );
        assert_eq!(
            values(&facts(&spaced.block(i))),
            values(&facts(&packed.block(i)))
        );
    }
    let x = find_in(&spaced, 0, K::Word).unwrap();
    let kinds: Vec<K> = x.children.iter().map(|c| c.kind).collect();
    assert_eq!(kinds, vec![K::Address, K::Trivia, K::Number], "G 1");
    let number = find_in(&spaced, 0, K::BlockNumber).unwrap();
    assert_eq!(text(&spaced, number.children.last().unwrap()), "10");
    assert_eq!(facts(&spaced.block(0)).block_number, Some(10));
}

#[test]
fn blanks_do_not_split_names_assignments_or_keywords() {
    let p = parse(b"N40 X1=10 RND=2 CR=5\nIF R1 > 0 GOTOF LBL\nLBL: GOTOB LBL\nR1 = 5\n");
    assert_eq!(errors(&p), Vec::<String>::new());
    assert_eq!(
        statement_kinds(&p, 0),
        vec![K::BlockNumber, K::Assign, K::Assign, K::Assign]
    );
    assert_eq!(statement_kinds(&p, 1), vec![K::If, K::Goto]);
    assert_eq!(statement_kinds(&p, 3), vec![K::Assign]);
    // A letter and a number after `=` are no word: `X 1=5` stays an error.
    assert_eq!(
        errors(&parse(b"X 1=5\n")),
        vec!["1:3 expected a word, assignment, call or keyword, found `1=5`"]
    );
}

#[test]
fn the_dialect_fixture_parses_with_warnings_only() {
    let p = parse(&fixture("dialect.mpf"));
    assert_eq!(
        diagnostics(&p),
        vec![
            (11, Severity::Warning, "label BACK is defined again".into()),
            (13, Severity::Warning, "label AHEAD is defined again".into()),
        ]
    );
    let s = analyze(&p);
    let labels: Vec<(&str, usize)> = s.labels.iter().map(|(l, b)| (l.as_str(), *b)).collect();
    assert_eq!(
        labels,
        vec![("BACK", 6), ("AHEAD", 8), ("BACK", 10), ("AHEAD", 12)],
        "every definition"
    );
    assert_eq!(
        resolved_jumps(&p),
        ["7 AHEAD 8", "9 BACK 6", "11 AHEAD 12", "11 AHEAD 12"],
        "GOTOF to the next AHEAD, GOTOB to the nearest BACK before it (the computed target is the \
         dry run's to resolve)"
    );
    // CASE values without blanks: `OF-1 GOTOF AHEAD-2 GOTOF AHEAD`.
    let case = find_in(&p, 11, K::Case).unwrap();
    let arms: Vec<String> = case
        .children
        .iter()
        .filter(|c| c.kind == K::CaseArm)
        .map(|c| text(&p, c))
        .collect();
    assert_eq!(
        arms,
        vec![
            "-1 GOTOF AHEAD",
            "-2 GOTOF AHEAD",
            "DEFAULT GOTOF \"AHE\"<<\"AD\""
        ]
    );
    let to_string = find_in(&p, 12, K::Unary).unwrap();
    assert_eq!(text(&p, &to_string), "<<R1");
    assert_eq!(
        p.block_kind(13),
        BlockKind::Plain,
        "the ELSE of a synchronized action"
    );
    let last = p.block_count() - 1;
    assert_eq!(text(&p, &p.block(last).root), "\u{1a}");
    assert_eq!(statement_kinds(&p, last), Vec::<K>::new());
}

#[test]
fn the_dos_end_of_file_byte_is_trivia() {
    for src in [
        &b"M30\x1a"[..],
        b"M30\n\x1a",
        b"M30\n\x1a\n",
        b"M30\r\n\x1a\r\n\x1a\x1a",
        b"\x1a",
    ] {
        let p = parse(src);
        assert_eq!(p.to_bytes(), src);
        assert_eq!(diagnostics(&p), vec![], "{}", src.escape_ascii());
        for b in p.blocks() {
            assert!(
                b.root.significant().all(|n| n.kind == K::Word),
                "{}",
                src.escape_ascii()
            );
        }
    }
    let p = parse(b"G1 X10\n\x1a\nG1 X20\n");
    assert_eq!(
        diagnostics(&p),
        vec![(
            2,
            Severity::Warning,
            "DOS end-of-file byte 0x1A before the end of the file".into()
        )]
    );
}

#[test]
fn control_characters_are_blanks_with_a_warning() {
    let p = parse(b"G1 X20\x00Y10\x7f\n");
    assert_eq!(statement_kinds(&p, 0), vec![K::Word, K::Word, K::Word]);
    assert_eq!(
        diagnostics(&p),
        vec![
            (
                1,
                Severity::Warning,
                "control character 0x00 read as a blank".into()
            ),
            (
                1,
                Severity::Warning,
                "control character 0x7F read as a blank".into()
            ),
        ]
    );
}

#[test]
fn full_width_punctuation_is_named_with_its_bytes() {
    let src = b"G1 X10 \xa3\xbb comment\nLBL\xa3\xba X1\nG1 X10\xa3\xa8abc\xa3\xa9\n\xb1\xea\xc7\xa9: X1\nMSG(\"\xa3\xbb\") ; \xa3\xbb\n";
    let p = parse(src);
    assert_eq!(p.to_bytes(), src);
    assert_eq!(
        errors(&p),
        vec![
            "1:8 expected a word, assignment, call or keyword, found a full-width `;` (GBK A3 BB)",
            "2:4 expected a word, assignment, call or keyword, found a full-width `:` (GBK A3 BA)",
            "3:7 expected a word, assignment, call or keyword, found a full-width `(` (GBK A3 A8)",
            "4:1 expected a word, assignment, call or keyword, found the non-ASCII byte 0xB1",
        ],
        "in a string or a comment they are fine"
    );
    let d = &p.diagnostics()[0];
    assert_eq!(d.span.slice(src), b"\xa3\xbb");
    assert!(d.help.as_deref().unwrap().contains("ASCII `;`"));
    assert_eq!(
        statement_kinds(&p, 0),
        vec![K::Word, K::Word, K::Error],
        "the words before the junk are kept"
    );
    let utf8 = parse("G1 X10 ；注释\n".as_bytes());
    assert_eq!(
        errors(&utf8),
        vec![
            "1:8 expected a word, assignment, call or keyword, found a full-width `;` (UTF-8 EF BC 9B)"
        ]
    );
}

#[test]
fn a_block_holds_one_control_statement() {
    let p = parse(b"IF R1>1\nX1\nELSE IF R1>2\nX2\nENDIF\nENDIF\n");
    assert_eq!(
        errors(&p),
        vec![
            "3:6 IF after ELSE in the same block: a block holds one control statement",
            "6:1 ENDIF on line 6 has no matching IF",
        ]
    );
    let p = parse(b"IF R1==1 GOTOF LA IF R1==2 GOTOF LB\nLA: X1\nLB: X2\n");
    assert_eq!(errors(&p), Vec::<String>::new(), "several IF … GOTO");
    assert_eq!(p.block_kind(0), BlockKind::Plain);
    let p = parse(b"ID=1 EVERY $A_IN[1] DO $R1=1 ELSE $R1=0 ELSE\n");
    assert_eq!(
        errors(&p),
        vec!["1:41 ELSE on line 1 has no matching IF"],
        "one ELSE belongs to the synchronized action, the second to no IF"
    );
}

/// The words the fast recogniser hands to a reader (the timeline's path), as letter and value.
#[derive(Default)]
struct Heard(Vec<(u8, Option<f64>)>);

impl Words for Heard {
    type Number = Decimal;
    fn skip_level(&mut self) {}
    fn word(&mut self, letter: u8, number: &Decimal) {
        self.0.push((letter, number.value()));
    }
    fn comment(&mut self) {}
    fn end_line(&mut self) {}
    fn other_line(&mut self, _: Option<&[u8]>) {
        self.0.push((b'?', None));
    }
}

fn heard(src: &str) -> Vec<(u8, Option<f64>)> {
    let (_, pieces) = parse_owned_with(src.as_bytes().to_vec(), Heard::default);
    pieces.into_iter().flat_map(|(_, h)| h.0).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// `X 10` is `X10` for the grammar, the views and the fast recogniser alike.
    #[test]
    fn blanks_after_an_address_letter_change_nothing(
        words in prop::collection::vec(
            (
                prop::sample::select(&b"GXYZABCFSTMDHIJKLPEgxyz"[..]),
                -99_999i32..99_999,
                0u32..4,
                prop::sample::select(&[" ", "  ", "\t", "&", " \t "][..]),
            ),
            1..8,
        )
    ) {
        let (mut packed, mut spaced) = (String::new(), String::new());
        for (letter, value, scale, blank) in words {
            let v = f64::from(value) / 10f64.powi(scale as i32);
            packed += &format!("{}{v} ", letter as char);
            spaced += &format!("{}{blank}{v} ", letter as char);
        }
        let (p, s) = (parse(packed.as_bytes()), parse(spaced.as_bytes()));
        prop_assert!(s.diagnostics().is_empty(), "{spaced}: {:?}", s.diagnostics());
        prop_assert_eq!(statement_kinds(&s, 0), statement_kinds(&p, 0));
        prop_assert_eq!(values(&facts(&s.block(0))), values(&facts(&p.block(0))));
        let spaced_words = heard(&spaced);
        prop_assert!(!spaced_words.contains(&(b'?', None)), "the fast path takes {spaced}");
        prop_assert_eq!(spaced_words, heard(&packed));
    }
}

#[test]
fn operators_and_names_the_control_refuses_are_errors_with_a_hint() {
    // `=<` is no relational operator (== <> < > <= >=), in a condition or in a synchronized action.
    let p = parse(b"IF R1=<2 GOTOF DONE\nID=1 WHEN $R1=<$AA_IM[X] DO M8\nDONE: M30\n");
    let found: Vec<(usize, String, Option<String>)> = p
        .diagnostics()
        .iter()
        .filter(|d| d.message.contains("found `=<"))
        .map(|d| {
            let line = LineIndex::new(p.source()).line_col(d.span.start).0;
            (line, d.message.clone(), d.help.clone())
        })
        .collect();
    assert_eq!(
        found.iter().map(|f| f.0).collect::<Vec<_>>(),
        [1, 2],
        "{found:?}"
    );
    for (_, _, help) in &found {
        assert!(help.as_deref().unwrap_or("").contains("write `<=`"));
    }
    let p = parse(b"WHILE R1=>0\nR1=R1-1\nENDWHILE\n");
    let help = p.diagnostics()[0].help.clone().unwrap();
    assert!(help.contains("write `>=`"), "{help}");
    // `$$` doubles the `$` once: three are no name, and DEF does not declare a system variable.
    assert_eq!(errors(&parse(b"ID=1 WHEN $$$AA_IM[X]>1 DO M8\n")).len(), 1);
    assert_eq!(errors(&parse(b"$$=1\n")).len(), 1);
    let p = parse(b"DEF INT $P_COUNT\n");
    assert_eq!(errors(&p).len(), 1);
    let help = p.diagnostics()[0].help.clone().unwrap();
    assert!(help.contains("system variables"), "{help}");
}
