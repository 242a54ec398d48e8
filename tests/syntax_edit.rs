//! Edit API: untouched blocks verbatim, new blocks in the file's line ending, checked before accepted.

mod syntax_support;

use driftloop::{EditError, Editor, parse};
use syntax_support::fixture;

#[test]
fn inserts_and_replacements_use_the_dominant_line_ending() {
    let src = fixture("crlf.mpf");
    let p = parse(&src);
    let mut e = Editor::new(&p);
    e.insert_before(0, "; measured").unwrap();
    e.insert_after(1, "R1=R1+1\nSTOPRE").unwrap();
    e.replace(2, "N30 M17").unwrap();
    assert_eq!(
        e.to_bytes(),
        b"; measured\r\nN10 G0 X0\r\nN20 G1 X10 F100\r\nR1=R1+1\r\nSTOPRE\r\nN30 M17\r\n".to_vec()
    );
    let edited = e.finish();
    assert_eq!(edited.block_count(), 6);
    assert!(!edited.has_errors());
}

#[test]
fn untouched_blocks_keep_their_own_endings() {
    let src = fixture("mixed_endings.mpf");
    let p = parse(&src);
    let mut e = Editor::new(&p);
    e.insert_after(2, "G4 F1").unwrap();
    let out = e.to_bytes();
    // Dominant ending of this file is CRLF (3 of 6 lines); the lone CR of block 2 stays.
    assert_eq!(
        out,
        b"N10 G0 X0\r\nN20 X1\nN30 X2\rG4 F1\r\nN40 X3\r\n\r\nN50 M30\n".to_vec()
    );
}

#[test]
fn bom_stays_first_and_missing_final_newline_stays_missing() {
    let p = parse(&fixture("bom.mpf"));
    let mut e = Editor::new(&p);
    e.insert_before(0, "; head").unwrap();
    assert_eq!(
        e.to_bytes(),
        b"\xef\xbb\xbf; head\nN10 G0 X0\nN20 M30\n".to_vec()
    );

    let p = parse(&fixture("no_final_newline.mpf"));
    let mut e = Editor::new(&p);
    e.insert_after(1, "; tail").unwrap();
    assert_eq!(e.to_bytes(), b"N10 G0 X0\nN20 M30\n; tail".to_vec());
    let mut e = Editor::new(&p);
    e.replace(1, "M02").unwrap();
    assert_eq!(e.to_bytes(), b"N10 G0 X0\nM02".to_vec());
}

#[test]
fn blocks_with_errors_are_refused() {
    let p = parse(b"G0 X0\n");
    let mut e = Editor::new(&p);
    match e.insert_after(0, "G1 X=(1+") {
        Err(EditError::Rejected { text, diagnostics }) => {
            assert_eq!(text, "G1 X=(1+");
            assert!(!diagnostics.is_empty());
        }
        other => panic!("expected a refusal, got {other:?}"),
    }
    assert!(matches!(
        e.replace(5, "G0"),
        Err(EditError::NoSuchBlock { index: 5, count: 1 })
    ));
    assert_eq!(
        e.to_bytes(),
        b"G0 X0\n".to_vec(),
        "a refused edit changes nothing"
    );
}

#[test]
fn inserted_structures_are_checked_on_the_finished_program() {
    let p = parse(b"G0 X0\nM30\n");
    let mut e = Editor::new(&p);
    e.insert_after(0, "IF R1>0").unwrap();
    let msgs: Vec<String> = e
        .finish()
        .diagnostics()
        .iter()
        .map(|d| d.message.clone())
        .collect();
    assert_eq!(msgs, vec!["IF on line 2 has no ENDIF"]);
}

#[test]
fn deleting_blocks_keeps_the_rest_verbatim() {
    let p = parse(&fixture("no_final_newline.mpf"));
    let mut e = Editor::new(&p);
    e.delete(1).unwrap();
    assert_eq!(
        e.to_bytes(),
        b"N10 G0 X0".to_vec(),
        "the new last block has no final newline either"
    );
    let p = parse(&fixture("crlf.mpf"));
    let mut e = Editor::new(&p);
    e.delete(0).unwrap();
    e.insert_after(1, "M1").unwrap();
    assert_eq!(
        e.to_bytes(),
        b"N20 G1 X10 F100\r\nM1\r\nN30 M30\r\n".to_vec()
    );
    assert!(matches!(
        e.delete(3),
        Err(EditError::NoSuchBlock { index: 3, count: 3 })
    ));
}
