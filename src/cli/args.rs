//! The flags the season commands share, and how the command line speaks of a spec: the
//! weather and plant flags map onto [`WeatherSpec`] and [`PlantSpec`] (their defaults read
//! from the specs' `Default`), a [`Choice`]'s flag value is parsed by its spec name
//! ([`choice`]), and a job's error about a spec field is said as its flag ([`flag`]).

use crate::cli::CliError;
use crate::job::{
    resume_season_job, run_season_job, Choice, JobError, JobOptions, PlantSpec, RunSpec,
    SeasonOutcome, WeatherSpec,
};
use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use clap::Args;
use std::path::{Path, PathBuf};

/// What a season command does with a run already in its `--out` folder.
#[derive(Debug, Clone, Args)]
pub struct FolderArgs {
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
    /// Continue the run of the same command killed in the --out folder: its steps are
    /// replayed from what it wrote and the controller decides from the first step not
    /// taken (MPC's first solve there is cold). Without such a run, start one.
    #[arg(long, conflicts_with = "overwrite")]
    pub resume: bool,
}

impl FolderArgs {
    /// Runs the season of `spec` into `out`, printing its figures: resumed with
    /// `--resume`, afresh otherwise.
    pub fn run_season(&self, spec: &RunSpec, out: &Path) -> Result<SeasonOutcome, JobError> {
        let options = JobOptions {
            overwrite: self.overwrite,
            verbose: true,
        };
        if self.resume {
            resume_season_job(spec, out, &options)
        } else {
            run_season_job(spec, out, &options)
        }
    }
}

/// The work to run at once that `--threads` gives: at least 1, the number of cores where
/// it is not given.
pub fn threads(given: Option<usize>) -> Result<usize, CliError> {
    match given {
        Some(0) => Err(CliError::Argument("--threads must be at least 1".into())),
        Some(n) => Ok(n),
        None => Ok(std::thread::available_parallelism().map_or(1, |n| n.get())),
    }
}

/// The flag of a spec field: `start_row` is `--start-row`.
pub fn flag(field: &str) -> String {
    format!("--{}", field.replace('_', "-"))
}

/// A flag's parser for a [`Choice`]: its values by their spec names, each with its help.
pub fn choice<T: Choice>() -> impl TypedValueParser<Value = T> {
    choice_where(|_: T| true)
}

/// [`choice`] for the values that `keep` keeps.
pub fn choice_where<T: Choice>(keep: fn(T) -> bool) -> impl TypedValueParser<Value = T> {
    let possible = T::ALL
        .iter()
        .filter(move |c| keep(**c))
        .map(|c| PossibleValue::new(c.name()).help(c.help()));
    // The parser accepts only the names listed, so the lookup always finds one.
    PossibleValuesParser::new(possible).try_map(|name: String| {
        T::from_name(&name).ok_or_else(|| format!("`{name}` is not a value of this option"))
    })
}

/// The weather a season runs on and its length ([`WeatherSpec`]).
#[derive(Debug, Clone, Args)]
pub struct WeatherArgs {
    /// Weather CSV with a header of named columns (e.g. $GHM_DATA/venlo2014_30min_model_units.csv).
    /// Without --weather or --knmi, ghm's built-in Dutch late-winter season is used.
    #[arg(long, value_name = "CSV", conflicts_with = "knmi")]
    pub weather: Option<PathBuf>,
    /// First data row of the weather file used as step 0 (Venlo: 1394 = 2014-02-08 01:00).
    #[arg(long, value_name = "N", default_value_t = WeatherSpec::default().start_row)]
    pub start_row: usize,
    /// KNMI hourly station file (uurgegevens), converted and interpolated to the model's period.
    #[arg(long, value_name = "FILE")]
    pub knmi: Option<PathBuf>,
    /// Outdoor CO₂ assumed with KNMI data (which has none), in ppm.
    #[arg(long, value_name = "PPM", default_value_t = WeatherSpec::default().knmi_co2)]
    pub knmi_co2: f64,
    /// Seed of the built-in weather generator.
    #[arg(long, value_name = "S", default_value_t = WeatherSpec::default().weather_seed)]
    pub weather_seed: u64,
    /// Season length in days (at most 10 000 000 steps) [default: 40].
    #[arg(long, value_name = "D", conflicts_with = "steps")]
    pub days: Option<f64>,
    /// Season length in steps (at most 10 000 000).
    #[arg(long, value_name = "N")]
    pub steps: Option<usize>,
}

impl WeatherArgs {
    /// The spec these flags say.
    pub fn spec(&self) -> WeatherSpec {
        WeatherSpec {
            weather: self.weather.clone(),
            start_row: self.start_row,
            knmi: self.knmi.clone(),
            knmi_co2: self.knmi_co2,
            weather_seed: self.weather_seed,
            days: self.days,
            steps: self.steps,
        }
    }
}

/// The plant's parametric uncertainty ([`PlantSpec`]).
#[derive(Debug, Clone, Args)]
pub struct PlantArgs {
    /// Parametric uncertainty δ of the plant (relative half-width; the model file says which
    /// parameters and how often they are redrawn). 0 = the nominal, deterministic plant;
    /// controllers predict with the nominal model either way.
    #[arg(long, value_name = "DELTA", default_value_t = PlantSpec::default().uncertainty)]
    pub uncertainty: f64,
    /// Seed of the parameter draws.
    #[arg(long, value_name = "S", default_value_t = PlantSpec::default().seed)]
    pub seed: u64,
}

impl PlantArgs {
    /// The spec these flags say.
    pub fn spec(&self) -> PlantSpec {
        PlantSpec {
            uncertainty: self.uncertainty,
            seed: self.seed,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::SolverChoice;
    use clap::Parser;

    #[derive(Debug, Parser)]
    struct Probe {
        #[arg(long, value_parser = choice::<SolverChoice>(), default_value_t = SolverChoice::default())]
        solver: SolverChoice,
        #[command(flatten)]
        weather: WeatherArgs,
        #[command(flatten)]
        plant: PlantArgs,
    }

    #[test]
    fn flags_default_to_the_specs_defaults_and_parse_choices_by_name() {
        let probe = Probe::try_parse_from(["probe"]).unwrap();
        assert_eq!(probe.weather.spec(), WeatherSpec::default());
        assert_eq!(probe.plant.spec(), PlantSpec::default());
        assert_eq!(probe.solver, SolverChoice::default());
        let probe = Probe::try_parse_from(["probe", "--solver", "sqp"]).unwrap();
        assert_eq!(probe.solver, SolverChoice::Sqp);
        let e = Probe::try_parse_from(["probe", "--solver", "fatrop"]).unwrap_err();
        assert!(
            e.to_string().contains("[possible values: ipm, sqp, ipopt]"),
            "{e}"
        );
        assert_eq!(flag("start_row"), "--start-row");
    }
}
