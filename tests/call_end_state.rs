//! What a called subprogram leaves its caller, and the other states a gate gives back that QA round 10
//! (public shop programs and variations of them) found wrong: each case through the binary, audited on the
//! virtual machine as `transform` always does, with every gate measuring where it can.

mod common;

/// A part subprogram per station, then the second tool: the program writes neither motion nor feed
/// between the call and the tool change.
const STATIONS: &str = "\
G17 G90 G40 G94 G71 G60
G54
T=\"EM_D12\"
M6
D1
S6000 M3 M8
G0 X0 Y0 Z50
PART
ATRANS X80
PART
TRANS
M9
T=\"DR_D10\" M6
D1
S3500 M3 M8
X0 Y0
Z5
G1 Z-2.5 F250
G0 Z50 M9
M30
";

/// Straight code: what it leaves is known for sure (G0, F1200, G40).
const PART: &str = "\
G0 X-30 Y-25 Z5
G1 Z-3 F800
G41 G1 X-20 Y-15 F1200
G1 Y15
G40 G1 X-30 Y-25
G0 Z5
M17
";

#[test]
fn the_gate_after_a_part_subprogram_gives_back_what_it_left_and_measures() {
    // QA round 9's F8 (round 5's open item): the fields a subprogram sets stayed unsure after its call, so
    // the gate at the next tool change could not measure. A subprogram without IFs, loops or jumps that
    // sets them by literals leaves its own values: the gate gives those back.
    for profile in ["blum-tc50", "tool-setter"] {
        let out =
            common::every_gate_transformed(profile, &[("p.mpf", STATIONS), ("PART.SPF", PART)]);
        let gate = common::gate_before(&out, "T=\"DR_D10\"");
        assert!(
            common::gate_measures(&gate),
            "{profile}:\n{}",
            gate.join("\n")
        );
        let back = gate.iter().rev().find(|l| l.contains(" G90")).unwrap();
        assert!(
            back.contains("G0 ") && back.contains("F1200"),
            "{profile}: {back}"
        );
    }
}

#[test]
fn a_feed_a_subprogram_sets_in_an_if_stays_unsure_after_it() {
    let part = PART.replace(
        "G41 G1 X-20 Y-15 F1200\n",
        "IF R1==1\nG41 G1 X-20 Y-15 F1200\nENDIF\n",
    );
    // The program set a feed before the call (F500), which the subprogram may have changed: a gate that
    // gave back F500 or F1200 would be wrong on one of the runs. (Where the program had set none, a gate
    // writes none back and the call's feed stays: no doubt then.)
    let prog = STATIONS
        .replace("G0 X0 Y0 Z50\nPART", "G0 X0 Y0 Z50\nG1 Z45 F500\nPART")
        .replace(
            "S3500 M3 M8\nX0 Y0\nZ5\nG1 Z-2.5 F250",
            "S3500 M3 M8\nG0 X0 Y0\nZ5\nG1 Z-2.5",
        );
    let out = common::every_gate_transformed("blum-tc50", &[("p.mpf", &prog), ("PART.SPF", &part)]);
    let gate = common::gate_before(&out, "T=\"DR_D10\"");
    assert!(!common::gate_measures(&gate), "{}", gate.join("\n"));
    assert!(
        !gate
            .iter()
            .any(|l| l.contains("F1200") || l.contains("F500")),
        "{gate:#?}"
    );
}

#[test]
fn a_subprogram_declared_with_save_gives_its_callers_g_codes_back() {
    // `PROC PART SAVE`: the control brings the caller's G codes back at its end (Siemens, K2). The
    // program's `X0 Y0` after the tool change runs in the G0 it had before the call, so the gate there
    // gives back G0, not the subprogram's G1.
    let part = "PROC PART SAVE\nG0 X-30 Y-25 Z5\nG1 Z-3 F800\nG1 X30\nG0 Z5\nM17\n";
    let out =
        common::every_gate_transformed("blum-tc50", &[("p.mpf", STATIONS), ("PART.SPF", part)]);
    let gate = common::gate_before(&out, "T=\"DR_D10\"");
    assert!(common::gate_measures(&gate), "{}", gate.join("\n"));
    let back = gate.iter().rev().find(|l| l.contains(" G90")).unwrap();
    assert!(back.contains("G0 ") && !back.contains("G1 "), "{back}");
}

#[test]
fn a_while_loop_that_may_not_run_leaves_the_fields_its_body_sets_unsure() {
    // The fold runs a loop's body once; after a WHILE that does not run (R1 = 0 here) the program goes on
    // in the state before it. A gate after it that gave back the body's F1400 would make the program's
    // `X20` (meant at F300) cut at F1400: the audit refused such outputs when the dry run skipped the loop.
    let prog = "\
G17 G90 G40 G94 G71 G60
G54
T=\"EM_D12\"
M6
D1
S6000 M3 M8
G0 X0 Y0 Z5
G1 Z-1 F300
R1=0
WHILE R1>0
G1 X10 F1400
R1=R1-1
ENDWHILE
G0 Z50
T=\"EM_D8\"
M6
D1
S7000 M3
G0 X20 Y0
Z-1
G1 X40
G0 Z50 M9
M30
";
    for profile in ["blum-tc50", "tool-setter"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", prog)]);
        let inserted = out.lines().filter(|l| l.ends_with(";DL"));
        assert!(
            !inserted.clone().any(|l| l.contains("F1400")),
            "{profile}:\n{out}"
        );
    }
}

#[test]
fn a_speed_change_without_s_or_m_gives_back_the_programs_state() {
    // QA round 10, H1: `G95` after `G96 S200 M3` ends constant cutting speed, so the speed changes at a
    // block without S or M. The state kept for that block's gate was the empty default: the gate gave back
    // `G0 G91` (every later block incremental), no plane, and left the spindle stopped for the next G95
    // feed.
    let prog = "\
G17 G90 G54
T=\"EM10\" M6
D1
G0 X100 Y0 Z200
G96 S200 M3
G95 F0.1
G0 X82 Y2
G1 Z-5
G0 Z200
M30
";
    let out = common::every_gate_transformed("blum-tc50", &[("p.mpf", prog)]);
    let inserted: Vec<&str> = out.lines().filter(|l| l.ends_with(";DL")).collect();
    assert!(
        !inserted.iter().any(|l| l.contains("G91")),
        "{}",
        inserted.join("\n")
    );
}

#[test]
fn a_subprogram_that_selects_the_work_offset_and_cuts_leaves_no_place_for_the_zero() {
    // QA round 10, H2: the zero went before the call, in whatever frame the previous program left, while
    // the subprogram selects G54 and cuts under it.
    let prog = "G0 G90 X0 Y0\nPOCKET_A\nM30\n";
    let sub = "PROC POCKET_A\nT1 D1 M6\nG17 G90 G54\nG0 Z100\nX0 Y0\nM3 S2000 M8\nG1 Z-2 F300\n\
               X40\nG0 Z100\nM5 M9\nRET\n";
    let (o, dir) = common::transform_in(
        &[("p.mpf", prog), ("POCKET_A.SPF", sub)],
        "p.mpf",
        "blum-tc50",
    );
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("the subprogram POCKET_A (line 2) selects the work offset"),
        "{err}"
    );
    // QA round 13, F6: the message named a setup ending after the first cut ("between the program's setup
    // (line 3) and its first cut (line 2)").
    assert!(
        err.contains("before the program's first cut (line 2), which its setup ends with"),
        "{err}"
    );
    assert!(!dir.path().join("out.mpf").exists());
}

#[test]
fn a_siemens_position_pattern_under_mcall_is_no_shop_cycle() {
    // QA round 10, N1: HOLES1 was read as a builder's or shop's cycle that might change tools, so the
    // spindle-probe profiles refused the program.
    let prog = "\
G17 G90 G54
T1 D1
S800 M3 M8
G0 X0 Y0 Z50
MCALL CYCLE81(50,0,2,-20,)
HOLES1(10,10,0,5,20,4)
MCALL
G0 Z100 M9
M30
";
    for profile in ["blum-tc50", "siemens-cycle978"] {
        let out = common::every_gate_transformed(profile, &[("p.mpf", prog)]);
        let zero = out.find("stage 4: reference").expect("a zero");
        assert!(zero < out.find("MCALL CYCLE81").unwrap(), "{out}");
    }
}

#[test]
fn a_feed_only_one_way_sets_is_given_back_by_no_gate() {
    // After a WHILE whose body sets F1800 where the program had set no feed before it, the feed differs
    // between the ways only by being unset on one: a gate writes no F back (each way keeps its own), so
    // it may measure — and must not write F1800.
    let prog = "\
G17 G90 G40 G94 G71 G60
G54
T=\"FM_D80\" M6
D1
S1600 M3 M8
G0 X-50 Y0 Z5
R22=0
WHILE R22>-2
R22=R22-1
G1 Z=R22 F400
G1 X250 F1800
G0 Z5
G0 X-50
ENDWHILE
G0 Z100
M9
M5
T=\"EM_D12\" M6
D1
S6000 M3 M8
G0 X-7 Y-7 Z5
G1 Z-7 F300
G1 X207 F1500
G0 Z100 M9
M30
";
    let out = common::every_gate_transformed("blum-tc50", &[("p.mpf", prog)]);
    let gate = common::gate_before(&out, "T=\"EM_D12\" M6");
    assert!(common::gate_measures(&gate), "{}", gate.join("\n"));
    assert!(!gate.iter().any(|l| l.contains("F1800")), "{gate:#?}");
}
