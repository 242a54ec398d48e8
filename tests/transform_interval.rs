//! `limits.max_interval_min`: a gate that can measure does once the time since the last measurement ran
//! out, even where the model predicts too little change to ask for one; `diagnose --profile` reports the
//! error with that probing interval.

mod common;

/// Six tools, each cutting about 12 min at a low speed: the model's change between tool changes stays below
/// δ', so without an interval only the zero measures.
fn six_slow_passes() -> String {
    let mut text = String::from("G17 G90 G94 G54\n");
    for t in 1..=6 {
        text.push_str(&format!(
            "T{t} M6\nD1\nS1000 M3 M8\nG0 X200 Y200 Z5\nG1 Z-1 F100\nG1 X800 F100\nG1 X200\nG0 Z50\n"
        ));
    }
    text.push_str("M30\n");
    text
}

fn with_interval(minutes: &str) -> String {
    driftloop::omm::DEFAULT_PROFILE.replace(
        "max_attempts = 8",
        &format!("max_attempts = 8\nmax_interval_min = {minutes}"),
    )
}

/// The gate headers' planned decisions, in order.
fn planned(out: &str) -> Vec<bool> {
    out.lines()
        .filter(|l| l.starts_with("; driftloop gate"))
        .map(|l| l.contains("planned: measure"))
        .collect()
}

#[test]
fn a_gate_measures_once_the_interval_since_the_last_measurement_ran_out() {
    let src = six_slow_passes();
    let plain = common::transformed_in(&[("p.mpf", &src)], "p.mpf", "blum-tc50");
    assert!(planned(&plain).iter().all(|m| !m), "{plain}");
    let profile = with_interval("15");
    let out = common::transformed_in(&[("p.mpf", &src), ("i.toml", &profile)], "p.mpf", "i.toml");
    let measured: Vec<usize> = planned(&out)
        .iter()
        .enumerate()
        .filter_map(|(k, m)| m.then_some(k))
        .collect();
    // Each pass takes about 12 min: the third and the fifth pass start 24 and 48 min after the zero.
    assert_eq!(measured.len(), 2, "{out}");
    // On the machine the same: the timer at each measurement is kept, and a gate skips only while both
    // the change is below δ' and the interval has not run out.
    let skip = out
        .lines()
        .find(|l| l.ends_with("GOTOF DLSKIP3 ;DL"))
        .unwrap();
    assert!(skip.contains("<15)"), "{skip}");
    let kept = out.lines().filter(|l| l.ends_with("=R51 ;DL")).count();
    assert!(
        kept >= 6,
        "the zero and every measuring gate keep the timer:\n{out}"
    );
}

#[test]
fn an_interval_that_is_no_time_is_refused() {
    for bad in ["0", "-5", "nan", "100000"] {
        let profile = with_interval(bad);
        let (o, _dir) = common::transform_in(
            &[("p.mpf", &six_slow_passes()), ("i.toml", &profile)],
            "p.mpf",
            "i.toml",
        );
        let err = common::stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{bad}: {err}");
        assert!(err.contains("limits.max_interval_min"), "{bad}: {err}");
    }
}

#[test]
fn diagnose_reports_probing_at_the_profiles_interval() {
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("i.toml");
    std::fs::write(&profile, with_interval("15")).unwrap();
    let profile = profile.display().to_string();
    let model = common::fixture("omm/model.toml");
    let data = common::fixture("data/characterisation.csv");
    let every = |extra: &[&str]| {
        let mut args = vec!["diagnose", &model, &data];
        args.extend(extra);
        let o = common::run(&args);
        // Exit 1: the diagnosis added effects; either way the report is on stdout.
        assert!(
            o.status.code().is_some_and(|c| c <= 1),
            "{}",
            common::stderr(&o)
        );
        String::from_utf8(o.stdout).unwrap()
    };
    assert!(every(&[]).contains("every 60 min"));
    assert!(every(&["--profile", &profile]).contains("every 15 min"));
    let flag = every(&["--profile", &profile, "--probe-every", "30min"]);
    assert!(flag.contains("every 30 min"), "{flag}");
}
