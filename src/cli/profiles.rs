//! `driftloop profiles [NAME]`: the machine profiles shipped inside the binary, or one of them as TOML to
//! start a profile of one's own from.

use std::process::ExitCode;

use super::Global;
use crate::omm::profile::BUILTIN;

#[derive(Debug, clap::Args)]
#[command(
    after_help = "Examples:\n  driftloop profiles\n  driftloop profiles tool-setter > my-machine.toml"
)]
pub struct Args {
    /// Print this profile's TOML (`driftloop profiles tool-setter > my-machine.toml`).
    #[arg(value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(BUILTIN.iter().map(|(name, _, _)| *name)))]
    name: Option<String>,
}

pub fn run(args: Args, _global: &Global) -> anyhow::Result<ExitCode> {
    match args.name {
        None => {
            let width = BUILTIN.iter().map(|(n, _, _)| n.len()).max().unwrap_or(0);
            for (name, what, _) in BUILTIN {
                super::output::print(&format!("{name:width$}  {what}\n"))?;
            }
            super::output::print(
                "\n`--profile NAME` uses one; `driftloop profiles NAME` prints it to adapt.\n",
            )?;
        }
        Some(name) => match BUILTIN.iter().find(|(n, _, _)| *n == name) {
            Some((_, _, text)) => super::output::print(text)?,
            None => anyhow::bail!(
                "no builtin profile `{name}`; there are: {}",
                BUILTIN
                    .iter()
                    .map(|(n, _, _)| *n)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        },
    }
    Ok(ExitCode::SUCCESS)
}
