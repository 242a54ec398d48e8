//! One test per language feature: the fixture parses into the expected structure, not just "no error".

mod syntax_support;

use driftloop::{BlockKind, NodeKind as K, Severity, analyze, parse};
use syntax_support::{errors, find_in, fixture, resolved_jumps, statement_kinds, text};

fn clean(name: &str) -> driftloop::Program {
    let program = parse(&fixture(name));
    assert_eq!(
        errors(&program),
        Vec::<String>::new(),
        "{name} has no errors"
    );
    program
}

#[test]
fn archive_headers_split_program_units() {
    let p = clean("archive.arc");
    let headers: Vec<usize> = (0..p.block_count())
        .filter(|&i| p.block_kind(i) == BlockKind::Header)
        .collect();
    assert_eq!(headers, vec![0, 5, 10]);
    assert_eq!(
        statement_kinds(&p, 1),
        Vec::<K>::new(),
        ";$PATH is a comment"
    );
    assert_eq!(
        find_in(&p, 1, K::Comment).map(|c| text(&p, &c)).as_deref(),
        Some(";$PATH=/_N_MPF_DIR")
    );
    assert_eq!(statement_kinds(&p, 7), vec![K::Proc]);
    // The _COM section holds alarm text, which is kept as one opaque Text leaf.
    assert_eq!(statement_kinds(&p, 12), vec![K::Text]);
}

#[test]
fn block_numbers_skip_levels_and_labels() {
    let p = clean("block_numbers.mpf");
    assert_eq!(statement_kinds(&p, 0), vec![K::BlockNumber, K::Word]);
    assert_eq!(text(&p, &find_in(&p, 1, K::BlockNumber).unwrap()), ":20");
    assert_eq!(
        statement_kinds(&p, 2),
        vec![K::Skip, K::BlockNumber, K::Word]
    );
    assert_eq!(text(&p, &find_in(&p, 3, K::Skip).unwrap()), "/3");
    assert_eq!(statement_kinds(&p, 4), vec![K::Label, K::Word, K::Word]);
    assert_eq!(
        statement_kinds(&p, 5),
        vec![K::BlockNumber, K::Label, K::Word, K::Word]
    );
    assert_eq!(text(&p, &find_in(&p, 5, K::Label).unwrap()), "AB_12:");
    assert_eq!(
        statement_kinds(&p, 6),
        vec![K::BlockNumber, K::Word],
        "lower case n60 x5"
    );
}

#[test]
fn words_plain_extended_and_axis_forms() {
    let p = clean("words.mpf");
    assert_eq!(
        statement_kinds(&p, 3),
        vec![K::BlockNumber, K::Word, K::Word, K::Word, K::Word, K::Word]
    );
    assert_eq!(
        statement_kinds(&p, 4),
        vec![K::BlockNumber, K::Assign, K::Assign, K::Assign]
    );
    assert_eq!(
        text(&p, &find_in(&p, 4, K::Str).unwrap()),
        "\"FACE MILL 50\""
    );
    let ic = find_in(&p, 5, K::FnCall).unwrap();
    assert_eq!(text(&p, &ic), "IC(5)");
    assert_eq!(text(&p, &find_in(&p, 5, K::Binary).unwrap()), "R1+5");
    assert_eq!(
        statement_kinds(&p, 8),
        vec![K::BlockNumber, K::Word, K::Word, K::Word, K::Assign]
    );
    // G1X10Y20Z-1F1000 without blanks is five words.
    assert_eq!(
        statement_kinds(&p, 10)
            .iter()
            .filter(|&&k| k == K::Word)
            .count(),
        5
    );
    assert_eq!(text(&p, &find_in(&p, 11, K::Number).unwrap()), "120");
    let exp = p.block(11).root.significant().nth(1).unwrap().children[1].clone();
    assert_eq!(text(&p, &exp), "1.5EX3");
}

#[test]
fn r_parameters_and_user_variables() {
    let p = clean("parameters.mpf");
    assert_eq!(statement_kinds(&p, 0), vec![K::Assign, K::Assign]);
    let indexed = find_in(&p, 1, K::RParam).unwrap();
    assert_eq!(text(&p, &indexed), "R[2]");
    assert!(indexed.find(K::Index).is_some());
    let nested = p.block(1).root.significant().nth(1).unwrap().children[0].clone();
    assert_eq!(text(&p, &nested), "R[R1+1]");
    assert_eq!(statement_kinds(&p, 2), vec![K::Def]);
    assert_eq!(
        find_in(&p, 3, K::Var).map(|v| text(&p, &v)).as_deref(),
        Some("COUNT")
    );
}

#[test]
fn declarations_proc_extern_define_def() {
    let p = clean("declarations.spf");
    let proc = find_in(&p, 0, K::Proc).unwrap();
    let params: Vec<_> = proc
        .find(K::Args)
        .unwrap()
        .children
        .iter()
        .filter(|c| c.kind == K::Param)
        .cloned()
        .collect();
    assert_eq!(params.len(), 4);
    assert_eq!(text(&p, &params[1]), "VAR INT HOLES");
    assert_eq!(text(&p, &params[2]), "STRING[32] NAME");
    let attrs: Vec<String> = proc
        .children
        .iter()
        .filter(|c| c.kind == K::Name)
        .map(|c| text(&p, c))
        .collect();
    assert_eq!(attrs, vec!["DRILL", "SAVE", "DISPLOF"]);
    let ext = find_in(&p, 1, K::Extern).unwrap();
    assert_eq!(
        ext.find(K::Args)
            .unwrap()
            .children
            .iter()
            .filter(|c| c.kind == K::Param)
            .count(),
        3
    );
    assert_eq!(
        find_in(&p, 2, K::Define)
            .unwrap()
            .find(K::Text)
            .map(|t| text(&p, t))
            .as_deref(),
        Some("M3 S1000")
    );
    let decls = |i| {
        find_in(&p, i, K::Def)
            .unwrap()
            .children
            .iter()
            .filter(|c| c.kind == K::Declarator)
            .count()
    };
    assert_eq!(decls(3), 2);
    assert_eq!(decls(4), 2);
    assert_eq!(text(&p, &find_in(&p, 4, K::FnCall).unwrap()), "SET(1,2,3)");
    assert_eq!(text(&p, &find_in(&p, 6, K::BitLiteral).unwrap()), "'H41'");
    assert_eq!(text(&p, &find_in(&p, 7, K::Index).unwrap()), "[20]");
    assert_eq!(
        find_in(&p, 10, K::Declarator)
            .map(|d| text(&p, &d))
            .as_deref(),
        Some("LIMIT")
    );
    assert_eq!(statement_kinds(&p, 11), vec![K::Redef]);
}

#[test]
fn system_variables_read_and_written() {
    let p = clean("sysvars.mpf");
    let target = find_in(&p, 0, K::SysVar).unwrap();
    assert_eq!(text(&p, &target), "$P_UIFR[1,Z,TR]");
    assert_eq!(
        target
            .find(K::Index)
            .unwrap()
            .children
            .iter()
            .filter(|c| c.kind != K::Punct)
            .count(),
        3
    );
    let reads: Vec<String> = {
        let b = p.block(1);
        let mut v = Vec::new();
        b.root.walk(&mut |n| {
            if n.kind == K::SysVar {
                v.push(text(&p, n))
            }
        });
        v
    };
    assert_eq!(reads, vec!["$AA_IM[X]", "$AC_MEA[1]"]);
    assert_eq!(p.block_kind(2), BlockKind::If);
}

#[test]
fn expressions_follow_sinumerik_precedence() {
    let p = clean("expressions.mpf");
    // R1=2+3*4-6/2 → (2 + (3*4)) - (6/2)
    let value = p.block(0).root.children[0].children[2].clone();
    assert_eq!(value.kind, K::Binary);
    assert_eq!(text(&p, &value.children[0]), "2+3*4");
    assert_eq!(text(&p, &value.children[2]), "6/2");
    // Comparison binds loosest: R1<>R2 at the top of line 3's expression.
    let cmp = p.block(2).root.children[0].children[2].clone();
    assert_eq!(text(&p, &cmp.children[1]), "<>");
    // B_AND binds tighter than B_XOR, which binds tighter than B_OR.
    let bits = p.block(3).root.children[0].children[2].clone();
    assert_eq!(text(&p, &bits.children[0]), "5 B_AND 3");
    assert_eq!(text(&p, &bits.children[2]), "B_OR");
    assert_eq!(text(&p, &bits.children[4]), "8 B_XOR B_NOT 1");
    let calls = |i: usize| {
        let b = p.block(i);
        let mut v = Vec::new();
        b.root.walk(&mut |n| {
            if n.kind == K::FnCall {
                v.push(text(&p, &n.children[0]))
            }
        });
        v
    };
    assert_eq!(calls(4), vec!["SIN", "COS", "TAN", "ATAN2"]);
    assert_eq!(calls(6), vec!["MINVAL", "MAXVAL", "BOUND"]);
    assert_eq!(
        find_in(&p, 7, K::BitLiteral)
            .map(|b| text(&p, &b))
            .as_deref(),
        Some("'H1F'")
    );
    assert_eq!(
        find_in(&p, 8, K::Unary).map(|u| text(&p, &u)).as_deref(),
        Some("-R1")
    );
    assert_eq!(statement_kinds(&p, 9), vec![K::Call]);
}

#[test]
fn control_structures_pair_up() {
    let p = clean("control.mpf");
    let kinds: Vec<BlockKind> = (0..p.block_count()).map(|i| p.block_kind(i)).collect();
    use BlockKind::*;
    assert_eq!(
        kinds,
        vec![
            If, Plain, Else, Plain, EndIf, While, Plain, EndWhile, For, Plain, EndFor, Repeat,
            Plain, Until, Loop, If, Plain, EndIf, EndLoop
        ]
    );
    let s = analyze(&p);
    let mut pairs = s.pairs.clone();
    pairs.sort();
    assert_eq!(
        pairs,
        vec![
            (0, 2),
            (2, 4),
            (5, 7),
            (8, 10),
            (11, 13),
            (14, 18),
            (15, 17)
        ]
    );
}

#[test]
fn jumps_resolve_to_labels_and_block_numbers() {
    let p = parse(&fixture("jumps.mpf"));
    assert_eq!(errors(&p), Vec::<String>::new());
    let warnings: Vec<&str> = p
        .diagnostics()
        .iter()
        .filter(|d| d.severity == Severity::Warning)
        .map(|d| d.message.as_str())
        .collect();
    assert_eq!(warnings, vec!["GOTOC target MISSING is not defined"]);
    assert_eq!(
        p.block_kind(2),
        BlockKind::Plain,
        "IF … GOTOB is a one-line jump, not a block IF"
    );
    assert_eq!(
        resolved_jumps(&p),
        [
            "2 MARK1 1",
            "3 MARK2 5",
            "5 N60 7",
            "7 MISSING -",
            "8 MARK3 9",
            "10 MARK4 11",
            "10 MARK4 11",
            "10 MARK4 11",
            "11 MARK1 1",
            "11 MARK2 5",
        ]
    );
    let case = find_in(&p, 10, K::Case).unwrap();
    assert_eq!(
        case.children
            .iter()
            .filter(|c| c.kind == K::CaseArm)
            .count(),
        3
    );
    assert_eq!(
        statement_kinds(&p, 11),
        vec![K::Label, K::Repeat, K::Assign]
    );
    assert_eq!(statement_kinds(&p, 12), vec![K::BlockNumber, K::Goto]);
}

#[test]
fn calls_of_every_form() {
    let p = clean("calls.mpf");
    let first: Vec<K> = (0..p.block_count())
        .map(|i| statement_kinds(&p, i)[0])
        .collect();
    use K::*;
    assert_eq!(
        first,
        vec![
            Command,
            Call,
            Word,
            ProgramCall,
            ProgramCall,
            ProgramCall,
            ProgramCall,
            ProgramCall,
            ProgramCall,
            Call,
            Call,
            Call,
            Command,
            Call,
            Word,
            Command,
            Word
        ]
    );
    let args = find_in(&p, 1, K::Args).unwrap();
    assert_eq!(text(&p, &args), "(1,,3)");
    assert_eq!(
        args.children.iter().filter(|c| c.kind == K::Number).count(),
        2
    );
    assert_eq!(
        find_in(&p, 4, K::Text).map(|t| text(&p, &t)).as_deref(),
        Some("/_N_SPF_DIR/_N_SUB_SPF")
    );
    assert_eq!(
        find_in(&p, 5, K::FnCall)
            .map(|c| text(&p, &c.children[0]))
            .as_deref(),
        Some("CYCLE81")
    );
}

#[test]
fn frames_and_work_offsets() {
    let p = clean("frames.mpf");
    assert_eq!(statement_kinds(&p, 3), vec![K::Command, K::Word, K::Word]);
    let chain = p.block(9).root.children[0].children[2].clone();
    assert_eq!(chain.kind, K::Binary);
    assert_eq!(text(&p, &chain.children[1]), ":");
}

#[test]
fn synchronized_actions() {
    let p = clean("sync_actions.mpf");
    assert_eq!(
        statement_kinds(&p, 0),
        vec![K::Assign, K::SyncCondition, K::Assign]
    );
    assert_eq!(
        statement_kinds(&p, 1),
        vec![K::Assign, K::SyncCondition, K::Word, K::Word]
    );
    assert_eq!(statement_kinds(&p, 4), vec![K::SyncCondition, K::Assign]);
    // `$$`: machine and setting data read or written in the main run.
    let main_run: Vec<String> = [5, 6]
        .iter()
        .flat_map(|&i| {
            let mut v = Vec::new();
            p.block(i).root.walk(&mut |n| {
                if n.kind == K::SysVar {
                    v.push(text(&p, n))
                }
            });
            v
        })
        .collect();
    assert_eq!(
        main_run,
        vec![
            "$AA_IM[Z]",
            "$$SA_OSCILL_REVERSE_POS1[Z]",
            "$AC_MARKER[3]",
            "$AA_IM[X]",
            "$$SN_SW_CAM_MINUS_POS_TAB_1[1]"
        ]
    );
    assert_eq!(
        statement_kinds(&p, 6),
        vec![K::Assign, K::SyncCondition, K::Assign]
    );
}

#[test]
fn oscillation_control_takes_a_list_of_set_and_reset_options() {
    let p = clean("oscillation.mpf");
    assert_eq!(statement_kinds(&p, 2), vec![K::Assign, K::Assign]);
    let control = p.block(2).root.significant().next().unwrap().clone();
    let value = control.children.last().unwrap();
    assert_eq!(value.kind, K::Args, "OSCTRL[Z]=(set, reset) is a list");
    assert_eq!(text(&p, value), "(2+16, 1)");
    assert_eq!(
        value
            .children
            .iter()
            .filter(|c| c.kind != K::Punct && c.kind != K::Trivia)
            .count(),
        2
    );
    // Elsewhere a parenthesis after `=` is still an expression.
    let osp = find_in(&p, 1, K::Assign).unwrap();
    assert_eq!(osp.children.last().unwrap().kind, K::Number);
}

#[test]
fn comments_and_parentheses() {
    let p = parse(&fixture("comments.mpf"));
    assert_eq!(statement_kinds(&p, 0), Vec::<K>::new());
    assert_eq!(
        find_in(&p, 1, K::Comment).map(|c| text(&p, &c)).as_deref(),
        Some("; trailing comment with \"quotes\" and ; more")
    );
    assert_eq!(statement_kinds(&p, 2), vec![K::Error]);
    assert_eq!(errors(&p).len(), 1);
    let help = p.diagnostics()[0].help.clone().unwrap();
    assert!(help.contains("not a comment"), "{help}");
}

#[test]
fn line_endings_bom_and_final_newline_are_kept_per_block() {
    let endings = |name: &str| {
        let p = parse(&fixture(name));
        (0..p.block_count())
            .map(|i| text(&p, p.block(i).root.children.last().unwrap()))
            .collect::<Vec<_>>()
    };
    assert_eq!(endings("crlf.mpf"), vec!["\r\n"; 3]);
    assert_eq!(endings("lone_cr.mpf"), vec!["\r"; 3]);
    assert_eq!(
        endings("mixed_endings.mpf"),
        vec!["\r\n", "\n", "\r", "\r\n", "\r\n", "\n"]
    );
    assert_eq!(endings("no_final_newline.mpf"), vec!["\n", ""]);
    let bom = parse(&fixture("bom.mpf"));
    assert_eq!(bom.block(0).root.children[0].kind, K::Bom);
    assert_eq!(
        statement_kinds(&bom, 0),
        vec![K::BlockNumber, K::Word, K::Word]
    );
    assert_eq!(parse(&fixture("crlf.mpf")).dominant_line_ending(), b"\r\n");
    assert_eq!(parse(&fixture("lone_cr.mpf")).dominant_line_ending(), b"\r");
}

#[test]
fn non_utf8_bytes_in_comments_and_strings() {
    for name in ["latin1.mpf", "gbk.mpf"] {
        let p = clean(name);
        assert_eq!(statement_kinds(&p, 1), vec![K::Call], "{name}");
        assert!(find_in(&p, 1, K::Str).unwrap().span.len() > 4);
    }
    let p = parse(&fixture("broken_bytes.mpf"));
    assert_eq!(
        errors(&p),
        vec!["3:5 expected a word, assignment, call or keyword, found the non-ASCII byte 0xFF"]
    );
    assert_eq!(statement_kinds(&p, 2), vec![K::Word, K::Command, K::Error]);
}

#[test]
fn tabs_and_ampersands_are_blanks() {
    let p = clean("tabs_ampersand.mpf");
    assert_eq!(
        statement_kinds(&p, 0),
        vec![K::BlockNumber, K::Word, K::Word]
    );
    assert_eq!(
        statement_kinds(&p, 1),
        vec![K::BlockNumber, K::Word, K::Word, K::Word]
    );
    assert_eq!(
        find_in(&p, 1, K::Trivia).map(|t| text(&p, &t)).as_deref(),
        Some("&")
    );
    assert_eq!(statement_kinds(&p, 2), vec![K::Word]);
}
