//! The library examples run, and say what they should: MPC beats the simpler controller
//! next to it. (Runs `cargo run --example …`, so the examples build as part of the tests.)

fn run_example(name: &str) -> String {
    let out = std::process::Command::new(env!("CARGO"))
        .args(["run", "--quiet", "--example", name])
        .output()
        .unwrap_or_else(|e| panic!("cargo run --example {name}: {e}"));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{name}: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The last number on the line that starts with `label` (after trimming).
fn last_number(text: &str, label: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(label))
        .unwrap_or_else(|| panic!("no line starting with {label:?} in\n{text}"));
    line.split_whitespace()
        .filter_map(|w| w.trim_end_matches('€').parse::<f64>().ok())
        .next_back()
        .unwrap_or_else(|| panic!("no number in {line:?}"))
}

#[test]
fn mpc_from_ghm_prints_its_season_figures() {
    let out = run_example("mpc_from_ghm");
    assert!(
        out.contains("EPI") && out.contains("cumulative reward"),
        "{out}"
    );
    assert!(out.contains("0 failed solves"), "{out}");
}

#[test]
fn custom_plant_mpc_beats_the_constant_heater() {
    let out = run_example("custom_plant");
    let constant = last_number(&out, "heater at 700 W");
    let mpc = last_number(&out, "economic MPC");
    assert!(mpc > constant, "MPC {mpc} vs constant {constant}\n{out}");
}

#[test]
fn custom_controller_runs_and_mpc_beats_the_rules() {
    let out = run_example("custom_controller");
    let rules = last_number(&out, "rule-based");
    let mpc = last_number(&out, "MPC, 3 h");
    assert!(mpc > rules, "MPC {mpc} vs rules {rules}\n{out}");
}

#[test]
fn rl_guided_mpc_runs_with_the_shipped_agent() {
    let out = run_example("rl_guided_mpc");
    for label in ["agent alone", "MPC", "RL-guided MPC"] {
        assert!(last_number(&out, label).is_finite(), "{out}");
    }
}
