//! The speed law of a spindle-mode fit (`fit --kind modes`) above its top characterised speed, chosen by
//! forward validation: each fold whose later rows reach a speed faster than any before its origin refits
//! the modes on the rows before the origin, extends them by gain(n) = gain(n_top)·(n / n_top)^p for every
//! candidate p, and scores the rows after the origin. The p with the lowest pooled error is the law the
//! whole-window model carries above its top speed — the situation a model meets on tomorrow's faster job.
//! Below the top speed nothing changes: the fitted gains on the characterised speeds stay as they are.

use serde::{Deserialize, Serialize};

use crate::data::{Dataset, SPINDLE, measured};

use super::forward::{Origins, elapsed};
use super::speed_law::PowerLaw;
use super::{DriftModel, Extrapolation};

/// Candidate exponents p (the distributed-lag fit's grid).
pub const EXPONENTS: [f64; 9] = [0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.5, 3.0];

/// How the law above the top characterised speed was chosen, kept in the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LawChoice {
    /// Elapsed minutes of the folds' origins whose later rows ran faster than the rows before them.
    pub origins_min: Vec<f64>,
    /// Scored rows over those folds.
    pub rows: usize,
    /// [p, forward RMS µm] of every candidate.
    pub trials: Vec<[f64; 2]>,
    /// The chosen p.
    pub exponent: f64,
}

/// The modes of `model` (fitted on `ds`, whose readings are `y`) extended above their top speed by the law
/// forward validation chooses; `None` (the model keeps the linear continuation) when no fold predicts a
/// speed faster than its training rows held, or none of those folds could be fitted. `refit` fits the
/// model the same way on a fold's training rows, without choosing a law.
pub fn choose(
    ds: &Dataset,
    y: &[f64],
    model: &DriftModel,
    refit: impl Fn(&Dataset) -> Option<DriftModel>,
) -> Option<(DriftModel, LawChoice)> {
    model.spindle.grid_rpm.last()?;
    let rpm = ds.values(SPINDLE)?;
    let when = elapsed(ds);
    let usable = measured(y);
    let mut sse = [0.0; EXPONENTS.len()];
    let mut rows = 0;
    let mut origins = Vec::new();
    for fold in Origins::default().folds(&when, &usable) {
        // Every row before the origin, read or not: the spindle ran at its speed either way.
        let trains = |i: usize| when[i] < fold.origin_min;
        let before = fastest(rpm, (0..ds.len()).filter(|&i| trains(i)));
        let after = fastest(rpm, fold.test.iter().copied());
        if before <= 0.0 || after <= before * (1.0 + 1e-9) {
            continue;
        }
        let train = ds.rows_where(trains);
        let Some(fitted) = refit(&train) else {
            continue;
        };
        let scores: Option<Vec<f64>> = EXPONENTS
            .iter()
            .map(|&p| {
                let pred = with_law(&fitted, p).predict(ds).ok()?;
                Some(fold.test.iter().map(|&i| (y[i] - pred[i]).powi(2)).sum())
            })
            .collect();
        let Some(scores) = scores else { continue };
        for (s, v) in sse.iter_mut().zip(scores) {
            *s += v;
        }
        rows += fold.test.len();
        origins.push(fold.origin_min);
    }
    if rows == 0 {
        return None;
    }
    let best = (0..EXPONENTS.len()).min_by(|&a, &b| sse[a].total_cmp(&sse[b]))?;
    let choice = LawChoice {
        origins_min: origins,
        rows,
        trials: EXPONENTS
            .iter()
            .zip(&sse)
            .map(|(&p, &s)| [p, (s / rows as f64).sqrt()])
            .collect(),
        exponent: EXPONENTS[best],
    };
    Some((with_law(model, EXPONENTS[best]), choice))
}

/// The fastest speed (its magnitude) on `rows`.
fn fastest(rpm: &[f64], rows: impl Iterator<Item = usize>) -> f64 {
    rows.map(|i| rpm[i].abs()).fold(0.0, f64::max)
}

/// `model` with its grid extended above its top speed by gain(n) = gain(top)·(n / top)^p per mode; the
/// characterised speeds keep their fitted gains.
pub fn with_law(model: &DriftModel, p: f64) -> DriftModel {
    let mut out = model.clone();
    let sp = &mut out.spindle;
    let Some(&top) = sp.grid_rpm.last() else {
        return out;
    };
    let law = PowerLaw {
        top_rpm: top,
        exponent: p,
    };
    let above: Vec<f64> = law
        .nodes(&sp.grid_rpm)
        .into_iter()
        .filter(|&n| n > top)
        .collect();
    for m in &mut sp.modes {
        let at_top = m.gain_um.last().copied().unwrap_or(0.0);
        m.gain_um.extend(above.iter().map(|&n| at_top * law.at(n)));
        // The top gain's error carried by the law (the exponent's own uncertainty is not in it).
        if let Some(&se) = m.gain_se_um.last() {
            m.gain_se_um.extend(above.iter().map(|&n| se * law.at(n)));
        }
        m.power_law_exponent = Some(p);
    }
    sp.grid_rpm.extend(above);
    sp.extrapolation = Extrapolation::PowerLaw;
    sp.characterised_top_rpm = Some(top);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::synth::{Rng, Sampling, characterisation, measure};
    use crate::model::{FitOptions, SpeedGrid, fit};

    /// Characterisation runs at 1000 … 3000 rpm of a truth whose gain grows as n^`p`, 0.2 µm noise.
    fn runs(p: f64, seed: u64) -> Dataset {
        let mut rng = Rng::new(seed);
        let speeds = [1000.0, 2000.0, 3000.0];
        let mut ds = characterisation(&speeds, 240.0, 60.0, Sampling::Every(2.0), &mut rng);
        let grid = vec![1000.0, 2000.0, 3000.0, 4000.0];
        let gains = |scale: f64| -> Vec<f64> {
            grid.iter()
                .map(|n| scale * (n / 3000.0f64).powf(p))
                .collect()
        };
        let truth = DriftModel::from_modes(
            "z_um",
            grid.clone(),
            &[(20.0, gains(6.0)), (120.0, gains(-9.0))],
            0.0,
        );
        measure(&truth, &mut ds, 0.2, &mut rng).unwrap();
        ds
    }

    #[test]
    fn the_law_follows_the_speeds_the_data_grow_by() {
        for (p, seed) in [(1.0, 3), (2.0, 4), (3.0, 5)] {
            let ds = runs(p, seed);
            let model = fit(&ds, &FitOptions::new("z_um")).unwrap();
            let law = model.fit.as_ref().and_then(|f| f.speed_law.clone());
            let law = law.unwrap_or_else(|| panic!("p = {p}: no law chosen"));
            assert!(
                (law.exponent - p).abs() <= 0.5,
                "truth p = {p}, chosen {}: {:?}",
                law.exponent,
                law.trials
            );
            // 4000 rpm, a third above the top: within 15 % of the truth's steady state.
            let truth = 6.0 * (4.0f64 / 3.0).powf(p) - 9.0 * (4.0f64 / 3.0).powf(p);
            let got = model.steady_state_um(4000.0);
            assert!(
                (got / truth - 1.0).abs() < 0.15,
                "p = {p}: {got} vs {truth}"
            );
            model.validate().unwrap();
        }
    }

    #[test]
    fn no_faster_speed_after_an_origin_keeps_the_linear_continuation() {
        // The fastest run first: no fold predicts a speed faster than its training rows held.
        let mut rng = Rng::new(9);
        let mut ds = characterisation(
            &[3000.0, 2000.0, 1000.0],
            240.0,
            60.0,
            Sampling::Every(2.0),
            &mut rng,
        );
        let truth = DriftModel::from_modes(
            "z_um",
            vec![1000.0, 2000.0, 3000.0],
            &[(30.0, vec![1.0, 4.0, 9.0])],
            0.0,
        );
        measure(&truth, &mut ds, 0.2, &mut rng).unwrap();
        let model = fit(&ds, &FitOptions::new("z_um")).unwrap();
        assert!(model.fit.as_ref().unwrap().speed_law.is_none());
        assert_eq!(
            model.spindle.extrapolation,
            Extrapolation::LinearLastSegment
        );
    }

    #[test]
    fn the_law_leaves_the_characterised_speeds_alone() {
        let m =
            DriftModel::from_modes("z_um", vec![1000.0, 2000.0], &[(30.0, vec![1.0, 3.0])], 0.5);
        let l = with_law(&m, 2.0);
        l.validate().unwrap();
        let grid = SpeedGrid::new(l.spindle.grid_rpm.clone()).unwrap();
        let g = |n: f64| grid.weights(n).apply(&l.spindle.modes[0].gain_um);
        assert_eq!(g(1000.0), 1.0);
        assert_eq!(g(1500.0), 2.0);
        assert_eq!(g(2000.0), 3.0);
        assert!((g(4000.0) / 12.0 - 1.0).abs() < 0.01, "{}", g(4000.0));
    }
}
