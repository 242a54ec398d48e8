//! Speeds never trained on. A model that follows a speed law stores it the way every consumer of a model
//! file already evaluates spindle gains: as gains on speed-grid nodes, piecewise linear between them
//! ([`super::speed_grid`]). The nodes are the characterised speeds plus a geometric ladder around them
//! (about 19 % apart, from a quarter to four times the top characterised speed), each carrying the law
//! gain·(n / n_top)^p; above the last node the last segment is continued. `predict`, `plan` and `transform`
//! therefore need nothing new to evaluate the law, and [`extrapolation_warning`] says when a speed leaves
//! the characterised range and which law is used there.

use super::{DriftModel, Extrapolation};

/// Ladder steps per doubling of speed.
const STEPS_PER_DOUBLING: i32 = 4;
/// Ladder reach in doublings below and above the top characterised speed.
const DOUBLINGS: i32 = 2;
/// Ladder nodes closer than this (relative) to a characterised speed are left out.
const MERGE: f64 = 0.05;

/// Gain ∝ (n / top)^p, 1 at the top characterised speed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerLaw {
    pub top_rpm: f64,
    pub exponent: f64,
}

impl PowerLaw {
    /// The law's relative gain at `rpm` (the sign of the speed is ignored).
    pub fn at(&self, rpm: f64) -> f64 {
        (rpm.abs() / self.top_rpm).powf(self.exponent)
    }

    /// Grid nodes for the law: the characterised speeds and the ladder, ascending.
    pub fn nodes(&self, characterised: &[f64]) -> Vec<f64> {
        let mut nodes: Vec<f64> = characterised.to_vec();
        for j in -DOUBLINGS * STEPS_PER_DOUBLING..=DOUBLINGS * STEPS_PER_DOUBLING {
            let n = self.top_rpm * 2f64.powf(f64::from(j) / f64::from(STEPS_PER_DOUBLING));
            if characterised
                .iter()
                .all(|c| (n - c).abs() > MERGE * c.max(n))
            {
                nodes.push(n);
            }
        }
        nodes.sort_by(f64::total_cmp);
        nodes
    }

    /// The law's relative gain at each node.
    pub fn gains(&self, nodes: &[f64]) -> Vec<f64> {
        nodes.iter().map(|&n| self.at(n)).collect()
    }
}

/// The top speed the model was characterised at: the law's reference for a power-law model, else the grid's
/// top node (a fitted grid holds only characterised speeds). `None` without spindle modes.
pub fn characterised_top(model: &DriftModel) -> Option<f64> {
    if model.spindle.modes.is_empty() {
        return None;
    }
    match model.spindle.extrapolation {
        Extrapolation::PowerLaw => model.spindle.characterised_top_rpm,
        Extrapolation::LinearLastSegment => model.spindle.grid_rpm.last().copied(),
    }
}

/// The law a model uses above its top characterised speed, in words.
pub fn extrapolation_law(model: &DriftModel) -> String {
    let sp = &model.spindle;
    let last = sp.grid_rpm.last().copied().unwrap_or(0.0);
    match (sp.extrapolation, sp.characterised_top_rpm) {
        (Extrapolation::PowerLaw, Some(top)) => {
            let shared = sp.modes.first().and_then(|m| m.power_law_exponent);
            if let Some(p) = shared.filter(|p| {
                sp.modes.len() > 1 && sp.modes.iter().all(|m| m.power_law_exponent == Some(*p))
            }) {
                return format!(
                    "the power law gain ∝ (n/{top:.0} rpm)^p, p = {p:.2} for every mode (chosen by forward validation), continued linearly above {last:.0} rpm"
                );
            }
            let per_mode: Vec<String> = sp
                .modes
                .iter()
                .map(|m| {
                    format!(
                        "{} (τ {})",
                        mode_law(model, m),
                        super::lag::fmt_tau(m.tau_min)
                    )
                })
                .collect();
            let laws = if sp.modes.iter().all(|m| m.power_law_exponent.is_some()) {
                "the power law"
            } else {
                "the averaged designs' power laws"
            };
            format!(
                "{laws} gain ∝ (n/{top:.0} rpm)^p, {} (chosen by forward validation), continued linearly above {last:.0} rpm",
                per_mode.join(", ")
            )
        }
        _ => "the last segment of the speed grid continued linearly".to_string(),
    }
}

/// The law of one mode of a power-law model: `p = 1.50`, or for a mode that sums the laws of averaged
/// designs, the exponent it grows with from the top characterised speed to twice that.
pub fn mode_law(model: &DriftModel, mode: &super::Mode) -> String {
    if let Some(p) = mode.power_law_exponent {
        return format!("p = {p:.2}");
    }
    let top = model.spindle.characterised_top_rpm.unwrap_or(0.0);
    let at = |n: f64| {
        model
            .speed_grid()
            .map_or(f64::NAN, |g| g.weights(n).apply(&mode.gain_um))
    };
    let ratio = at(2.0 * top) / at(top);
    if ratio.is_finite() && ratio > 0.0 {
        format!(
            "a mix of laws growing as n^{:.2} from {top:.0} to {:.0} rpm",
            ratio.log2(),
            2.0 * top
        )
    } else {
        format!("a mix of laws changing sign by {:.0} rpm", 2.0 * top)
    }
}

/// A warning when `rpm` is above the speeds the model was characterised at, naming the speed and the law
/// used there; `None` inside the characterised range or for a model without spindle modes. For `plan`,
/// `transform` and `predict` to print.
pub fn extrapolation_warning(model: &DriftModel, rpm: f64) -> Option<String> {
    let top = characterised_top(model)?;
    (rpm.abs() > top * (1.0 + 1e-9)).then(|| {
        format!(
            "{:.0} rpm is above the top characterised speed {top:.0} rpm of the model of {}: its gains there are extrapolated by {}",
            rpm.abs(),
            model.channel,
            extrapolation_law(model)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_keep_the_characterised_speeds_and_carry_the_law() {
        let law = PowerLaw {
            top_rpm: 2500.0,
            exponent: 1.5,
        };
        let nodes = law.nodes(&[1250.0, 2500.0]);
        assert!(nodes.contains(&1250.0) && nodes.contains(&2500.0));
        assert!(nodes.windows(2).all(|w| w[1] > w[0] * 1.04));
        assert!((nodes.last().unwrap() - 10000.0).abs() < 1e-6);
        let gains = law.gains(&nodes);
        let top = nodes.iter().position(|&n| n == 2500.0).unwrap();
        assert_eq!(gains[top], 1.0);
        // Piecewise linear between nodes ≈ the law within a few per cent at an unseen 5000 rpm.
        let grid = crate::model::SpeedGrid::new(nodes.clone()).unwrap();
        let at5000 = grid.weights(5000.0).apply(&gains);
        assert!((at5000 / law.at(5000.0) - 1.0).abs() < 0.01, "{at5000}");
    }

    #[test]
    fn the_warning_names_the_speed_and_the_law() {
        let mut m = DriftModel::from_modes(
            "ch1_um",
            vec![1250.0, 2500.0],
            &[(30.0, vec![1.0, 2.0])],
            0.0,
        );
        assert_eq!(extrapolation_warning(&m, 2500.0), None);
        let w = extrapolation_warning(&m, 3750.0).unwrap();
        assert!(w.contains("3750 rpm") && w.contains("2500 rpm") && w.contains("last segment"));
        let law = PowerLaw {
            top_rpm: 2500.0,
            exponent: 1.25,
        };
        let nodes = law.nodes(&[1250.0, 2500.0]);
        m.spindle.modes[0].gain_um = law.gains(&nodes);
        m.spindle.modes[0].power_law_exponent = Some(1.25);
        m.spindle.grid_rpm = nodes;
        m.spindle.extrapolation = Extrapolation::PowerLaw;
        m.spindle.characterised_top_rpm = Some(2500.0);
        m.validate().unwrap();
        assert_eq!(extrapolation_warning(&m, -2400.0), None);
        let w = extrapolation_warning(&m, 5000.0).unwrap();
        assert!(
            w.contains("5000 rpm") && w.contains("p = 1.25 (τ 30.0 min)"),
            "{w}"
        );
        // A merged mode of averaged designs, gain ∝ x + x²: it grows 3× from 2500 to 5000 rpm, as n^1.58.
        let mixed: Vec<f64> = m
            .spindle
            .grid_rpm
            .iter()
            .map(|n| n / 2500.0 + (n / 2500.0).powi(2))
            .collect();
        m.spindle.modes[0].gain_um = mixed;
        m.spindle.modes[0].power_law_exponent = None;
        m.validate().unwrap();
        let w = extrapolation_warning(&m, 5000.0).unwrap();
        assert!(
            w.contains("a mix of laws growing as n^1.58 from 2500 to 5000 rpm (τ 30.0 min)"),
            "{w}"
        );
        m.spindle.modes[0].gain_um = m.spindle.grid_rpm.iter().map(|n| n - 3000.0).collect();
        assert!(mode_law(&m, &m.spindle.modes[0]).contains("changing sign"));
        let bare = DriftModel::from_modes("ch1_um", vec![], &[], 0.0);
        assert_eq!(extrapolation_warning(&bare, 9000.0), None);
    }
}
