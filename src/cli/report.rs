//! `ghm report`: the tables and figures of study folders, merged.

use crate::cli::CliError;
use crate::report::atomic;
use crate::study::{gather, report_markdown, splice, write_report};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Study folders (the --out of `ghm study`): runs or shards of one study, or several.
    /// A season found in several folders (the same study run again, to time it) is reported
    /// once, its solve times the median over the runs.
    #[arg(required = true, value_name = "DIR")]
    pub dirs: Vec<PathBuf>,
    /// Where the report goes: report.md, results.csv, and per model a CSV table and a PNG
    /// figure.
    #[arg(long, value_name = "DIR", default_value = "runs/report")]
    pub out: PathBuf,
    /// Also put the report's tables into this markdown document, between its lines
    /// `<!-- begin ghm report NAME -->` and `<!-- end ghm report NAME -->`, NAME being the
    /// --out folder as seen from the document's folder (how docs/results.md is made).
    #[arg(long, value_name = "FILE")]
    pub into: Option<PathBuf>,
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
        "{} seasons of {} model{} → {}/{}",
        outcome.jobs,
        outcome.models.len(),
        if outcome.models.len() == 1 { "" } else { "s" },
        args.out.display(),
        outcome.files.join(", ")
    );
    if let Some(document) = &args.into {
        let name = relative_to_document(document, &args.out);
        let text = std::fs::read_to_string(document).map_err(|source| CliError::Io {
            what: format!("cannot read {}", document.display()),
            source,
        })?;
        let generated = report_markdown(&rows, &format!("{name}/"));
        let text = splice(&text, &name, &generated)
            .map_err(|e| CliError::Argument(format!("{} {e}", document.display())))?;
        atomic::write(document, text).map_err(|source| CliError::Io {
            what: format!("cannot write {}", document.display()),
            source,
        })?;
        println!("tables and figures of {name} → {}", document.display());
    }
    Ok(())
}

/// `out` as a link from `document`'s folder sees it: relative where `out` lies under that
/// folder, else as given.
fn relative_to_document(document: &Path, out: &Path) -> String {
    let folder = document
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let (Ok(folder), Ok(out_full)) = (folder.canonicalize(), out.canonicalize()) else {
        return out.display().to_string();
    };
    match out_full.strip_prefix(&folder) {
        Ok(p) if p.as_os_str().is_empty() => ".".into(),
        Ok(p) => p.display().to_string(),
        Err(_) => out.display().to_string(),
    }
}
