//! `ghm import greenlight`: a GreenLight model (JSON files) and weather CSV as a `.ghm`
//! model and a ghm weather CSV (`docs/import.md`); `ghm import venlo`: the paper's
//! published Venlo weather as the lettuce studies' weather file (`docs/data.md`).

use crate::cli::CliError;
use crate::import::greenlight::{convert, write, Options, DEFAULT_INTEGRATOR};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ImportArgs {
    #[command(subcommand)]
    source: Source,
}

#[derive(Debug, Subcommand)]
enum Source {
    /// A GreenLight model (main .json, e.g. main_katzin_2021.json) and weather CSV.
    Greenlight(GreenlightArgs),
    /// The paper's Venlo 2014 weather as its authors published it
    /// (outdoorWeatherWurGlas2014.mat or .csv), into the data folder the lettuce studies
    /// read (docs/data.md).
    Venlo(VenloArgs),
}

#[derive(Debug, Args)]
pub struct VenloArgs {
    /// outdoorWeatherWurGlas2014.mat (MAT-file, matrix `d`) or outdoorWeatherWurGlas2014.csv
    /// (no header: time, radiation, temperature, humidity, wind, CO₂).
    pub source: PathBuf,
    /// The data folder to write DIR/venlo2014_30min_model_units.csv into (then set
    /// GHM_DATA=DIR for the tests).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// The period to keep, in seconds: the rows whose time is a multiple of it (the
    /// lettuce models sample every 30 minutes).
    #[arg(long, default_value_t = 1800.0)]
    pub period: f64,
}

#[derive(Debug, Args)]
pub struct GreenlightArgs {
    /// The model's main JSON file (its processing_order is followed).
    pub model: PathBuf,
    /// GreenLight's weather CSV (default: a .csv the processing_order names, if any); its
    /// columns become the model's disturbances and it is written as DIR/weather.csv.
    #[arg(long)]
    pub weather: Option<PathBuf>,
    /// The folder to write DIR/<model>.ghm (and DIR/weather.csv) into.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Controls to make open-loop inputs in [0, 1], comma separated, or `none` to keep
    /// every control as GreenLight's rule. Default: uBoil,uRoof,uThScr,uLamp,uExtCo2 (those
    /// the model has).
    #[arg(long, value_name = "NAMES")]
    pub inputs: Option<String>,
    /// The integrator written in `sample` (passed through; `ghm check` says which exist).
    #[arg(long, default_value = DEFAULT_INTEGRATOR)]
    pub integrator: String,
    /// The sample period in seconds.
    #[arg(long, default_value_t = 300.0)]
    pub step: f64,
    /// Integration steps per period (default: 4 per 300 s for an implicit integrator, 72 for
    /// rk4 and euler).
    #[arg(long)]
    pub substeps: Option<usize>,
}

pub fn run(args: &ImportArgs) -> Result<(), CliError> {
    match &args.source {
        Source::Greenlight(a) => greenlight(a),
        Source::Venlo(a) => venlo(a),
    }
}

fn venlo(a: &VenloArgs) -> Result<(), CliError> {
    let (path, rows) = crate::import::venlo::import(&a.source, a.period, &a.out)?;
    println!("wrote {} ({rows} rows of {} s)", path.display(), a.period);
    Ok(())
}

fn greenlight(a: &GreenlightArgs) -> Result<(), CliError> {
    let inputs = a.inputs.as_deref().map(|s| {
        if s.trim() == "none" {
            Vec::new()
        } else {
            s.split(',')
                .map(|n| n.trim().to_string())
                .filter(|n| !n.is_empty())
                .collect()
        }
    });
    let mut command = format!("ghm import greenlight {}", a.model.display());
    if let Some(w) = &a.weather {
        command.push_str(&format!(" --weather {}", w.display()));
    }
    command.push_str(&format!(" --out {}", a.out.display()));
    if let Some(i) = &a.inputs {
        command.push_str(&format!(" --inputs {i}"));
    }
    if a.integrator != DEFAULT_INTEGRATOR {
        command.push_str(&format!(" --integrator {}", a.integrator));
    }
    if a.step != 300.0 {
        command.push_str(&format!(" --step {}", a.step));
    }
    if let Some(n) = a.substeps {
        command.push_str(&format!(" --substeps {n}"));
    }
    let opts = Options {
        model: a.model.clone(),
        weather: a.weather.clone(),
        inputs,
        integrator: a.integrator.clone(),
        step_s: a.step,
        substeps: a.substeps,
        command: Some(command),
    };
    let imported = convert(&opts)?;
    let c = &imported.counts;
    let m = &imported.model;
    println!(
        "read {} GreenLight variables from {} file(s)",
        imported.resolved.vars.len(),
        imported.resolved.files.len()
    );
    println!(
        "model {}: {} states, {} inputs ({}), {} disturbances, {} const, {} let ({} aux, {} const reading variables, {} input rules), {} fn ({} GreenLight functions as built-ins), {} outputs",
        imported.name,
        c.states,
        c.inputs,
        m.inputs.iter().map(|u| u.info.name.as_str()).collect::<Vec<_>>().join(", "),
        c.disturbances,
        c.consts,
        c.lets_from_aux + c.lets_from_const + c.lets_from_input,
        c.lets_from_aux,
        c.lets_from_const,
        c.lets_from_input,
        c.functions,
        c.builtin_functions,
        c.outputs,
    );
    for n in &imported.notes {
        println!("note: {n}");
    }
    if !m.warnings.is_empty() {
        println!(
            "the model loads with {} warning(s) (see `ghm check`)",
            m.warnings.len()
        );
    }
    let written = write(&imported, &a.out)?;
    for p in written {
        println!("wrote {}", p.display());
    }
    Ok(())
}
