//! `ghm study`: every season of a study file, in parallel, resumable, into one folder.

use crate::cli::args;
use crate::cli::CliError;
use crate::study::{run_study, Shard, StudyOptions};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct StudyArgs {
    /// The study file (.toml): models, weather, controllers, horizons, scenarios. See
    /// `examples/studies/`.
    pub file: PathBuf,
    /// Output folder: one run folder per job, `study.json` (the plan) and `results.csv`.
    /// Running the same study into the same folder again runs only what is not complete.
    #[arg(long, value_name = "DIR", default_value = "runs/study")]
    pub out: PathBuf,
    /// Jobs run at once (default: the number of cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Run only the slice `i/n` of the jobs (job k belongs to shard k mod n). Default in a
    /// Slurm array task: SLURM_ARRAY_TASK_ID / SLURM_ARRAY_TASK_COUNT.
    #[arg(long, value_name = "i/n")]
    pub shard: Option<String>,
    /// Run again the jobs whose last run failed (by default they are listed and left).
    #[arg(long)]
    pub retry_failed: bool,
}

pub fn run(args: &StudyArgs) -> Result<(), CliError> {
    let shard = match &args.shard {
        Some(text) => Some(Shard::parse(text)?),
        None => Shard::from_slurm()?,
    };
    let threads = args::threads(args.threads)?;
    let options = StudyOptions {
        threads,
        shard,
        retry_failed: args.retry_failed,
    };
    let result = run_study(&args.file, &args.out, &options);
    if let Ok(o) = &result {
        println!(
            "{} jobs: {} run now, {} done before; {} results in {}",
            o.total,
            o.ran,
            o.already_done,
            o.results,
            args.out.join("results.csv").display()
        );
    }
    result.map(|_| ()).map_err(CliError::from)
}
