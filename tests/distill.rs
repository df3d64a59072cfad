//! Policy distillation (`ghm distill`, `job::distill`): DAgger on the lettuce greenhouse's
//! built-in season (no ../shared needed), taught by MPC at 2 h.

use ghm::agent::PolicyFile;
use ghm::job::distill::{run_distill_job, DistillSpec, StartRows};
use ghm::job::{
    run_season_job, ControllerSpec, CostForm, GuideChoice, JobOptions, MpcSpec, OptimumSpec,
    PlantSpec, RlmpcSpec, RunSpec, WeatherSpec,
};
use ghm::sim::weather::{saturation_vapour_pressure, Warming};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn spec(iterations: usize) -> DistillSpec {
    DistillSpec {
        model: "models/lettuce.ghm".into(),
        weather: WeatherSpec {
            days: Some(2.0),
            ..WeatherSpec::default()
        },
        teacher: ControllerSpec::Mpc(MpcSpec {
            horizon: "2h".into(),
            ..MpcSpec::default()
        }),
        iterations,
        roll_outs: 2,
        ..DistillSpec::default()
    }
}

const QUIET: JobOptions = JobOptions {
    overwrite: false,
    verbose: false,
};

/// A fresh folder for one test.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ghm-distill-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn summary(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap()
}

#[test]
fn dagger_brings_the_student_closer_to_its_teacher_than_behaviour_cloning() {
    let out = temp_dir("dagger");
    run_distill_job(&spec(4), &out, &QUIET, false, 2).unwrap();
    let summary = summary(&out);
    let curve = summary["curve"].as_array().unwrap();
    assert_eq!(curve.len(), 4);
    let reward = |i: usize, field: &str| curve[i][field].as_f64().unwrap();
    // Iteration 0 rolls out the teacher: its reward is the teacher's season.
    let teacher = summary["teacher_reward"].as_f64().unwrap();
    assert_eq!(teacher, reward(0, "roll_out_reward"));
    // The student fitted to the teacher's own path only (behaviour cloning) strays from
    // it; the students fitted to the states they visit themselves come closer.
    let cloned_gap = (teacher - reward(0, "student_reward")).abs();
    let last_gap = (teacher - reward(3, "student_reward")).abs();
    assert!(
        last_gap < cloned_gap,
        "teacher {teacher}: behaviour cloning's gap {cloned_gap}, DAgger's after 4 iterations {last_gap}"
    );
    // Every roll-out labels every step: 2 roll-outs of 96 half-hour steps an iteration.
    assert_eq!(curve[3]["labels"].as_u64(), Some(4 * 2 * 96));
    let labels = std::fs::read_to_string(out.join("labels/iteration-03.csv")).unwrap();
    assert_eq!(labels.lines().count(), 1 + 2 * 96);
    // The best student is a policy file for the model, with its evaluation.
    let policy = PolicyFile::load(&out.join("policy.json")).unwrap();
    let model = ghm::lang::load(Path::new("models/lettuce.ghm")).unwrap();
    policy.check_fits(&model, &out.join("policy.json")).unwrap();
    let best = summary["best"]["student_reward"].as_f64().unwrap();
    assert_eq!(policy.eval_reward, Some(best));
    assert!((0..4).all(|i| reward(i, "student_reward") <= best));
}

#[test]
fn a_distillation_given_more_iterations_ends_as_one_run_at_once() {
    let dir = temp_dir("continue");
    let (stepwise, at_once) = (dir.join("stepwise"), dir.join("at-once"));
    run_distill_job(&spec(2), &stepwise, &QUIET, true, 1).unwrap();
    run_distill_job(&spec(3), &stepwise, &QUIET, true, 1).unwrap();
    run_distill_job(&spec(3), &at_once, &QUIET, true, 2).unwrap();
    let rewards = |dir: &Path| -> Vec<(f64, f64)> {
        summary(dir)["curve"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| {
                (
                    r["roll_out_reward"].as_f64().unwrap(),
                    r["student_reward"].as_f64().unwrap(),
                )
            })
            .collect()
    };
    assert_eq!(rewards(&stepwise).len(), 3);
    assert_eq!(rewards(&stepwise), rewards(&at_once));
    let net = |dir: &Path| -> Value {
        let text = std::fs::read_to_string(dir.join("student.json")).unwrap();
        serde_json::from_str::<Value>(&text).unwrap()["net"].clone()
    };
    assert_eq!(net(&stepwise), net(&at_once));
    // Another spec in the same folder is refused, not continued.
    let other = DistillSpec {
        noise: 0.3,
        ..spec(3)
    };
    let refused = run_distill_job(&other, &stepwise, &QUIET, true, 1).unwrap_err();
    assert!(refused.to_string().contains("overwrite"), "{refused}");
}

#[test]
fn roll_outs_that_start_elsewhere_label_other_weather_and_keep_the_season_for_evaluation() {
    let out = temp_dir("start-rows");
    let spread = DistillSpec {
        start_rows: Some(StartRows {
            first: 200,
            last: 400,
        }),
        ..spec(1)
    };
    run_distill_job(&spread, &out, &QUIET, false, 2).unwrap();
    let labels = std::fs::read_to_string(out.join("labels/iteration-00.csv")).unwrap();
    let header: Vec<&str> = labels.lines().next().unwrap().split(',').collect();
    let radiation = header.iter().position(|c| *c == "radiation").unwrap();
    let column = |roll_out: &str| -> Vec<String> {
        labels
            .lines()
            .skip(1)
            .filter(|l| l.starts_with(&format!("{roll_out},")))
            .map(|l| l.split(',').nth(radiation).unwrap().to_string())
            .collect()
    };
    // The first roll-out is the season's (as without start rows); the second saw other days.
    let at_home = temp_dir("start-rows-home");
    run_distill_job(&spec(1), &at_home, &QUIET, false, 2).unwrap();
    let home = std::fs::read_to_string(at_home.join("labels/iteration-00.csv")).unwrap();
    let first_rows: Vec<&str> = labels.lines().take(1 + 96).collect();
    assert_eq!(first_rows, home.lines().take(1 + 96).collect::<Vec<_>>());
    assert_ne!(column("0"), column("1"));
    assert_eq!(
        summary(&out)["teacher_reward"],
        summary(&at_home)["teacher_reward"]
    );
    // A range that runs past the weather is refused by name before anything runs.
    let short = temp_dir("start-rows-weather");
    std::fs::create_dir_all(&short).unwrap();
    let csv = short.join("ten-rows.csv");
    let rows = "0,0.0007,5,0.006\n".repeat(10);
    std::fs::write(
        &csv,
        format!("rad_Wm2,co2_out_kgm3,temp_out_C,vapdens_out_kgm3\n{rows}"),
    )
    .unwrap();
    let file = DistillSpec {
        weather: WeatherSpec {
            weather: Some(csv),
            steps: Some(2),
            ..WeatherSpec::default()
        },
        start_rows: Some(StartRows { first: 0, last: 9 }),
        ..spec(1)
    };
    let e = run_distill_job(&file, &temp_dir("start-rows-short"), &QUIET, false, 1).unwrap_err();
    assert!(e.to_string().contains("`start_rows`"), "{e}");
}

#[test]
fn warmed_roll_outs_label_warmer_weather_at_the_same_relative_humidity() {
    let warming =
        |range: &str, keep: &str| Some(range.parse::<Warming>().unwrap().keeping_humidity([keep]));
    let out = temp_dir("warming");
    let warmed = DistillSpec {
        warming: warming("5..5", "hum_out"),
        ..spec(1)
    };
    run_distill_job(&warmed, &out, &QUIET, false, 2).unwrap();
    let labels = std::fs::read_to_string(out.join("labels/iteration-00.csv")).unwrap();
    let header: Vec<&str> = labels.lines().next().unwrap().split(',').collect();
    let at = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (temperature, humidity) = (at("temp_out"), at("hum_out"));
    let rows = |roll_out: &str| -> Vec<Vec<f64>> {
        labels
            .lines()
            .skip(1)
            .filter(|l| l.starts_with(&format!("{roll_out},")))
            .map(|l| {
                l.split(',')
                    .map(|v| v.parse().unwrap_or(f64::NAN))
                    .collect()
            })
            .collect()
    };
    // Roll-out 0 is the season as recorded; roll-out 1 the same days, 5 degrees warmer.
    let (recorded, warmer) = (rows("0"), rows("1"));
    assert_eq!(recorded.len(), warmer.len());
    for (r, w) in recorded.iter().zip(&warmer) {
        let t = r[temperature];
        assert!(
            (w[temperature] - (t + 5.0)).abs() < 1e-9,
            "{} {}",
            w[temperature],
            t
        );
        let kept = saturation_vapour_pressure(t + 5.0) / saturation_vapour_pressure(t)
            * (t + 273.15)
            / (t + 5.0 + 273.15);
        assert!((w[humidity] / r[humidity] - kept).abs() < 1e-9);
    }
    // The students are still evaluated on the season as recorded.
    let at_home = temp_dir("warming-home");
    run_distill_job(&spec(1), &at_home, &QUIET, false, 2).unwrap();
    assert_eq!(
        summary(&out)["teacher_reward"],
        summary(&at_home)["teacher_reward"]
    );
    // A humidity in another unit is refused by the field's name before anything runs.
    let wrong = DistillSpec {
        warming: warming("0..8", "radiation"),
        ..spec(1)
    };
    let e = run_distill_job(&wrong, &temp_dir("warming-wrong"), &QUIET, false, 1).unwrap_err();
    assert!(
        e.to_string().contains("`warming`") && e.to_string().contains("radiation"),
        "{e}"
    );
}

#[test]
fn a_teacher_that_plans_a_whole_season_or_no_iteration_is_refused_by_name() {
    let dir = temp_dir("refused");
    let optimum = DistillSpec {
        teacher: ControllerSpec::Optimum(OptimumSpec::default()),
        ..spec(2)
    };
    let e = run_distill_job(&optimum, &dir, &QUIET, false, 1).unwrap_err();
    assert!(e.to_string().contains("`teacher`"), "{e}");
    let e = run_distill_job(&spec(0), &dir, &QUIET, false, 1).unwrap_err();
    assert!(e.to_string().contains("`iterations`"), "{e}");
}

#[test]
fn a_student_that_sees_the_forecast_is_a_version_2_policy_that_runs_as_it_was_taught() {
    let out = temp_dir("forecast");
    let ahead = DistillSpec {
        forecast_rows: 3,
        ..spec(1)
    };
    run_distill_job(&ahead, &out, &QUIET, false, 2).unwrap();
    let path = out.join("policy.json");
    let policy = PolicyFile::load(&path).unwrap();
    assert_eq!(policy.observation.version(), 2);
    assert_eq!(policy.observation.forecast_rows(), 3);
    let model = ghm::lang::load(Path::new("models/lettuce.ghm")).unwrap();
    policy.check_fits(&model, &path).unwrap();
    // Outputs, previous inputs, step, then four rows of the four weather columns.
    let nd = model.disturbances.len();
    assert_eq!(policy.observation_names.len(), 4 + 3 + 1 + 4 * nd);
    let last = policy.observation_names.last().unwrap();
    assert!(last.ends_with("[k+3]"), "{last}");
    let labels = std::fs::read_to_string(out.join("labels/iteration-00.csv")).unwrap();
    assert!(labels.lines().next().unwrap().contains(last.as_str()));

    // The same student as a controller of a season (the job layer: what `ghm policy`,
    // serve, compile and Python build) earns what it earned in its evaluation on the
    // training environment: it observes the same forecast rows.
    let run = |controller: ControllerSpec| RunSpec {
        model: "models/lettuce.ghm".into(),
        weather: spec(1).weather,
        plant: PlantSpec::NOMINAL,
        controller,
    };
    let season =
        |controller, name: &str| run_season_job(&run(controller), &out.join(name), &QUIET).unwrap();
    let student = || ControllerSpec::Policy {
        agent: Some(out.clone()),
    };
    let alone = season(student(), "alone");
    let evaluated = policy.eval_reward.unwrap();
    let reward = alone.metrics.cumulative_reward;
    assert!(
        (reward - evaluated).abs() <= 1e-9 * evaluated.abs().max(1.0),
        "season {reward}, evaluation {evaluated}"
    );
    // A controller driven step by step (serve, compile, Python) asks for the rows it
    // reads, the current one and three after it.
    let standalone = ghm::job::build_controller(&run(student())).unwrap();
    assert_eq!(standalone.forecast_rows, 4);
    // RL-guided MPC rolls the guide out over its horizon with the rows past it.
    let guided = season(
        ControllerSpec::Rlmpc(RlmpcSpec {
            guide: GuideChoice::Distilled,
            agent: Some(out.clone()),
            terminal_cost: CostForm::None,
            ..RlmpcSpec::default()
        }),
        "rlmpc",
    );
    assert_eq!(guided.metrics.solve.failed_solves, 0);
    assert!(guided.metrics.cumulative_reward.is_finite());

    // A version this ghm does not know is refused by name, not misread.
    let text = std::fs::read_to_string(&path).unwrap();
    let future = text.replace("\"version\":2", "\"version\":3");
    assert_ne!(future, text);
    let unknown = out.join("future.json");
    std::fs::write(&unknown, future).unwrap();
    let e = PolicyFile::load(&unknown).unwrap_err().to_string();
    assert!(e.contains("observation version 3"), "{e}");
}
