//! A fuzz harness on stable Rust (issue 16): grammar-aware mutations of the shipped models,
//! arbitrary bytes as a model file, mutated weather CSV, and mutated policy and value JSON.
//! Every case must end in a value or an error with a message, never a panic; a model that
//! loads is also built into a plant and its step's derivatives verified at its initial
//! point (the path of `ghm check --verify-derivatives`).
//!
//! By default it runs a bounded, seeded batch (part of the test suite) and replays the
//! committed corpus `tests/fuzz/` (the hostile cases of issue 16, one file each). For a long
//! run, say how long and from which seed:
//!
//! ```sh
//! GHM_FUZZ_SECONDS=3600 GHM_FUZZ_SEED=7 cargo test --release --test fuzz -- --nocapture
//! ```
//!
//! A case that panics is written to `target/fuzz-failures/` before the test fails, to be
//! added to the corpus once fixed.

use ghm::control::ValueFile;
use ghm::lang::{load, load_str, Model};
use ghm::model::{verify::verify_step_derivatives, Plant};
use ghm::rl::PolicyFile;
use ghm::sim::weather::load_csv;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Cases of each kind in the default batch.
const DEFAULT_CASES: usize = 300;

/// Numbers that break arithmetic: extremes, signed zero, values past `f64`.
const HOSTILE_NUMBERS: &[&str] = &[
    "0",
    "-0",
    "1e308",
    "-1e308",
    "1e-308",
    "1e400",
    "4.9e-324",
    "18446744073709551615",
    "NaN",
    "inf",
    "-1",
    "0.0000000001",
    "1e9",
];

/// Tokens that break structure: operators, brackets, keywords, odd characters.
const HOSTILE_TOKENS: &[&str] = &[
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    ",",
    ";",
    "=",
    "+",
    "-",
    "*",
    "/",
    "^",
    "if(",
    "sqrt(",
    "log(",
    "exp(",
    "let",
    "state",
    "input",
    "output",
    "soft",
    "in",
    "plan",
    "\u{feff}",
    "\u{200b}",
    "\r",
    "\t",
    "Δw",
    "température",
    "#",
    "\"",
    "..",
    "[h]",
    "[s]",
    "fn",
    "and",
    "or",
    "not",
    "==",
    "!=",
    "mod(",
    "floor(",
    "clock",
    "rule",
    "\u{0}",
];

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(relative: &str) -> String {
    std::fs::read_to_string(repo().join(relative))
        .unwrap_or_else(|e| panic!("cannot read {relative}: {e}"))
}

/// A scratch folder of this test process.
fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("ghm-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("create a scratch folder");
    d
}

/// The text cut into tokens: runs of word characters, runs of blanks, and single other
/// characters, so that joining them gives the text back.
fn tokens(text: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let class = |c: char| {
        if c.is_alphanumeric() || c == '_' || c == '.' {
            0
        } else if c.is_whitespace() {
            1
        } else {
            2
        }
    };
    for c in text.chars() {
        match out.last_mut() {
            Some(last) if class(c) != 2 && last.chars().next().map(class) == Some(class(c)) => {
                last.push(c)
            }
            _ => out.push(c.to_string()),
        }
    }
    out
}

/// One to four grammar-aware mutations of a model's text.
fn mutate_model(text: &str, donor: &str, rng: &mut StdRng) -> String {
    let mut t = tokens(text);
    for _ in 0..rng.random_range(1..=4) {
        if t.is_empty() {
            t.push("state".into());
        }
        let i = rng.random_range(0..t.len());
        match rng.random_range(0..9) {
            0 => {
                t.remove(i);
            }
            1 => {
                let copy = t[i].clone();
                t.insert(i, copy);
            }
            2 => {
                let j = rng.random_range(0..t.len());
                t.swap(i, j);
            }
            3 => {
                if let Some(k) =
                    (i..t.len()).find(|&k| t[k].starts_with(|c: char| c.is_ascii_digit()))
                {
                    t[k] = HOSTILE_NUMBERS[rng.random_range(0..HOSTILE_NUMBERS.len())].into();
                }
            }
            4 => t.insert(
                i,
                HOSTILE_TOKENS[rng.random_range(0..HOSTILE_TOKENS.len())].into(),
            ),
            5 => {
                // A deep nest of brackets around one token.
                let depth = rng.random_range(1..2_000);
                t[i] = format!("{}{}{}", "(".repeat(depth), t[i], ")".repeat(depth));
            }
            6 => t.truncate(i),
            7 => {
                // A line of another model spliced in.
                let lines: Vec<&str> = donor.lines().collect();
                let line = lines[rng.random_range(0..lines.len())];
                t.insert(i, format!("\n{line}\n"));
            }
            _ => {
                // An identifier used where another one was.
                let names: Vec<usize> = (0..t.len())
                    .filter(|&k| t[k].starts_with(|c: char| c.is_alphabetic()))
                    .collect();
                if !names.is_empty() {
                    let from = names[rng.random_range(0..names.len())];
                    t[i] = t[from].clone();
                }
            }
        }
    }
    t.concat()
}

/// Up to eight random byte changes of `bytes` (flips, insertions, deletions).
fn mutate_bytes(bytes: &[u8], rng: &mut StdRng) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for _ in 0..rng.random_range(1..=8) {
        if b.is_empty() {
            b.push(rng.random());
            continue;
        }
        let i = rng.random_range(0..b.len());
        match rng.random_range(0..3) {
            0 => b[i] ^= 1 << rng.random_range(0..8),
            1 => b.insert(i, rng.random()),
            _ => {
                b.remove(i);
            }
        }
    }
    b
}

/// A JSON document with one to four leaves or containers changed: numbers made hostile,
/// keys removed, arrays cut or grown, values of the wrong type.
fn mutate_json(value: &serde_json::Value, rng: &mut StdRng) -> serde_json::Value {
    let mut v = value.clone();
    for _ in 0..rng.random_range(1..=4) {
        mutate_one(&mut v, rng);
    }
    v
}

fn mutate_one(v: &mut serde_json::Value, rng: &mut StdRng) {
    use serde_json::Value;
    // Walk down a random path, sometimes stopping early.
    match v {
        Value::Object(map) if !map.is_empty() && rng.random_bool(0.8) => {
            let keys: Vec<String> = map.keys().cloned().collect();
            let key = &keys[rng.random_range(0..keys.len())];
            if rng.random_bool(0.1) {
                map.remove(key);
            } else if let Some(child) = map.get_mut(key) {
                mutate_one(child, rng);
            }
        }
        Value::Array(items) if !items.is_empty() && rng.random_bool(0.8) => {
            match rng.random_range(0..10) {
                0 => items.truncate(rng.random_range(0..items.len())),
                1 => {
                    let copy = items[0].clone();
                    items.push(copy);
                }
                _ => {
                    let i = rng.random_range(0..items.len());
                    mutate_one(&mut items[i], rng);
                }
            }
        }
        _ => {
            *v = match rng.random_range(0..6) {
                0 => Value::from(1e308),
                1 => Value::from(-0.0),
                2 => Value::from(u64::MAX),
                3 => Value::from("NaN"),
                4 => Value::Array(Vec::new()),
                _ => Value::Null,
            }
        }
    }
}

/// What a loaded model must survive: a plant built from it, its step's derivatives
/// verified at its initial state with the inputs at their start values.
fn exercise_model(model: Model) {
    let mut point = model.initial_state();
    point.extend(model.inputs.iter().map(|u| u.start));
    point.extend(std::iter::repeat_n(1.0, model.disturbances.len()));
    point.extend(model.nominal_params());
    let plant = Plant::new(model);
    let _ = verify_step_derivatives(&plant, &[point]);
}

/// Runs `case` and fails the test with the case's input saved when it panics.
fn survive(kind: &str, input: &[u8], case: impl FnOnce()) {
    if catch_unwind(AssertUnwindSafe(case)).is_err() {
        let dir = repo().join("target/fuzz-failures");
        let _ = std::fs::create_dir_all(&dir);
        let file = dir.join(format!("{kind}-{}", std::process::id()));
        let _ = std::fs::write(&file, input);
        panic!("{kind}: a panic; the input is in {}", file.display());
    }
}

/// Returns whether the model loaded (the rest were errors with a message).
fn model_text_case(text: &str) -> bool {
    let mut loaded = false;
    survive("model", text.as_bytes(), || {
        match load_str("fuzz.ghm", text) {
            Ok(model) => {
                loaded = true;
                exercise_model(model)
            }
            Err(failure) => assert!(!failure.render().trim().is_empty(), "an empty error"),
        }
    });
    loaded
}

fn model_bytes_case(bytes: &[u8], dir: &Path) -> bool {
    let path = dir.join("bytes.ghm");
    std::fs::write(&path, bytes).expect("write the case");
    let mut loaded = false;
    survive("model-bytes", bytes, || match load(&path) {
        Ok(model) => {
            loaded = true;
            exercise_model(model)
        }
        Err(failure) => assert!(!failure.render().trim().is_empty(), "an empty error"),
    });
    loaded
}

fn weather_case(bytes: &[u8], dir: &Path) {
    let path = dir.join("weather.csv");
    std::fs::write(&path, bytes).expect("write the case");
    let columns: Vec<String> = ["rad_Wm2", "temp_out_C"].map(String::from).into();
    survive("weather", bytes, || {
        if let Err(e) = load_csv(&path, &columns, 1800.0) {
            assert!(!e.to_string().is_empty(), "an empty error");
        }
    });
}

fn agent_file_case(kind: &str, bytes: &[u8], dir: &Path) {
    let path = dir.join(format!("{kind}.json"));
    std::fs::write(&path, bytes).expect("write the case");
    survive(kind, bytes, || {
        let message = match kind {
            // A policy that loads is also asked for an action, of a width it may not take.
            "policy" => match PolicyFile::load(&path) {
                Ok(policy) => {
                    for width in [policy.observation_names.len(), 12, 0] {
                        let _ = policy.action(&vec![0.5; width]);
                    }
                    None
                }
                Err(e) => Some(e.to_string()),
            },
            _ => ValueFile::load(&path).err().map(|e| e.to_string()),
        };
        if let Some(m) = message {
            assert!(m.contains(&path.display().to_string()), "{m}");
        }
    });
}

/// The seeded batch, or a long run when `GHM_FUZZ_SECONDS` says so.
#[test]
fn mutated_inputs_end_in_a_value_or_an_error_never_a_panic() {
    let seed: u64 = std::env::var("GHM_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let deadline = std::env::var("GHM_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .map(|s| Instant::now() + Duration::from_secs(s));
    let mut rng = StdRng::seed_from_u64(seed);
    let dir = scratch();
    let models: Vec<String> = [
        "lettuce.ghm",
        "lettuce-thesis.ghm",
        "cstr.ghm",
        "bioreactor.ghm",
        "lamp-clock.ghm",
    ]
    .iter()
    .map(|m| read(&format!("models/{m}")))
    .collect();
    let weather = read("tests/fuzz/weather-seed.csv");
    let policy: serde_json::Value =
        serde_json::from_str(&read("models/agents/lettuce/policy.json")).expect("policy");
    let value: serde_json::Value =
        serde_json::from_str(&read("models/agents/lettuce/value-sac.json")).expect("value");
    let (mut cases, mut loaded) = (0, 0);
    loop {
        let text = &models[rng.random_range(0..models.len())];
        let donor = &models[rng.random_range(0..models.len())];
        loaded += usize::from(model_text_case(&mutate_model(text, donor, &mut rng)));
        loaded += usize::from(model_bytes_case(
            &mutate_bytes(text.as_bytes(), &mut rng),
            &dir,
        ));
        weather_case(&mutate_bytes(weather.as_bytes(), &mut rng), &dir);
        let p = serde_json::to_vec(&mutate_json(&policy, &mut rng)).expect("json");
        agent_file_case("policy", &p, &dir);
        let v = serde_json::to_vec(&mutate_json(&value, &mut rng)).expect("json");
        agent_file_case("value", &v, &dir);
        cases += 1;
        let done = match deadline {
            Some(t) => Instant::now() >= t,
            None => cases >= DEFAULT_CASES,
        };
        if done {
            break;
        }
    }
    eprintln!(
        "fuzz: {cases} rounds of 5 cases from seed {seed}, no panic; {loaded} of {} mutated \
         models loaded and had their derivatives verified",
        2 * cases
    );
    // Both outcomes must be exercised: mutations that always fail to parse test nothing
    // beyond the parser.
    assert!(
        loaded > 0 && loaded < 2 * cases,
        "{loaded} of {} loaded",
        2 * cases
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The committed corpus: every file under `tests/fuzz/corpus/` goes through the target
/// its extension names (`.ghm` model, `.csv` weather, `.policy.json`, `.value.json`).
#[test]
fn the_corpus_of_hostile_cases_ends_in_a_value_or_an_error() {
    let dir = scratch().join("corpus");
    std::fs::create_dir_all(&dir).expect("scratch");
    let corpus = repo().join("tests/fuzz/corpus");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&corpus)
        .expect("tests/fuzz/corpus")
        .map(|e| e.expect("entry").path())
        .collect();
    files.sort();
    assert!(files.len() >= 10, "the corpus holds {} files", files.len());
    for file in &files {
        let bytes = std::fs::read(file).expect("read a corpus file");
        let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if name.ends_with(".ghm") {
            model_bytes_case(&bytes, &dir);
        } else if name.ends_with(".csv") {
            weather_case(&bytes, &dir);
        } else if name.ends_with(".policy.json") {
            agent_file_case("policy", &bytes, &dir);
        } else if name.ends_with(".value.json") {
            agent_file_case("value", &bytes, &dir);
        } else {
            panic!("{name}: no target for this extension");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
