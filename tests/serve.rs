//! `ghm serve` and `ghm replay` as a user runs them (the built binary): a replayed season
//! equals the direct one to the last bit, a service killed mid-season and restarted on its
//! journal finishes it the same, every bad request gets a clear 4xx while the service
//! keeps serving, and the live page (in headless Chromium) draws the decisions as they
//! come in.

mod common;

use common::bin::{ghm_with_stdout, temp_dir};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::Duration;

const MODEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/lettuce.ghm");
/// The thesis variant: every parameter uncertain, the output map's too.
const THESIS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/lettuce-thesis.ghm");
const TOKEN: &str = "test-token-0123456789abcdef";

/// A running `ghm serve`, killed (SIGKILL) when dropped.
struct Server {
    child: Child,
    url: String,
    stderr: Option<std::thread::JoinHandle<String>>,
}

impl Server {
    /// `ghm serve MODEL args`, once it listens.
    fn start(args: &[&str]) -> Server {
        Server::start_model(MODEL, args)
    }

    /// `ghm serve model args`, once it listens.
    fn start_model(model: &str, args: &[&str]) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_ghm"))
            .arg("serve")
            .arg(model)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run ghm serve");
        let mut stderr = child.stderr.take().expect("stderr");
        let stderr = std::thread::spawn(move || {
            let mut text = String::new();
            let _ = stderr.read_to_string(&mut text);
            text
        });
        let mut line = String::new();
        let mut out = BufReader::new(child.stdout.take().expect("stdout"));
        out.read_line(&mut line).expect("read ghm serve's stdout");
        let Some(url) = line.split_whitespace().find(|w| w.starts_with("http://")) else {
            let _ = child.kill();
            let _ = child.wait();
            panic!("ghm serve did not start: {line}{}", stderr.join().unwrap());
        };
        Server {
            url: url.trim_end_matches(',').to_string(),
            child,
            stderr: Some(stderr),
        }
    }

    /// Kills the service (SIGKILL) and returns what it wrote to stderr.
    fn kill(mut self) -> String {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let text = self
            .stderr
            .take()
            .map(|h| h.join().unwrap())
            .unwrap_or_default();
        assert!(!text.contains("panicked"), "{text}");
        text
    }

    fn metric(&self, name: &str) -> f64 {
        let (status, text) = get(&format!("{}/metrics", self.url));
        assert_eq!(status, 200);
        text.lines()
            .find_map(|l| l.strip_prefix(name)?.strip_prefix(' ')?.parse().ok())
            .unwrap_or(0.0)
    }
}

/// `ghm serve MODEL args`, which must refuse to start: its stderr. One that starts after
/// all is killed and fails the test (it would serve forever).
fn refused_to_start(args: &[&str]) -> String {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .arg("serve")
        .arg(MODEL)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run ghm serve");
    let mut line = String::new();
    let mut out = BufReader::new(child.stdout.take().expect("stdout"));
    out.read_line(&mut line).expect("read ghm serve's stdout");
    if line.starts_with("serving") {
        let _ = child.kill();
        let _ = child.wait();
        panic!("ghm serve {args:?} started: {line}");
    }
    let output = child.wait_with_output().expect("wait for ghm serve");
    let err = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(
        !output.status.success() && !err.contains("panicked"),
        "{err}"
    );
    err
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .proxy(None)
        .http_status_as_error(false)
        .build()
        .into()
}

fn get(url: &str) -> (u16, String) {
    get_with_token(url, None)
}

/// `GET url`, with `Authorization: Bearer token` when given.
fn get_with_token(url: &str, token: Option<&str>) -> (u16, String) {
    let mut request = agent().get(url);
    if let Some(t) = token {
        request = request.header("Authorization", format!("Bearer {t}"));
    }
    let mut r = request.call().expect("GET");
    let status = r.status().as_u16();
    (status, r.body_mut().read_to_string().expect("body"))
}

fn post(url: &str, token: Option<&str>, body: &[u8]) -> (u16, serde_json::Value) {
    let mut request = agent()
        .post(format!("{url}/decide"))
        .header("Content-Type", "application/json");
    if let Some(t) = token {
        request = request.header("Authorization", format!("Bearer {t}"));
    }
    let mut r = request.send(body).expect("POST");
    let status = r.status().as_u16();
    let text = r.body_mut().read_to_string().expect("body");
    let json = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"));
    (status, json)
}

/// `trajectory.csv` of a run folder without its solve-time column (the only one a
/// machine's speed changes): header and rows.
fn trajectory(dir: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(dir.join("trajectory.csv"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut lines = text
        .lines()
        .map(|l| l.split(',').map(String::from).collect::<Vec<_>>());
    let header = lines.next().expect("header");
    let keep: Vec<usize> = (0..header.len())
        .filter(|i| header[*i] != "solve_ms")
        .collect();
    assert_eq!(
        keep.len() + 1,
        header.len(),
        "a solve_ms column: {header:?}"
    );
    let pick = |row: Vec<String>| keep.iter().map(|i| row[*i].clone()).collect::<Vec<_>>();
    (pick(header), lines.map(pick).collect())
}

/// Asserts two trajectories are the same season: every column but the solve time, the
/// inputs to the last printed digit (ryu: the shortest text that reads back to the bits).
fn assert_same_season(direct: &Path, replayed: &Path) {
    let (h1, r1) = trajectory(direct);
    let (h2, r2) = trajectory(replayed);
    assert_eq!(h1, h2);
    assert!(h1.iter().any(|h| h.starts_with("u_")), "{h1:?}");
    assert_eq!(r1.len(), r2.len(), "steps");
    for (k, (a, b)) in r1.iter().zip(&r2).enumerate() {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert_eq!(x, y, "step {k}, column {}", h1[i]);
        }
    }
}

const DAYS: &str = "4";

/// `ghm mpc` over DAYS days at a 1 h horizon on the built-in weather, run once.
fn direct_mpc() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let out = temp_dir("serve-direct-mpc");
        let o = out.to_str().unwrap();
        let (ok, _, err) =
            ghm_with_stdout(&["mpc", MODEL, "--days", DAYS, "--horizon", "1h", "--out", o]);
        assert!(ok, "{err}");
        out
    })
}

fn replay(url: &str, out: &Path, extra: &[&str]) -> Child {
    replay_days(MODEL, url, out, DAYS, extra)
}

fn replay_days(model: &str, url: &str, out: &Path, days: &str, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(["replay", model, "--server", url, "--days", days, "--out"])
        .arg(out)
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run ghm replay")
}

fn finish(child: Child) -> String {
    let out = child.wait_with_output().expect("wait for ghm replay");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success() && !err.contains("panicked"), "{err}");
    err
}

#[test]
fn a_replayed_season_is_the_direct_season_to_the_last_bit() {
    let dir = temp_dir("serve-replay");
    std::fs::create_dir_all(&dir).unwrap();
    let journal = dir.join("journal.sqlite");
    let server = Server::start(&[
        "--controller",
        "mpc",
        "--horizon",
        "1h",
        "--listen",
        "127.0.0.1:0",
        "--journal",
        journal.to_str().unwrap(),
    ]);
    let out = dir.join("replay");
    finish(replay(&server.url, &out, &[]));
    assert_same_season(direct_mpc(), &out);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["controller"], "mpc-ipm");
    assert_eq!(summary["served_spec"]["controller"]["horizon"], "1h");
    let steps = summary["metrics"]["steps"].as_f64().unwrap();
    assert_eq!(server.metric("ghm_decisions_total"), steps);

    // The same replay again: every step is journaled, so every answer comes from the
    // journal, and the season is the same.
    let again = dir.join("again");
    finish(replay(&server.url, &again, &[]));
    assert_same_season(direct_mpc(), &again);
    assert_eq!(server.metric("ghm_journal_answers_total"), steps);
    assert_eq!(server.metric("ghm_decisions_total"), steps);
    server.kill();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// RL-guided MPC, and a policy on an uncertain plant whose output map is uncertain too (the
/// replay sends the outputs as the season observes them; the service's own would be the
/// nominal model's, and the policy reads outputs).
#[test]
fn rl_guided_mpc_and_a_policy_served_give_their_commands_seasons() {
    let dir = temp_dir("serve-rlmpc-policy");
    std::fs::create_dir_all(&dir).unwrap();
    let cases: [(&str, &str, &[&str], &[&str]); 2] = [
        ("rlmpc", MODEL, &["--guide", "expert"], &[]),
        (
            "policy",
            THESIS,
            &[],
            &["--uncertainty", "0.1", "--seed", "3"],
        ),
    ];
    for (command, model, options, season) in cases {
        let direct = dir.join(format!("{command}-direct"));
        let out = direct.to_str().unwrap();
        let mut args = vec![command, model, "--days", "1", "--out", out];
        args.extend(options);
        args.extend(season);
        let (ok, _, err) = ghm_with_stdout(&args);
        assert!(ok, "{err}");
        let journal = dir.join(format!("{command}.sqlite"));
        let mut serve = vec!["--controller", command, "--listen", "127.0.0.1:0"];
        serve.extend(["--journal", journal.to_str().unwrap()]);
        serve.extend(options);
        let server = Server::start_model(model, &serve);
        let replayed = dir.join(format!("{command}-replay"));
        finish(replay_days(model, &server.url, &replayed, "1", season));
        assert_same_season(&direct, &replayed);
        server.kill();
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The GreenLight tomato's economic MPC (issue 35, step 4) served: a replay of its first
/// steps is `ghm mpc`'s season to the last bit, cold start from the rules' roll-out
/// included. Skipped without GreenLight's model files (`.ci/run` provides them).
#[test]
fn the_greenlight_tomato_mpc_served_gives_ghm_mpcs_season() {
    let Some(weather) =
        common::greenlight::weather_or_skip("the served GreenLight MPC", "serve-greenlight-import")
    else {
        return;
    };
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/greenlight/tomato_economic.ghm"
    );
    let dir = temp_dir("serve-greenlight");
    std::fs::create_dir_all(&dir).unwrap();
    let controller = [
        "--horizon",
        "1h",
        "--warm-start",
        "primal-dual",
        "--bands",
        "planning",
    ];
    let season = ["--weather", weather.to_str().unwrap(), "--steps", "6"];
    let direct = dir.join("direct");
    let mut args = vec!["mpc", model, "--out", direct.to_str().unwrap()];
    args.extend(controller);
    args.extend(season);
    let (ok, _, err) = ghm_with_stdout(&args);
    assert!(ok, "{err}");
    let journal = dir.join("journal.sqlite");
    let mut serve = vec!["--controller", "mpc", "--listen", "127.0.0.1:0"];
    serve.extend(["--journal", journal.to_str().unwrap()]);
    serve.extend(controller);
    serve.extend(["--weather", weather.to_str().unwrap()]);
    let server = Server::start_model(model, &serve);
    let replayed = dir.join("replay");
    let child = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(["replay", model, "--server", &server.url, "--out"])
        .arg(&replayed)
        .args(season)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run ghm replay");
    finish(child);
    assert_same_season(&direct, &replayed);
    server.kill();
    let _ = std::fs::remove_dir_all(weather.parent().unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A free port on loopback (bound and released, for a service restarted on it).
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

#[test]
fn a_service_killed_mid_season_and_restarted_on_its_journal_finishes_the_same_season() {
    let dir = temp_dir("serve-restart");
    std::fs::create_dir_all(&dir).unwrap();
    let journal = dir.join("journal.sqlite");
    let listen = format!("127.0.0.1:{}", free_port());
    let args = [
        "--controller",
        "mpc",
        "--horizon",
        "1h",
        "--listen",
        listen.as_str(),
        "--journal",
        journal.to_str().unwrap(),
    ];
    let server = Server::start(&args);
    let out = dir.join("replay");
    let client = replay(&server.url, &out, &["--retry-for", "60"]);
    // Let it decide part of the season, then kill it without warning.
    while server.metric("ghm_decisions_total") < 20.0 {
        std::thread::sleep(Duration::from_millis(2));
    }
    let first = server.kill();
    assert!(!first.contains("restored"), "{first}");
    let server = Server::start(&args);
    let restored = server.metric("ghm_restored_decisions");
    let err = finish(client);
    assert!(
        err.contains("retrying"),
        "the replay never saw the service down: {err}"
    );
    assert!(restored >= 20.0, "restored {restored}");
    let steps = 48.0 * DAYS.parse::<f64>().unwrap();
    assert!(
        restored < steps,
        "the season was over before the kill: {restored}"
    );
    // Nothing decided was lost or decided twice: the steps decided before the kill and
    // after it add up to the season (a retry of the step in flight may come from the
    // journal).
    let after = server.metric("ghm_decisions_total");
    assert_eq!(restored + after, steps);
    assert_same_season(direct_mpc(), &out);
    server.kill();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A request of the right shape for the lettuce model with `rows` forecast rows.
fn request(step: u64, rows: usize) -> serde_json::Value {
    serde_json::json!({
        "session": "house-1",
        "step": step,
        "state": [0.0035, 0.001, 15.0, 0.008],
        "previous_input": [0.0, 0.0, 50.0],
        "forecast": vec![[0.0, 0.0007, 5.0, 0.005]; rows],
    })
}

fn message(v: &serde_json::Value) -> &str {
    v["error"]
        .as_str()
        .unwrap_or_else(|| panic!("no error message: {v}"))
}

#[test]
fn every_bad_request_gets_a_clear_4xx_and_the_service_keeps_serving() {
    let (server, dir) = start_with_token("serve-bad", "3h", &["--max-body", "8192"]);
    let journal = dir.join("journal.sqlite");
    let url = server.url.clone();
    let (status, model) = get(&format!("{url}/model"));
    assert_eq!(status, 200);
    let model: serde_json::Value = serde_json::from_str(&model).unwrap();
    assert_eq!(model["forecast_rows"], 6);
    assert_eq!(model["states"][2]["unit"], "°C");
    let good = |step| serde_json::to_vec(&request(step, 6)).unwrap();
    let step = std::cell::Cell::new(0);
    // After each refusal, a good request is decided.
    let still_serving = |label: &str| {
        let (status, answer) = post(&url, Some(TOKEN), &good(step.get()));
        assert_eq!(status, 200, "after {label}: {answer}");
        assert_eq!(answer["input"].as_array().unwrap().len(), 3);
        assert_eq!(answer["from_journal"], false);
        step.set(step.get() + 1);
        answer
    };
    let first = still_serving("nothing");
    assert_eq!(first["status"], "optimal");
    assert_eq!(first["plan"]["inputs"].as_array().unwrap().len(), 6);
    assert_eq!(first["plan"]["states"][5].as_array().unwrap().len(), 4);

    let refused = |token: Option<&str>, body: &[u8], status: u16, says: &str| {
        let (s, v) = post(&url, token, body);
        assert_eq!(s, status, "{v}");
        assert!(message(&v).contains(says), "{v}");
        assert!(!message(&v).contains(TOKEN));
    };
    refused(None, &good(50), 401, "API token");
    still_serving("no token");
    refused(
        Some("test-token-0123456789abcdeX"),
        &good(50),
        401,
        "API token",
    );
    still_serving("a wrong token");
    refused(
        Some(TOKEN),
        b"{\"step\": 3, \"state\": [1,",
        400,
        "not a decision request",
    );
    still_serving("a malformed body");
    let nan = String::from_utf8(good(50)).unwrap().replace("15.0", "NaN");
    refused(Some(TOKEN), nan.as_bytes(), 400, "JSON has no NaN");
    still_serving("a NaN literal");
    let mut missing = request(50, 6);
    missing["state"][2] = serde_json::Value::Null;
    let missing = serde_json::to_vec(&missing).unwrap();
    refused(
        Some(TOKEN),
        &missing,
        422,
        "state[2] (temp_air [°C]) is null",
    );
    still_serving("a null measurement");
    let big = serde_json::to_vec(&request(50, 400)).unwrap();
    assert!(big.len() > 8192);
    refused(Some(TOKEN), &big, 413, "larger than 8192 bytes");
    still_serving("an oversized body");
    let short = serde_json::to_vec(&request(50, 2)).unwrap();
    refused(
        Some(TOKEN),
        &short,
        422,
        "forecast has 2 rows; the controller needs 6",
    );
    still_serving("a short forecast");
    let mut wide = request(50, 6);
    wide["previous_input"] = serde_json::json!([0.0, 0.0, 50.0, 1.0]);
    let wide = serde_json::to_vec(&wide).unwrap();
    refused(
        Some(TOKEN),
        &wide,
        422,
        "previous_input has 4 values; the model has 3",
    );
    still_serving("a wrong length");
    let mut kelvin = request(50, 6);
    kelvin["units"] = serde_json::json!({"state": ["kg m^-2", "kg m^-3", "K", "kg m^-3"]});
    let kelvin = serde_json::to_vec(&kelvin).unwrap();
    refused(Some(TOKEN), &kelvin, 422, "units.state[2] is \"K\"");
    still_serving("a wrong unit");

    // A retry of a decided step gets the journaled answer; another request for it, or a
    // step behind the last, is a conflict.
    let last = step.get() - 1;
    let (s, again) = post(&url, Some(TOKEN), &good(last));
    assert_eq!(s, 200, "{again}");
    assert_eq!(again["from_journal"], true);
    let mut other = request(last, 6);
    other["state"][2] = serde_json::json!(16.0);
    let other = serde_json::to_vec(&other).unwrap();
    refused(
        Some(TOKEN),
        &other,
        409,
        "decided already, for another request",
    );
    still_serving("a conflicting retry");

    let (status, health) = get(&format!("{url}/health"));
    assert_eq!((status, health.as_str()), (200, r#"{"status":"ok"}"#));
    assert_eq!(
        server.metric("ghm_requests_failed_total{status=\"401\"}"),
        2.0
    );
    assert_eq!(
        server.metric("ghm_requests_failed_total{status=\"422\"}"),
        4.0
    );
    assert_eq!(server.metric("ghm_decisions_total"), step.get() as f64);
    let err = server.kill();
    assert!(!err.contains(TOKEN), "the token is in the log: {err}");
    // The journal (its file and write-ahead log, the service killed) holds the decisions
    // and not the token.
    let mut bytes = std::fs::read(&journal).unwrap();
    bytes.extend(std::fs::read(format!("{}-wal", journal.display())).unwrap_or_default());
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.contains("house-1"), "the journal holds no decision");
    assert!(!text.contains(TOKEN), "the token is in the journal");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_journal_is_resumed_only_by_the_service_and_decisions_it_was_written_with() {
    let dir = temp_dir("serve-journal");
    std::fs::create_dir_all(&dir).unwrap();
    let journal = dir.join("journal.sqlite");
    let j = journal.to_str().unwrap();
    let expert = [
        "--controller",
        "expert",
        "--listen",
        "127.0.0.1:0",
        "--journal",
        j,
    ];
    let server = Server::start(&expert);
    for step in 0..3 {
        let (s, v) = post(
            &server.url,
            None,
            &serde_json::to_vec(&request(step, 1)).unwrap(),
        );
        assert_eq!(s, 200, "{v}");
    }
    server.kill();

    // Another controller on this journal is refused, before it listens.
    let err = refused_to_start(&[
        "--controller",
        "mpc",
        "--listen",
        "127.0.0.1:0",
        "--journal",
        j,
    ]);
    assert!(err.contains("begun by a service of another spec"), "{err}");

    // The same one resumes it.
    let server = Server::start(&expert);
    assert_eq!(server.metric("ghm_restored_decisions"), 3.0);
    server.kill();

    // A journaled input that deciding again does not give: refused, naming the step.
    let conn = rusqlite::Connection::open(&journal).unwrap();
    let changed = conn
        .execute(
            "UPDATE decisions SET response = json_set(response, '$.input[2]', 99.5) WHERE step = 1",
            [],
        )
        .unwrap();
    assert_eq!(changed, 1);
    drop(conn);
    let err = refused_to_start(&expert);
    assert!(
        err.contains("does not replay at step 1") && err.contains("99.5"),
        "{err}"
    );

    // Beyond loopback, no token: refused before anything listens.
    let err = refused_to_start(&[
        "--controller",
        "expert",
        "--listen",
        "0.0.0.0:0",
        "--journal",
        j,
    ]);
    assert!(err.contains("beyond loopback, needs an API token"), "{err}");

    std::fs::remove_dir_all(&dir).unwrap();
}

/// `ghm serve` of the lettuce model's MPC at `horizon` with TOKEN and `extra` options, on
/// loopback; the folder `name` holding its journal (`journal.sqlite`) and token file goes
/// with it.
fn start_with_token(name: &str, horizon: &str, extra: &[&str]) -> (Server, PathBuf) {
    let dir = temp_dir(name);
    std::fs::create_dir_all(&dir).unwrap();
    let journal = dir.join("journal.sqlite");
    let token_file = dir.join("token");
    std::fs::write(&token_file, format!("{TOKEN}\n")).unwrap();
    let mut args = vec![
        "--controller",
        "mpc",
        "--horizon",
        horizon,
        "--listen",
        "127.0.0.1:0",
        "--journal",
        journal.to_str().unwrap(),
        "--token-file",
        token_file.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    (Server::start(&args), dir)
}

/// Posts the decision of `step` (session house-1, 2 forecast rows), which must succeed.
fn decide_step(url: &str, step: u64) -> serde_json::Value {
    let body = serde_json::to_vec(&request(step, 2)).unwrap();
    let (status, answer) = post(url, Some(TOKEN), &body);
    assert_eq!(status, 200, "step {step}: {answer}");
    answer
}

fn history(url: &str, query: &str) -> serde_json::Value {
    let (status, text) = get_with_token(&format!("{url}/history?{query}"), Some(TOKEN));
    assert_eq!(status, 200, "{text}");
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{e}: {text}"))
}

#[test]
fn the_history_holds_the_last_decisions_and_the_plan_behind_the_token() {
    let (server, dir) = start_with_token("serve-history", "1h", &[]);
    let url = server.url.clone();
    let (status, page) = get(&format!("{url}/"));
    assert_eq!(status, 200);
    assert!(
        page.contains("<title>ghm serve") && page.contains("/history?"),
        "{page}"
    );
    let (status, text) = get(&format!("{url}/history"));
    assert_eq!(status, 401, "the history without the token: {text}");
    let empty = history(&url, "");
    assert_eq!(empty["steps"].as_array().unwrap().len(), 0);
    assert!(empty["plan"].is_null());

    let answers: Vec<_> = (0..3).map(|k| decide_step(&url, k)).collect();
    let h = history(&url, "session=house-1&days=2");
    assert_eq!(h["session"], "house-1");
    assert_eq!(h["sessions"], serde_json::json!(["house-1"]));
    let steps = h["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 3);
    for (k, (point, answer)) in steps.iter().zip(&answers).enumerate() {
        assert_eq!(point["step"], k as u64);
        assert_eq!(point["state"], request(k as u64, 2)["state"]);
        assert_eq!(point["input"], answer["input"]);
        // The lettuce model's outputs, evaluated by the service: crop, CO2, temperature,
        // humidity.
        assert_eq!(point["outputs"].as_array().unwrap().len(), 4, "{point}");
    }
    let plan = &h["plan"];
    assert_eq!(plan["step"], 2);
    assert_eq!(plan["inputs"], answers[2]["plan"]["inputs"]);
    assert_eq!(plan["states"], answers[2]["plan"]["states"]);
    assert_eq!(plan["outputs"].as_array().unwrap().len(), 2, "{plan}");
    assert_eq!(plan["outputs"][1].as_array().unwrap().len(), 4, "{plan}");
    // Without a session it is the only one; a short window keeps the last step.
    let last = history(&url, "days=0.01");
    assert_eq!(last["session"], "house-1");
    assert_eq!(last["steps"].as_array().unwrap().len(), 1);
    assert_eq!(last["steps"][0]["step"], 2);
    let other = history(&url, "session=elsewhere");
    assert!(other["steps"].as_array().unwrap().is_empty() && other["plan"].is_null());
    let (status, text) = get_with_token(&format!("{url}/history?days=-1"), Some(TOKEN));
    assert_eq!(status, 400, "{text}");
    assert!(text.contains("positive number of days"), "{text}");

    // GET /model carries the soft bands the page shades: temperature in [10, 20] °C, the
    // relative humidity only bounded above.
    let (_, model) = get(&format!("{url}/model"));
    let model: serde_json::Value = serde_json::from_str(&model).unwrap();
    let outputs = model["outputs"].as_array().unwrap();
    let temp = outputs.iter().find(|y| y["name"] == "temp").unwrap();
    assert_eq!(
        (temp["lower"].as_f64(), temp["upper"].as_f64()),
        (Some(10.0), Some(20.0))
    );
    let rh = outputs.iter().find(|y| y["name"] == "rh_pct").unwrap();
    assert!(rh.get("lower").is_none() && rh["upper"] == 80.0, "{rh}");
    server.kill();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The DOM of `url` after its scripts ran, from headless Chromium (Debian's package).
fn chromium_dom(url: &str, profile: &Path) -> String {
    let mut child = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--virtual-time-budget=5000",
            "--dump-dom",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(url)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run chromium ({e}): the live page's test needs a headless browser; \
                 install it with `apt-get install chromium`"
            )
        });
    let deadline = std::time::Instant::now() + Duration::from_secs(120);
    while child.try_wait().expect("wait for chromium").is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("chromium did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("chromium's output");
    let dom = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success() && dom.contains("</html>"),
        "chromium failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    dom
}

/// The `data-points` of every `<path class="{class}" …>` of a DOM.
fn path_points(dom: &str, class: &str) -> Vec<usize> {
    let tag = format!("<path class=\"{class}\" data-points=\"");
    dom.match_indices(&tag)
        .filter_map(|(at, _)| {
            let rest = &dom[at + tag.len()..];
            rest[..rest.find('"')?].parse().ok()
        })
        .collect()
}

#[test]
fn the_live_page_draws_every_quantity_and_shows_a_new_decision() {
    let test = "the_live_page_draws_every_quantity_and_shows_a_new_decision";
    if !common::tool(
        "chromium",
        "a headless browser; Debian: apt-get install chromium",
        test,
    ) {
        return;
    }
    let (server, dir) = start_with_token("serve-page", "1h", &[]);
    let url = server.url.clone();
    for k in 0..2 {
        decide_step(&url, k);
    }
    let page = format!("{url}/#token={TOKEN}");
    let clock = std::time::Instant::now();
    let dom = chromium_dom(&page, &dir.join("chromium-1"));
    eprintln!("chromium: {:.1} s", clock.elapsed().as_secs_f64());
    assert!(
        dom.contains("lettuce · mpc"),
        "the model was not read: {dom}"
    );
    assert!(
        dom.contains(">step 1<"),
        "the last step is not shown: {dom}"
    );
    // One panel per state (4), input (3) and output (4): the past solid, the plan dashed.
    let past = path_points(&dom, "past");
    let plan = path_points(&dom, "plan");
    assert_eq!(past.len(), 11, "{dom}");
    assert_eq!(plan.len(), 11, "{dom}");
    assert!(past.iter().all(|n| *n >= 2), "{past:?}");
    assert!(plan.iter().all(|n| *n >= 2), "{plan:?}");
    assert_eq!(
        dom.matches("class=\"band\"").count(),
        3,
        "the outputs' soft bands"
    );

    decide_step(&url, 2);
    let dom = chromium_dom(&page, &dir.join("chromium-2"));
    assert!(
        dom.contains(">step 2<"),
        "the new decision is not shown: {dom}"
    );
    let more = path_points(&dom, "past");
    assert!(
        more.iter().zip(&past).all(|(a, b)| a > b),
        "{past:?} → {more:?}"
    );

    // Without the token the page says what to do.
    let dom = chromium_dom(&format!("{url}/"), &dir.join("chromium-3"));
    assert!(dom.contains("401"), "{dom}");
    assert!(dom.contains("#token=YOUR_TOKEN"), "{dom}");
    server.kill();
    std::fs::remove_dir_all(&dir).unwrap();
}
