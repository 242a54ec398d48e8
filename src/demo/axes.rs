//! The demo's two-axis part: the same program on a machine that drifts along X too (a second spindle mode
//! the shop characterises on its own channel), measured and corrected on X and Z together.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, anyhow};

use super::{
    CHARACTERISATION_RPM, MACHINE, PROGRAM, Settings, characterisation_data, machine, run,
    sha256_hex,
};
use crate::model::DriftModel;
use crate::model::fit::{FitOptions, fit};
use crate::omm::profile::{AlsoMeasured, Axis};
use crate::omm::{ModelRef, Profile};
use crate::vm::{AxisError, Run};

const CHANNEL_X: &str = "drift_x_um";
/// The side face the probe measures X on (work coordinates, mm), and where it starts.
const FACE_X: f64 = 70.0;
const START: [f64; 3] = [80.0, 10.0, -1.0];

/// X and Z cutting errors without and with compensation.
#[derive(Debug)]
pub struct TwoAxes {
    pub before: [AxisError; 2],
    pub after: [AxisError; 2],
    pub measurements: usize,
    pub end: String,
}

/// The X truth: one slow mode, 18 µm at 6000 rpm through τ = 45 min.
fn truth_x() -> DriftModel {
    DriftModel::from_modes(
        CHANNEL_X,
        CHARACTERISATION_RPM.to_vec(),
        &[(45.0, vec![5.0, 12.0, 18.0])],
        0.0,
    )
}

/// Fits an X model to its own characterisation, transforms the part with it and the Z model under
/// `profile` plus X, and runs the original and the transformed part on a machine drifting on both axes.
pub fn two_axes(
    fitted_z: &DriftModel,
    profile: &Profile,
    settings: &Settings,
    dir: &Path,
) -> anyhow::Result<TwoAxes> {
    let truth = truth_x();
    std::fs::write(dir.join("truth_x.toml"), truth.to_toml())
        .context("cannot write the X truth")?;
    let data = characterisation_data(&truth, settings)?;
    let fitted_x = fit(&data, &FitOptions::new(CHANNEL_X)).context("fit X")?;
    std::fs::write(dir.join("model_x.toml"), fitted_x.to_toml())
        .context("cannot write the X model")?;
    let mut profile = profile.clone();
    profile.position.also.push(AlsoMeasured {
        axis: Axis::X,
        nominal: FACE_X,
        x: START[0],
        y: START[1],
        z: START[2],
        channel: CHANNEL_X.into(),
    });
    let (sha_z, sha_x) = (
        sha256_hex(&fitted_z.to_toml()),
        sha256_hex(&fitted_x.to_toml()),
    );
    let models = [
        ModelRef {
            model: fitted_z,
            sha256: &sha_z,
        },
        ModelRef {
            model: &fitted_x,
            sha256: &sha_x,
        },
    ];
    let program = crate::parse(PROGRAM.as_bytes());
    let prepared = crate::omm::prepare_timed(
        &program,
        &crate::omm::parse_timed(PROGRAM.as_bytes().to_vec()).1,
        &models,
        &profile,
        false,
    )
    .map_err(|e| anyhow!("transform on two axes: {e}"))?;
    let mut bytes = Vec::new();
    prepared.write_to(&mut bytes)?;
    let transformed = dir.join("stepped_surface_xz.mpf");
    std::fs::write(&transformed, &bytes).context("cannot write the two-axis program")?;
    let original = dir.join("stepped_surface.mpf");
    // The day's machine, drifting along X as well; the probe cycle's second argument names the axis.
    let text = MACHINE
        .replace(
            "[probe]\n",
            &format!("[probe]\naxis_arg = 2\nsurfaces = {{ X = {FACE_X} }}\n"),
        )
        .replace("[models]\n", "[models]\nX = { file = \"truth_x.toml\" }\n");
    let xz = machine(&text, dir, settings)?;
    let before = run(&original, &xz, settings.seed)?;
    let after = run(&transformed, &xz, settings.seed)?;
    Ok(TwoAxes {
        before: errors(&before),
        after: errors(&after),
        measurements: after.measurements.len(),
        end: format!("{:?}", after.end),
    })
}

fn errors(run: &Run) -> [AxisError; 2] {
    ["X", "Z"].map(|a| run.cutting_error.get(a).cloned().unwrap_or_default())
}

impl TwoAxes {
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "\ntwo axes at once: X (its own model, fitted to its own characterisation) and Z, measured and corrected together:"
        );
        let _ = writeln!(
            s,
            "{:<30} {:>9} {:>9} {:>9} {:>9} {:>13}",
            "cutting error (µm)", "X max", "X RMS", "Z max", "Z RMS", "probe calls"
        );
        for (name, e, calls) in [
            ("uncompensated", &self.before, 0),
            ("compensated, X and Z", &self.after, self.measurements),
        ] {
            let _ = writeln!(
                s,
                "{:<30} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>13}",
                name, e[0].max_abs_um, e[0].rms_um, e[1].max_abs_um, e[1].rms_um, calls
            );
        }
        s
    }
}
