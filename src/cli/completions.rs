//! `ghm completions SHELL`: the shell's completion script for every command and flag,
//! generated from the same clap definition the commands parse with, so it never lags them.

use super::{Cli, CliError};
use clap::{Args, CommandFactory};
use clap_complete::Shell;

/// The arguments of `ghm completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell: bash, zsh, fish, elvish or powershell.
    pub shell: Shell,
}

/// Writes the completion script to standard output.
pub fn run(args: &CompletionsArgs) -> Result<(), CliError> {
    let mut command = Cli::command();
    clap_complete::generate(args.shell, &mut command, "ghm", &mut std::io::stdout());
    Ok(())
}
