//! Logs with rows that carry time and inputs but no reading (an empty `*_um` cell): the production log of
//! a transformed program writes a row at every gate and measures only at some. Every consumer must use the
//! rows without a reading for the input history and leave them out of every fit, score and count.

mod common;

use driftloop::data::{Dataset, Require, read_bytes};
use driftloop::diagnose::{Options, diagnose};
use driftloop::model::synth::{Rng, measure};
use driftloop::model::{DriftModel, FitOptions, ModesChoice, Schedule, fit};

fn read(text: &str) -> Dataset {
    read_bytes("log.csv", text.as_bytes(), Require::Displacement).unwrap()
}

/// The rows of `ds` where `keep` holds (runs kept, their labels with them).
fn keep_rows(ds: &Dataset, keep: &[bool]) -> Dataset {
    let mut out = Dataset::new(ds.source.clone(), ds.time_unit, Vec::new());
    out.run_starts.clear();
    let mut idx = Vec::new();
    for run in ds.runs() {
        out.run_starts.push(idx.len());
        idx.extend(run.filter(|&i| keep[i]));
    }
    out.run_labels = ds.run_labels.clone();
    out.time_min = idx.iter().map(|&i| ds.time_min[i]).collect();
    for c in &ds.columns {
        out.push_column(&c.name, idx.iter().map(|&i| c.values[i]).collect());
    }
    out
}

/// `ds` with the channel blanked (NaN) where `keep` is false.
fn blank(ds: &Dataset, channel: &str, keep: &[bool]) -> Dataset {
    let mut out = ds.clone();
    let v: Vec<f64> = ds
        .values(channel)
        .unwrap()
        .iter()
        .zip(keep)
        .map(|(v, k)| if *k { *v } else { f64::NAN })
        .collect();
    out.push_column(channel, v);
    out
}

fn truth() -> DriftModel {
    DriftModel::from_modes(
        "z_um",
        vec![2000.0, 4000.0, 6000.0],
        &[(35.0, vec![6.0, 15.0, 27.0])],
        0.5,
    )
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn an_empty_displacement_cell_is_a_row_without_a_reading_and_writes_back_empty() {
    let text = "time_min,spindle_rpm,z_um,ambient_c\n0,1000,0,20\n10,2000,,20.5\n20,2000,1.5,21\n";
    let ds = read(text);
    let z = ds.values("z_um").unwrap();
    assert!(z[0] == 0.0 && z[1].is_nan() && z[2] == 1.5);
    assert_eq!(ds.values("spindle_rpm").unwrap()[1], 2000.0);
    let mut out = Vec::new();
    ds.write_csv(&mut out).unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), text);
    // An empty time cell is an error at its line and column, and so is an input with no value at all.
    for (bad, msg) in [
        (
            "time_min,spindle_rpm,z_um\n0,1000,0\n,1000,1\n",
            "log.csv:3:1: column `time_min` is empty",
        ),
        (
            "time_min,z_um,ambient_c\n0,0,\n10,1,nan\n",
            "log.csv:2:3: column `ambient_c` is empty",
        ),
    ] {
        let err = read_bytes("log.csv", bad.as_bytes(), Require::Displacement).unwrap_err();
        assert_eq!(err.to_string(), msg);
    }
}

/// Three heating runs at constant speed, a row every 2 min, a reading every third row (and at each run's
/// first and last row).
fn constant_speed_runs() -> (Dataset, Vec<bool>) {
    let mut text = String::from("time_min,run,spindle_rpm\n");
    for (r, rpm) in [2000, 4000, 6000].iter().enumerate() {
        for k in 0..=120 {
            text.push_str(&format!("{},{r},{rpm}\n", 2 * k));
        }
    }
    let mut ds = read_bytes("runs.csv", text.as_bytes(), Require::InputsOnly).unwrap();
    measure(&truth(), &mut ds, 0.2, &mut Rng::new(11)).unwrap();
    let keep: Vec<bool> = ds
        .runs()
        .flat_map(|r| {
            let (s, e) = (r.start, r.end);
            r.map(move |i| (i - s) % 3 == 0 || i == e - 1)
        })
        .collect();
    (ds, keep)
}

#[test]
fn with_constant_inputs_rows_without_a_reading_fit_as_the_readings_alone() {
    let (ds, keep) = constant_speed_runs();
    let mut opts = FitOptions::new("z_um");
    opts.modes = ModesChoice::Fixed(1);
    let sparse = fit(&blank(&ds, "z_um", &keep), &opts).unwrap();
    let alone = fit(&keep_rows(&ds, &keep), &opts).unwrap();
    let (a, b) = (&sparse.spindle.modes[0], &alone.spindle.modes[0]);
    assert!(close(a.tau_min, b.tau_min, 1e-6), "{a:?} {b:?}");
    for (x, y) in a.gain_um.iter().zip(&b.gain_um) {
        assert!(close(*x, *y, 1e-6), "{a:?} {b:?}");
    }
    let (fs, fa) = (sparse.fit.unwrap(), alone.fit.unwrap());
    assert_eq!(fs.samples, keep.iter().filter(|k| **k).count());
    assert_eq!(fs.samples, fa.samples);
    assert!(close(fs.rms_um, fa.rms_um, 1e-6));
    assert_eq!(
        fs.per_run.iter().map(|r| r.samples).collect::<Vec<_>>(),
        fa.per_run.iter().map(|r| r.samples).collect::<Vec<_>>()
    );
    // The rows without a reading are in the data the model was fitted on, not in its statistics.
    assert_eq!(sparse.data.unwrap().rows, ds.len());
}

#[test]
fn when_inputs_change_between_readings_the_rows_without_one_make_the_fit_better() {
    // The speed changes every 10 to 30 min; the probe reads every 40 min.
    let schedule: Schedule = "2000:30,6000:20,0:10,4000:30,6000:30,2000:20,0:20,6000:40,4000:40"
        .parse()
        .unwrap();
    let mut ds = schedule.to_dataset(10.0);
    measure(&truth(), &mut ds, 0.1, &mut Rng::new(3)).unwrap();
    let keep: Vec<bool> = ds
        .time_min
        .iter()
        .map(|t| (t % 40.0).abs() < 1e-9)
        .collect();
    let mut opts = FitOptions::new("z_um");
    opts.modes = ModesChoice::Fixed(1);
    let sparse = fit(&blank(&ds, "z_um", &keep), &opts).unwrap();
    let dropped = fit(&keep_rows(&ds, &keep), &opts).unwrap();
    // Scored against the truth on the full schedule.
    let error = |m: &DriftModel| {
        let want = truth().predict(&ds).unwrap();
        let got = m.predict(&ds).unwrap();
        let e: Vec<f64> = want.iter().zip(&got).map(|(a, b)| a - b).collect();
        (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt()
    };
    let (es, ed) = (error(&sparse), error(&dropped));
    assert!(
        es < 0.5 && es < 0.25 * ed,
        "with the rows {es} µm, without {ed} µm"
    );
    assert!(
        (sparse.spindle.modes[0].tau_min - 35.0).abs() < 5.0,
        "{:?}",
        sparse.spindle.modes
    );
}

#[test]
fn diagnose_fits_scores_and_counts_only_rows_with_a_reading() {
    let (ds, keep) = constant_speed_runs();
    let mut declared = truth();
    declared.spindle.modes[0].tau_min = 25.0;
    let opts = Options::new("z_um").holdout_from(200.0);
    let sparse = diagnose(&declared, &blank(&ds, "z_um", &keep), &opts).unwrap();
    let alone = diagnose(&declared, &keep_rows(&ds, &keep), &opts).unwrap();
    let readings = keep.iter().filter(|k| **k).count();
    assert_eq!(sparse.rows_fit + sparse.rows_holdout, readings);
    assert_eq!(sparse.rows_unmeasured, ds.len() - readings);
    assert_eq!(
        (sparse.rows_fit, sparse.rows_holdout),
        (alone.rows_fit, alone.rows_holdout)
    );
    assert_eq!(alone.rows_unmeasured, 0);
    for (s, a) in [
        (&sparse.before, &alone.before),
        (&sparse.recalibrated, &alone.recalibrated),
        (&sparse.after, &alone.after),
        (&sparse.uncompensated, &alone.uncompensated),
    ] {
        assert!(close(s.fit.rms_um, a.fit.rms_um, 1e-6), "{s:?} {a:?}");
        let (sh, ah) = (s.holdout.unwrap(), a.holdout.unwrap());
        assert!(close(sh.max_um, ah.max_um, 1e-6), "{s:?} {a:?}");
    }
    assert_eq!(sparse.effects_added.len(), alone.effects_added.len());
    assert_eq!(sparse.residual_white, alone.residual_white);
    // The text says what the unmeasured rows are; the HTML draws no NaN.
    assert!(
        sparse
            .human()
            .contains("rows carry the inputs but no reading")
    );
    assert!(!sparse.html().contains("NaN"));
}

#[test]
fn sensors_regress_on_the_rows_with_a_reading() {
    use driftloop::sensors::{self, synth};
    let ds = synth::dataset(4, 3, 120, synth::TRUTH);
    let keep: Vec<bool> = ds
        .runs()
        .flat_map(|r| {
            let s = r.start;
            r.map(move |i| (i - s) % 4 == 0)
        })
        .collect();
    let opts = sensors::Options::new("e_um");
    let sparse = sensors::analyse(&blank(&ds, "e_um", &keep), &opts).unwrap();
    let alone = sensors::analyse(&keep_rows(&ds, &keep), &opts).unwrap();
    assert_eq!(sparse.training_samples, keep.iter().filter(|k| **k).count());
    assert_eq!(sparse.chosen, alone.chosen);
    for (a, b) in sparse.coefficients.iter().zip(&alone.coefficients) {
        assert!(close(a.value, b.value, 1e-9), "{a:?} {b:?}");
    }
    assert!(close(
        sparse.validation.score.residual_rms_um,
        alone.validation.score.residual_rms_um,
        1e-9
    ));
}

#[test]
fn predict_data_leaves_the_residual_empty_where_nothing_was_measured() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("log.csv");
    std::fs::write(
        &data,
        "time_min,spindle_rpm,drift_z_um\n0,4000,0\n20,4000,\n40,0,20\n",
    )
    .unwrap();
    let out = common::run(&[
        "predict",
        "fixtures/omm/spindle_40min.toml",
        "--data",
        data.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", common::stderr(&out));
    let text = common::stdout(&out);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "time_min,spindle_rpm,drift_z_um,predicted_um,residual_um"
    );
    let row: Vec<&str> = lines[2].split(',').collect();
    assert_eq!(row[2], "", "{text}");
    assert_eq!(row[4], "", "{text}");
    assert!(row[3].parse::<f64>().unwrap() > 10.0, "{text}");
    let last: Vec<&str> = lines[3].split(',').collect();
    assert!(last[4].parse::<f64>().is_ok(), "{text}");
}

#[test]
fn a_missing_input_sample_holds_the_value_before_it_and_a_note_says_so() {
    let text = "time_min,spindle_rpm,z_um,ambient_c,coolant_c\n0,,0,,18\n10,2000,NaN,20.5,18.2\n\
20,,1.5,N/A,\n30,1000,2,21,18.4\n";
    let ds = read(text);
    // Before its first value an input takes that value; after it, the value before the gap.
    assert_eq!(
        ds.values("spindle_rpm").unwrap(),
        &[2000.0, 2000.0, 2000.0, 1000.0]
    );
    assert_eq!(ds.values("ambient_c").unwrap(), &[20.5, 20.5, 20.5, 21.0]);
    assert_eq!(ds.values("coolant_c").unwrap(), &[18.0, 18.2, 18.2, 18.4]);
    // A logger's NaN in a channel is a row without a reading, as an empty cell is.
    assert!(ds.values("z_um").unwrap()[1].is_nan());
    assert_eq!(ds.notes.len(), 3, "{:?}", ds.notes);
    assert!(
        ds.notes[0].contains("`spindle_rpm`: 2 missing values (the first at line 2)"),
        "{:?}",
        ds.notes
    );
    assert!(ds.notes[2].contains("`coolant_c`: 1 missing value (the first at line 4)"));
}

#[test]
fn a_text_column_among_the_signals_is_left_out_but_a_named_one_must_be_numbers() {
    let ds = read("time_min,spindle_rpm,z_um,operator\n0,0,0,bob\n10,1000,1,ann\n");
    assert!(ds.values("operator").is_none());
    assert_eq!(ds.columns.len(), 2);
    assert!(ds.notes[0].contains("column `operator` holds text (`bob` at line 2)"));
    let err = read_bytes(
        "log.csv",
        b"time_min,spindle_rpm,z_um,ambient_c\n0,0,0,warm\n",
        Require::Displacement,
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "log.csv:2:4: column `ambient_c`: `warm` is not a number"
    );
}
