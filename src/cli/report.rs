//! `ghm report`: the tables and figures of study folders, merged.

use crate::cli::CliError;
use crate::study::{gather, write_report};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Study folders (the --out of `ghm study`): runs or shards of one study, or several.
    #[arg(required = true, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    /// Where the report goes: report.md, results.csv, and per model a CSV table and a PNG
    /// figure.
    #[arg(long, value_name = "DIR", default_value = "runs/report")]
    pub out: PathBuf,
}

pub fn run(args: &ReportArgs) -> Result<(), CliError> {
    let rows = gather(&args.dirs)?;
    if rows.is_empty() {
        return Err(CliError::Argument(format!(
            "no complete job in {}: run `ghm study` into it first",
            args.dirs
                .iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let outcome = write_report(&rows, &args.out)?;
    println!(
        "{} seasons of {} model{} → {}/report.md, results.csv, {}",
        outcome.jobs,
        outcome.models.len(),
        if outcome.models.len() == 1 { "" } else { "s" },
        args.out.display(),
        outcome
            .models
            .iter()
            .map(|m| format!("{m}.csv, {m}-solve-times.csv, {m}.png, {m}.svg"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    Ok(())
}
