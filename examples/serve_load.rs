//! A load test of `ghm serve` on loopback: C clients, each a session of its own (a
//! greenhouse), send N decisions in all as fast as they are answered, and the throughput
//! and latency percentiles are printed. With `--restart` the service is killed (SIGKILL)
//! halfway and restarted on its journal while the clients keep asking; afterwards the
//! journal must hold every decision exactly once.
//!
//! ```text
//! cargo build --release
//! cargo run --release --example serve_load -- target/release/ghm [--decisions 10000]
//!     [--clients 8] [--controller expert|policy] [--restart]
//! ```
//!
//! Bounded: N requests (plus the retries of those in flight at a restart, each given up
//! after 60 s), to 127.0.0.1 only. `docs/benchmarks.md` has the figures.

use std::error::Error;
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

const MODEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/lettuce.ghm");

struct Settings {
    ghm: String,
    decisions: usize,
    clients: usize,
    controller: String,
    restart: bool,
}

fn settings() -> Result<Settings, String> {
    let mut args = std::env::args().skip(1);
    let mut s = Settings {
        ghm: String::new(),
        decisions: 10_000,
        clients: 8,
        controller: "expert".into(),
        restart: false,
    };
    let usage = "usage: serve_load GHM_BINARY [--decisions N] [--clients C] \
                 [--controller expert|policy] [--restart]";
    while let Some(a) = args.next() {
        let mut value = || {
            args.next()
                .ok_or_else(|| format!("{a} needs a value; {usage}"))
        };
        match a.as_str() {
            "--decisions" => s.decisions = value()?.parse().map_err(|e| format!("{e}"))?,
            "--clients" => s.clients = value()?.parse().map_err(|e| format!("{e}"))?,
            "--controller" => s.controller = value()?,
            "--restart" => s.restart = true,
            _ if s.ghm.is_empty() && !a.starts_with('-') => s.ghm = a,
            _ => return Err(usage.into()),
        }
    }
    if s.ghm.is_empty() || s.clients == 0 || s.decisions < s.clients || s.decisions > 1_000_000 {
        return Err(format!("{usage} (1 ≤ C ≤ N ≤ 1 000 000)"));
    }
    Ok(s)
}

/// `ghm serve` on `port`, once it listens.
fn start(s: &Settings, port: u16, journal: &str) -> Result<Child, Box<dyn Error>> {
    let mut child = Command::new(&s.ghm)
        .args([
            "serve",
            MODEL,
            "--controller",
            &s.controller,
            "--journal",
            journal,
        ])
        .args(["--listen", &format!("127.0.0.1:{port}")])
        .stdout(Stdio::piped())
        .spawn()?;
    let mut line = String::new();
    BufReader::new(child.stdout.take().ok_or("no stdout")?).read_line(&mut line)?;
    if !line.starts_with("serving") {
        let _ = child.kill();
        return Err(format!("ghm serve did not start: {line}").into());
    }
    Ok(child)
}

/// The request of `session` at `step`: the lettuce model's state, drifting with the step.
fn request(session: usize, step: usize) -> String {
    let temp = 12.0 + (step % 20) as f64 * 0.4;
    format!(
        r#"{{"session":"load-{session}","step":{step},"state":[0.0035,0.0008,{temp},0.008],
            "previous_input":[0.0,0.0,50.0],"forecast":[[0.0,0.0007,5.0,0.005]]}}"#
    )
}

/// One client: its session's decisions, in order; the time each took (retries included)
/// and how many attempts were retried.
fn client(
    url: String,
    session: usize,
    steps: usize,
    done: Arc<AtomicUsize>,
) -> Result<(Vec<f64>, usize), String> {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .proxy(None)
        .http_status_as_error(false)
        .build()
        .into();
    let mut latencies = Vec::with_capacity(steps);
    let mut retried = 0;
    for step in 0..steps {
        let body = request(session, step);
        let started = Instant::now();
        loop {
            let answer = agent
                .post(&url)
                .header("Content-Type", "application/json")
                .send(&body)
                .and_then(|mut r| Ok((r.status().as_u16(), r.body_mut().read_to_string()?)));
            match answer {
                Ok((200, _)) => break,
                Ok((503, _)) | Err(_) if started.elapsed() < Duration::from_secs(60) => {
                    retried += 1;
                    std::thread::sleep(Duration::from_millis(20));
                }
                Ok((status, text)) => return Err(format!("step {step}: {status} {text}")),
                Err(e) => return Err(format!("step {step}: {e}")),
            }
        }
        latencies.push(started.elapsed().as_secs_f64());
        done.fetch_add(1, Ordering::Relaxed);
    }
    Ok((latencies, retried))
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

fn main() -> Result<(), Box<dyn Error>> {
    let s = settings()?;
    let dir = std::env::temp_dir().join(format!("ghm-serve-load-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let journal = dir.join("journal.sqlite");
    let journal_arg = journal.to_str().ok_or("temp path not UTF-8")?.to_string();
    let port = std::net::TcpListener::bind("127.0.0.1:0")?
        .local_addr()?
        .port();
    let mut server = start(&s, port, &journal_arg)?;
    let url = format!("http://127.0.0.1:{port}/decide");
    let per_client = s.decisions / s.clients;
    let total = per_client * s.clients;
    let done = Arc::new(AtomicUsize::new(0));
    let started = Instant::now();
    let clients: Vec<_> = (0..s.clients)
        .map(|c| {
            let (url, done) = (url.clone(), done.clone());
            std::thread::spawn(move || client(url, c, per_client, done))
        })
        .collect();
    let mut outage = None;
    if s.restart {
        while done.load(Ordering::Relaxed) < total / 2 {
            std::thread::sleep(Duration::from_millis(1));
        }
        server.kill()?;
        server.wait()?;
        let killed = Instant::now();
        let at = done.load(Ordering::Relaxed);
        server = start(&s, port, &journal_arg)?;
        outage = Some((at, killed.elapsed().as_secs_f64()));
    }
    let mut latencies = Vec::with_capacity(total);
    let mut retried = 0;
    for c in clients {
        let (l, r) = c.join().map_err(|_| "a client panicked")??;
        latencies.extend(l);
        retried += r;
    }
    let elapsed = started.elapsed().as_secs_f64();
    server.kill()?;
    server.wait()?;

    // Nothing lost, nothing twice: every (session, step) journaled once.
    let conn = rusqlite::Connection::open(&journal)?;
    let (rows, distinct): (i64, i64) = conn.query_row(
        "SELECT COUNT(*), COUNT(DISTINCT session || '/' || step) FROM decisions",
        [],
        |r| Ok((r.get(0)?, r.get(1)?)),
    )?;
    let per_session: Vec<i64> = conn
        .prepare("SELECT COUNT(*) FROM decisions GROUP BY session")?
        .query_map([], |r| r.get(0))?
        .collect::<Result<_, _>>()?;
    drop(conn);
    std::fs::remove_dir_all(&dir)?;
    latencies.sort_by(f64::total_cmp);
    println!(
        "{total} decisions of `{}` from {} clients in {elapsed:.2} s: {:.0} decisions/s",
        s.controller,
        s.clients,
        total as f64 / elapsed
    );
    println!(
        "latency ms: p50 {:.2}, p95 {:.2}, p99 {:.2}, max {:.2}",
        percentile(&latencies, 0.5) * 1e3,
        percentile(&latencies, 0.95) * 1e3,
        percentile(&latencies, 0.99) * 1e3,
        percentile(&latencies, 1.0) * 1e3
    );
    if let Some((at, restart_s)) = outage {
        println!(
            "killed (SIGKILL) after {at} answers, restarted on the journal in {restart_s:.2} s; \
             {retried} attempts retried"
        );
    }
    let whole = rows == total as i64
        && distinct == rows
        && per_session.len() == s.clients
        && per_session.iter().all(|n| *n == per_client as i64);
    println!(
        "journal: {rows} decisions, {distinct} distinct (session, step), {} sessions: {}",
        per_session.len(),
        if whole { "nothing lost" } else { "NOT WHOLE" }
    );
    if !whole {
        return Err("the journal does not hold every decision exactly once".into());
    }
    Ok(())
}
