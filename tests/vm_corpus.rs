//! The 32 example programs of CEAD-group/nc-gcode-interpreter come with the axis positions that independent
//! interpreter produced. Where our subset covers a program, the sequence of axis positions must agree.
//!
//! Comparison: the reference writes a row per block with only the axes programmed so far; we take, per
//! executed block, the commanded machine position of the same axes (empty until programmed). Rows where no
//! compared axis has a value are dropped and consecutive equal rows merged on both sides (the two interpreters
//! emit rows for different sets of non-moving blocks), then the sequences must be equal to 0.0005 mm (the
//! reference prints three decimals).

mod shared_data;

use std::path::{Path, PathBuf};

use driftloop::vm::{Config, SimpleMachine, run_file};

/// Columns of the reference CSV that are not axis positions.
fn is_axis_column(name: &str) -> bool {
    !(name.starts_with("gg")
        || matches!(
            name,
            "N" | "F"
                | "S"
                | "T"
                | "D"
                | "M"
                | "I"
                | "J"
                | "K"
                | "CR"
                | "PW"
                | "SD"
                | "PL"
                | "comment"
                | "non_returning_function_call"
                | "flattened"
        ))
}

type Row = Vec<Option<f64>>;

fn compress(rows: impl Iterator<Item = Row>) -> Vec<Row> {
    let mut out: Vec<Row> = Vec::new();
    for r in rows {
        if r.iter().all(Option::is_none) || out.last().is_some_and(|l| close(l, &r)) {
            continue;
        }
        out.push(r);
    }
    out
}

fn close(a: &Row, b: &Row) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| match (x, y) {
            (Some(x), Some(y)) => (x - y).abs() <= 0.0005,
            (None, None) => true,
            _ => false,
        })
}

#[derive(Debug, PartialEq)]
enum Outcome {
    Agree,
    /// The run stopped with an error (text of the error).
    Unsupported(String),
    /// The runs disagree: first differing row.
    Differ(String),
}

fn compare(mpf: &Path) -> Outcome {
    // The flattening demo's plain interpretation is stored as `…_raw.csv`.
    let raw = mpf.with_file_name(format!(
        "{}_raw.csv",
        mpf.file_stem().unwrap().to_string_lossy()
    ));
    let csv_path = if raw.exists() {
        raw
    } else {
        mpf.with_extension("csv")
    };
    let mut reader = csv::Reader::from_path(&csv_path).expect("reference CSV");
    let headers: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    let columns: Vec<(usize, String)> = headers
        .iter()
        .enumerate()
        .filter(|(_, h)| is_axis_column(h))
        .map(|(i, h)| (i, h.to_ascii_uppercase()))
        .collect();
    let expected = compress(reader.records().map(|r| {
        let r = r.unwrap();
        columns
            .iter()
            .map(|(i, _)| {
                r.get(*i)
                    .filter(|v| !v.is_empty())
                    .map(|v| v.parse().unwrap())
            })
            .collect()
    }));
    let mut cfg = Config::default();
    for (_, name) in &columns {
        if !cfg.axes.contains(name) {
            cfg.axes.push(name.clone());
        }
    }
    // The reference does not model feed; geometry is what is compared.
    cfg.default_feed_mm_min = Some(1000.0);
    let run = match run_file(mpf, &cfg, &mut SimpleMachine::cold()) {
        Ok(run) => run,
        Err(e) => return Outcome::Unsupported(e.message),
    };
    let index: Vec<usize> = columns
        .iter()
        .map(|(_, n)| run.axes.iter().position(|a| a == n).unwrap())
        .collect();
    let ours = compress(run.trace.iter().map(|t| {
        index
            .iter()
            .map(|&a| (t.moved_axes & (1 << a) != 0).then(|| t.machine[a]))
            .collect()
    }));
    for k in 0..expected.len().max(ours.len()) {
        match (expected.get(k), ours.get(k)) {
            (Some(e), Some(o)) if close(e, o) => {}
            (e, o) => {
                return Outcome::Differ(format!("position row {k}: reference {e:?}, ours {o:?}"));
            }
        }
    }
    Outcome::Agree
}

/// What we expect per program, and why where it is not agreement.
fn expectation(name: &str) -> Result<(), &'static str> {
    Err(match name {
        "arrays" => "FOR counters NN, M, O are used without DEF (alarm 12550 on a control)",
        "axis_index_assignment" => {
            "ACC[E]: E is an axis of that machine, not of the dry run's (X Y Z A B C), and X=ACC[E] reads ACC as a value"
        }
        "custom_vars" => {
            "reads AA and BB, which the program never defines (alarm 12550 on a control)"
        }
        "edge_cases" => "assigns E_MULTIPLIER without DEF (alarm 12550 on a control)",
        "simple" => "G2 without centre or radius (an alarm on a control)",
        "function_calls" => "SETAL stops the program in the dry run; the reference carries on",
        "increment" => "the reference gives Y = 900.9 for Y=IC(0.1*NN) with NN = 9; we get 0.9",
        _ => return Ok(()),
    })
}

#[test]
fn corpus_positions_agree_with_the_reference_interpreter() {
    let Some(dir) = shared_data::path("corpus/nc-gcode-interpreter-examples/examples") else {
        return;
    };
    let mut files: Vec<PathBuf> = [dir.clone(), dir.join("flattening")]
        .iter()
        .flat_map(|d| std::fs::read_dir(d).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "mpf"))
        .collect();
    files.sort();
    assert_eq!(files.len(), 32, "the corpus holds 32 programs");
    let mut agree = 0;
    let mut report = String::new();
    let mut surprises = Vec::new();
    for f in &files {
        let name = f.file_stem().unwrap().to_string_lossy().into_owned();
        let outcome = compare(f);
        if outcome == Outcome::Agree {
            agree += 1;
        }
        report.push_str(&format!("{name:28} {outcome:?}\n"));
        let expected = expectation(&name);
        let ok = match (&outcome, expected) {
            (Outcome::Agree, Ok(())) => true,
            (Outcome::Unsupported(_) | Outcome::Differ(_), Err(why)) => {
                report.push_str(&format!("{:28} ↳ {why}\n", ""));
                true
            }
            _ => false,
        };
        if !ok {
            surprises.push(format!("{name}: {outcome:?} (expected {expected:?})"));
        }
    }
    eprintln!("{report}corpus: {agree} of {} agree", files.len());
    assert!(
        surprises.is_empty(),
        "unexpected outcomes:\n{}",
        surprises.join("\n")
    );
}

/// Real programs of the corpus run to their end: 5-axis CAM output (SUPA, CYCLE800(), tool names as strings)
/// and an 828D warm-up routine in inch (G70/G700) calling a PROC subprogram from the control's subprogram
/// folder, whose spindle schedule is what the thermal model needs.
#[test]
fn real_corpus_programs_run_to_their_end() {
    let Some(corpus) = shared_data::path("corpus") else {
        return;
    };
    let cam = corpus.join("sinumerik-840d-sl-cas-package/Approach A/CAM TEST.MPF");
    let run = run_file(&cam, &Config::default(), &mut SimpleMachine::cold()).unwrap();
    assert_eq!(
        run.end,
        driftloop::vm::End::ProgramEnd { code: "M30".into() }
    );
    assert!(run.spindle.steps.iter().any(|s| s.1 == 1061.0));
    assert!(!run.passes.is_empty());

    let warmup = corpus.join("syil-x7-warmup-routines");
    let cfg = Config {
        subprogram_dirs: vec![warmup.join("subroutines")],
        ..Config::default()
    };
    let run = run_file(
        &warmup.join("routines/DAILY.MPF"),
        &cfg,
        &mut SimpleMachine::cold(),
    )
    .unwrap();
    let speeds: Vec<f64> = run.spindle.steps.iter().map(|s| s.1).collect();
    assert_eq!(
        speeds,
        [3600.0, 7200.0, 0.0],
        "30 % then 60 % of the top speed, then M5"
    );
    // Each call runs 600 s / 15 s = 40 cycles of the same moves, so both speeds last equally long.
    let steps = &run.spindle.steps;
    let (first, second) = (steps[1].0 - steps[0].0, steps[2].0 - steps[1].0);
    assert!(
        (first - second).abs() < 1e-9 && first > 1.0,
        "{first} vs {second} min"
    );
}
