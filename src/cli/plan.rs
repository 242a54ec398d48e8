//! `driftloop plan PROGRAM --model model.toml [--profile machine.toml]`: the timeline of the program, the
//! predicted drift along it and where driftloop would measure, as a table (or JSON).

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use serde::Serialize;

use super::style;
use super::transform::{Setup, beside_program};
use super::{Format, Global};
use crate::diagnostic::Severity;
use crate::omm::{self, Plan};
use crate::walk::Input;

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop plan fixtures/omm/handwritten.mpf --model fixtures/omm/model.toml --profile blum-tc50"
)]
pub struct Args {
    /// The program (`-` reads stdin).
    #[arg(value_name = "PROGRAM")]
    program: PathBuf,
    #[command(flatten)]
    setup: Setup,
    /// `human`: tables; `json`: the plan as JSON.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    format: Format,
    /// Plan programs with syntax errors too.
    #[arg(long)]
    force: bool,
}

#[derive(Serialize)]
struct JsonPlan<'a> {
    program: String,
    profile: &'a str,
    program_min: f64,
    passes: Vec<omm::report::PassRow>,
    inexact_blocks: usize,
    untimed_calls: Vec<omm::report::CallCount>,
    timed_calls: Vec<omm::report::TimedCall>,
    #[serde(flatten)]
    plan: &'a Plan,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    let (models, profile) = args.setup.load()?;
    let drift: Vec<&crate::model::DriftModel> = models.iter().map(|(m, _)| m).collect();
    let input = if args.program.as_os_str() == "-" {
        Input::Stdin
    } else {
        Input::File(args.program.clone())
    };
    let bytes = input.read()?;
    if let Some(why) = crate::text::not_text(&bytes, crate::text::NC_PROGRAM) {
        anyhow::bail!("{input}: {why}");
    }
    let (program, moves) = omm::parse_timed(bytes);
    let name = input.to_string();
    // The subprograms beside the program are found as `transform` finds them.
    let beside = beside_program(&input, &profile);
    let profile = beside.as_ref().unwrap_or(&profile);
    let planned = omm::check_timed(&program, &moves, args.force)
        .and_then(|()| omm::plan_timed(&program, &moves, &drift, profile));
    let (timeline, plan) = match planned {
        Ok(p) => p,
        Err(e) => {
            anstream::eprintln!("{} {name}: {e}", style::label(Severity::Error));
            return Ok(ExitCode::from(2));
        }
    };
    for w in &plan.warnings {
        anstream::eprintln!("{} {name}: {w}", style::label(Severity::Warning));
    }
    if args.setup.strict && !plan.warnings.is_empty() {
        anstream::eprintln!(
            "{} {name}: --strict refuses a plan with warnings",
            style::label(Severity::Error)
        );
        return Ok(ExitCode::from(2));
    }
    let unforeseen: Vec<&str> = models.iter().flat_map(|(m, _)| m.signals()).collect();
    if !unforeseen.is_empty() {
        anstream::eprintln!(
            "{} the model also reads {}; the plan cannot foresee them and holds them at their values at the zero, so its predicted drift is the spindle part only; the transformed program reads them (`$A_INA`) and corrects with them at every gate",
            style::label(Severity::Note),
            unforeseen.join(", ")
        );
    }
    let mut out = super::output::stdout();
    match args.format {
        Format::Json => {
            let j = JsonPlan {
                program: name,
                profile: &profile.name,
                program_min: timeline.total_min,
                passes: omm::report::pass_rows(&program, &timeline),
                inexact_blocks: timeline.inexact_blocks,
                untimed_calls: omm::report::untimed_calls(&timeline),
                timed_calls: omm::report::timed_calls(&timeline),
                plan: &plan,
            };
            serde_json::to_writer_pretty(&mut out, &j)?;
            writeln!(out)?;
        }
        Format::Human => {
            omm::report::write_passes(&mut out, &omm::report::pass_rows(&program, &timeline))?;
            writeln!(out)?;
            omm::report::write_table(&mut out, &program, &plan)?;
            omm::report::write_unfit(&mut out, &program, &plan)?;
            omm::report::write_loops(&mut out, &program, &plan)?;
            omm::report::write_untimed(&mut out, &omm::report::untimed_calls(&timeline))?;
            omm::report::write_timed(&mut out, &omm::report::timed_calls(&timeline))?;
        }
    }
    Ok(ExitCode::SUCCESS)
}
