//! A season optimum's checkpoints: where its long solve stood ([`Checkpoint`]), written into
//! its run folder at most once a minute, so that the same job run again (`ghm optimum` with
//! the same flags, a study run again) goes on from there instead of from the start. The
//! GreenLight tomato's 60-day optimum takes hours; a session or a Slurm job may end first.
//!
//! The file names the spec and the model (its sources' hash) it belongs to; a checkpoint
//! of another spec or model is refused, and `--overwrite` starts afresh.

use crate::job::output::write_atomically;
use crate::job::JobError;
use crate::solve::{Checkpoint, CheckpointSink};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The checkpoint's file in the run folder.
pub const FILE: &str = ".optimum-checkpoint.json";

/// The least time between two checkpoints written.
const INTERVAL: Duration = Duration::from_secs(60);

/// What the file holds.
#[derive(Serialize, Deserialize)]
struct Saved {
    /// The run spec whose optimum it is.
    spec: serde_json::Value,
    /// The model's sources' hash.
    model_hash: String,
    /// Where the solve stood.
    checkpoint: Checkpoint,
}

/// The checkpoint a stopped optimum of `spec` and the model of `model_hash` left in `out`;
/// `None` where there is none. One of another spec or model is an error that says so.
pub fn read(
    out: &Path,
    spec: &serde_json::Value,
    model_hash: &str,
) -> Result<Option<Checkpoint>, JobError> {
    let path = out.join(FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => return Err(JobError::Io { path, source }),
    };
    let refuse = |message: String| JobError::Resume {
        path: path.clone(),
        message,
    };
    let saved: Saved = serde_json::from_str(&text)
        .map_err(|e| refuse(format!("not a checkpoint of ghm's ({e}); remove it")))?;
    if &saved.spec != spec {
        return Err(refuse(
            "it is of another optimum (other flags or weather); pass --overwrite to start afresh"
                .into(),
        ));
    }
    if saved.model_hash != model_hash {
        return Err(refuse(
            "the model file changed since; pass --overwrite to start afresh".into(),
        ));
    }
    Ok(Some(saved.checkpoint))
}

/// A sink that writes the checkpoints of `spec` into `out`, at most once a minute, counting
/// the `iterations_before` of the stopped runs it goes on from. One that cannot be written
/// is a warning: the solve goes on.
pub fn sink(
    out: &Path,
    (spec, model_hash): (serde_json::Value, String),
    iterations_before: usize,
) -> Box<dyn CheckpointSink> {
    Box::new(Writer {
        out: out.to_path_buf(),
        spec,
        model_hash,
        iterations_before,
        last: Instant::now(),
    })
}

/// [`sink`]'s writer.
struct Writer {
    out: PathBuf,
    spec: serde_json::Value,
    model_hash: String,
    iterations_before: usize,
    /// When the last checkpoint was written (or the solve began).
    last: Instant,
}

impl CheckpointSink for Writer {
    fn wants(&mut self, _iteration: usize) -> bool {
        self.last.elapsed() >= INTERVAL
    }

    fn keep(&mut self, checkpoint: &Checkpoint) {
        self.last = Instant::now();
        let saved = Saved {
            spec: self.spec.clone(),
            model_hash: self.model_hash.clone(),
            checkpoint: Checkpoint {
                iteration: self.iterations_before + checkpoint.iteration,
                ..checkpoint.clone()
            },
        };
        if let Err(e) = write(&self.out, &saved) {
            eprintln!("warning: {e}; the solve goes on without it");
        }
    }
}

/// Writes `saved` into `out` (made if missing), atomically.
fn write(out: &Path, saved: &Saved) -> Result<(), JobError> {
    std::fs::create_dir_all(out).map_err(|source| JobError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    write_atomically(&out.join(FILE), |path: &Path| -> Result<(), String> {
        use std::io::Write;
        let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
        let mut writer = std::io::BufWriter::new(file);
        serde_json::to_writer(&mut writer, saved).map_err(|e| e.to_string())?;
        writer.flush().map_err(|e| e.to_string())
    })
}

/// Removes the checkpoint in `out`, if any: the optimum is done, or starts afresh.
pub fn remove(out: &Path) -> Result<(), JobError> {
    let path: PathBuf = out.join(FILE);
    match std::fs::remove_file(&path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(JobError::Io { path, source }),
    }
}
