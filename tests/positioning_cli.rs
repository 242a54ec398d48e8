//! `driftloop positioning` through the binary, on the generated fixtures.

mod common;

use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/positioning")
        .join(name)
}

/// Deterministic pseudo-random normal numbers (64-bit LCG + Box–Muller), so the fixture is reproducible.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// One simulated axis: targets (mm), systematic deviation and reversal (µm) as functions of position.
struct SimulatedAxis {
    name: &'static str,
    targets: &'static [f64],
    systematic: fn(f64) -> f64,
    reversal: fn(f64) -> f64,
}

/// A ball-screw axis X (500 mm, lead error 30 µm/m, a 250 mm periodic term, backlash growing along the
/// travel) and a shorter axis Y; five runs of the ISO 230-2 cycle (targets upwards in +, downwards in −).
fn generate_fixture() -> String {
    let axes = [
        SimulatedAxis {
            name: "X",
            targets: &[
                0.0, 48.3, 101.2, 149.1, 202.6, 250.4, 298.7, 351.5, 399.2, 452.8, 500.0,
            ],
            systematic: |p| 0.03 * p + 3.0 * (2.0 * std::f64::consts::PI * p / 250.0).sin(),
            reversal: |p| 6.0 + 0.008 * p,
        },
        SimulatedAxis {
            name: "Y",
            targets: &[0.0, 51.7, 98.4, 152.0, 197.9, 251.3, 300.0],
            systematic: |p| -4.0 + 0.00015 * (p - 150.0).powi(2),
            reversal: |_| 3.0,
        },
    ];
    let mut noise = Noise(27_843);
    let mut out = String::from("axis,target_mm,direction,run,deviation_um\n");
    for axis in axes {
        for run in 1..=5 {
            for &p in axis.targets {
                let value = (axis.systematic)(p) + (axis.reversal)(p) / 2.0 + 1.2 * noise.normal();
                out += &format!("{},{p},+,{run},{value:.1}\n", axis.name);
            }
            for &p in axis.targets.iter().rev() {
                let value = (axis.systematic)(p) - (axis.reversal)(p) / 2.0 + 1.2 * noise.normal();
                out += &format!("{},{p},-,{run},{value:.1}\n", axis.name);
            }
        }
    }
    out
}

#[test]
fn fixture_is_what_the_generator_writes() {
    let path = fixture("two_axes.csv");
    let generated = generate_fixture();
    if std::env::var_os("DRIFTLOOP_WRITE_FIXTURES").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let stored = std::fs::read_to_string(&path)
        .expect("fixture present (DRIFTLOOP_WRITE_FIXTURES=1 writes it)");
    assert!(
        stored == generated,
        "fixtures/positioning/two_axes.csv differs from the generator"
    );
}

#[test]
fn worked_row_through_the_binary() {
    let out = common::stdout(&common::run(&[
        "positioning",
        "fixtures/positioning/paper_row.csv",
    ]));
    let row = out
        .lines()
        .find(|l| l.trim_start().starts_with("50.000"))
        .expect("row for 50 mm");
    let fields: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(
        fields,
        [
            "50.000", "5", "9.00", "3.39", "-1.17", "19.17", "5", "-8.80", "1.79", "-14.17",
            "-3.43", "17.80", "33.34"
        ]
    );
}

#[test]
fn human_output_iso() {
    let out = common::stdout(&common::run(&[
        "positioning",
        "fixtures/positioning/two_axes.csv",
        "--standard",
        "iso230-2",
    ]));
    insta::assert_snapshot!(out);
}

#[test]
fn json_output_dstu() {
    let out = common::stdout(&common::run(&[
        "positioning",
        "fixtures/positioning/two_axes.csv",
        "--format",
        "json",
        "--grid",
        "X=0:50:500",
        "--grid",
        "0:100:300",
    ]));
    let value: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    assert_eq!(value["standard"], "dstu27843");
    assert_eq!(value["k"], 3.0);
    assert_eq!(value["axes"][0]["correction"]["grid"]["step_mm"], 50.0);
    assert_eq!(value["axes"][1]["correction"]["grid"]["step_mm"], 100.0);
    insta::assert_snapshot!(out);
}

#[test]
fn iso_and_dstu_differ_only_by_k_in_the_limits() {
    let json = |standard: &str| -> serde_json::Value {
        let out = common::stdout(&common::run(&[
            "positioning",
            "fixtures/positioning/paper_row.csv",
            "--format",
            "json",
            "--standard",
            standard,
        ]));
        serde_json::from_str(&out).unwrap()
    };
    let (iso, dstu) = (json("iso230-2"), json("dstu27843"));
    let row = |v: &serde_json::Value, field: &str| {
        v["axes"][0]["targets"][1]["plus"][field].as_f64().unwrap()
    };
    assert_eq!(row(&iso, "mean_um"), row(&dstu, "mean_um"));
    assert_eq!(row(&iso, "s_um"), row(&dstu, "s_um"));
    let s = row(&iso, "s_um");
    assert!((row(&iso, "upper_um") - (9.0 + 2.0 * s)).abs() < 1e-12);
    assert!((row(&dstu, "upper_um") - (9.0 + 3.0 * s)).abs() < 1e-12);
    assert!(
        iso["axes"][0]["summary"]["R"].is_number()
            && dstu["axes"][0]["summary"]["w_max"].is_number()
    );
}

#[test]
fn sinumerik_table_text() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("comp.ini");
    let out = common::run(&[
        "positioning",
        "fixtures/positioning/two_axes.csv",
        "--standard",
        "iso230-2",
        "--grid",
        "X=0:50:500",
        "--grid",
        "Y=0:50:300",
        "--table",
        path.to_str().unwrap(),
    ]);
    common::stdout(&out);
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(
        text.matches("%_N_AX_EEC_INI").count(),
        4,
        "two axes × two directions"
    );
    assert_eq!(text.matches("$AA_ENC_COMP[0,").count(), 2 * 11 + 2 * 7);
    assert!(text.contains("$AA_ENC_COMP_STEP[0,X]=50.000\n$AA_ENC_COMP_MIN[0,X]=0.000\n$AA_ENC_COMP_MAX[0,X]=500.000\n"));
    insta::assert_snapshot!(text);
}

#[test]
fn csv_table_to_stdout_replaces_the_report() {
    let out = common::stdout(&common::run(&[
        "positioning",
        "fixtures/positioning/paper_row.csv",
        "--grid",
        "0:25:100",
        "--table",
        "-",
    ]));
    let mut lines = out.lines();
    assert_eq!(
        lines.next(),
        Some(
            "axis,kind,position_mm,correction_plus_um,correction_minus_um,residual_plus_um,residual_minus_um"
        )
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 3 + 5);
    assert_eq!(rows[1], "X,measured,50.000,-9.000,8.800,0.000,0.000");
    assert!(
        rows[3].starts_with("X,grid,0.000,-2.400,3.400,,"),
        "{}",
        rows[3]
    );
}

#[test]
fn html_report_is_written_and_self_contained() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.html");
    common::stdout(&common::run(&[
        "positioning",
        "fixtures/positioning/two_axes.csv",
        "--report",
        path.to_str().unwrap(),
    ]));
    let html = std::fs::read_to_string(&path).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert_eq!(html.matches("<svg").count(), 6, "three charts per axis");
    assert!(html.contains("How to read this"));
    assert!(html.contains("x̄↑ ± 3·s↑"));
    assert!(html.contains("$AA_ENC_COMP[0,0,X]="));
    assert!(!html.contains("<script") && !html.contains("<link"));
    let namespaces = html.matches("xmlns=\"http://www.w3.org/2000/svg\"").count();
    assert_eq!(
        html.matches("http").count(),
        namespaces,
        "no address but the SVG namespace"
    );
}

#[test]
fn bad_input_exits_2_naming_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.csv");
    let good = std::fs::read_to_string(fixture("paper_row.csv")).unwrap();
    std::fs::write(&path, good.replacen("X,50,-,3,-11", "X,50,-,3,-1l", 1)).unwrap();
    let out = common::run(&["positioning", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bad.csv:19:5 (deviation_um): expected a deviation in µm, found `-1l`"),
        "{stderr}"
    );
    assert!(out.stdout.is_empty());
}

#[test]
fn too_few_approaches_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("short.csv");
    let good = std::fs::read_to_string(fixture("paper_row.csv")).unwrap();
    let short: String = good
        .lines()
        .filter(|l| *l != "X,100,+,5,6")
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&path, short).unwrap();
    let out = common::run(&["positioning", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("axis X target 100 mm direction +: 4 value(s), at least 5 approaches"),
        "{stderr}"
    );
}

#[test]
fn bad_grid_and_missing_file_exit_2() {
    let out = common::run(&[
        "positioning",
        "fixtures/positioning/paper_row.csv",
        "--grid",
        "0:30:100",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a whole number of STEP"));
    let out = common::run(&[
        "positioning",
        "fixtures/positioning/paper_row.csv",
        "--grid",
        "Z=0:50:100",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("axis Z, which is not in"));
    let out = common::run(&["positioning", "fixtures/positioning/no_such_file.csv"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("cannot read fixtures/positioning/no_such_file.csv")
    );
}

#[test]
fn reads_stdin() {
    let out = common::driftloop(
        Path::new(env!("CARGO_MANIFEST_DIR")),
        &["positioning", "-", "--format", "json"],
        &std::fs::read(fixture("paper_row.csv")).unwrap(),
    );
    let value: serde_json::Value = serde_json::from_str(&common::stdout(&out)).unwrap();
    assert_eq!(value["axes"][0]["targets"].as_array().unwrap().len(), 3);
}

#[test]
fn documented_worked_example_is_the_real_output() {
    let readme = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/commands/positioning.md"),
    )
    .unwrap();
    let marker =
        "```sh\ndriftloop positioning fixtures/positioning/paper_row.csv\n```\n\n```text\n";
    let start = readme
        .find(marker)
        .expect("docs/commands/positioning.md shows the worked example")
        + marker.len();
    let end = start + readme[start..].find("```").unwrap();
    let out = common::stdout(&common::run(&[
        "positioning",
        "fixtures/positioning/paper_row.csv",
    ]));
    assert_eq!(&readme[start..end], out, "update the documented example");
}
