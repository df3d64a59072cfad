//! `ghm compile`: the header is cbindgen's output of the C ABI; a controller compiled into
//! a static library, linked into the C example with the system C compiler, runs a day of
//! the lettuce season (and the first steps of the GreenLight tomato's economic MPC) with
//! the same inputs, to the last bit, as the command it stands for; bad arguments get clear
//! messages.
//!
//! Needs `cbindgen` (Debian: cbindgen) and a C compiler (`cc`); `.ci/run` installs them.
//! The GreenLight case needs GreenLight's files (`tests/common/greenlight.rs`) and says
//! that it skipped without them.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const GHM: &str = env!("CARGO_BIN_EXE_ghm");

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ghm-compile-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn ghm(args: &[&str]) -> Output {
    Command::new(GHM)
        .args(args)
        .current_dir(root())
        .output()
        .expect("run ghm")
}

fn succeed(what: &str, output: Output) -> String {
    assert!(
        output.status.success(),
        "{what} failed:\n{}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

#[test]
fn the_header_is_cbindgens_output_of_the_c_abi() {
    let test = "the_header_is_cbindgens_output_of_the_c_abi";
    if !common::tool("cbindgen", "Debian: apt-get install cbindgen", test) {
        return;
    }
    let output = Command::new("cbindgen")
        .args(["--config", "src/embed/cbindgen.toml", "src/embed/ffi.rs"])
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run cbindgen ({e}): this test needs it; install it with `apt-get install cbindgen`")
        });
    let generated = succeed("cbindgen", output);
    let committed = std::fs::read_to_string(root().join("src/embed/ghm_controller.h")).unwrap();
    assert!(
        generated == committed,
        "src/embed/ghm_controller.h is not cbindgen's output of src/embed/ffi.rs; regenerate it:\n  \
         cbindgen --config src/embed/cbindgen.toml --output src/embed/ghm_controller.h src/embed/ffi.rs"
    );
}

/// The weather of `ghm mpc models/lettuce.ghm --days 1` on the built-in season, with the
/// forecast rows beyond it, as a CSV with the model's weather columns.
fn builtin_weather_csv(path: &Path, steps: usize, extra: usize) {
    let model = ghm::lang::load(&root().join("models/lettuce.ghm")).unwrap();
    let spec = ghm::job::WeatherSpec {
        days: Some(1.0),
        ..Default::default()
    };
    let weather = spec.load(&model, steps, extra).unwrap();
    let mut text = model.weather_columns().join(",");
    text.push('\n');
    for k in 0..weather.len() {
        let row: Vec<String> = weather.at(k).iter().map(|v| format!("{v:e}")).collect();
        text.push_str(&row.join(","));
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// The input columns of a CSV (named `u_*`, `inputs` of them), as bit patterns, row by
/// row.
fn input_bits(csv: &str, inputs: usize) -> Vec<Vec<u64>> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let columns: Vec<usize> = (0..header.len())
        .filter(|&i| header[i].starts_with("u_"))
        .collect();
    assert_eq!(columns.len(), inputs, "{header:?}");
    lines
        .map(|line| {
            let fields: Vec<&str> = line.split(',').collect();
            columns
                .iter()
                .map(|&i| fields[i].parse::<f64>().unwrap().to_bits())
                .collect()
        })
        .collect()
}

/// A compiled controller against the command it stands for.
struct Case<'a> {
    name: &'a str,
    model: &'a str,
    /// `mpc`, `rlmpc`, …
    command: &'a str,
    /// `--controller KIND` and the controller's options, as `ghm compile` takes them (the
    /// command takes them without the first two).
    controller_args: &'a [&'a str],
    /// The command's weather and length (`--days 1`, or `--weather W --steps N`).
    season_args: Vec<String>,
    /// The weather file the C program reads (the season's rows and the horizon's beyond).
    weather: PathBuf,
    steps: usize,
    inputs: usize,
}

/// Compiles the controller of `case`, links the C example against it, runs the season,
/// and checks its inputs equal those of `ghm <command>`.
fn c_run_equals_command(case: Case) {
    if !common::tool("cc", "a C compiler; Debian: apt-get install gcc", case.name) {
        return;
    }
    let dir = scratch(case.name);
    let out = dir.join("controller");
    let out_s = out.to_str().unwrap();
    let mut args = vec!["compile", case.model];
    args.extend_from_slice(case.controller_args);
    args.extend_from_slice(&["--out", out_s]);
    let said = succeed("ghm compile", ghm(&args));
    assert!(said.contains("libghm_controller.a"), "{said}");
    for file in [
        "include/ghm_controller.h",
        "lib/libghm_controller.a",
        "lib/libghm.a",
        "src/ghm_bundle.c",
        "bundle.json",
        "README.md",
    ] {
        assert!(out.join(file).is_file(), "{file} missing");
    }

    let program = dir.join("lettuce_day");
    let mut cc = Command::new("cc");
    cc.arg("-I")
        .arg(out.join("include"))
        .arg(root().join("examples/c/lettuce_day.c"))
        .arg("-L")
        .arg(out.join("lib"))
        .args(ghm::embed::package::link_flags().split_whitespace())
        .arg("-o")
        .arg(&program);
    let compiled = cc.output().unwrap_or_else(|e| {
        panic!("cannot run cc ({e}): this test needs a C compiler (Debian: gcc)")
    });
    succeed("cc", compiled);

    let run = Command::new(&program)
        .arg(&case.weather)
        .arg(case.steps.to_string())
        .output()
        .unwrap();
    let from_c = succeed("the C example", run);

    let season = dir.join("season");
    let mut args = vec![case.command, case.model];
    args.extend(case.season_args.iter().map(String::as_str));
    // Without `--controller KIND`.
    args.extend(case.controller_args.iter().skip(2).copied());
    args.extend_from_slice(&["--out", season.to_str().unwrap()]);
    succeed(case.command, ghm(&args));
    let trajectory = std::fs::read_to_string(season.join("trajectory.csv")).unwrap();

    let c_inputs = input_bits(&from_c, case.inputs);
    assert_eq!(c_inputs.len(), case.steps);
    assert_eq!(
        c_inputs,
        input_bits(&trajectory, case.inputs),
        "the C program's inputs differ"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A day of the lettuce season on the built-in weather.
fn lettuce_day(name: &str, command: &str, controller_args: &[&str]) {
    let steps = 48;
    let weather = scratch(&format!("{name}-weather")).join("weather.csv");
    // As many rows as the season loads: its steps and a 1 h horizon (2 steps) beyond.
    builtin_weather_csv(&weather, steps, 2);
    c_run_equals_command(Case {
        name,
        model: "models/lettuce.ghm",
        command,
        controller_args,
        season_args: vec!["--days".into(), "1".into()],
        weather: weather.clone(),
        steps,
        inputs: 3,
    });
    let _ = std::fs::remove_dir_all(weather.parent().unwrap());
}

#[test]
fn a_compiled_mpc_runs_a_day_in_c_with_ghm_mpcs_inputs() {
    lettuce_day("mpc", "mpc", &["--controller", "mpc", "--horizon", "1h"]);
}

#[test]
fn a_compiled_rlmpc_runs_a_day_in_c_with_ghm_rlmpcs_inputs() {
    lettuce_day(
        "rlmpc",
        "rlmpc",
        &["--controller", "rlmpc", "--horizon", "1h"],
    );
}

/// Issue 35's fourth point: the GreenLight tomato's economic MPC (the imported Katzin 2021
/// model, its implicit step and exact derivatives), compiled unchanged, decides its first
/// six steps in C as `ghm mpc` does.
#[test]
fn a_compiled_greenlight_mpc_decides_in_c_as_ghm_mpc_does() {
    let Some(weather) =
        common::greenlight::weather_or_skip("the compiled GreenLight MPC", "compile-greenlight")
    else {
        return;
    };
    c_run_equals_command(Case {
        name: "greenlight-mpc",
        model: "models/greenlight/tomato_economic.ghm",
        command: "mpc",
        controller_args: &[
            "--controller",
            "mpc",
            "--horizon",
            "1h",
            "--warm-start",
            "primal-dual",
            "--bands",
            "planning",
        ],
        season_args: vec![
            "--weather".into(),
            weather.to_str().unwrap().into(),
            "--steps".into(),
            "6".into(),
        ],
        weather: weather.clone(),
        steps: 6,
        inputs: 5,
    });
    let _ = std::fs::remove_dir_all(weather.parent().unwrap());
}

#[test]
fn compile_refuses_what_it_cannot_build_with_a_message() {
    let dir = scratch("refuse");
    let out = dir.join("out");
    let out_s = out.to_str().unwrap();
    let fails = |args: &[&str], expected: &str| {
        let output = ghm(args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    };
    fails(
        &[
            "compile",
            "models/lettuce.ghm",
            "--controller",
            "expert",
            "--runtime",
            "/no/such/libghm.a",
            "--out",
            out_s,
        ],
        "runtime library is not at /no/such/libghm.a",
    );
    fails(
        &[
            "compile",
            "models/lettuce.ghm",
            "--controller",
            "policy",
            "--horizon",
            "1h",
            "--out",
            out_s,
        ],
        "--horizon is for --controller mpc and rlmpc",
    );
    fails(
        &[
            "compile",
            "models/no-such.ghm",
            "--controller",
            "mpc",
            "--out",
            out_s,
        ],
        "cannot read model file",
    );
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    fails(
        &[
            "compile",
            "models/lettuce.ghm",
            "--controller",
            "expert",
            "--out",
            out_s,
        ],
        "holds files that are not a compiled controller's (notes.txt)",
    );
    fails(
        &[
            "compile",
            "models/lettuce.ghm",
            "--controller",
            "expert",
            "--cc",
            "/no/such/cc",
            "--overwrite",
            "--out",
            out_s,
        ],
        "ghm compile needs a C compiler",
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
