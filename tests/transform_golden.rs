//! Golden files of `transform` over the fixtures (and the real CAM program when ../shared is present), and
//! the properties every output must have: it parses without errors, and removing the inserted blocks gives
//! the input byte for byte.

mod shared_data;

mod common;

use std::path::PathBuf;

use driftloop::model::DriftModel;
use driftloop::omm::emit::MARK;
use driftloop::omm::{ModelRef, Profile, TransformError, Transformed, transform};
use driftloop::views::used_r_parameters;

const FIXTURES: [&str; 5] = [
    "handwritten.mpf",
    "r_in_free_range.mpf",
    "crlf.mpf",
    "latin1.mpf",
    "loops.mpf",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn model() -> DriftModel {
    let path = root().join("fixtures/omm/model.toml");
    DriftModel::read(&path).expect("model fixture")
}

fn run(src: &[u8], profile: &Profile) -> Result<Transformed, TransformError> {
    let program = driftloop::parse(src);
    let model = model();
    let model = ModelRef {
        model: &model,
        sha256: "0123456789abcdef0123456789abcdef",
    };
    let t = transform(&program, model, profile, false)?;
    // The streamed output is the same bytes.
    let mut streamed = Vec::new();
    let prepared = driftloop::omm::prepare(&program, model, profile, false)?;
    prepared.write_to(&mut streamed).unwrap();
    assert!(streamed == t.bytes, "streamed output differs");
    Ok(t)
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(root().join("fixtures/omm").join(name)).expect("fixture")
}

/// The output with every inserted block (content ending in the marker comment) removed.
fn without_inserted(out: &[u8]) -> Vec<u8> {
    let mut kept = Vec::new();
    for line in out.split_inclusive(|&b| b == b'\n') {
        let content = line.strip_suffix(b"\n").unwrap_or(line);
        let content = content.strip_suffix(b"\r").unwrap_or(content);
        if !content.ends_with(MARK.as_bytes()) {
            kept.extend_from_slice(line);
        }
    }
    kept
}

/// The inserted blocks, grouped under `before input line N`.
fn insertions(out: &[u8]) -> String {
    let mut text = String::new();
    let mut input_line = 1;
    let mut in_group = false;
    for line in out.split(|&b| b == b'\n') {
        let content = line.strip_suffix(b"\r").unwrap_or(line);
        if content.ends_with(MARK.as_bytes()) {
            if !in_group {
                text.push_str(&format!("-- before input line {input_line}\n"));
                in_group = true;
            }
            text.push_str(&String::from_utf8_lossy(content));
            text.push('\n');
        } else {
            input_line += 1;
            in_group = false;
        }
    }
    text
}

fn check_properties(name: &str, input: &[u8], t: &Transformed) {
    let reparsed = driftloop::parse(&t.bytes);
    let errors: Vec<_> = reparsed
        .diagnostics()
        .iter()
        .filter(|d| d.severity == driftloop::Severity::Error)
        .map(|d| d.message.clone())
        .collect();
    assert!(errors.is_empty(), "{name}: output has errors: {errors:?}");
    assert!(
        without_inserted(&t.bytes) == input,
        "{name}: removing the inserted blocks does not give the input back"
    );
    let inserted = t.bytes.split(|&b| b == b'\n').count() - input.split(|&b| b == b'\n').count();
    assert_eq!(
        inserted, t.summary.blocks_inserted,
        "{name}: inserted count"
    );
    for line in t.bytes.split(|&b| b == b'\n') {
        assert!(line.len() <= 512, "{name}: block over 512 characters");
    }
    let used = used_r_parameters(&driftloop::parse(input));
    for r in &t.summary.r_parameters {
        assert!(!used.contains(r), "{name}: R{r} is the program's own");
    }
}

#[test]
fn fixtures_transform_into_golden_files() {
    let profile = Profile::default_profile();
    for name in FIXTURES {
        let input = fixture(name);
        let t = run(&input, &profile).unwrap_or_else(|e| panic!("{name}: {e}"));
        check_properties(name, &input, &t);
        insta::assert_snapshot!(
            format!("transform_{}", name.replace('.', "_")),
            String::from_utf8_lossy(&t.bytes)
        );
    }
}

#[test]
fn crlf_and_latin1_keep_their_bytes() {
    let profile = Profile::default_profile();
    let crlf = run(&fixture("crlf.mpf"), &profile).unwrap();
    // Inserted blocks take the file's line ending; no bare LF appears.
    assert!(
        !crlf
            .bytes
            .windows(2)
            .any(|w| w[1] == b'\n' && w[0] != b'\r')
    );
    assert!(
        crlf.bytes
            .starts_with(b"%_N_CRLF_PART_MPF\r\n;$PATH=/_N_MPF_DIR\r\n; driftloop-omm")
    );
    let latin = fixture("latin1.mpf");
    let out = run(&latin, &profile).unwrap();
    assert!(
        out.bytes.windows(3).any(|w| w == b"f\xfcr"),
        "Latin-1 byte kept as is"
    );
    assert!(std::str::from_utf8(&out.bytes).is_err());
}

#[test]
fn r_parameters_in_the_free_range_are_moved_around() {
    let mut profile = Profile::default_profile();
    (profile.registers.r_first, profile.registers.r_last) = (900, 989);
    let t = run(&fixture("r_in_free_range.mpf"), &profile).unwrap();
    for own in [900, 901, 902, 950] {
        assert!(!t.summary.r_parameters.contains(&own));
    }
    assert_eq!(t.summary.r_parameters[0], 903);
    // A range too small for driftloop's registers is refused with a message that says so.
    let mut narrow = profile.clone();
    narrow.registers.r_first = 900;
    narrow.registers.r_last = 920;
    let err = run(&fixture("r_in_free_range.mpf"), &narrow)
        .unwrap_err()
        .to_string();
    assert!(err.contains("not enough free R-parameters"), "{err}");
    assert!(err.contains("uses 3 of them"), "{err}");
}

#[test]
fn refusals_are_clear() {
    let profile = Profile::default_profile();
    let once = run(&fixture("handwritten.mpf"), &profile).unwrap();
    let again = run(&once.bytes, &profile).unwrap_err().to_string();
    assert!(
        again.contains("already carries driftloop's blocks (line 1"),
        "{again}"
    );
    let broken = run(b"T1 M6\nIF R1>\nG1 X1\nM30\n", &profile)
        .unwrap_err()
        .to_string();
    assert!(broken.contains("syntax error"), "{broken}");
    let archive = run(
        b"\x00\x01PCARC checksum 1234\n%_N_A_MPF\nT1 M6\nM30\n",
        &profile,
    )
    .unwrap_err()
    .to_string();
    assert!(archive.contains("PC-format archive"), "{archive}");
    let computed = run(
        b"G54\nT1 M6\nS1000 M3\nR[R1+1]=5\nG1 X10 F100\nM30\n",
        &profile,
    )
    .unwrap_err()
    .to_string();
    assert!(
        computed.contains("line 4 indexes R-parameters"),
        "{computed}"
    );
    // The default corrects the offset in force; a profile that corrects the stored G54 refuses G55.
    let g55 = b"G55\nT1 M6\nS1000 M3\nG1 X10 F100\nM30\n";
    run(g55, &profile).unwrap();
    let other = run(g55, &common::frame_profile()).unwrap_err().to_string();
    assert!(other.contains("selects G55 (line 1)"), "{other}");
    let still = run(b"T1 M6\nS1000 M3\nM30\n", &profile)
        .unwrap_err()
        .to_string();
    assert!(still.contains("moves no axis"), "{still}");
    // With `unknown_tool = "refuse"` a spindle probe is not swapped for a tool nobody named; the message
    // says what to set.
    let mut refusing = profile.clone();
    refusing.probe.unknown_tool = driftloop::omm::profile::UnknownTool::Refuse;
    let no_tool = run(b"G54\nS1000 M3\nG1 X10 F100\nM30\n", &refusing)
        .unwrap_err()
        .to_string();
    assert!(
        no_tool.contains("no place for the reference measurement")
            && no_tool.contains("line 2")
            && no_tool.contains("tool in the spindle is not known")
            && no_tool.contains("kind = \"tool-setter\""),
        "{no_tool}"
    );
}

#[test]
fn plan_of_the_handwritten_program() {
    let profile = Profile::default_profile();
    let t = run(&fixture("handwritten.mpf"), &profile).unwrap();
    let program = driftloop::parse(&fixture("handwritten.mpf"));
    let mut table = Vec::new();
    let timeline = driftloop::omm::timeline::build(&program, &profile);
    let rows = driftloop::omm::report::pass_rows(&program, &timeline);
    driftloop::omm::report::write_passes(&mut table, &rows).unwrap();
    driftloop::omm::report::write_table(&mut table, &program, &t.plan).unwrap();
    insta::assert_snapshot!("plan_handwritten", String::from_utf8(table).unwrap());
    // An extra measuring cycle inside the long first pass, where the prediction crossed δ'.
    assert!(
        t.plan
            .gates
            .iter()
            .any(|g| g.measure && g.kind == driftloop::omm::GateKind::Extra)
    );
    // And a gate in the body of the program's own WHILE loop (line 21), where the program decides on every
    // iteration, although the plan, counting the loop once, expects no measurement there.
    let in_loop = t
        .plan
        .gates
        .iter()
        .find(|g| g.block == 20)
        .expect("gate in the loop");
    assert!(
        in_loop.kind == driftloop::omm::GateKind::Extra && in_loop.can_measure && !in_loop.measure
    );
}

#[test]
fn plan_of_the_loops_program() {
    let profile = Profile::default_profile();
    let input = fixture("loops.mpf");
    let t = run(&input, &profile).unwrap();
    let program = driftloop::parse(&input);
    let timeline = driftloop::omm::timeline::build(&program, &profile);
    let mut table = Vec::new();
    let rows = driftloop::omm::report::pass_rows(&program, &timeline);
    driftloop::omm::report::write_passes(&mut table, &rows).unwrap();
    driftloop::omm::report::write_table(&mut table, &program, &t.plan).unwrap();
    driftloop::omm::report::write_loops(&mut table, &program, &t.plan).unwrap();
    insta::assert_snapshot!("plan_loops", String::from_utf8(table).unwrap());
    // The roughing FOR runs six times, the finishing contour once plus three repeats, the FOR bounded by R10
    // (assigned 4) four times; the WHILE is counted once.
    let runs: Vec<Option<u64>> = t.plan.loops.iter().map(|l| l.runs).collect();
    assert_eq!(runs, [Some(6), Some(4), Some(4), None]);
    // The gate in the roughing loop's body runs with every layer, and the plan expects it to measure in
    // some of them, although its first run predicts less than δ'.
    let in_for = t.plan.gates.iter().find(|g| g.block == 18).unwrap();
    assert_eq!(in_for.runs, 6);
    assert!(in_for.measurements >= 1 && in_for.predicted_um < t.plan.working_limit_um);
    assert_eq!(
        t.plan.measurements,
        t.plan.gates.iter().map(|g| g.measurements).sum::<usize>()
    );
    // Counted once, the same program would end 30 min earlier than the loops make it.
    let once = timeline
        .loops
        .iter()
        .map(|l| l.further_runs() as f64 * l.body_min);
    assert!(once.sum::<f64>() > 30.0);
}

#[test]
fn cam_program_from_the_corpus() {
    let Some(path) =
        shared_data::path("corpus/sinumerik-840d-sl-cas-package/Approach A/CAM TEST.MPF")
    else {
        return;
    };
    let input = std::fs::read(&path).unwrap();
    let t = run(&input, &Profile::default_profile()).unwrap();
    check_properties("CAM TEST.MPF", &input, &t);
    // The corpus file's own text stays out of the repository: only the inserted blocks are kept, each group
    // headed by the input line it is inserted before.
    insta::assert_snapshot!("transform_cam_test_mpf_insertions", insertions(&t.bytes));
}

#[test]
fn cycle978_profile_reads_its_result_variable() {
    let text = std::fs::read_to_string(root().join("fixtures/omm/siemens-cycle978.toml")).unwrap();
    let profile = Profile::from_toml(&text, "cycle978").unwrap();
    let t = run(&fixture("handwritten.mpf"), &profile).unwrap();
    let out = String::from_utf8(t.bytes.clone()).unwrap();
    assert!(out.contains("=_OVR[4] ;DL"));
    assert!(out.contains("CYCLE978(0,0,,1,0,10,1,3,2,1,"));
    check_properties(
        "handwritten.mpf (CYCLE978)",
        &fixture("handwritten.mpf"),
        &t,
    );
}
