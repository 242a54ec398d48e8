//! `driftloop fit DATA.csv --channel NAME`: fits the drift model of one channel and writes the model file.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use super::{Format, Global};
use crate::data::{Dataset, Minutes, Require};
use crate::model::dlag::{Averaging, DlagOptions, fit_dlag};
use crate::model::lag::fmt_tau;
use crate::model::{DriftModel, FitOptions, ModesChoice, fit};

/// Which model `fit` makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Kind {
    /// Spindle-driven first-order modes on the characterised speed grid (plus declared lagged inputs).
    Modes,
    /// Every temperature at several lags plus a power-law spindle basis, ridge, chosen by forward
    /// validation.
    Dlag,
}

/// Which designs make a `--kind dlag` model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Design {
    /// Average the designs within the forward folds' noise of the best (weighted by their forward RMS).
    Average,
    /// The one design with the lowest forward RMS.
    Best,
}

impl Design {
    pub fn averaging(self) -> Averaging {
        match self {
            Design::Average => Averaging::Weighted,
            Design::Best => Averaging::Best,
        }
    }
}

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop fit fixtures/data/characterisation.csv --channel drift_z_um -o model.toml\n  driftloop fit data.csv --kind dlag --until 16h -o model.toml"
)]
pub struct Args {
    /// Measurement CSV (time_s|time_min|time_h, spindle_rpm, *_um channels, …); `-` reads stdin.
    pub data: PathBuf,
    /// Displacement channel to model, e.g. ch3_um (default: the data's only `*_um` column).
    #[arg(long)]
    pub channel: Option<String>,
    /// The model to fit: `modes` (spindle modes) or `dlag` (every temperature at several lags plus a
    /// power-law spindle term, chosen by forward validation). Without it: `modes`, and where the data
    /// log temperatures that vary, the report compares both kinds on later time.
    #[arg(long, value_enum)]
    pub kind: Option<Kind>,
    /// Declared inputs of `--kind modes`, comma separated: spindle_rpm gives the spindle modes, any other
    /// column a lagged linear term (e.g. spindle_rpm,ambient_c).
    #[arg(long, value_delimiter = ',', default_value = "spindle_rpm")]
    pub inputs: Vec<String>,
    /// Number of modes of `--kind modes`, or `auto` (BIC).
    #[arg(long, default_value = "auto")]
    pub modes: ModesChoice,
    /// Fit only the rows before this time of the data's time axis: `16h`, `960min`, `57600s`; a bare
    /// number is minutes.
    #[arg(long, value_name = "TIME")]
    pub until: Option<Minutes>,
    /// `--kind dlag`: the sensor columns (comma separated; default every `*_c` column that varies).
    #[arg(long, value_delimiter = ',')]
    pub signals: Option<Vec<String>>,
    /// `--kind dlag`: one lag set for the sensors, times (`15min`, `4h`; a bare number is minutes), 0 =
    /// unlagged (default: forward validation chooses among 0,15,60,240 / 0,60,240 / 0,15,60,240,960).
    #[arg(long, value_delimiter = ',', value_name = "TIME,…")]
    pub lags: Option<Vec<Minutes>>,
    /// `--kind dlag`: lags of the spindle terms, times each above 0 (`15min`, `4h`; a bare number is
    /// minutes; default 15,60,240).
    #[arg(long, value_delimiter = ',', value_name = "TIME,…")]
    pub spindle_lags: Option<Vec<Minutes>>,
    /// `--kind dlag`: the exponents p of gain ∝ (n/n_top)^p forward validation chooses among (each
    /// spindle term its own; default 0.5 to 3).
    #[arg(long, value_delimiter = ',', value_name = "P,…")]
    pub exponents: Option<Vec<f64>>,
    /// `--kind dlag`: `average` the designs within the forward folds' noise of the best, or take the
    /// `best` one alone.
    #[arg(long, value_enum, default_value_t = Design::Average)]
    pub design: Design,
    /// `--kind dlag`: the probing interval the trend gain of a probe's re-zeroing is chosen for (`60min`,
    /// `1h`; a bare number is minutes).
    #[arg(long, value_name = "TIME", default_value = "60min")]
    pub probe_every: Minutes,
    /// Write the model file here (`-` = stdout, the report then goes to stderr).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// `human`: the report as text; `json`: the model as JSON.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    super::output::refuse_overwriting(&[("-o", args.output.as_deref())], &[&args.data])?;
    let ds = super::log::read_data(&args.data, Require::Displacement)?;
    let channel = only_channel(&ds, args.channel.as_deref())?;
    let until_min = args.until.map(|u| u.0);
    let model = match args.kind.unwrap_or(Kind::Modes) {
        Kind::Modes => fit(
            &ds,
            &FitOptions {
                channel,
                inputs: args.inputs.clone(),
                modes: args.modes,
                until_min,
            },
        )
        .map_err(|e| super::log::of_data(&ds, e))?,
        Kind::Dlag => {
            let mut opts = DlagOptions::new(channel);
            if let Some(lags) = &args.spindle_lags {
                let lags: Vec<f64> = lags.iter().map(|l| l.0).collect();
                anyhow::ensure!(
                    lags.iter().all(|l| *l > 0.0),
                    "--spindle-lags must be positive times (a spindle term is a mode with a time constant)"
                );
                opts.spindle_lags = vec![lags];
            }
            anyhow::ensure!(
                args.probe_every.0 > 0.0,
                "--probe-every must be a positive time"
            );
            opts.probe_every_min = Some(args.probe_every.0);
            opts.averaging = args.design.averaging();
            opts.until_min = until_min;
            opts.signals = args.signals.clone();
            if let Some(p) = &args.exponents {
                anyhow::ensure!(
                    !p.is_empty() && p.iter().all(|p| p.is_finite() && *p > 0.0),
                    "--exponents must be positive numbers"
                );
                opts.exponents = p.clone();
            }
            if let Some(lags) = &args.lags {
                let lags: Vec<f64> = lags.iter().map(|l| l.0).collect();
                anyhow::ensure!(
                    lags.iter().all(|l| *l >= 0.0),
                    "--lags must be times, 0 or more"
                );
                opts.sensor_lags = vec![lags];
            }
            fit_dlag(&ds, &opts).map_err(|e| super::log::of_data(&ds, e))?
        }
    };
    let report = match args.format {
        Format::Human if args.kind.is_none() => {
            summary(&model) + &kind_comparison(&ds, &model, &args).unwrap_or_default()
        }
        Format::Human => summary(&model),
        Format::Json => serde_json::to_string_pretty(&model)? + "\n",
    };
    super::write_model(args.output.as_deref(), &model, &report)?;
    Ok(ExitCode::SUCCESS)
}

/// Where the data log temperatures that vary and no `--kind` was asked for: both kinds' whole fits, scored
/// on later time (each fitted on the rows before every forward origin and predicting the rows after it),
/// and which predicts better. A `dlag` model reads the sensors in the NC program, so it is named, not
/// chosen.
fn kind_comparison(ds: &Dataset, model: &DriftModel, args: &Args) -> Option<String> {
    let window = ds.until_opt(args.until.map(|u| u.0));
    let sensors = DlagOptions::new(model.channel.clone());
    let modes_at = |until: f64| {
        let mut o = FitOptions::new(model.channel.clone());
        (o.inputs, o.modes, o.until_min) = (args.inputs.clone(), args.modes, Some(until));
        fit(&window, &o).ok()
    };
    let dlag_at = |until: f64| {
        let mut o = sensors.clone();
        o.until_min = Some(until);
        fit_dlag(&window, &o).ok()
    };
    let usable = crate::data::measured(window.values(&model.channel)?);
    let temperatures = crate::model::dlag::varying_temperatures(&window, &usable).len();
    if temperatures == 0 {
        return None;
    }
    let modes = crate::model::forward::procedure_rms(&window, &model.channel, modes_at)?;
    let dlag = crate::model::forward::procedure_rms(&window, &model.channel, dlag_at)?;
    let verdict = if dlag < modes {
        format!(
            "`--kind dlag` predicts later time better; it reads the {temperatures} temperature(s) in the NC program, through analog inputs the profile maps ([log] inputs)"
        )
    } else {
        "the spindle modes predict later time as well or better".to_string()
    };
    Some(format!(
        "  forward RMS (each kind fitted before every forward origin, scored after it): spindle modes {modes:.2} µm, distributed-lag over {temperatures} temperature(s) {dlag:.2} µm: {verdict}\n"
    ))
}

/// The channel asked for, or the data's only displacement channel.
pub(crate) fn only_channel(ds: &Dataset, asked: Option<&str>) -> anyhow::Result<String> {
    if let Some(c) = asked {
        return Ok(c.to_ascii_lowercase());
    }
    let channels: Vec<&str> = ds.channels().map(|c| c.name.as_str()).collect();
    match channels.as_slice() {
        [one] => Ok(one.to_string()),
        _ => anyhow::bail!(
            "{}: several displacement channels ({}); choose one with --channel",
            ds.source,
            channels.join(", ")
        ),
    }
}

/// The human summary: modes, τ, gains at each speed, fit statistics, and why each order was or was not
/// chosen.
pub fn summary(model: &DriftModel) -> String {
    if let Some(s) = crate::model::dlag::text::summary(model) {
        return s;
    }
    let mut s = String::new();
    let modes = &model.spindle.modes;
    let plural = if modes.len() == 1 { "" } else { "s" };
    let _ = writeln!(
        s,
        "{}: {} spindle mode{plural}{}",
        model.channel,
        modes.len(),
        crate::model::fit::fitted_on(model)
    );
    for (k, m) in modes.iter().enumerate() {
        let se = m
            .tau_se_min
            .map(|e| format!(" ± {}", fmt_tau(e)))
            .unwrap_or_default();
        let _ = writeln!(s, "  mode {}: τ = {}{se}", k + 1, fmt_tau(m.tau_min));
    }
    for i in &model.inputs {
        let _ = writeln!(
            s,
            "  input {}: τ = {}, {:.4} µm per unit",
            i.signal,
            fmt_tau(i.tau_min),
            i.gain_um_per_unit
        );
    }
    if !modes.is_empty() {
        let _ = write!(s, "  steady-state gain (µm)\n      rpm");
        for k in 0..modes.len() {
            let _ = write!(s, "  {:>9}", format!("mode {}", k + 1));
        }
        let _ = writeln!(s, "  {:>9}", "total");
        let top = crate::model::speed_law::characterised_top(model).unwrap_or(0.0);
        for (j, rpm) in model.spindle.grid_rpm.iter().enumerate() {
            if *rpm > top {
                break;
            }
            let _ = write!(s, "  {rpm:>7.0}");
            for m in modes {
                let _ = write!(s, "  {:>9.3}", m.gain_um[j]);
            }
            let _ = writeln!(s, "  {:>9.3}", model.steady_state_um(*rpm));
        }
        let _ = writeln!(
            s,
            "  between speeds: piecewise linear; above {top:.0} rpm: {}",
            crate::model::speed_law::extrapolation_law(model)
        );
        if let Some(law) = model.fit.as_ref().and_then(|f| f.speed_law.as_ref()) {
            let origins: Vec<String> = law.origins_min.iter().map(|o| format!("{o:.0}")).collect();
            let trials: Vec<String> = law
                .trials
                .iter()
                .map(|[p, rms]| format!("{p} → {rms:.3}"))
                .collect();
            let _ = writeln!(
                s,
                "    law chosen on the folds from {} min elapsed, whose later rows ran faster than the rows before ({} rows; forward RMS µm by p: {})",
                origins.join(", "),
                law.rows,
                trials.join(", ")
            );
            if let (Some(first), Some(last)) = (law.trials.first(), law.trials.last())
                && (law.exponent == first[0] || law.exponent == last[0])
            {
                let _ = writeln!(
                    s,
                    "    note: p = {} is the edge of the candidates {} … {}: the data want a law {} than they offer; treat speeds above {top:.0} rpm with care",
                    law.exponent,
                    first[0],
                    last[0],
                    if law.exponent == first[0] {
                        "flatter"
                    } else {
                        "steeper"
                    }
                );
            }
            let _ = writeln!(
                s,
                "    steady state a third above the top speed, at {:.0} rpm: {:.3} µm",
                top * 4.0 / 3.0,
                model.steady_state_um(top * 4.0 / 3.0)
            );
        }
    }
    let _ = writeln!(s, "  offset {:.3} µm", model.offset_um);
    if let Some(fit) = &model.fit {
        let _ = writeln!(
            s,
            "  fit: RMS {:.3} µm, max {:.3} µm, R² {:.4}, τ searched in {} … {}",
            fit.rms_um,
            fit.max_abs_um,
            fit.r2,
            fmt_tau(fit.tau_bounds_min[0]),
            fmt_tau(fit.tau_bounds_min[1])
        );
        if fit.per_run.len() > 1 {
            for r in &fit.per_run {
                let _ = writeln!(
                    s,
                    "    run {}: {} samples, RMS {:.3} µm, max {:.3} µm",
                    r.run, r.samples, r.rms_um, r.max_abs_um
                );
            }
        }
        let _ = writeln!(s, "  orders tried ({}):", fit.selection);
        for o in &fit.orders {
            let _ = writeln!(
                s,
                "    {} mode{}: RMS {:.3} µm, BIC {:.1} — {}",
                o.modes,
                if o.modes == 1 { "" } else { "s" },
                o.rms_um,
                o.bic,
                o.note
            );
        }
    }
    s
}
