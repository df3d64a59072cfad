//! Running a planned study: which jobs are already done, the rest in parallel on a pool of
//! threads with one progress view, `timings.csv` appended as each job ends (so that a
//! study's time, phase by phase, survives a kill), and `results.csv` gathered from every
//! complete job ([`report::write_results`]).

use crate::job::distill::run_distill_job;
use crate::job::folder;
use crate::job::output::{io_err, model_file_hash, progress_bar};
use crate::job::train::run_train_job;
use crate::job::value::run_value_job;
use crate::job::{resume_season_job, run_season_job, JobError, JobOptions};
use crate::report::atomic;
use crate::report::table::csv_writer;
use crate::study::plan::{plan, Job, Work};
use crate::study::report;
use crate::study::StudyError;
use rayon::prelude::*;
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// A deterministic slice of a study's jobs: job `k` (in plan order) belongs to shard
/// `k mod count`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, from 0.
    pub index: usize,
    /// How many shards share the study.
    pub count: usize,
}

impl Shard {
    /// `i/n` as written on the command line.
    pub fn parse(text: &str) -> Result<Shard, StudyError> {
        let bad = || {
            StudyError::Shard(format!(
                "--shard {text}: expected i/n with 0 ≤ i < n, e.g. 0/4"
            ))
        };
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }

    /// The shard of a Slurm array task (`SLURM_ARRAY_TASK_ID` of
    /// `SLURM_ARRAY_TASK_COUNT`), if this process is one.
    pub fn from_slurm() -> Result<Option<Shard>, StudyError> {
        let id = std::env::var("SLURM_ARRAY_TASK_ID");
        let count = std::env::var("SLURM_ARRAY_TASK_COUNT");
        match (id, count) {
            (Ok(i), Ok(n)) => Shard::parse(&format!("{i}/{n}")).map(Some),
            _ => Ok(None),
        }
    }
}

/// How a study runs.
#[derive(Debug, Clone)]
pub struct StudyOptions {
    /// Jobs run at once (at least 1).
    pub threads: usize,
    /// Only this slice of the jobs; `None`: all.
    pub shard: Option<Shard>,
    /// Run again the jobs whose last run failed (otherwise they are reported and left).
    pub retry_failed: bool,
}

/// What a study run did.
#[derive(Debug, Clone, Default)]
pub struct StudyOutcome {
    /// Jobs of this run (or shard).
    pub total: usize,
    /// Found complete and left alone.
    pub already_done: usize,
    /// Run now, successfully.
    pub ran: usize,
    /// Failed, now or before (folders relative to the output folder).
    pub failed: Vec<PathBuf>,
    /// Rows written to `results.csv` (complete jobs of the whole study).
    pub results: usize,
}

/// Where a job stands before the run.
#[derive(Debug, PartialEq)]
enum Found {
    Done,
    Failed,
    ToRun,
}

fn found(job: &Job, out: &Path, model_hashes: &mut ModelHashes) -> Found {
    let dir = out.join(&job.folder);
    let Some((status, spec)) = folder::recorded(&dir) else {
        return Found::ToRun;
    };
    let same = job.work.spec_json() == spec;
    match status.as_str() {
        "complete" if same && model_changed(job, &dir, model_hashes) => {
            eprintln!(
                "{}: its model file changed since it ran; running it again",
                job.folder.display()
            );
            Found::ToRun
        }
        "complete" if same => Found::Done,
        "failed" if same => Found::Failed,
        _ => Found::ToRun,
    }
}

/// The hash of each model file as it is now ([`model_file_hash`]), loaded once per file
/// however many seasons name it (a paper study's 1 180 name two).
type ModelHashes = std::collections::HashMap<std::path::PathBuf, Option<String>>;

/// Whether a complete season's `summary.json` names another model text than its model
/// file holds now (the spec names the file, not what is in it).
fn model_changed(job: &Job, dir: &Path, model_hashes: &mut ModelHashes) -> bool {
    let Some(spec) = job.work.season() else {
        return false;
    };
    let recorded = folder::summary(dir)
        .and_then(|summary| summary["model_sha256"].as_str().map(str::to_string));
    let now = model_hashes
        .entry(spec.model.clone())
        .or_insert_with(|| model_file_hash(&spec.model));
    match (recorded, now) {
        (Some(recorded), Some(now)) => recorded != *now,
        _ => false,
    }
}

/// Plans the study at `path` and runs what is not done yet into `out`; see the
/// [module documentation](self).
pub fn run_study(
    path: &Path,
    out: &Path,
    options: &StudyOptions,
) -> Result<StudyOutcome, StudyError> {
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    // The trainings' folders are named in the seasons' specs: one spelling of the folder,
    // however the study is reached.
    let out = &std::fs::canonicalize(out).map_err(io_err(out))?;
    let all = plan(path, out)?;
    write_plan(out, path, &all)?;
    let jobs: Vec<&Job> = all
        .iter()
        .enumerate()
        .filter(|(k, _)| options.shard.is_none_or(|s| k % s.count == s.index))
        .map(|(_, j)| j)
        .collect();
    let mut outcome = StudyOutcome {
        total: jobs.len(),
        ..StudyOutcome::default()
    };
    let mut pending = Vec::new();
    let mut model_hashes = ModelHashes::new();
    for job in &jobs {
        match found(job, out, &mut model_hashes) {
            Found::Done => outcome.already_done += 1,
            Found::Failed if !options.retry_failed => outcome.failed.push(job.folder.clone()),
            _ => pending.push(*job),
        }
    }
    eprintln!(
        "study {}: {} jobs{}, {} done already, {} failed before{}, {} to run on {} thread{}",
        path.display(),
        jobs.len(),
        options.shard.map_or(String::new(), |s| format!(
            " (shard {}/{})",
            s.index, s.count
        )),
        outcome.already_done,
        outcome.failed.len(),
        if outcome.failed.is_empty() || options.retry_failed {
            ""
        } else {
            " (--retry-failed runs them again)"
        },
        pending.len(),
        options.threads,
        if options.threads == 1 { "" } else { "s" }
    );
    // Phase by phase (trainings, value fits, seasons): a job reads only earlier phases'.
    pending.sort_by_key(|job| job.work.phase());
    let results = run_pending(&pending, out, options, jobs.len() - pending.len())?;
    for (job, result) in pending.iter().zip(results) {
        match result {
            Ok(()) => outcome.ran += 1,
            Err(_) => outcome.failed.push(job.folder.clone()),
        }
    }
    let rows = report::gather(&[out.to_path_buf()])?;
    report::write_results(out, &rows)?;
    outcome.results = rows.len();
    if outcome.failed.is_empty() {
        Ok(outcome)
    } else {
        Err(StudyError::JobsFailed {
            failed: outcome.failed.len(),
            total: outcome.total,
            list: outcome
                .failed
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        })
    }
}

/// Runs `pending` on a pool of `options.threads` threads, with a progress view counting
/// from `done_before` jobs; one result per job, in order.
fn run_pending(
    pending: &[&Job],
    out: &Path,
    options: &StudyOptions,
    done_before: usize,
) -> Result<Vec<Result<(), JobError>>, StudyError> {
    let total = done_before + pending.len();
    let bar = progress_bar(
        total as u64,
        "{spinner} jobs [{bar:30}] {pos}/{len} ({elapsed}, eta {eta}) {msg}",
    );
    bar.set_position(done_before as u64);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.threads.max(1))
        .build()
        .map_err(|e| StudyError::Shard(format!("cannot start the study's threads: {e}")))?;
    let timings = Timings::open(out)?;
    let running = AtomicUsize::new(0);
    let finished = AtomicUsize::new(done_before);
    let mut results = Vec::with_capacity(pending.len());
    for phase in pending.chunk_by(|a, b| a.work.phase() == b.work.phase()) {
        let phase_clock = Instant::now();
        results.extend(pool.install(|| {
            phase
                .par_iter()
                .map(|job| {
                    let now = running.fetch_add(1, Ordering::SeqCst) + 1;
                    bar.set_message(format!(
                        "{now} running, last started {}",
                        job.folder.display()
                    ));
                    let started = unix_seconds();
                    let clock = Instant::now();
                    let result = wait_for_needs(job, out, options.shard.is_some())
                        .and_then(|()| run_job(job, out));
                    let seconds = clock.elapsed().as_secs_f64();
                    running.fetch_sub(1, Ordering::SeqCst);
                    timings.record(job, started, seconds, result.is_ok());
                    let k = finished.fetch_add(1, Ordering::SeqCst) + 1;
                    let line = match &result {
                        Ok(what) => format!(
                            "[{k}/{total}] {}: {what} ({seconds:.1} s)",
                            job.folder.display()
                        ),
                        Err(e) => format!("[{k}/{total}] {}: failed: {e}", job.folder.display()),
                    };
                    bar.suspend(|| eprintln!("{line}"));
                    bar.inc(1);
                    result.map(|_| ())
                })
                .collect::<Vec<_>>()
        }));
        if let Some(first) = phase.first() {
            let line = format!(
                "phase {}: {} job{} in {} on {} thread{}",
                first.work.phase_name(),
                phase.len(),
                if phase.len() == 1 { "" } else { "s" },
                duration(phase_clock.elapsed().as_secs_f64()),
                options.threads.max(1),
                if options.threads.max(1) == 1 { "" } else { "s" }
            );
            bar.suspend(|| eprintln!("{line}"));
        }
    }
    bar.finish_and_clear();
    Ok(results)
}

/// `DIR/timings.csv`: one line per job run, appended as it ends (`job, kind, phase,
/// started_unix, wall_s, status`), so that the time of a study stopped and rerun, phase by
/// phase, is still known. A line that cannot be written is only warned about: timing is
/// not worth a job.
struct Timings {
    path: PathBuf,
    file: Mutex<Option<std::fs::File>>,
}

impl Timings {
    const HEADER: &'static str = "job,kind,phase,started_unix,wall_s,status\n";

    fn open(out: &Path) -> Result<Timings, StudyError> {
        let path = out.join("timings.csv");
        // Only the run that creates the file writes the header: shards of one Slurm array
        // start together in the same folder.
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
        {
            Ok(mut created) => created
                .write_all(Self::HEADER.as_bytes())
                .map_err(io_err(&path))?,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(io_err(&path)(e).into()),
        }
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .map_err(io_err(&path))?;
        Ok(Timings {
            path,
            file: Mutex::new(Some(file)),
        })
    }

    fn record(&self, job: &Job, started_unix: f64, wall_s: f64, ok: bool) {
        let fields = [
            job.folder.display().to_string(),
            job.work.kind().to_string(),
            job.work.phase_name().to_string(),
            format!("{started_unix:.0}"),
            format!("{wall_s:.3}"),
            (if ok { "complete" } else { "failed" }).to_string(),
        ];
        let mut row = csv_writer(Vec::new());
        if row.write_record(&fields).is_err() {
            return;
        }
        let Ok(line) = row.into_inner() else {
            return;
        };
        let Ok(mut guard) = self.file.lock() else {
            return;
        };
        if let Some(file) = guard.as_mut() {
            if let Err(e) = file.write_all(&line) {
                eprintln!(
                    "warning: {}: {e}; no more timings written",
                    self.path.display()
                );
                *guard = None;
            }
        }
    }
}

/// Seconds since the Unix epoch (0 on a clock before it).
fn unix_seconds() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// `95 s`, `12.5 min`, `1.3 h`.
fn duration(seconds: f64) -> String {
    if seconds < 120.0 {
        format!("{seconds:.0} s")
    } else if seconds < 7200.0 {
        format!("{:.1} min", seconds / 60.0)
    } else {
        format!("{:.1} h", seconds / 3600.0)
    }
}

/// Runs one job into its folder; says what it gave.
fn run_job(job: &Job, out: &Path) -> Result<String, JobError> {
    let dir = out.join(&job.folder);
    let options = JobOptions {
        overwrite: true,
        verbose: false,
    };
    match &job.work {
        // A season killed in an earlier run of the study continues where it stopped, or
        // runs afresh where that run cannot be continued (its model file changed).
        Work::Season(spec) => resume_season_job(spec, &dir, &options)
            .or_else(|e| {
                if e.refuses_resume() {
                    run_season_job(spec, &dir, &options)
                } else {
                    Err(e)
                }
            })
            .map(|o| {
                format!(
                    "cumulative reward {:+.4} {}, {} failed solves",
                    o.metrics.cumulative_reward, o.unit, o.metrics.solve.failed_solves
                )
            }),
        Work::Train(spec) => run_train_job(spec, &dir, &options, true)
            .map(|()| format!("trained ({} episodes)", spec.episodes)),
        Work::Value(spec) => run_value_job(spec, &dir, &options)
            .map(|()| format!("value network fitted ({} roll-outs)", spec.trajectories)),
        // One thread per job, as the study's other jobs: the study runs them side by side.
        Work::Distill(spec) => run_distill_job(spec, &dir, &options, true, 1)
            .map(|()| format!("distilled ({} iterations)", spec.iterations)),
    }
}

/// Waits until every job `job` reads is complete: at once where the whole study runs here
/// (they ran in an earlier phase), polling where another shard may still be running them.
/// A job it reads that failed fails it.
fn wait_for_needs(job: &Job, out: &Path, sharded: bool) -> Result<(), JobError> {
    let mut announced = false;
    for need in &job.needs {
        loop {
            match folder::recorded(&out.join(need)) {
                Some((status, _)) if status == "complete" => break,
                Some((status, _)) if status == "failed" => {
                    return Err(JobError::Spec(format!(
                        "it reads {}, which failed (--retry-failed runs it again)",
                        need.display()
                    )))
                }
                _ if !sharded => {
                    return Err(JobError::Spec(format!(
                        "it reads {}, which did not run",
                        need.display()
                    )))
                }
                _ => {
                    if !announced {
                        eprintln!(
                            "{} waits for {} (another shard's)",
                            job.folder.display(),
                            need.display()
                        );
                        announced = true;
                    }
                    std::thread::sleep(std::time::Duration::from_secs(5));
                }
            }
        }
    }
    Ok(())
}

/// `study.json`: the study file and every job of its plan with its folder and spec.
fn write_plan(out: &Path, path: &Path, jobs: &[Job]) -> Result<(), StudyError> {
    let plan = json!({
        "study": path.display().to_string(),
        "jobs": jobs.iter().map(|j| json!({
            "folder": j.folder.display().to_string(),
            "model": j.model,
            "controller": j.controller,
            "horizon": j.horizon,
            "scenario": j.scenario,
            "kind": j.work.kind(),
            "needs": j.needs,
            "spec": j.work.spec_json(),
        })).collect::<Vec<_>>(),
    });
    let target = out.join("study.json");
    let text = serde_json::to_string_pretty(&plan).unwrap_or_default() + "\n";
    atomic::write(&target, text).map_err(io_err(&target))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_bad_ones_are_refused() {
        assert_eq!(Shard::parse("1/4").unwrap(), Shard { index: 1, count: 4 });
        for bad in ["4/4", "1", "a/b", "0/0", "-1/2"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
    }
}
