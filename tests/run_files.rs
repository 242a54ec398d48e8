//! `run --write-files DIR`: the files a program writes with WRITE (a transformed program's DRIFTLOG) land in
//! DIR, one folder per job, and the logs of several jobs merge into one series for `diagnose`.

mod common;

#[test]
fn the_drift_logs_of_two_jobs_are_written_and_merge_into_two_runs() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let o = common::run(&[
        "transform",
        "fixtures/omm/handwritten.mpf",
        "--model",
        "fixtures/omm/model.toml",
        "--no-audit",
        "-o",
        &p("part.mpf"),
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    for (job, seed) in [("job1", "1"), ("job2", "2")] {
        let o = common::run(&[
            "run",
            &p("part.mpf"),
            "--machine",
            "fixtures/vm/machines/model_truth.toml",
            "--seed",
            seed,
            "--write-files",
            &p(job),
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
    }
    let log = std::fs::read_to_string(p("job1/DRIFTLOG")).unwrap();
    assert!(
        log.starts_with("time_min,spindle_rpm,drift_z_um,pass,run\n"),
        "{log}"
    );
    assert_eq!(log.matches("time_min").count(), 1, "one job, one header");
    let merged = common::stdout(&common::run(&[
        "log",
        "merge",
        &p("job1/DRIFTLOG"),
        &p("job2/DRIFTLOG"),
    ]));
    let runs: std::collections::BTreeSet<&str> = merged
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(runs.len(), 2, "{merged}");
    // Run again into the same folder: the file is replaced, not appended to.
    let o = common::run(&[
        "run",
        &p("part.mpf"),
        "--machine",
        "fixtures/vm/machines/model_truth.toml",
        "--write-files",
        &p("job1"),
    ]);
    assert!(o.status.success());
    assert_eq!(std::fs::read_to_string(p("job1/DRIFTLOG")).unwrap(), log);
}
