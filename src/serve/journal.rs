//! The journal: every decision, with the request it answered, in one SQLite file (WAL mode,
//! `synchronous=FULL`), appended in one transaction before the answers leave. It also
//! records the spec and the model's hash it was begun with, so that a service restarted on
//! it serves the same controller. Reading it back is [`Journal::for_each`]; nothing here
//! decides.

use super::api::{DecideRequest, DecideResponse};
use super::ServeError;
use crate::job::RunSpec;
use rusqlite::{params, Connection, OptionalExtension};
use std::path::{Path, PathBuf};

/// How a journaled step ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The answer sent.
    Answer(DecideResponse),
    /// The controller failed; the message sent with the 500.
    Failed(String),
}

/// One journaled decision.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// The request, as checked.
    pub request: DecideRequest,
    /// What came of it.
    pub outcome: Outcome,
}

/// The journal file, open.
pub struct Journal {
    conn: Connection,
    path: PathBuf,
}

/// The journal format this build writes and reads.
const FORMAT: &str = "1";

impl Journal {
    /// Opens (or begins) the journal at `path` for `spec` on a model of hash
    /// `model_sha256`; a journal begun with another spec or model is refused.
    pub fn open(path: &Path, spec: &RunSpec, model_sha256: &str) -> Result<Journal, ServeError> {
        let fail = |e: rusqlite::Error| journal_error(path, e);
        let conn = Connection::open(path).map_err(fail)?;
        let mode: String = conn
            .query_row("PRAGMA journal_mode=WAL", [], |r| r.get(0))
            .map_err(fail)?;
        if !mode.eq_ignore_ascii_case("wal") {
            return Err(ServeError::Journal {
                path: path.to_path_buf(),
                message: format!("SQLite would not switch to WAL mode (it says {mode})"),
            });
        }
        conn.execute_batch(
            "PRAGMA synchronous=FULL;
             CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
             CREATE TABLE IF NOT EXISTS decisions (
                 id INTEGER PRIMARY KEY,
                 session TEXT NOT NULL,
                 step INTEGER NOT NULL,
                 request TEXT NOT NULL,
                 response TEXT,
                 error TEXT,
                 decided_unix_ms INTEGER NOT NULL,
                 UNIQUE (session, step)
             );",
        )
        .map_err(fail)?;
        let journal = Journal {
            conn,
            path: path.to_path_buf(),
        };
        journal.check_meta(spec, model_sha256)?;
        Ok(journal)
    }

    /// Records the spec and model hash of a new journal, or checks an existing one's.
    fn check_meta(&self, spec: &RunSpec, model_sha256: &str) -> Result<(), ServeError> {
        let fail = |e: rusqlite::Error| journal_error(&self.path, e);
        let spec_json = serde_json::to_string(spec).map_err(|e| ServeError::Journal {
            path: self.path.clone(),
            message: e.to_string(),
        })?;
        let get = |key: &str| -> Result<Option<String>, ServeError> {
            self.conn
                .query_row("SELECT value FROM meta WHERE key = ?1", [key], |r| r.get(0))
                .optional()
                .map_err(fail)
        };
        let Some(stored_spec) = get("spec")? else {
            for (key, value) in [
                ("format", FORMAT),
                ("spec", spec_json.as_str()),
                ("model_sha256", model_sha256),
                ("ghm_version", env!("CARGO_PKG_VERSION")),
            ] {
                self.conn
                    .execute(
                        "INSERT OR REPLACE INTO meta (key, value) VALUES (?1, ?2)",
                        params![key, value],
                    )
                    .map_err(fail)?;
            }
            return Ok(());
        };
        let mismatch = |message: String| ServeError::JournalMismatch {
            path: self.path.clone(),
            message,
        };
        if get("format")?.as_deref() != Some(FORMAT) {
            return Err(mismatch(format!(
                "it is not a journal of format {FORMAT}, which this ghm reads"
            )));
        }
        let same_spec = serde_json::from_str::<RunSpec>(&stored_spec)
            .map(|stored| stored == *spec)
            .unwrap_or(false);
        if !same_spec {
            return Err(mismatch(format!(
                "it was begun by a service of another spec:\n  journal: {stored_spec}\n  now:     \
                 {spec_json}\nstart with the journal's options, or begin another --journal"
            )));
        }
        let stored_hash = get("model_sha256")?.unwrap_or_default();
        if stored_hash != model_sha256 {
            return Err(mismatch(format!(
                "the model file changed since it was begun (SHA-256 {stored_hash}, now \
                 {model_sha256}): restore the model it was begun with, or begin another --journal"
            )));
        }
        Ok(())
    }

    /// Appends `entries` in one transaction: all or none are journaled.
    pub fn append(&mut self, entries: &[Entry]) -> Result<(), ServeError> {
        let fail = |e: rusqlite::Error| journal_error(&self.path, e);
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as i64);
        let tx = self.conn.transaction().map_err(fail)?;
        {
            let mut insert = tx
                .prepare_cached(
                    "INSERT INTO decisions (session, step, request, response, error, \
                     decided_unix_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6)",
                )
                .map_err(fail)?;
            for e in entries {
                let request = to_json(&self.path, &e.request)?;
                let (response, error) = match &e.outcome {
                    Outcome::Answer(a) => (Some(to_json(&self.path, a)?), None),
                    Outcome::Failed(m) => (None, Some(m.clone())),
                };
                let step = i64::try_from(e.request.step).map_err(|_| ServeError::Journal {
                    path: self.path.clone(),
                    message: format!("step {} does not fit the journal", e.request.step),
                })?;
                insert
                    .execute(params![
                        e.request.session,
                        step,
                        request,
                        response,
                        error,
                        now
                    ])
                    .map_err(fail)?;
            }
        }
        tx.commit().map_err(fail)
    }

    /// The journaled decision of `session` at `step`, if any.
    pub fn lookup(&self, session: &str, step: u64) -> Result<Option<Entry>, ServeError> {
        let Ok(step) = i64::try_from(step) else {
            return Ok(None);
        };
        let row = self
            .conn
            .query_row(
                "SELECT request, response, error FROM decisions WHERE session = ?1 AND step = ?2",
                params![session, step],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)),
            )
            .optional()
            .map_err(|e| journal_error(&self.path, e))?;
        row.map(|row| self.entry(row)).transpose()
    }

    /// The sessions journaled, in the order they began.
    pub fn sessions(&self) -> Result<Vec<String>, ServeError> {
        let fail = |e: rusqlite::Error| journal_error(&self.path, e);
        let mut q = self
            .conn
            .prepare("SELECT session FROM decisions GROUP BY session ORDER BY MIN(id)")
            .map_err(fail)?;
        let names = q
            .query_map([], |r| r.get(0))
            .map_err(fail)?
            .collect::<Result<Vec<String>, _>>()
            .map_err(fail)?;
        Ok(names)
    }

    /// Calls `each` with every journaled decision of `session`, in the order decided; stops
    /// at the first error `each` returns.
    pub fn for_each(
        &self,
        session: &str,
        mut each: impl FnMut(Entry) -> Result<(), ServeError>,
    ) -> Result<(), ServeError> {
        let fail = |e: rusqlite::Error| journal_error(&self.path, e);
        let mut q = self
            .conn
            .prepare(
                "SELECT request, response, error FROM decisions WHERE session = ?1 ORDER BY id",
            )
            .map_err(fail)?;
        let mut rows = q.query([session]).map_err(fail)?;
        while let Some(r) = rows.next().map_err(fail)? {
            let row = (
                r.get(0).map_err(fail)?,
                r.get(1).map_err(fail)?,
                r.get(2).map_err(fail)?,
            );
            each(self.entry(row)?)?;
        }
        Ok(())
    }

    /// Decisions journaled, in all sessions.
    pub fn count(&self) -> Result<u64, ServeError> {
        self.conn
            .query_row("SELECT COUNT(*) FROM decisions", [], |r| r.get::<_, i64>(0))
            .map(|n| n.max(0) as u64)
            .map_err(|e| journal_error(&self.path, e))
    }

    /// An entry from its stored columns.
    fn entry(
        &self,
        (request, response, error): (String, Option<String>, Option<String>),
    ) -> Result<Entry, ServeError> {
        let corrupt = |what: &str, e: serde_json::Error| ServeError::Journal {
            path: self.path.clone(),
            message: format!("a journaled {what} does not read back: {e}"),
        };
        let request = serde_json::from_str(&request).map_err(|e| corrupt("request", e))?;
        let outcome = match (response, error) {
            (Some(r), _) => {
                Outcome::Answer(serde_json::from_str(&r).map_err(|e| corrupt("response", e))?)
            }
            (None, message) => Outcome::Failed(message.unwrap_or_default()),
        };
        Ok(Entry { request, outcome })
    }
}

fn to_json(path: &Path, value: &impl serde::Serialize) -> Result<String, ServeError> {
    serde_json::to_string(value).map_err(|e| ServeError::Journal {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

fn journal_error(path: &Path, e: rusqlite::Error) -> ServeError {
    ServeError::Journal {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::ControllerSpec;

    fn spec(model: &str) -> RunSpec {
        RunSpec {
            model: model.into(),
            weather: Default::default(),
            plant: Default::default(),
            controller: ControllerSpec::Expert,
        }
    }

    fn entry(session: &str, step: u64, input: f64) -> Entry {
        Entry {
            request: DecideRequest {
                session: session.into(),
                step,
                state: vec![Some(1.0)],
                previous_input: vec![Some(0.0)],
                outputs: None,
                forecast: vec![vec![Some(0.1)]],
                units: None,
            },
            outcome: Outcome::Answer(DecideResponse {
                session: session.into(),
                step,
                input: vec![input],
                status: None,
                iterations: 0,
                inertia_corrections: 0,
                solve_time_ms: 0.1,
                fallback: None,
                terminal_region: None,
                plan: None,
                from_journal: false,
            }),
        }
    }

    #[test]
    fn decisions_read_back_in_order_and_a_journal_keeps_its_spec() {
        let path = std::env::temp_dir().join(format!("ghm-journal-{}.sqlite", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let mut j = Journal::open(&path, &spec("a.ghm"), "h").unwrap();
        // An input that the default JSON parser would not read back to the same bits.
        let odd = 0.1 + 0.2;
        j.append(&[entry("b", 0, 1.0), entry("a", 0, odd)]).unwrap();
        j.append(&[entry("b", 1, 2.0)]).unwrap();
        // A step journaled twice is refused, and the transaction with it.
        assert!(j.append(&[entry("a", 1, 3.0), entry("b", 1, 4.0)]).is_err());
        drop(j);

        let j = Journal::open(&path, &spec("a.ghm"), "h").unwrap();
        assert_eq!(j.count().unwrap(), 3);
        assert_eq!(j.sessions().unwrap(), ["b", "a"]);
        let mut seen = Vec::new();
        j.for_each("b", |e| {
            seen.push(e);
            Ok(())
        })
        .unwrap();
        assert_eq!(seen, [entry("b", 0, 1.0), entry("b", 1, 2.0)]);
        assert_eq!(j.lookup("a", 0).unwrap(), Some(entry("a", 0, odd)));
        assert_eq!(j.lookup("a", 1).unwrap(), None);
        drop(j);

        let other = Journal::open(&path, &spec("b.ghm"), "h").err().unwrap();
        assert!(other.to_string().contains("another spec"), "{other}");
        let changed = Journal::open(&path, &spec("a.ghm"), "g").err().unwrap();
        assert!(
            changed.to_string().contains("model file changed"),
            "{changed}"
        );
        for suffix in ["", "-wal", "-shm"] {
            let _ = std::fs::remove_file(format!("{}{suffix}", path.display()));
        }
    }
}
