//! Run folders: the per-step trajectory CSV, `summary.json`, the trajectory plot, and the
//! progress bar. Every file is written atomically ([`atomic`]): the trajectory is streamed
//! (and flushed daily) into a temporary file that becomes `trajectory.csv` only when the
//! season is complete; a season that fails keeps its rows as `trajectory.incomplete.csv`,
//! and one killed leaves them in the hidden temporary file, never as a `trajectory.csv`
//! that looks like a shorter valid run.

use crate::job::JobError;
use crate::model::Plant;
use crate::report::atomic::{self, AtomicFile};
use crate::report::plot::{draw_png, Figure, Line, Panel};
use crate::report::table::csv_writer;
use crate::sim::season::{StepLog, StepSink};
use indicatif::{ProgressBar, ProgressStyle};
use sha2::{Digest, Sha256};
use std::fmt::Write as _;
use std::fs::File;
use std::path::{Path, PathBuf};

/// An I/O error of `path` as a [`JobError::Io`].
pub fn io_err(path: &Path) -> impl Fn(std::io::Error) -> JobError + '_ {
    move |source| JobError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes the result file `path` atomically: `write` writes the file at the path it is
/// given (a temporary name beside `path`), which is then renamed into place.
pub fn write_atomically<E: std::fmt::Display>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), JobError> {
    let fail = |message: String| JobError::Output {
        path: path.to_path_buf(),
        message,
    };
    let file = AtomicFile::new(path);
    write(file.path()).map_err(|e| fail(e.to_string()))?;
    file.commit().map_err(|e| fail(e.to_string()))
}

/// SHA-256 of the model file and its imports, in load order.
pub fn model_hash(plant: &Plant) -> String {
    sources_hash(&plant.model)
}

/// [`sources_hash`] of the model file at `path` as it is now; `None` where it does not
/// load (its run will say why).
pub fn model_file_hash(path: &Path) -> Option<String> {
    crate::lang::load(path)
        .ok()
        .map(|model| sources_hash(&model))
}

/// The SHA-256 of a model's source files (the file and those it imports), in hex.
pub fn sources_hash(model: &crate::lang::model::Model) -> String {
    let mut h = Sha256::new();
    for f in &model.sources.files {
        h.update(f.text.as_bytes());
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The columns of `trajectory.csv`: step and time, states, outputs, inputs, weather,
/// stage terms, the economic term, the penalties, reward, cumulative reward, and how the
/// controller decided (solve time, iterations, inertia corrections, and the text columns
/// [`TEXT_COLUMNS`]).
pub fn trajectory_header(plant: &Plant) -> Vec<String> {
    let m = &plant.model;
    let mut header = vec!["k".to_string(), "time_h".to_string()];
    header.extend(m.states.iter().map(|s| format!("x_{}", s.info.name)));
    header.extend(m.outputs.iter().map(|o| format!("y_{}", o.info.name)));
    header.extend(m.inputs.iter().map(|u| format!("u_{}", u.info.name)));
    header.extend(m.disturbances.iter().map(|d| format!("d_{}", d.info.name)));
    header.extend(
        plant
            .stage_term_index
            .iter()
            .map(|&i| format!("term_{}", m.terms[i].info.name)),
    );
    header.push("economic".into());
    header.extend(
        m.soft
            .iter()
            .map(|b| format!("penalty_{}", m.outputs[b.output].info.name)),
    );
    header.extend(
        [
            "reward",
            "cumulative_reward",
            "solve_ms",
            "iterations",
            "inertia_corrections",
        ]
        .map(String::from),
    );
    header.extend(TEXT_COLUMNS.map(String::from));
    header
}

/// The columns of `trajectory.csv` that hold text, last in its header.
pub const TEXT_COLUMNS: [&str; 3] = ["status", "fallback", "terminal_region"];

/// The numeric columns of [`trajectory_header`] (all but [`TEXT_COLUMNS`]) of one step,
/// in its order.
pub fn numeric_fields(log: &StepLog, period_h: f64) -> Vec<f64> {
    let mut row = vec![log.step as f64, log.step as f64 * period_h];
    row.extend(season_numbers(log));
    row.push(log.record.solve_time_s * 1e3);
    row.push(log.record.iterations as f64);
    row.push(log.record.inertia_corrections as f64);
    row
}

/// A step's numbers of the plant and the season, from the states to the cumulative reward.
fn season_numbers(log: &StepLog) -> impl Iterator<Item = f64> + '_ {
    log.state
        .iter()
        .chain(&log.outputs)
        .chain(&log.input)
        .chain(&log.disturbance)
        .chain(&log.terms)
        .chain(std::iter::once(&log.economic))
        .chain(&log.penalties)
        .chain([&log.reward, &log.cumulative_reward])
        .copied()
}

/// The text columns ([`TEXT_COLUMNS`]) of one step.
pub fn text_fields(log: &StepLog) -> [&str; 3] {
    [
        log.record.status_name(),
        log.record.fallback_name().unwrap_or_default(),
        log.record.terminal_region.as_deref().unwrap_or_default(),
    ]
}

/// The name under which a failed season's rows are kept.
pub const INCOMPLETE_TRAJECTORY: &str = "trajectory.incomplete.csv";

/// Writes `trajectory.csv`, keeps the series for the plot, and drives the progress bar.
pub struct TrajectoryWriter {
    path: PathBuf,
    file: Option<AtomicFile>,
    out: csv::Writer<File>,
    steps_per_day: usize,
    period_h: f64,
    pub logs: Vec<StepLog>,
    bar: ProgressBar,
    /// Where each field of a row is formatted before it is written.
    scratch: String,
}

/// Steps between updates of the progress bar's message (the day and the reward so far),
/// which is also updated at each new day and at the first step written.
const PROGRESS_MESSAGE_EVERY: usize = 16;

impl TrajectoryWriter {
    /// Starts `dir/trajectory.csv` for a season of `steps` steps; `progress` draws the
    /// per-step progress bar.
    pub fn create(
        dir: &Path,
        plant: &Plant,
        steps: usize,
        progress: bool,
    ) -> Result<TrajectoryWriter, JobError> {
        let path = dir.join("trajectory.csv");
        let file = AtomicFile::new(&path);
        let mut out = csv_writer(File::create(file.path()).map_err(io_err(&path))?);
        let m = &plant.model;
        let header = trajectory_header(plant);
        out.write_record(&header)
            .map_err(|e| io_err(&path)(e.into()))?;
        let steps_per_day = (86400.0 / m.sample_period).round().max(1.0) as usize;
        let bar = ProgressBar::new(steps as u64);
        if !progress {
            bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        }
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} day {msg} [{bar:30}] {pos}/{len} steps ({per_sec}, eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        Ok(TrajectoryWriter {
            path,
            file: Some(file),
            out,
            steps_per_day,
            period_h: m.sample_period / 3600.0,
            logs: Vec::with_capacity(steps),
            bar,
            scratch: String::new(),
        })
    }

    /// Ends the trajectory: renamed to `trajectory.csv` if the season is `complete`,
    /// otherwise to `trajectory.incomplete.csv`.
    pub fn finish(&mut self, complete: bool) -> Result<(), JobError> {
        self.bar.finish_and_clear();
        self.out.flush().map_err(io_err(&self.path))?;
        let Some(file) = self.file.take() else {
            return Ok(());
        };
        if complete {
            file.commit().map_err(io_err(&self.path))
        } else {
            let kept = self.path.with_file_name(INCOMPLETE_TRAJECTORY);
            std::fs::rename(file.path(), &kept).map_err(io_err(&kept))
        }
    }

    /// Writes one step's row, each field formatted into the one scratch string: a season
    /// of short steps (GreenLight's 111 days, 31 968 rows) spent a sixth of its time
    /// allocating a string per field.
    fn write_row(&mut self, log: &StepLog) -> csv::Result<()> {
        let (out, scratch) = (&mut self.out, &mut self.scratch);
        let mut field = |out: &mut csv::Writer<File>, text: std::fmt::Arguments| {
            scratch.clear();
            // Formatting into a `String` cannot fail.
            let _ = scratch.write_fmt(text);
            out.write_field(scratch.as_bytes())
        };
        field(out, format_args!("{}", log.step))?;
        field(out, format_args!("{}", log.step as f64 * self.period_h))?;
        let mut digits = ryu::Buffer::new();
        for v in season_numbers(log) {
            out.write_field(digits.format(v))?;
        }
        field(out, format_args!("{:.4}", log.record.solve_time_s * 1e3))?;
        field(out, format_args!("{}", log.record.iterations))?;
        field(out, format_args!("{}", log.record.inertia_corrections))?;
        for text in text_fields(log) {
            out.write_field(text)?;
        }
        out.write_record(std::iter::empty::<&[u8]>())
    }
}

impl StepSink for TrajectoryWriter {
    fn step(&mut self, log: &StepLog) -> Result<(), String> {
        self.write_row(log).map_err(|e| e.to_string())?;
        if (log.step + 1).is_multiple_of(self.steps_per_day) {
            self.out.flush().map_err(|e| e.to_string())?;
        }
        self.bar.set_position(log.step as u64 + 1);
        if log.step.is_multiple_of(PROGRESS_MESSAGE_EVERY)
            || log.step.is_multiple_of(self.steps_per_day)
            || self.logs.is_empty()
        {
            self.bar.set_message(format!(
                "{} reward {:+.3}",
                log.step / self.steps_per_day + 1,
                log.cumulative_reward
            ));
        }
        self.logs.push(log.clone());
        Ok(())
    }
}

/// A progress bar of `len` units with `template`, hidden when stderr is not a terminal
/// (the commands then print a line per unit of work themselves).
pub fn progress_bar(len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// [`progress_bar`] where a job is verbose; a hidden bar (drawing nothing) where it is quiet,
/// as a study's jobs are.
pub fn progress_bar_if(verbose: bool, len: u64, template: &str) -> ProgressBar {
    if verbose {
        progress_bar(len, template)
    } else {
        ProgressBar::hidden()
    }
}

/// Prints `line` above `bar` where the bar is drawn, plainly where it is hidden (output
/// that is not a terminal), so that a job's per-step lines reach a log file too.
pub fn println_beside(bar: &ProgressBar, line: String) {
    if bar.is_hidden() {
        println!("{line}");
    } else {
        bar.println(line);
    }
}

/// Writes `summary.json`.
pub fn write_summary(dir: &Path, summary: &serde_json::Value) -> Result<(), JobError> {
    let path = dir.join("summary.json");
    let text = serde_json::to_string_pretty(summary).map_err(|e| JobError::Output {
        path: path.clone(),
        message: e.to_string(),
    })?;
    atomic::write(&path, text + "\n").map_err(io_err(&path))
}

/// Draws `trajectory.png`: each state and output with its band, the inputs, and the
/// cumulative reward, against time (days, hours or minutes by the run's length).
pub fn plot_trajectory(
    dir: &Path,
    plant: &Plant,
    logs: &[StepLog],
    title: &str,
) -> Result<(), JobError> {
    let m = &plant.model;
    // Time in days, hours or minutes, whichever suits the run's length.
    let span_s = logs.len() as f64 * m.sample_period;
    let (unit_s, x_label) = if span_s >= 2.0 * 86400.0 {
        (86400.0, "day")
    } else if span_s >= 2.0 * 3600.0 {
        (3600.0, "hour")
    } else {
        (60.0, "minute")
    };
    let x: Vec<f64> = logs
        .iter()
        .map(|l| l.step as f64 * m.sample_period / unit_s)
        .collect();
    let mut panels = Vec::new();
    for (i, o) in m.outputs.iter().enumerate() {
        let band = m
            .soft
            .iter()
            .find(|b| b.output == i)
            .map(|b| (b.lower, b.upper));
        panels.push(Panel {
            title: o
                .info
                .description
                .split('(')
                .next()
                .unwrap_or(&o.info.name)
                .trim()
                .to_string(),
            unit: o.info.unit.clone(),
            lines: vec![Line {
                label: o.info.name.clone(),
                values: logs.iter().map(|l| l.outputs[i]).collect(),
            }],
            band,
            spreads: Vec::new(),
        });
    }
    for (i, u) in m.inputs.iter().enumerate() {
        panels.push(Panel {
            title: u
                .info
                .description
                .split('(')
                .next()
                .unwrap_or(&u.info.name)
                .trim()
                .to_string(),
            unit: u.info.unit.clone(),
            lines: vec![Line {
                label: u.info.name.clone(),
                values: logs.iter().map(|l| l.input[i]).collect(),
            }],
            band: None,
            spreads: Vec::new(),
        });
    }
    panels.push(Panel {
        title: "cumulative reward".into(),
        unit: plant.model.objective_unit(),
        lines: vec![Line {
            label: "reward".into(),
            values: logs.iter().map(|l| l.cumulative_reward).collect(),
        }],
        band: None,
        spreads: Vec::new(),
    });
    let fig = Figure {
        title: title.to_string(),
        x_label: x_label.into(),
        x,
        panels,
    };
    write_atomically(&dir.join("trajectory.png"), |path| draw_png(&fig, path))
}

/// A figure of money for the terminal: four decimals, or four significant digits in
/// scientific notation from 1e9 on (a 300-digit EPI is unreadable, whatever caused it).
///
/// `signed` shows a `+` on positive figures.
pub fn figure(v: f64, signed: bool) -> String {
    match (v.abs() < 1e9, signed) {
        (true, true) => format!("{v:+.4}"),
        (true, false) => format!("{v:.4}"),
        (false, true) => format!("{v:+.4e}"),
        (false, false) => format!("{v:.4e}"),
    }
}
