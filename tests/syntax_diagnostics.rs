//! Diagnostics: error lines, unmatched control structures and unknown labels point at both ends.

mod syntax_support;

use driftloop::{LineIndex, Severity, parse};
use syntax_support::{errors, fixture};

#[test]
fn errors_fixture_reports_each_problem_once_at_its_place() {
    let p = parse(&fixture("errors.mpf"));
    assert_eq!(
        errors(&p),
        vec![
            "3:5 WHILE on line 3 has no ENDWHILE",
            "5:11 GOTOF target NOWHERE is not defined",
            "6:11 GOTOB searches backward, but LATER is on line 7",
            "8:11 expected `)`, found end of line",
            "9:12 expected a word, assignment, call or keyword, found `)`",
            "10:5 ENDFOR on line 10 has no matching FOR",
        ]
    );
    assert!(p.has_errors());
    let index = LineIndex::new(p.source());
    let warnings: Vec<(usize, &str, Vec<&str>)> = p
        .diagnostics()
        .iter()
        .filter(|d| d.severity == Severity::Warning)
        .map(|d| {
            let notes = d.related.iter().map(|r| r.1.as_str()).collect();
            (index.line_col(d.span.start).0, d.message.as_str(), notes)
        })
        .collect();
    assert_eq!(
        warnings,
        vec![(
            12,
            "label DUP is defined again",
            vec!["first defined on line 11"]
        )],
        "the control accepts a label twice: a warning, not an error"
    );
}

#[test]
fn unclosed_structure_points_at_both_ends() {
    let src = b"N10 G0 X0\nN20 IF R1>0\nN30 G1 X1\nN40 M30\n";
    let p = parse(src);
    let index = LineIndex::new(src);
    assert_eq!(p.diagnostics().len(), 1);
    let d = &p.diagnostics()[0];
    assert_eq!(d.severity, Severity::Error);
    assert_eq!(d.message, "IF on line 2 has no ENDIF");
    assert_eq!(index.line_col(d.span.start), (2, 5));
    assert_eq!(d.span.slice(src), b"IF");
    assert_eq!(d.related.len(), 1);
    assert_eq!(
        index.line_col(d.related[0].0.start).0,
        4,
        "the other end: where the program ends"
    );
}

#[test]
fn stray_closer_names_the_open_structure() {
    let p = parse(b"WHILE R1<3\nENDIF\nENDWHILE\n");
    let d: Vec<_> = p.diagnostics().iter().collect();
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].message, "ENDIF on line 2 has no matching IF");
    assert_eq!(d[0].related[0].1, "innermost open WHILE is on line 1");
}

#[test]
fn structures_and_labels_are_scoped_per_archive_unit() {
    let src = b"%_N_A_MPF\nIF R1\nSHARED: X1\n%_N_B_MPF\nENDIF\nGOTOB SHARED\n";
    let msgs: Vec<String> = parse(src)
        .diagnostics()
        .iter()
        .map(|d| d.message.clone())
        .collect();
    assert_eq!(
        msgs,
        vec![
            "IF on line 2 has no ENDIF",
            "ENDIF on line 5 has no matching IF",
            "GOTOB target SHARED is not defined"
        ]
    );
}

#[test]
fn error_line_diagnostic_has_expected_found_and_help() {
    let p = parse(b"G1 X10\nG1 X=\nG0 Y0\n");
    assert_eq!(
        errors(&p),
        vec!["2:6 expected an operand, found end of line"]
    );
    assert!(p.diagnostics()[0].help.is_some());
    assert_eq!(
        p.block(2).root.significant().count(),
        2,
        "parsing continues after the error line"
    );
}

#[test]
fn an_assignment_with_no_value_says_which_word_and_what_to_do() {
    // QA round 15 (F10): a CAM post's probing output writes a measuring cycle's parameter with nothing after
    // its `=`. The error names the line; the help names the word and the two ways to mend it.
    let p = parse(b"N10 _TSA=1 _PRNUM=1 _VMS=0 _NMSP=1 _FA=5 _K=\nN20 CYCLE978\n");
    assert_eq!(
        errors(&p),
        vec!["1:45 expected an operand, found end of line"]
    );
    let help = p.diagnostics()[0].help.as_deref().unwrap();
    assert!(
        help.contains("`_K=` assigns no value") && help.contains("`_K=1`"),
        "{help}"
    );
    // Another error at the end of a line keeps its general help.
    let p = parse(b"G1 X10 +\n");
    assert!(
        !p.diagnostics()[0]
            .help
            .as_deref()
            .unwrap()
            .contains("assigns no value")
    );
}

#[test]
fn diagnostics_are_sorted_by_position() {
    let p = parse(&fixture("errors.mpf"));
    let starts: Vec<usize> = p.diagnostics().iter().map(|d| d.span.start).collect();
    let mut sorted = starts.clone();
    sorted.sort();
    assert_eq!(starts, sorted);
}

#[test]
fn label_names_follow_the_control_rules() {
    let p = parse(b"_1LBL: X1\nA: X2\nOK_1: X3\n");
    assert_eq!(
        errors(&p),
        vec![
            "1:1 label names have 2 to 32 characters, the first two letters or `_`",
            "2:1 label names have 2 to 32 characters, the first two letters or `_`"
        ]
    );
}

#[test]
fn error_spans_cover_whole_utf8_characters_only_when_valid() {
    let span_of = |src: &[u8]| parse(src).diagnostics()[0].span;
    assert_eq!(span_of("G1 X=\u{fc}\n".as_bytes()).len(), 2, "ü in UTF-8");
    assert_eq!(span_of("R1=5 \u{20ac}\n".as_bytes()).len(), 3, "€ in UTF-8");
    assert_eq!(
        span_of(b"\n\xef\xbb\xbf \n").len(),
        3,
        "a BOM in the middle of the file"
    );
    assert_eq!(span_of(b"G1 X=\xfc\n").len(), 1, "Latin-1 ü");
    assert_eq!(span_of(b"G1 X=\xe2\x82\n").len(), 1, "truncated sequence");
}
