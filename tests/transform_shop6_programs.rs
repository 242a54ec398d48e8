//! What QA round 6 found in the blocks `transform` inserts and in what it refuses (fixtures/shop6, its
//! README lists the programs), each as a minimal program through the binary. `transform` audits its output
//! as planned and with every gate measuring, and writes nothing on a finding.

mod common;

/// `prog` transformed with the builtin `profile` measuring at every gate: the output.
fn every_gate(prog: &str, profile: &str) -> String {
    let files = [
        ("p.mpf", prog),
        ("every.toml", &common::measuring_builtin(profile)),
    ];
    common::transformed_in(&files, "p.mpf", "every.toml")
}

/// `prog` transformed with `profile`: the run (for a refusal's message).
fn transform_run(prog: &str, profile: &str) -> std::process::Output {
    common::transform_in(&[("p.mpf", prog)], "p.mpf", profile).0
}

/// The inserted lines that give the modal state back (they carry the plane word the gates write).
fn modal_lines(out: &str) -> Vec<&str> {
    out.lines()
        .filter(|l| l.ends_with(";DL") && l.starts_with("G18 "))
        .collect()
}

/// Whether a probe call of the builtin spindle-probe profile follows the line starting with `from`.
fn probes_after(out: &str, from: &str) -> bool {
    let at = out.find(from).expect(from);
    out[at..].contains("BL9700(")
}

const LATHE_DIAM90: &str = "\
N10 G18 G90 G95 G71 DIAM90 G54
N20 T=\"SCHRUPP_80GRD\" D1
N30 G96 S180 LIMS=2500 M4 M8
N40 G0 X64 Z2
N50 G1 X-1.6 Z0 F0.2
N60 G0 X60 Z2
N70 G1 Z-80 F0.3
N80 G91 X2
N90 G90 G0 Z2
N100 X54
N110 G1 Z-50
N120 G91 X2
N130 G90 G0 Z2
N140 X48
N150 G1 Z-30
N160 G91 X2
N170 G90 G0 X100 Z100 M9
N180 M5
N190 M30
";

#[test]
fn a_gate_gives_diam90_back_not_diamon() {
    // fixtures/shop6/23: a gate switched to DIAMOF and gave back DIAMON. Under DIAMON the program's
    // `G91 X2` retracts (2 mm in radius under DIAM90) moved 1 mm: every later incremental X was halved.
    let out = every_gate(LATHE_DIAM90, "lathe-setter");
    let back = modal_lines(&out);
    assert!(back.len() >= 2, "{out}");
    for line in back {
        assert!(
            line.contains("DIAM90") && !line.contains("DIAMON"),
            "{line}"
        );
    }
}

#[test]
fn a_gate_gives_constant_cutting_speed_back() {
    // fixtures/shop6/20, 23: the modal line wrote G95, which shares G96's group and ends constant cutting
    // speed: the rest of the program turned at a fixed speed (200 rpm for S200 m/min, or whatever the
    // control froze). The gate now writes G96 with the cutting speed.
    let out = every_gate(LATHE_DIAM90, "lathe-setter");
    let back = modal_lines(&out);
    assert!(!back.is_empty(), "{out}");
    for line in back.iter().skip(1) {
        assert!(line.contains("G96 S180") && !line.contains("G95"), "{line}");
    }
}

#[test]
fn no_spindle_probe_gate_measures_under_an_axial_offset_g58() {
    // fixtures/shop6/10: G58 Z-20 was read as a move to Z-20, not as a translation: a gate after the M0
    // measured, and the probe descended to its start point 20 mm lower than the probe surface.
    let prog = "\
G17 G90 G94 G71 G40 G54
T=\"VHM_D10\" M6
D1
S4000 M3 M8
G0 X20 Y0 Z50
G58 Z-20
G0 X20 Y0 Z10
G1 Z-3 F400
X60 F1200
G0 Z50
M0
G0 X20 Y0
G1 Z-3 F400
X60 F1200
G0 Z50
M30
";
    let out = every_gate(prog, "blum-tc50");
    assert!(!probes_after(&out, "G58 Z-20"), "{out}");
    // The same program without the offset measures there: the place itself is fit.
    let out = every_gate(&prog.replace("G58 Z-20\n", ""), "blum-tc50");
    assert!(probes_after(&out, "M0\n"), "{out}");
}

#[test]
fn a_program_that_starts_another_channel_is_refused_with_its_line() {
    // fixtures/shop6/04: START(2) counted as a subprogram call; later gates stopped the spindle and moved
    // channel 1's turret while channel 2 may cut the same part.
    let prog = "\
N10 G18 G90 G95 G71 DIAMON G54
N20 T=\"SCHRUPP_80GRD\" D1
N30 G96 S220 LIMS=3000 M4 M8
N40 G0 X62 Z2
N50 G1 X-1.6 F0.2
N60 G0 X120 Z100
N70 START(2)
N80 G0 X56 Z2
N90 G1 Z-60 F0.12
N100 G0 X120 Z100 M9
N110 WAITE(2)
N120 M30
";
    for profile in ["lathe-setter", "grinder-gauge"] {
        let o = transform_run(prog, profile);
        assert_eq!(o.status.code(), Some(2), "{profile}");
        let err = common::stderr(&o);
        assert!(
            err.contains("line 7: START coordinates this program with another channel"),
            "{profile}: {err}"
        );
    }
}

#[test]
fn iso_programs_are_refused_by_their_words_before_the_syntax_check() {
    // fixtures/shop6/18: the (…) comments of an ISO program were reported as syntax errors to fix; a
    // program with only an O number and M99 as ISO words was written (without an audit).
    let with_comments = "O2041 (BUCHSE)\nG291\nG90 G54 G17\nT5 M6\nS2200 M3\nG0 X0 Y0 Z5\nG1 Z-1 F100\nG0 Z50\nM99\n";
    let o = transform_run(with_comments, "tool-setter");
    assert_eq!(o.status.code(), Some(2));
    assert!(
        common::stderr(&o).contains("line 1: O2041 is a word of the ISO dialect"),
        "{}",
        common::stderr(&o)
    );
    let m99 = "G90 G54 G17\nT1 M6\nS2000 M3\nG0 X0 Y0 Z50\nZ2\nG1 Z-1 F100\nX50\nG0 Z50\nM5\nM99\n";
    let o = transform_run(m99, "tool-setter");
    assert_eq!(o.status.code(), Some(2));
    assert!(
        common::stderr(&o).contains("line 10: M99 is a word of the ISO dialect"),
        "{}",
        common::stderr(&o)
    );
}

#[test]
fn a_poly_program_parses_transforms_and_strips_back() {
    // fixtures/shop6/09: PO[X]=(xe, a2, a3) did not parse, so the program was refused for syntax errors.
    let prog = "\
G17 G90 G94 G71 G40 G54
T=\"TORUS_D8_R1\" M6
D1
S8000 M3 M8
G0 X0 Y0 Z20
Z2
G1 Z-0.5 F800
POLY PO[X]=(12.5,0.8,-0.2) PO[Y]=(3.1,0.4) PO[Z]=(-0.7,0.1)
PO[X]=(25.0,0.6,-0.1) PO[Y]=(6.8,0.3,0.05) PO[Z]=(-0.9,0.05)
G1
G0 Z50 M9
M5
M30
";
    let out = every_gate(prog, "tool-setter");
    let stripped = common::driftloop(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")),
        &["strip", "-"],
        out.as_bytes(),
    );
    assert_eq!(common::stdout(&stripped), prog);
}

#[test]
fn fixed_points_and_called_blocks_are_audited_to_the_end() {
    // fixtures/shop6/11 and 03: G75 FP=n and CALL BLOCK stopped the dry run, and the output was written
    // without the audit from there on.
    let prog = "\
G17 G90 G94 G71 G40 G54
G75 FP=1 Z0
T=\"SF_D8\" M6
D1
S6000 M3 M8
G0 X20 Y20 Z20
Z2
G1 Z-2 F400
CALL BLOCK KONT_A TO KONT_E
G0 Z20
G75 FP=2 X0 Y0
M5
GOTOF ENDE
KONT_A:
G1 X60 F900
Y60
KONT_E:
ENDE:
M30
";
    for profile in ["blum-tc50", "tool-setter"] {
        let o = transform_run(prog, profile);
        let err = common::stderr(&o);
        assert!(o.status.success(), "{profile}: {err}");
        assert!(!err.contains("audit incomplete"), "{profile}: {err}");
    }
}

#[test]
fn a_setter_zero_goes_before_a_frame_that_runs_straight_into_a_cut() {
    // fixtures/shop6/10: `TRANS X40 Y30` followed at once by a subprogram that cuts left no place after
    // the setup and before the first cut: the setter profiles refused the program. A reference in machine
    // coordinates reads nothing through the frame: the zero went before it; since QA round 11 the block of
    // the call that cuts is a place before the first cut too (the gate runs before the call).
    let prog = "\
G17 G90 G94 G54
T=\"VHM_D10\" M6
D1
S3000 M3
G0 X0 Y0 Z50
TRANS X40 Y30
L_TASCHE
TRANS
G0 Z100
M5
M30
";
    let sub = std::fs::read_to_string(common::fixture("shop6/subs/L_TASCHE.SPF")).unwrap();
    let files = [("p.mpf", prog), ("L_TASCHE.SPF", sub.as_str())];
    let out = common::transformed_in(&files, "p.mpf", "tool-setter");
    let zero = out.find("stage 4").expect("a zero");
    assert!(zero < out.find("\nL_TASCHE").unwrap(), "{out}");
}

#[test]
fn a_setter_zero_is_not_measured_with_the_tool_left_before_shopmill_steps() {
    // fixtures/shop6/01: the ShopMill steps load their tools inside their E_ cycles; the setter's zero went
    // before E_HEAD and measured whatever the spindle held from before (or its bare nose).
    let steps = "\
N10 G17 G90 DIAMOF
N20 E_HEAD(0,0,\"G54\",1,-60,-40,0,120,80,-20,0,100,0,2,1,1,100,20,0,0,0,\"\",0,0)
N30 E_MI_PL(1,\"FACEMILL_63\",1,0.12,2,250,1,-60,-40,60,40,2,0,0.3,0.5,0.8,0.1,100,1,0,0,0,0,0,0,0,0,0)
N40 E_END(2,0,100,0,20,1,0)
N50 M30
";
    let o = transform_run(steps, "tool-setter");
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    assert!(
        err.contains("ShopMill steps (E_… cycles) load their tools"),
        "{err}"
    );
    // With the first step's tool loaded before the steps, as the message says, the zero measures it.
    let loaded = steps.replace(
        "N20 E_HEAD",
        "N12 T=\"FACEMILL_63\" M6\nN14 D1\nN16 G0 Z100\nN20 E_HEAD",
    );
    let o = transform_run(&loaded, "tool-setter");
    assert!(o.status.success(), "{}", common::stderr(&o));
}
