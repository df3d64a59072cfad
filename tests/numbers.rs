//! Every number checked where it is made (issue 16, item 1): a NaN or an infinity in a
//! season stops it with the step, the quantity's name and its model line; soft bands never
//! count NaN as inside; the derivative check fails on any non-finite value or derivative;
//! `if`, `min` and `max` differentiate only the branch they take; a season in which every
//! solve failed is not a success; weather outside its physical range is refused; and
//! arguments too large to allocate are errors, not aborts.

mod common;

use common::bin::{ghm, temp_dir};
use ghm::control::ConstantInput;
use ghm::graph::{Derivatives, Graph, Op};
use ghm::lang::load_str;
use ghm::model::verify::verify_step_derivatives;
use ghm::model::{band_penalty, Plant};
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::Weather;
use std::path::{Path, PathBuf};

fn plant(text: &str) -> Plant {
    Plant::new(load_str("m.ghm", text).unwrap_or_else(|e| panic!("{}", e.render())))
}

/// `text` written to `name` in a fresh folder for test `test`.
fn model_file(test: &str, name: &str, text: &str) -> (PathBuf, PathBuf) {
    let dir = temp_dir(test);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let path = dir.join(name);
    std::fs::write(&path, text).expect("write the file");
    (dir, path)
}

/// The season's error message, or a panic if it ran through.
fn season_error(plant: &Plant, input: Vec<f64>, steps: usize) -> String {
    let weather = Weather::constant(vec![], &[], steps, plant.model.sample_period);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let result = run_season(
        plant,
        &weather,
        &mut ConstantInput(input),
        &config,
        &mut |_: &StepLog| {},
    );
    match result {
        Ok(r) => panic!("the season ran through: {:?}", r.metrics),
        Err(e) => e.to_string(),
    }
}

// ---- non-finite numbers stop a season, named --------------------------------------------

const NAN_OUTPUT: &str = "\
model nanout
state x = 10
input u in [0, 1] start 0
der x = u * 0
output y = sqrt(x - 100)
cost c = u
soft y in [0, 1] weight 1
sample 1 [h]
";

#[test]
fn a_nan_output_is_outside_its_band_and_stops_the_season() {
    let p = plant(NAN_OUTPUT);
    let band = &p.model.soft[0];
    assert!(band_penalty(band, f64::NAN).is_nan(), "NaN is not inside");
    assert!(p.penalties(&[f64::NAN])[0].outside);
    let e = season_error(&p, vec![0.0], 3);
    assert_eq!(
        e,
        "step 0: output `y` (m.ghm:5:8) is NaN; the season stops here"
    );

    let (dir, file) = model_file("numbers-nan-output", "nan.ghm", NAN_OUTPUT);
    let out = dir.join("run");
    let (ok, err) = ghm(&[
        "simulate",
        file.to_str().unwrap(),
        "--steps",
        "3",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("step 0: output `y` (") && err.contains("nan.ghm:5:8) is NaN"),
        "{err}"
    );
    assert!(
        !out.join("summary.json").exists(),
        "no summary of a NaN season"
    );
}

/// A state that leaves the domain of the outputs after some steps: the step, the state
/// after it and the model line are named.
#[test]
fn a_state_that_becomes_infinite_is_named_with_its_step() {
    let p = plant(
        "state x = 1\ninput u in [0, 1e300] start 1e300\nder x = x * u * u\nsample 1 [s] integrator euler\n",
    );
    let e = season_error(&p, vec![1e300], 5);
    assert_eq!(
        e,
        "step 0: state `x` (m.ghm:1:7) after the step is inf; the season stops here"
    );
}

#[test]
fn an_input_that_is_not_a_number_stops_the_season_before_the_step() {
    let p = plant("state x = 1\ninput u in [0, 1] start 0\nder x = u\nsample 1 [s]\n");
    let e = season_error(&p, vec![f64::NAN], 2);
    assert_eq!(
        e,
        "step 0: input `u` (m.ghm:2:7) is NaN; the season stops here"
    );
}

#[test]
fn non_finite_and_absurd_inputs_on_the_command_line() {
    let dir = temp_dir("numbers-inputs");
    let out = dir.to_str().unwrap();
    let (ok, err) = ghm(&[
        "simulate",
        "models/lettuce.ghm",
        "--steps",
        "3",
        "--inputs",
        "const:NaN,1,40",
        "--out",
        out,
    ]);
    assert!(!ok);
    assert!(
        err.contains("--inputs const:NaN,1,40: the value of co2_supply is NaN"),
        "{err}"
    );
    // 1e308 mg m⁻² s⁻¹ of CO2 without the input bounds: the CO2 concentration overflows.
    let (ok, err) = ghm(&[
        "simulate",
        "models/lettuce.ghm",
        "--steps",
        "3",
        "--inputs",
        "const:1e308,1,40",
        "--no-rate-limit",
        "--out",
        out,
        "--overwrite",
    ]);
    assert!(!ok);
    assert!(
        err.contains("step 0: output `co2_ppm` (") && err.contains(") after the step is inf"),
        "{err}"
    );
    // Huge but finite figures are printed in scientific notation, not with 300 digits.
    let out_ok = Path::new(out).join("finite");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args([
            "simulate",
            "models/lettuce.ghm",
            "--steps",
            "3",
            "--inputs",
            "const:1e20,1,40",
            "--no-rate-limit",
            "--out",
            out_ok.to_str().unwrap(),
        ])
        .output()
        .expect("run ghm");
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}");
    let epi = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("EPI"))
        .expect("an EPI line");
    assert!(epi.contains("e17") && epi.len() < 50, "{epi}");
}

// ---- the derivative check --------------------------------------------------------------

#[test]
fn the_derivative_check_fails_where_the_step_is_not_finite() {
    for (expr, what) in [
        ("1 / x", "is inf"),
        ("log(x)", "is NaN"),
        ("sqrt(-x - 1)", "is NaN"),
        ("sqrt(x)", "∂(state `x` ("),
    ] {
        let text = format!(
            "model d\nstate x = 0\ninput u in [0, 1] start 0\nder x = u + {expr}\ncost c = u\nsample 1 [h]\n"
        );
        let p = plant(&text);
        let point: Vec<f64> = vec![0.0, 0.0];
        let r = verify_step_derivatives(&p, &[point]);
        assert!(r.max().is_nan() || r.max() > 1e-6, "{expr}: {r:?}");

        let (_, file) = model_file("numbers-verify", "d.ghm", &text);
        let (ok, err) = ghm(&["check", file.to_str().unwrap(), "--verify-derivatives"]);
        assert!(!ok, "{expr}: the check passed");
        assert!(
            err.contains("derivative check failed: at the initial state and start input")
                && err.contains(what),
            "{expr}: {err}"
        );
    }
}

// ---- if, min and max differentiate the branch they take ----------------------------------

/// `if(x > 0, x, sqrt(-x - 1))`, `max(0, sqrt(-1 - x))` and `min(x, sqrt(-1 - x))` at
/// x = 1: the branch not taken is NaN there, and must not reach the gradient or Hessian.
#[test]
fn the_branch_not_taken_does_not_reach_the_derivatives() {
    let mut g = Graph::new();
    let x = g.var(0);
    let zero = g.constant(0.0);
    let one = g.constant(1.0);
    let cond = g.apply(Op::Gt, &[x, zero]);
    let neg = g.apply(Op::Neg, &[x]);
    let inside = g.sub(neg, one);
    let root = g.apply(Op::Sqrt, &[inside]);
    let square = g.mul(x, x);
    let chosen = g.apply(Op::Select, &[cond, square, root]);
    let max = g.apply(Op::Max, &[zero, root]);
    let min = g.apply(Op::Min, &[x, root]);
    let tape = g.compile(&[chosen, max, min], 1);
    let mut d = Derivatives::new(&tape, &[0]);
    for weights in [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 2.0, 3.0],
    ] {
        let e = d.hessian(&tape, &[1.0], &weights);
        // Values: x² = 1, max(0, NaN) = 0, min(1, NaN) = 1.
        assert_eq!(e.values, [1.0, 0.0, 1.0]);
        let expect_g = 2.0 * weights[0] + weights[2];
        let expect_h = 2.0 * weights[0];
        assert_eq!(e.gradient, [expect_g], "{weights:?}");
        assert_eq!(e.hessian, [expect_h], "{weights:?}");
        assert_eq!(e.jacobian, [2.0, 0.0, 1.0]);
    }
}

const IF_MODEL: &str = "\
model iftest
state x = 1
input u in [0, 1] rate 0.5 start 0
der x = (u - 0.5 * x) / 3600
output y = if(x > 0, x, sqrt(-x - 1))
reward grow = next(x)
cost c = 0.3 * u
sample 1 [h]
";

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("JSON")
}

#[test]
fn an_output_with_an_undefined_branch_does_not_fail_the_mpc() {
    let (dir, file) = model_file("numbers-if", "if.ghm", IF_MODEL);
    for solver in ["ipm", "sqp"] {
        let out = dir.join(solver);
        let (ok, err) = ghm(&[
            "mpc",
            file.to_str().unwrap(),
            "--steps",
            "5",
            "--horizon",
            "3h",
            "--solver",
            solver,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(ok, "{solver}: {err}");
        let s = summary(&out);
        assert_eq!(s["metrics"]["solve"]["failed_solves"], 0, "{solver}: {s}");
        assert_eq!(s["warnings"], serde_json::json!([]), "{solver}");
    }
}

// ---- a season of failed solves ----------------------------------------------------------

/// `sqrt(u)` at u = 0, where every solve starts: its derivative is infinite and every
/// solve fails, so the season is the fallback's.
#[test]
fn a_season_in_which_every_solve_failed_is_not_a_success() {
    let (dir, file) = model_file(
        "numbers-all-failed",
        "fail.ghm",
        "model allfail\nstate x = 0.5\ninput u in [0, 1] start 0\nder x = (u - x) / 36000\n\
         reward r = next(x)\ncost c = sqrt(u)\nsample 1 [h]\n",
    );
    let out = dir.join("run");
    let (ok, err) = ghm(&[
        "mpc",
        file.to_str().unwrap(),
        "--steps",
        "4",
        "--horizon",
        "3h",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!ok, "every solve failed, yet the run succeeded");
    assert!(err.contains("every one of the 4 solves failed"), "{err}");
    let s = summary(&out);
    assert_eq!(s["metrics"]["solve"]["failed_solves"], 4);
    let warning = s["warnings"][0].as_str().expect("a warning");
    assert!(
        warning.starts_with("every one of the 4 solves failed"),
        "{warning}"
    );
    assert!(
        out.join("trajectory.csv").exists(),
        "the record of the season is kept"
    );
}

// ---- weather outside its physical range --------------------------------------------------

const RAD_MODEL: &str = "\
model r
state x = 1
input u in [0, 1] start 0
disturbance rad column \"rad_Wm2\"
disturbance rh column \"rh_out_pct\"
der x = u * rad * rh * 1e-9
cost c = u
sample 30 [min]
";

#[test]
fn weather_outside_its_physical_range_or_with_a_duplicated_column_is_refused() {
    let (dir, file) = model_file("numbers-weather", "r.ghm", RAD_MODEL);
    let cases = [
        (
            "rad.csv",
            "rad_Wm2,rh_out_pct\r\n100,80\r\n-500,80\r\n",
            "rad.csv: line 3, column `rad_Wm2`: -500 W m^-2 is outside the physical range [0, 1500] W m^-2",
        ),
        (
            "rh.csv",
            "rad_Wm2,rh_out_pct\n100,80\n100,80\n100,200\n",
            "rh.csv: line 4, column `rh_out_pct`: 200 % is outside the physical range [0, 100] %",
        ),
        (
            "dup.csv",
            "rad_Wm2,rh_out_pct,rad_Wm2\n100,80,100\n100,80,100\n",
            "dup.csv: line 1: the header has column `rad_Wm2` twice (columns 1 and 3)",
        ),
    ];
    for (name, text, message) in cases {
        let weather = dir.join(name);
        std::fs::write(&weather, text).expect("write the weather");
        let out = dir.join(format!("run-{name}"));
        let (ok, err) = ghm(&[
            "simulate",
            file.to_str().unwrap(),
            "--weather",
            weather.to_str().unwrap(),
            "--steps",
            "2",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!ok, "{name} was accepted");
        assert!(err.contains(message), "{name}: {err}");
    }
}

// ---- arguments too large to allocate -----------------------------------------------------

#[test]
fn season_horizon_and_training_sizes_are_checked_before_anything_is_allocated() {
    let dir = temp_dir("numbers-args");
    let out = dir.to_str().unwrap();
    let max = u64::MAX.to_string();
    let cases: [(&[&str], &str); 8] = [
        (
            &["simulate", "--days", "1e20"],
            "a season has at most 10000000 steps",
        ),
        (
            &["simulate", "--steps", &max],
            "a season has at most 10000000 steps",
        ),
        (
            &["mpc", "--horizon", "1e15h", "--steps", "2"],
            "a horizon has at most 100000 steps",
        ),
        (
            &["mpc", "--horizon", &max, "--steps", "2"],
            "a horizon has at most 100000 steps",
        ),
        (
            &["simulate", "--steps", "2", "--start-row", &max],
            "the first row must be at most 10000000",
        ),
        (
            &["train", "--episodes", &max, "--steps", "2"],
            "a training has at most 100000 episodes",
        ),
        (
            &[
                "value",
                "--guide",
                "expert",
                "--trajectories",
                &max,
                "--steps",
                "2",
            ],
            "--trajectories 18446744073709551615: must be from 1 to 10000000",
        ),
        (
            &[
                "value", "--guide", "expert", "--epochs", &max, "--steps", "2",
            ],
            "--epochs 18446744073709551615: must be from 1 to 1000000",
        ),
    ];
    for (args, message) in cases {
        let mut all = vec![args[0], "models/lettuce.ghm"];
        all.extend(&args[1..]);
        all.extend(["--out", out, "--overwrite"]);
        let (ok, err) = ghm(&all);
        assert!(!ok, "{args:?} was accepted");
        assert!(err.contains(message), "{args:?}: {err}");
    }
}
