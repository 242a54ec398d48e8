//! The `driftloop` command line. Each subcommand lives in its own module with an `Args` struct and a
//! `run` function; this module only dispatches and maps errors to the exit-code convention
//! (0 clean, 1 findings / would change, 2 usage, I/O or internal error).

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};

mod bench;
mod check;
mod demo;
mod diagnose;
mod fit;
mod forward;
mod log;
mod output;
mod parse;
mod plan;
mod positioning;
mod predict;
mod profiles;
mod progress;
mod render;
mod run;
mod sensors;
mod signals;
mod simulate;
mod strip;
mod style;
mod transform;

/// `-o` of the commands that make a model (`fit`, `sensors`): the model file to `path` and the report to
/// stdout, or with `-o -` the model to stdout and the report to stderr; without `-o` the report alone.
fn write_model(
    path: Option<&std::path::Path>,
    model: &crate::model::DriftModel,
    report: &str,
) -> anyhow::Result<()> {
    use anyhow::Context;
    // A model the loaders would refuse is not written: the same checks, before the file exists.
    model
        .validate()
        .map_err(|e| anyhow::anyhow!("the model made is not usable: {e}"))?;
    match path {
        Some(path) if path.as_os_str() == "-" => {
            output::print(&model.to_toml())?;
            eprint!("{report}");
        }
        Some(path) => {
            std::fs::write(path, model.to_toml())
                .with_context(|| format!("cannot write the model file {}", path.display()))?;
            output::print(report)?;
        }
        None => output::print(report)?,
    }
    Ok(())
}

/// Options every subcommand understands.
#[derive(Debug, Clone, clap::Args)]
pub struct Global {
    /// When to colour what is written to the terminal (NO_COLOR is honoured under `auto`).
    #[arg(long, value_enum, default_value_t = ColorChoice::Auto, global = true)]
    pub color: ColorChoice,
}

pub use style::ColorChoice;

impl Global {
    /// Whether output written to stderr should carry ANSI colour (decided once, in [`main`]).
    pub fn stderr_color(&self) -> bool {
        style::stderr_colored()
    }
}

/// Output format of commands that report to humans or machines (`--format human|json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Text for people.
    Human,
    /// JSON for programs.
    Json,
}

/// Thermal drift compensation for Sinumerik NC programs.
#[derive(Debug, Parser)]
#[command(
    name = "driftloop",
    version,
    about,
    long_about = None,
    after_help = "Examples:\n\
                  \x20 driftloop demo                                                   the whole loop on the bundled example\n\
                  \x20 driftloop fit DATA.csv -o model.toml                             fit the drift model to a characterisation\n\
                  \x20 driftloop transform PART.MPF --model model.toml -o PART_DL.MPF   insert the measuring gates\n\
                  \x20 driftloop COMMAND --help                                         every flag of a command, with examples\n\n\
                  Exit codes: 0 clean, 1 findings or would change (--check, --diff), 2 usage, I/O or internal error.\n\
                  `-` reads stdin / writes stdout. Times take a unit: 90s, 30min, 24h (a bare number is minutes).\n\
                  Colour: --color auto|always|never; NO_COLOR turns it off under auto.\n\
                  Documentation: docs/ in the source tree (docs/README.md lists the pages; docs/tutorial.md first)."
)]
struct Cli {
    #[command(flatten)]
    global: Global,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the whole job on the bundled example and print what happened.
    Demo(demo::Args),
    /// Report the diagnostics of programs and directories of programs.
    Check(check::Args),
    /// Dump the syntax tree of a program as JSON, or print the program back from it.
    Parse(parse::Args),
    /// Fit the thermal drift model of one displacement channel from measured data.
    Fit(fit::Args),
    /// Predict drift for a spindle schedule or the inputs of a data file.
    Predict(predict::Args),
    /// Fit every channel on earlier time and score it on later time, without and with probing.
    Forward(forward::Args),
    /// Measurement logs: `log merge` joins characterisation CSVs and DRIFTLOG files into one series.
    Log(log::Args),
    /// Insert probe measurements, nested measuring loops and drift corrections into NC programs.
    Transform(transform::Args),
    /// Remove the blocks `transform` inserted: the original program, byte for byte.
    Strip(strip::Args),
    /// Print the timeline, predicted drift and planned measurements of a program.
    Plan(plan::Args),
    /// Dry run of an NC program on a virtual machine: time, passes, machined error, measurements.
    Run(run::Args),
    /// Trace a model's residual on new data to the effects it lacks, add them, report before and after.
    Diagnose(diagnose::Args),
    /// Write simulated characterisation runs and a production log with a chosen undeclared effect.
    SimulateData(simulate::Args),
    /// Temperature-sensor selection (correlation, redundant clusters) and regression of a channel.
    Sensors(sensors::Args),
    /// Positioning accuracy (DSTU/GOST 27843, VDI 3441, ISO 230-2) and compensation tables.
    Positioning(positioning::Args),
    /// Measure parse + print throughput and peak memory on a generated 100 MB program.
    Bench(bench::Args),
    /// List the machine profiles shipped inside the binary, or print one to adapt.
    Profiles(profiles::Args),
}

/// Entry point of the binary.
pub fn main() -> ExitCode {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let color = style::choice_from_args(&args);
    style::apply(color);
    let parsed = Cli::command()
        .color(color.into())
        .try_get_matches_from(&args)
        .and_then(|matches| Cli::from_arg_matches(&matches));
    let cli = match parsed {
        Ok(cli) => cli,
        // `--help` goes to stdout: a failed write there is an error too (`clap::Error::exit` ignores it).
        Err(e) => {
            let printed = e
                .print()
                .and_then(|()| std::io::Write::flush(&mut std::io::stdout()));
            return match printed {
                Err(err) if err.kind() != std::io::ErrorKind::BrokenPipe => {
                    eprintln!("error: cannot write to standard output: {err}");
                    ExitCode::from(2)
                }
                _ => ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2)),
            };
        }
    };
    let result = match cli.command {
        Command::Demo(args) => demo::run(args, &cli.global),
        Command::Positioning(args) => positioning::run(args, &cli.global),
        Command::Sensors(args) => sensors::run(args, &cli.global),
        Command::Fit(args) => fit::run(args, &cli.global),
        Command::Predict(args) => predict::run(args, &cli.global),
        Command::Forward(args) => forward::run(args, &cli.global),
        Command::Log(args) => log::run(args, &cli.global),
        Command::Check(args) => check::run(args, &cli.global),
        Command::Parse(args) => parse::run(args, &cli.global),
        Command::Bench(args) => bench::run(args, &cli.global),
        Command::Run(args) => run::run(args, &cli.global),
        Command::Diagnose(args) => diagnose::run(args, &cli.global),
        Command::SimulateData(args) => simulate::run(args, &cli.global),
        Command::Transform(args) => transform::run(args, &cli.global),
        Command::Strip(args) => strip::run(args, &cli.global),
        Command::Plan(args) => plan::run(args, &cli.global),
        Command::Profiles(args) => profiles::run(args, &cli.global),
    };
    // What is still buffered is written now, while a failure can still change the exit code.
    let result = result.and_then(|code| {
        std::io::Write::flush(&mut output::stdout())?;
        Ok(code)
    });
    match result {
        Ok(code) => code,
        // A reader that stops early (`driftloop transform … --diff | head`) is not a failure of ours.
        Err(err) if is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            anstream::eprintln!(
                "{} {}",
                style::label(crate::Severity::Error),
                error_chain(&err)
            );
            if wants_json(&args) {
                // A program reading the JSON gets the failure as JSON too, not an empty stdout.
                let record = serde_json::json!({ "error": error_chain(&err) });
                let _ = output::print(&format!("{record}\n"));
            }
            ExitCode::from(2)
        }
    }
}

/// Whether the command line asks for `--format json`.
fn wants_json(args: &[std::ffi::OsString]) -> bool {
    args.iter().any(|a| a == "--format=json")
        || args
            .windows(2)
            .any(|w| w[0] == "--format" && w[1] == "json")
}

/// The error and its causes joined with `: `, leaving out a cause whose text the message before it already
/// carries (an error that prints its source, as `cannot read x.csv: No such file …`, would repeat the OS
/// error).
fn error_chain(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text
}

fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

#[cfg(test)]
mod tests {
    use super::{error_chain, is_broken_pipe};
    use anyhow::Context;
    use std::io;

    #[test]
    fn a_broken_pipe_under_context_is_recognised_and_nothing_else() {
        let pipe: anyhow::Result<()> = Err(io::Error::from(io::ErrorKind::BrokenPipe).into());
        assert!(is_broken_pipe(&pipe.context("cannot write -").unwrap_err()));
        let missing: anyhow::Result<()> = Err(io::Error::from(io::ErrorKind::NotFound).into());
        assert!(!is_broken_pipe(
            &missing.context("cannot read x.mpf").unwrap_err()
        ));
        assert!(!is_broken_pipe(&anyhow::anyhow!("broken pipe")));
    }

    #[test]
    fn an_os_error_a_message_already_carries_is_printed_once() {
        let missing = io::Error::from(io::ErrorKind::NotFound);
        let os = missing.to_string();
        let repeated = anyhow::Error::new(missing).context(format!("x.csv: cannot read: {os}"));
        assert_eq!(error_chain(&repeated), format!("x.csv: cannot read: {os}"));
        let plain: anyhow::Result<()> = Err(io::Error::from(io::ErrorKind::NotFound).into());
        let chained = plain.context("cannot read x.mpf").unwrap_err();
        assert_eq!(error_chain(&chained), format!("cannot read x.mpf: {os}"));
    }
}
