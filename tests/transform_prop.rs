//! Property: for any program put together from CAM-like and hand-written lines, in LF or CRLF, `transform`
//! either refuses it with a reason or produces a program that parses without errors and gives the input
//! back byte for byte once the inserted blocks are removed.

use driftloop::model::DriftModel;
use driftloop::omm::emit::MARK;
use driftloop::omm::{ModelRef, Profile, transform};
use proptest::prelude::*;

const LINES: &[&str] = &[
    "T=\"MILL\" M6",
    "T2 M6 ; PASS roughing",
    "S3000 M3",
    "S5000 M4",
    "M5",
    "G0 Z50",
    "G0 X10 Y10",
    "G1 X200 Y40 F150",
    "G1 Z-3 F100",
    "G2 X0 Y50 I-10 J25",
    "G3 X40 Y40 CR=-20",
    "G4 F5",
    "G91 G1 X10",
    "G90",
    "R1=R1+1",
    "R905=2 ; inside the default free range",
    "LBL1:",
    "IF R1>3 GOTOF LBL1",
    "WHILE R2<2",
    "R2=R2+1",
    "ENDWHILE",
    "FOR R3 = 1 TO 4",
    "ENDFOR",
    "REPEAT LBL1 P=2",
    "; plain comment",
    "",
    "N10 G1 X=R1 Y=IC(5)",
    "MSG(\"Schlichten\")",
];

fn model() -> DriftModel {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/omm/model.toml");
    DriftModel::read(path.as_ref()).unwrap()
}

fn program(picks: &[usize], crlf: bool) -> Vec<u8> {
    let eol = if crlf { "\r\n" } else { "\n" };
    let mut text = format!("G54{eol}T1 M6{eol}S2000 M3{eol}");
    for &p in picks {
        text.push_str(LINES[p]);
        text.push_str(eol);
    }
    text.push_str("M30");
    text.push_str(eol);
    text.into_bytes()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn transform_inserts_only(picks in prop::collection::vec(0..LINES.len(), 0..60), crlf: bool) {
        let input = program(&picks, crlf);
        let parsed = driftloop::parse(&input);
        let model = model();
        let profile = Profile::default_profile();
        let reference = ModelRef { model: &model, sha256: "prop" };
        match transform(&parsed, reference, &profile, false) {
            Err(e) => {
                // Only the refusals a valid input can meet: unbalanced loops from the random picks, no
                // move at all to compensate, or an incremental move (IC) right after G54 that carries the
                // offset's traverse, before which no gate may go.
                let moves = e.reason() == "moves no axis";
                let traverse = e.to_string().contains("is not yet traversed");
                prop_assert!(e.to_string().contains("syntax error") || moves || traverse, "{e}");
                prop_assert!(parsed.has_errors() || moves || traverse);
            }
            Ok(t) => inserts_only(&parsed, &input, &t)?,
        }
    }

    /// Every builtin profile, measuring at every gate or as planned, on programs that name no tool, never
    /// start the spindle, or neither: the gates that read the tool at run time and those that measure only
    /// where the operator's spindle stands. A refusal may have any reason but an internal error (an output
    /// that does not parse, which the last stop's doubled ENDIF was).
    #[test]
    fn every_profile_inserts_only(
        picks in prop::collection::vec(prop::sample::select(atoms()), 0..40),
        start in 0..STARTS.len(),
        profile in 0..PROFILES.len(),
        every_gate: bool,
    ) {
        let mut input = STARTS[start].to_string();
        for p in &picks {
            input.push_str(p);
            input.push('\n');
        }
        input.push_str("M30\n");
        let input = input.into_bytes();
        let parsed = driftloop::parse(&input);
        let model = model();
        let mut profile = Profile::builtin(PROFILES[profile]).unwrap();
        profile.log.measure_every_gate = every_gate;
        let reference = ModelRef { model: &model, sha256: "prop" };
        match transform(&parsed, reference, &profile, false) {
            Err(e) => prop_assert_ne!(e.reason(), "internal error", "{}", e),
            Ok(t) => inserts_only(&parsed, &input, &t)?,
        }
    }
}

/// Pieces that parse on their own in any order: the lines above that open or close nothing (no loop, label
/// or jump), and closed structures.
fn atoms() -> Vec<&'static str> {
    let opens_or_closes = |l: &&str| {
        ["WHILE", "ENDWHILE", "FOR", "ENDFOR", "LBL", "IF", "REPEAT"]
            .iter()
            .any(|w| l.starts_with(w))
    };
    let mut v: Vec<&str> = LINES
        .iter()
        .copied()
        .filter(|l| !opens_or_closes(l))
        .collect();
    v.extend([
        "T3",
        "M6",
        "M8",
        "M9",
        "G55",
        "M0",
        "M1",
        "L100",
        "WHILE R2<2\nR2=R2+1\nG1 X20 F300\nENDWHILE",
        "FOR R3 = 1 TO 4\nG1 Z=-R3 F100\nENDFOR",
        "IF R1>3\nG0 Z80\nELSE\nG1 X5 F100\nENDIF",
    ]);
    v
}

const STARTS: &[&str] = &[
    "G54\nT1 M6\nS2000 M3\n",
    "G54\nS2000 M3\n",
    "G54\nT1 M6\n",
    "G54\n",
];

const PROFILES: &[&str] = &[
    "blum-tc50",
    "siemens-cycle978",
    "tool-setter",
    "grinder-gauge",
    "lathe-setter",
];

/// The output parses without errors, gives the input back once the inserted blocks are taken out, and
/// uses no R-parameter of the program's.
fn inserts_only(
    parsed: &driftloop::Program,
    input: &[u8],
    t: &driftloop::omm::Transformed,
) -> Result<(), TestCaseError> {
    let again = driftloop::parse(&t.bytes);
    prop_assert!(!again.has_errors(), "{:?}", again.diagnostics().first());
    let mut kept = Vec::new();
    for line in t.bytes.split_inclusive(|&b| b == b'\n') {
        let content = line.strip_suffix(b"\n").unwrap_or(line);
        let content = content.strip_suffix(b"\r").unwrap_or(content);
        if !content.ends_with(MARK.as_bytes()) {
            kept.extend_from_slice(line);
        }
    }
    prop_assert_eq!(kept, input);
    let own = driftloop::views::used_r_parameters(parsed);
    prop_assert!(t.summary.r_parameters.iter().all(|r| !own.contains(r)));
    Ok(())
}
