//! The service's counters and the solve-time histogram, rendered in the Prometheus text
//! format for `GET /metrics`. Updated by the controller thread (decisions) and the HTTP
//! handlers (refusals); read by scrapes.

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::Mutex;

/// Upper bounds of the solve-time buckets, in seconds.
const BUCKETS_S: [f64; 14] = [
    0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1.0, 5.0, 30.0,
];

/// One metric: its name, type, help text, and its lines (labels, value).
type Family = (
    &'static str,
    &'static str,
    &'static str,
    Vec<(String, String)>,
);

/// What happened, counted since the service started.
#[derive(Debug, Default)]
struct Counts {
    decisions: u64,
    journal_answers: u64,
    controller_failures: u64,
    fallbacks: BTreeMap<String, u64>,
    failed: BTreeMap<u16, u64>,
    restored: u64,
    sessions: u64,
    /// Per bucket of [`BUCKETS_S`], then `+Inf`: decisions at most that long.
    solve_buckets: [u64; BUCKETS_S.len() + 1],
    solve_sum_s: f64,
}

/// The service's metrics.
#[derive(Debug, Default)]
pub struct Metrics {
    counts: Mutex<Counts>,
}

impl Metrics {
    fn with(&self, f: impl FnOnce(&mut Counts)) {
        // A poisoned lock only means a panic elsewhere; the counts are still counts.
        let mut c = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        f(&mut c);
    }

    /// A decision made, with its solve time and fallback.
    pub fn decided(&self, solve_time_s: f64, fallback: Option<&str>) {
        self.with(|c| {
            c.decisions += 1;
            let bucket = BUCKETS_S
                .iter()
                .position(|b| solve_time_s <= *b)
                .unwrap_or(BUCKETS_S.len());
            c.solve_buckets[bucket] += 1;
            c.solve_sum_s += solve_time_s;
            if let Some(f) = fallback {
                *c.fallbacks.entry(f.to_string()).or_default() += 1;
            }
        });
    }

    /// A retry answered from the journal.
    pub fn journal_answer(&self) {
        self.with(|c| c.journal_answers += 1);
    }

    /// A decision the controller failed at (answered 500).
    pub fn controller_failed(&self) {
        self.with(|c| c.controller_failures += 1);
    }

    /// A request answered with the error `status`.
    pub fn failed(&self, status: u16) {
        self.with(|c| *c.failed.entry(status).or_default() += 1);
    }

    /// Decisions re-decided from the journal at start.
    pub fn restored(&self, n: u64) {
        self.with(|c| c.restored += n);
    }

    /// Sessions held now.
    pub fn sessions(&self, n: usize) {
        self.with(|c| c.sessions = n as u64);
    }

    /// The Prometheus text exposition of every metric.
    pub fn render(&self) -> String {
        let c = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        let plain = |v: u64| vec![(String::new(), v.to_string())];
        let labelled = |label: &str, counts: Vec<(String, u64)>| -> Vec<(String, String)> {
            counts
                .into_iter()
                .map(|(k, n)| (format!("{{{label}=\"{k}\"}}"), n.to_string()))
                .collect()
        };
        let mut histogram = Vec::new();
        let mut cumulative = 0;
        for (i, n) in c.solve_buckets.iter().enumerate() {
            cumulative += n;
            let le = BUCKETS_S
                .get(i)
                .map_or("+Inf".to_string(), |b| b.to_string());
            histogram.push((format!("_bucket{{le=\"{le}\"}}"), cumulative.to_string()));
        }
        histogram.push(("_sum".into(), c.solve_sum_s.to_string()));
        histogram.push(("_count".into(), cumulative.to_string()));
        let table: [Family; 8] = [
            (
                "ghm_decisions_total",
                "counter",
                "Decisions made and journaled.",
                plain(c.decisions),
            ),
            (
                "ghm_journal_answers_total",
                "counter",
                "Retries of a decided step, answered from the journal.",
                plain(c.journal_answers),
            ),
            (
                "ghm_controller_failures_total",
                "counter",
                "Decisions the controller failed at (answered 500).",
                plain(c.controller_failures),
            ),
            (
                "ghm_fallbacks_total",
                "counter",
                "Decisions whose first choice failed, by the fallback that gave the input.",
                labelled(
                    "fallback",
                    c.fallbacks.iter().map(|(f, n)| (f.clone(), *n)).collect(),
                ),
            ),
            (
                "ghm_requests_failed_total",
                "counter",
                "Requests answered with an error, by HTTP status.",
                labelled(
                    "status",
                    c.failed.iter().map(|(s, n)| (s.to_string(), *n)).collect(),
                ),
            ),
            (
                "ghm_restored_decisions",
                "gauge",
                "Journaled decisions re-decided when the service started.",
                plain(c.restored),
            ),
            (
                "ghm_sessions",
                "gauge",
                "Sessions (greenhouses) served.",
                plain(c.sessions),
            ),
            (
                "ghm_solve_seconds",
                "histogram",
                "Time the controller took per decision.",
                histogram,
            ),
        ];
        let mut s = String::new();
        for (name, kind, help, lines) in table {
            let _ = writeln!(s, "# HELP {name} {help}");
            let _ = writeln!(s, "# TYPE {name} {kind}");
            for (labels, value) in lines {
                let _ = writeln!(s, "{name}{labels} {value}");
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_histogram_is_cumulative_and_counts_add_up() {
        let m = Metrics::default();
        m.decided(0.0002, None);
        m.decided(0.003, Some("cold_start"));
        m.decided(100.0, None);
        m.failed(422);
        m.failed(422);
        let text = m.render();
        for line in [
            "ghm_decisions_total 3",
            "ghm_fallbacks_total{fallback=\"cold_start\"} 1",
            "ghm_requests_failed_total{status=\"422\"} 2",
            "ghm_solve_seconds_bucket{le=\"0.0001\"} 0",
            "ghm_solve_seconds_bucket{le=\"0.00025\"} 1",
            "ghm_solve_seconds_bucket{le=\"0.005\"} 2",
            "ghm_solve_seconds_bucket{le=\"30\"} 2",
            "ghm_solve_seconds_bucket{le=\"+Inf\"} 3",
            "ghm_solve_seconds_count 3",
            "# TYPE ghm_solve_seconds histogram",
        ] {
            assert!(text.lines().any(|l| l == line), "{line} not in\n{text}");
        }
    }
}
