//! `driftloop forward DATA.csv --until 16h`: the forward benchmark. Every channel is fitted on the rows
//! before the time and scored on the rows from it on — the model predicting later hours it never saw —
//! without probing and with a probe re-zeroing the correction every P minutes.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use serde::Serialize;

use super::fit::{Design, Kind};
use super::progress::Progress;
use super::{Format, Global};
use crate::data::{Minutes, Require};
use crate::diagnose::holdout::{HoldoutScore, rate};
use crate::model::dlag::{DlagOptions, fit_dlag};
use crate::model::probing::Probing;
use crate::model::{FitOptions, fit};

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop forward data.csv --until 16h\n  driftloop forward data.csv --until 8h --to 16h --probe-every 30min"
)]
pub struct Args {
    /// Measurement CSV with the channels, the spindle speed and the sensors; `-` reads stdin.
    pub data: PathBuf,
    /// Fit on the rows before this time, score the rows from it on: `16h`, `960min`, `57600s`; a bare
    /// number is minutes.
    #[arg(long, value_name = "TIME")]
    pub until: Minutes,
    /// Score only the rows before this time (default: every row from `--until` on). `--until 8h --to 16h`
    /// predicts the next 8 h only: the next-speed check inside a longer file.
    #[arg(long, value_name = "TIME")]
    pub to: Option<Minutes>,
    /// Channels to score (comma separated; default every `*_um` column).
    #[arg(long, value_delimiter = ',')]
    pub channel: Option<Vec<String>>,
    /// The model: `dlag` (sensors at several lags plus a power-law spindle term) or `modes` (spindle only).
    #[arg(long, value_enum, default_value_t = Kind::Dlag)]
    pub kind: Kind,
    /// `--kind dlag`: `average` the designs within the forward folds' noise of the best, or take the
    /// `best` one alone.
    #[arg(long, value_enum, default_value_t = Design::Average)]
    pub design: Design,
    /// A probe re-zeroes the correction this often from the holdout's start (`60min`, `1h`).
    #[arg(long, value_name = "TIME", default_value = "60min")]
    pub probe_every: Minutes,
    /// With probing, also continue the error's rate between the last two probings, scaled by the trend
    /// gain the dlag fit chose by forward validation (default: re-zero only).
    #[arg(long)]
    pub probe_trend: bool,
    /// `human`: a table; `json`: one JSON array with every number.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
}

/// One channel's line of the table.
#[derive(Debug, Serialize)]
struct Line {
    channel: String,
    score: HoldoutScore,
    rate_model: f64,
    rate_model_probed: Option<f64>,
    rate_probe_only: Option<f64>,
    /// How the model was chosen, in words.
    design: String,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let ds = super::log::read_data(&args.data, Require::Displacement)?;
    let until = args.until.0;
    let to = args.to.map_or(f64::INFINITY, |t| t.0);
    anyhow::ensure!(
        args.probe_every.0 > 0.0,
        "--probe-every must be a positive time"
    );
    anyhow::ensure!(to > until, "--to must be later than --until");
    let channels: Vec<String> = match &args.channel {
        Some(c) => c.iter().map(|s| s.to_ascii_lowercase()).collect(),
        None => ds.channels().map(|c| c.name.clone()).collect(),
    };
    let mut lines = Vec::new();
    let progress = Progress::new("channels fitted and scored", channels.len());
    for ch in &channels {
        let model = match args.kind {
            Kind::Dlag => {
                let mut o = DlagOptions::new(ch.clone());
                o.until_min = Some(until);
                o.probe_every_min = Some(args.probe_every.0);
                o.averaging = args.design.averaging();
                fit_dlag(&ds, &o).map_err(|e| super::log::of_data(&ds, format!("{ch}: {e}")))?
            }
            Kind::Modes => {
                let mut o = FitOptions::new(ch.clone());
                o.until_min = Some(until);
                fit(&ds, &o).map_err(|e| super::log::of_data(&ds, format!("{ch}: {e}")))?
            }
        };
        let predicted = model.predict(&ds)?;
        let measured = ds.values(ch).unwrap_or_default();
        let later: Vec<bool> = ds.time_min.iter().map(|&t| t >= until && t < to).collect();
        let forward = model.fit.as_ref().and_then(|f| f.forward.as_ref());
        // With --probe-trend the model's re-zeroing (the trend gain its fit chose for this interval).
        let probing = forward
            .and_then(|f| f.probe.as_ref())
            .filter(|_| args.probe_trend)
            .map_or(Probing::every(args.probe_every.0), |p| p.probing());
        let score = HoldoutScore::of(&ds, measured, &predicted, &later, Some(probing)).ok_or_else(
            || {
                anyhow::anyhow!(
                    "{}: no reading of {ch} from {until} min{}",
                    ds.source,
                    span(to)
                )
            },
        )?;
        let design = match forward {
            Some(f) => format!(
                "{}lags {:?} min, spindle lags {:?} min with p {:?}, penalty {:.0e}, forward CV {:.2} µm{}",
                match f.trials.iter().filter(|t| t.weight.is_some()).count() {
                    0 | 1 => String::new(),
                    n => format!("average of {n} designs, the best: "),
                },
                f.sensor_lags_min,
                f.spindle_lags_min,
                f.exponents,
                f.penalty,
                f.cv_rms_um,
                f.probe.as_ref().map_or(String::new(), |p| format!(
                    "; probe trend gain {} by forward CV{}",
                    p.trend_gain,
                    if args.probe_trend {
                        " (used)"
                    } else {
                        " (--probe-trend uses it)"
                    }
                ))
            ),
            None => {
                let modes = match model.spindle.modes.len() {
                    1 => "1 spindle mode".to_string(),
                    n => format!("{n} spindle modes"),
                };
                let top = crate::model::speed_law::characterised_top(&model).unwrap_or(0.0);
                match model.fit.as_ref().and_then(|f| f.speed_law.as_ref()) {
                    Some(law) => format!(
                        "{modes}, above {top:.0} rpm gain ∝ n^{} chosen by forward validation",
                        law.exponent
                    ),
                    None => format!("{modes}, above {top:.0} rpm the last segment continued"),
                }
            }
        };
        lines.push(Line {
            channel: ch.clone(),
            rate_model: rate(&score.model, &score.uncompensated),
            rate_model_probed: score.model_probed.map(|e| rate(&e, &score.uncompensated)),
            rate_probe_only: score.probe_only.map(|e| rate(&e, &score.uncompensated)),
            score,
            design,
        });
        progress.tick();
    }
    progress.finish();
    match args.format {
        Format::Json => {
            super::output::print(&format!("{}\n", serde_json::to_string_pretty(&lines)?))?
        }
        Format::Human => super::output::print(&table(&lines, until, to, args.probe_every.0))?,
    }
    Ok(ExitCode::SUCCESS)
}

/// ` on` (to the end of the data) or ` to T min`.
fn span(to: f64) -> String {
    if to.is_finite() {
        format!(" to {to} min")
    } else {
        " on".to_string()
    }
}

fn table(lines: &[Line], until: f64, to: f64, every: f64) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "fitted before {until} min, scored from it{}; RMS in µm, rate = 1 − RMS / RMS uncompensated; a probe re-zeroes every {every} min",
        span(to)
    );
    let _ = writeln!(
        s,
        "channel   rows  uncomp   model   rate   model+probe   rate   probe alone   rate"
    );
    let pct = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{:.1} %", 100.0 * r));
    let rms = |e: Option<crate::diagnose::stats::ErrorStats>| {
        e.map_or("-".to_string(), |e| format!("{:.2}", e.rms_um))
    };
    for l in lines {
        let _ = writeln!(
            s,
            "{:<8} {:>5} {:>7.2} {:>7.2} {:>7} {:>12} {:>7} {:>12} {:>7}",
            l.channel,
            l.score.rows,
            l.score.uncompensated.rms_um,
            l.score.model.rms_um,
            pct(Some(l.rate_model)),
            rms(l.score.model_probed),
            pct(l.rate_model_probed),
            rms(l.score.probe_only),
            pct(l.rate_probe_only),
        );
    }
    for l in lines {
        let _ = writeln!(s, "  {}: {}", l.channel, l.design);
    }
    s
}
