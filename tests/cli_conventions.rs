//! The conventions every command follows, as rustfmt and ruff do: `--check` and `--diff` exit 1 when something
//! would change, 0 when nothing would, 2 on error; one colour policy for our output and clap's (`--color`,
//! NO_COLOR); a missing file's OS error printed once.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};

fn code(o: &Output) -> i32 {
    o.status.code().expect("exit code")
}

const MODEL: &str = "fixtures/omm/model.toml";
const PART: &str = "fixtures/omm/handwritten.mpf";

/// The fixture part transformed, in a temporary folder.
fn transformed(dir: &Path) -> String {
    let out = dir.join("part_t.mpf").display().to_string();
    let o = common::run(&["transform", PART, "--model", MODEL, "-o", &out]);
    assert_eq!(code(&o), 0, "{}", common::stderr(&o));
    out
}

#[test]
fn diff_exits_1_when_the_program_would_change_0_when_transformed_already_and_2_on_error() {
    let o = common::run(&["transform", PART, "--model", MODEL, "--diff"]);
    assert_eq!(code(&o), 1, "{}", common::stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("+; driftloop-omm"));

    let dir = tempfile::tempdir().unwrap();
    let done = transformed(dir.path());
    let o = common::run(&["transform", &done, "--model", MODEL, "--diff"]);
    assert_eq!(code(&o), 0, "{}", common::stderr(&o));
    assert!(o.stdout.is_empty(), "no diff for a transformed program");
    assert!(
        common::stderr(&o).contains("already transformed"),
        "{}",
        common::stderr(&o)
    );

    let o = common::run(&["transform", PART, "--model", "missing.toml", "--diff"]);
    assert_eq!(code(&o), 2);
    let o = common::run(&[
        "transform",
        "fixtures/nc/errors.mpf",
        "--model",
        MODEL,
        "--diff",
    ]);
    assert_eq!(code(&o), 2, "a refusal is an error, not a change");
    assert!(o.stdout.is_empty());
}

#[test]
fn check_calls_a_transformed_program_already_transformed_and_exits_0() {
    let dir = tempfile::tempdir().unwrap();
    let done = transformed(dir.path());
    let before = std::fs::read(&done).unwrap();
    let o = common::run(&["transform", &done, "--model", MODEL, "--check"]);
    assert_eq!(code(&o), 0, "{}", common::stderr(&o));
    let err = common::stderr(&o);
    assert!(
        err.contains("already transformed (driftloop header on line 1); nothing would change"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(&done).unwrap(),
        before,
        "--check writes nothing"
    );

    let o = common::run(&[
        "transform",
        &done,
        "--model",
        MODEL,
        "--check",
        "--format",
        "json",
    ]);
    assert_eq!(code(&o), 0);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json[0]["changed"], false);
    assert_eq!(json[0]["already_transformed"], 1);

    // The original still would change; writing a transformed program again stays a refusal.
    let o = common::run(&["transform", PART, "--model", MODEL, "--check"]);
    assert_eq!(code(&o), 1);
    let again = dir.path().join("again.mpf").display().to_string();
    let o = common::run(&["transform", &done, "--model", MODEL, "-o", &again]);
    assert_eq!(code(&o), 2);
    assert!(!Path::new(&again).exists());
}

#[test]
fn a_batch_check_counts_the_programs_transformed_already() {
    let dir = tempfile::tempdir().unwrap();
    transformed(dir.path());
    std::fs::copy(PART, dir.path().join("part.mpf")).unwrap();
    let d = dir.path().display().to_string();
    let o = common::run(&["transform", &d, "--model", MODEL, "--check"]);
    assert_eq!(code(&o), 1, "the original would change");
    let err = common::stderr(&o);
    assert!(
        err.contains("1 of 2 programs transform (50.0 %); already transformed: 1"),
        "{err}"
    );
}

/// `driftloop ARGS` with the given environment, stderr not a terminal.
fn with_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_driftloop"));
    cmd.args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("NO_COLOR")
        .env_remove("CLICOLOR_FORCE")
        .env_remove("CLICOLOR")
        .stdin(Stdio::null());
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().unwrap()
}

fn coloured(o: &Output) -> bool {
    o.stderr.contains(&0x1b)
}

#[test]
fn one_colour_policy_for_our_diagnostics_our_errors_and_clap() {
    let diagnostics = ["check", "fixtures/nc/errors.mpf"];
    let ours = ["fit", "missing.csv", "--channel", "z_um"];
    let claps = ["check", "--no-such-flag"];
    for args in [&diagnostics[..], &ours[..], &claps[..]] {
        let plain = with_env(args, &[]);
        assert!(!coloured(&plain), "auto, not a terminal: {args:?}");
        assert_ne!(code(&plain), 0);
        let always: Vec<&str> = ["--color", "always"].iter().chain(args).copied().collect();
        assert!(
            coloured(&with_env(&always, &[])),
            "--color always: {args:?}"
        );
        let late: Vec<&str> = args.iter().copied().chain(["--color=always"]).collect();
        assert!(
            coloured(&with_env(&late, &[])),
            "--color=always last: {args:?}"
        );
        assert!(
            coloured(&with_env(&always, &[("NO_COLOR", "1")])),
            "an explicit flag wins over NO_COLOR: {args:?}"
        );
        assert!(
            coloured(&with_env(args, &[("CLICOLOR_FORCE", "1")])),
            "{args:?}"
        );
        assert!(
            !coloured(&with_env(
                args,
                &[("CLICOLOR_FORCE", "1"), ("NO_COLOR", "1")]
            )),
            "NO_COLOR wins under auto: {args:?}"
        );
        let never: Vec<&str> = ["--color", "never"].iter().chain(args).copied().collect();
        assert!(
            !coloured(&with_env(&never, &[("CLICOLOR_FORCE", "1")])),
            "{args:?}"
        );
    }
}

#[test]
fn the_os_error_of_a_missing_file_is_printed_once_and_names_the_file() {
    let commands: [&[&str]; 12] = [
        &["check", "nope.mpf"],
        &["parse", "nope.mpf"],
        &["transform", "nope.mpf", "--model", MODEL],
        &["transform", PART, "--model", "nope.toml"],
        &["plan", "nope.mpf", "--model", MODEL],
        &["strip", "nope.mpf"],
        &["run", "nope.mpf"],
        &["fit", "nope.csv", "--channel", "z_um"],
        &["predict", MODEL, "--data", "nope.csv"],
        &["diagnose", MODEL, "nope.csv", "--channel", "drift_z_um"],
        &["sensors", "nope.csv", "--channel", "z_um"],
        &["positioning", "nope.csv"],
    ];
    // The OS's own text ends in its code on every platform the standard library knows.
    let os = "(os error ";
    for args in commands {
        let o = common::run(args);
        assert_eq!(code(&o), 2, "{args:?}");
        let err = common::stderr(&o);
        assert_eq!(err.matches(os).count(), 1, "{args:?}: {err}");
        assert!(err.contains("nope."), "{args:?}: {err}");
    }
}

#[test]
fn enumerated_values_are_listed_in_the_help() {
    for (command, values) in [
        (&["check"][..], &["human", "json"][..]),
        (&["parse"], &["json", "source"]),
        (&["fit"], &["modes", "dlag", "human", "json"]),
        (
            &["transform"],
            &["human", "json", "auto", "always", "never"],
        ),
        (
            &["positioning"],
            &["dstu27843", "vdi3441", "iso230-2", "csv", "sinumerik"],
        ),
        (
            &["simulate-data"],
            &[
                "input_lag",
                "extra_mode",
                "cooling_asymmetry",
                "position_slope",
                "time_trend",
                "periodic",
                "step",
                "none",
            ],
        ),
        (
            &["profiles"],
            &[
                "blum-tc50",
                "siemens-cycle978",
                "tool-setter",
                "grinder-gauge",
                "lathe-setter",
            ],
        ),
    ] {
        let args: Vec<&str> = command.iter().copied().chain(["--help"]).collect();
        let help = common::stdout(&common::run(&args));
        for v in values {
            assert!(help.contains(v), "{command:?} --help lacks {v}:\n{help}");
        }
    }
}

/// `predict --step`, the durations of `--schedule`, `run --pause` and `fit --lags` took bare minutes only
/// (`--step 30s`: "invalid float literal") while every other time flag took `24h`, `90min`, `57600s`.
#[test]
fn every_time_on_the_command_line_takes_its_unit() {
    let same = |a: &[&str], b: &[&str]| {
        let (x, y) = (common::run(a), common::run(b));
        assert_eq!(code(&x), 0, "{a:?}: {}", common::stderr(&x));
        assert_eq!(x.stdout, y.stdout, "{a:?} and {b:?} differ");
    };
    same(
        &[
            "predict",
            MODEL,
            "--schedule",
            "5000:1h,0:1800s",
            "--step",
            "0.5h",
        ],
        &[
            "predict",
            MODEL,
            "--schedule",
            "5000:60,0:30",
            "--step",
            "30",
        ],
    );
    let dir = tempfile::tempdir().unwrap();
    let part = transformed(dir.path());
    same(
        &[
            "run", &part, "--jobs", "2", "--pause", "1h", "--format", "json",
        ],
        &[
            "run", &part, "--jobs", "2", "--pause", "60", "--format", "json",
        ],
    );
    let o = common::run(&["predict", MODEL, "--schedule", "5000:1 hour"]);
    assert_eq!(code(&o), 2);
    assert!(
        common::stderr(&o).contains("unknown time unit `hour`"),
        "{}",
        common::stderr(&o)
    );
    // No flag asks for bare minutes any more: a time is `<TIME>`.
    for command in [
        "fit",
        "predict",
        "run",
        "forward",
        "diagnose",
        "sensors",
        "simulate-data",
    ] {
        let help = common::stdout(&common::run(&[command, "--help"]));
        assert!(
            !help.contains("<MIN>") && !help.contains("<MIN,"),
            "{command} --help:\n{help}"
        );
    }
}
