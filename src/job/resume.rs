//! Resuming a stopped season. A season killed halfway leaves its run folder's `run.json`
//! saying `running` and its rows in the hidden temporary file of `trajectory.csv`
//! (`.trajectory.<pid>.partial.csv`, flushed once a simulated day); read back here as the
//! steps taken ([`StepsTaken`]), they are replayed by
//! [`resume_season`](crate::sim::season::resume_season) before the controller takes over.

use crate::control::{Fallback, StepRecord};
use crate::job::folder;
use crate::job::output::{io_err, trajectory_header};
use crate::job::JobError;
use crate::model::Plant;
use crate::report::atomic;
use crate::sim::season::StepsTaken;
use crate::solve::SolveStatus;
use std::path::{Path, PathBuf};

/// The trajectory a season stopped in `dir` left, if `dir` holds one of a run of `spec`
/// that was killed: the largest of its temporary trajectory files (a run resumed before
/// and killed again leaves two). `Err` where that run's process is still alive.
pub fn stopped_trajectory(
    dir: &Path,
    spec: &serde_json::Value,
) -> Result<Option<PathBuf>, JobError> {
    let Some((status, recorded)) = folder::recorded(dir) else {
        return Ok(None);
    };
    if status != "running" || recorded != *spec {
        return Ok(None);
    }
    if let Some(pid) = folder::recorded_pid(dir).filter(|&p| p != std::process::id()) {
        if process_alive(pid) {
            return Err(JobError::Spec(format!(
                "{} is still being written by process {pid}; wait for it, or stop it first",
                dir.display()
            )));
        }
    }
    Ok(temporary_trajectories(dir)
        .into_iter()
        .max_by_key(|p| std::fs::metadata(p).map_or(0, |m| m.len())))
}

/// Whether process `pid` is alive (Linux: it has a `/proc` entry that is not a zombie's);
/// elsewhere a killed run's process is taken to be gone.
fn process_alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|stat| {
            let state = stat.rsplit_once(')')?.1.trim_start().chars().next()?;
            Some(state != 'Z' && state != 'X')
        })
        .unwrap_or(false)
}

/// Removes the temporary trajectories that stopped runs left in `dir` (once the resumed
/// season is complete).
pub fn remove_stopped_trajectories(dir: &Path) -> Result<(), JobError> {
    for path in temporary_trajectories(dir) {
        std::fs::remove_file(&path).map_err(io_err(&path))?;
    }
    Ok(())
}

fn temporary_trajectories(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| atomic::is_temporary(n) && n.starts_with(".trajectory."))
        })
        .collect()
}

/// The steps a stopped season's trajectory at `path` holds, for `plant`. Its header must
/// be the one this model writes; the rows are read in order until one that is cut short
/// (the run was killed while writing it) or the file ends. A file killed before its header
/// was flushed holds no step.
pub fn read_steps_taken(path: &Path, plant: &Plant) -> Result<StepsTaken, JobError> {
    let refuse = |message: String| JobError::Resume {
        path: path.to_path_buf(),
        message,
    };
    let text = std::fs::read(path).map_err(|e| refuse(e.to_string()))?;
    if !text.contains(&b'\n') {
        return Ok(StepsTaken::default());
    }
    let mut reader = csv::ReaderBuilder::new()
        .flexible(true)
        .from_reader(text.as_slice());
    let header: Vec<String> = reader
        .headers()
        .map_err(|e| refuse(e.to_string()))?
        .iter()
        .map(String::from)
        .collect();
    if header != trajectory_header(plant) {
        return Err(refuse(
            "its columns are not the ones this model writes (the model changed since)".into(),
        ));
    }
    let m = &plant.model;
    let column = |name: &str| header.iter().position(|h| h == name);
    let columns = |prefix: &str, names: Vec<&str>| -> Vec<usize> {
        names
            .iter()
            .filter_map(|n| column(&format!("{prefix}{n}")))
            .collect()
    };
    let states = columns(
        "x_",
        m.states.iter().map(|s| s.info.name.as_str()).collect(),
    );
    let inputs = columns(
        "u_",
        m.inputs.iter().map(|u| u.info.name.as_str()).collect(),
    );
    let [k, solve_ms, iterations, corrections, status, fallback, region] = [
        "k",
        "solve_ms",
        "iterations",
        "inertia_corrections",
        "status",
        "fallback",
        "terminal_region",
    ]
    .map(|name| column(name).unwrap_or(usize::MAX));
    let mut taken = StepsTaken::default();
    for row in reader.records() {
        let Ok(row) = row else { break };
        if row.len() != header.len() {
            break;
        }
        let number = |i: usize| row.get(i).and_then(|v| v.parse::<f64>().ok());
        let numbers = |cols: &[usize]| cols.iter().map(|&i| number(i)).collect::<Option<Vec<_>>>();
        let text = |i: usize| row.get(i).unwrap_or_default();
        let (Some(x), Some(u), Some(step), Some(ms), Some(its), Some(corr)) = (
            numbers(&states),
            numbers(&inputs),
            number(k),
            number(solve_ms),
            row.get(iterations).and_then(|v| v.parse::<usize>().ok()),
            row.get(corrections).and_then(|v| v.parse::<usize>().ok()),
        ) else {
            break;
        };
        if step != taken.len() as f64 {
            return Err(refuse(format!(
                "row {} is step {step}, not step {}",
                taken.len() + 1,
                taken.len()
            )));
        }
        fn named(name: &str) -> Option<&str> {
            (!name.is_empty()).then_some(name)
        }
        taken.states.push(x);
        taken.inputs.push(u);
        taken.records.push(StepRecord {
            solve_time_s: ms / 1e3,
            iterations: its,
            inertia_corrections: corr,
            status: named(text(status)).and_then(SolveStatus::from_name),
            fallback: named(text(fallback)).and_then(Fallback::from_name),
            terminal_region: named(text(region)).map(String::from),
        });
    }
    Ok(taken)
}
