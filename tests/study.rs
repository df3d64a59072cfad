//! `ghm study` end to end on `examples/studies/tiny.toml`: every job planned runs into its
//! folder and into `results.csv`; a second run recomputes nothing; a study killed halfway
//! completes when run again, with the same figures as one never stopped; a job whose spec
//! or model text changed runs again.

mod common;

use common::bin::{ghm_with_stdout as ghm, temp_dir};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The tiny study's jobs: the optimum, expert and SAC on 3 scenarios, MPC and RL-MPC on
/// 2 horizons × 3 scenarios.
const TINY_JOBS: usize = 1 + 3 + 3 + 2 * 3 + 2 * 3;

/// `results.csv` as folder → (cumulative reward, EPI, failed solves): the figures, not the
/// times.
fn results(out: &Path) -> BTreeMap<String, (String, String, String)> {
    let text = std::fs::read_to_string(out.join("results.csv")).expect("results.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (folder, reward, epi, failed) = (
        col("folder"),
        col("cumulative_reward"),
        col("epi"),
        col("failed_solves"),
    );
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), header.len(), "{l}");
            (
                f[folder].to_string(),
                (f[reward].into(), f[epi].into(), f[failed].into()),
            )
        })
        .collect()
}

fn complete_jobs(out: &Path) -> usize {
    fn walk(dir: &Path, n: &mut usize) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(&p, n);
            } else if p.file_name().is_some_and(|f| f == "run.json")
                && std::fs::read_to_string(&p).is_ok_and(|t| t.contains("\"complete\""))
            {
                *n += 1;
            }
        }
    }
    let mut n = 0;
    walk(out, &mut n);
    n
}

#[test]
fn a_study_runs_every_job_once_and_resumes_after_a_kill() {
    let study = "examples/studies/tiny.toml";
    let whole = temp_dir("study-whole");
    let w = whole.to_str().unwrap();
    let (ok, out, err) = ghm(&["study", study, "--out", w, "--threads", "2"]);
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains(&format!(
            "{TINY_JOBS} jobs: {TINY_JOBS} run now, 0 done before"
        )),
        "{out}"
    );
    let first = results(&whole);
    assert_eq!(first.len(), TINY_JOBS, "{first:?}");
    for (folder, (reward, _, failed)) in &first {
        assert!(
            reward.parse::<f64>().is_ok_and(f64::is_finite),
            "{folder}: {reward}"
        );
        assert_eq!(failed, "0", "{folder}");
    }
    // The optimum is the ceiling of the nominal seasons.
    let optimum: f64 = first["lettuce/optimum"].0.parse().unwrap();
    for (folder, (reward, _, _)) in &first {
        if folder.ends_with("/nominal") {
            let r: f64 = reward.parse().unwrap();
            assert!(
                r <= optimum + 1e-6,
                "{folder}: {r} above the optimum {optimum}"
            );
        }
    }
    assert!(whole.join("study.json").is_file());

    // Run again: nothing is recomputed.
    let stamp = std::fs::metadata(whole.join("lettuce/mpc/2h/nominal/summary.json"))
        .and_then(|m| m.modified())
        .unwrap();
    let (ok, out, err) = ghm(&["study", study, "--out", w]);
    assert!(ok, "{err}");
    assert!(
        out.contains(&format!(
            "{TINY_JOBS} jobs: 0 run now, {TINY_JOBS} done before"
        )),
        "{out}"
    );
    let again = std::fs::metadata(whole.join("lettuce/mpc/2h/nominal/summary.json"))
        .and_then(|m| m.modified())
        .unwrap();
    assert_eq!(stamp, again);

    // Killed after a few jobs, then run again: the same figures as the whole run.
    let killed = temp_dir("study-killed");
    let k = killed.to_str().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(["study", study, "--out", k, "--threads", "1"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start ghm study");
    let clock = Instant::now();
    while complete_jobs(&killed) < 4 && clock.elapsed() < Duration::from_secs(300) {
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().expect("kill ghm study");
    let _ = child.wait();
    let done_at_kill = complete_jobs(&killed);
    assert!(
        (4..TINY_JOBS).contains(&done_at_kill),
        "{done_at_kill} jobs complete when killed"
    );
    let (ok, out, err) = ghm(&["study", study, "--out", k]);
    assert!(ok, "{out}\n{err}");
    let run_now = TINY_JOBS - done_at_kill;
    assert!(
        out.contains(&format!(
            "{TINY_JOBS} jobs: {run_now} run now, {done_at_kill} done before"
        )),
        "{out}"
    );
    assert_eq!(results(&killed), first);

    // A changed study (another terminal region for RL-MPC) runs the changed jobs only.
    let changed = killed.join("changed.toml");
    let text = std::fs::read_to_string(study).unwrap();
    let models = std::fs::canonicalize("models/lettuce.ghm").unwrap();
    let text = text
        .replace(
            "\"../../models/lettuce.ghm\"",
            &format!("{:?}", models.display().to_string()),
        )
        .replace("guide = \"sac\"", "guide = \"sac\"\nepsilon = 0.1");
    std::fs::write(&changed, text).unwrap();
    let (ok, out, err) = ghm(&["study", changed.to_str().unwrap(), "--out", k]);
    assert!(ok, "{out}\n{err}");
    let rlmpc_jobs = 2 * 3;
    assert!(
        out.contains(&format!(
            "{TINY_JOBS} jobs: {rlmpc_jobs} run now, {} done before",
            TINY_JOBS - rlmpc_jobs
        )),
        "{out}"
    );

    // The report of both folders: each (controller, horizon, scenario) once, the first
    // folder's where both hold it; one table line per controller and horizon.
    let report = whole.join("report");
    let (ok, out, err) = ghm(&["report", w, k, "--out", report.to_str().unwrap()]);
    assert!(ok, "{out}\n{err}");
    assert!(
        out.starts_with(&format!("{TINY_JOBS} seasons of 1 model")),
        "{out}"
    );
    let table = std::fs::read_to_string(report.join("lettuce.csv")).unwrap();
    let lines: Vec<&str> = table.lines().skip(1).collect();
    assert_eq!(lines.len(), 1 + 1 + 1 + 2 + 2, "{table}");
    let mpc_2h = lines
        .iter()
        .find(|l| l.starts_with("MPC,2h,"))
        .expect("MPC at 2h");
    let field = |line: &str, i: usize| line.split(',').nth(i).unwrap_or_default().to_string();
    assert_eq!(field(mpc_2h, 4), first["lettuce/mpc/2h/nominal"].0);
    assert_eq!(field(mpc_2h, 5), "2", "two stochastic seasons: {mpc_2h}");
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(
        md.contains("![lettuce: against the prediction horizon](lettuce.svg)")
            && md.contains("| nominal plant | 1h | 2h |")
            && md.contains("| RL-MPC reward |"),
        "{md}"
    );
    // The same tables spliced into a document between its markers, the prose kept.
    let document = whole.join("results.md");
    std::fs::write(
        &document,
        "Prose.\n<!-- begin ghm report report -->\nold\n<!-- end ghm report report -->\nMore.\n",
    )
    .unwrap();
    let (ok, out, err) = ghm(&[
        "report",
        w,
        "--out",
        report.to_str().unwrap(),
        "--into",
        document.to_str().unwrap(),
    ]);
    assert!(ok, "{out}\n{err}");
    let spliced = std::fs::read_to_string(&document).unwrap();
    assert!(
        spliced.starts_with("Prose.\n<!-- begin ghm report report -->\n"),
        "{spliced}"
    );
    assert!(
        spliced.ends_with("<!-- end ghm report report -->\nMore.\n"),
        "{spliced}"
    );
    assert!(
        spliced.contains("](report/lettuce.svg)") && !spliced.contains("\nold\n"),
        "{spliced}"
    );
    let png = std::fs::read(report.join("lettuce.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let svg = std::fs::read_to_string(report.join("lettuce.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("RL-MPC"), "{svg}");
    let times = std::fs::read_to_string(report.join("lettuce-solve-times.csv")).unwrap();
    assert!(times.starts_with("controller,horizon,horizon_h,median_ms,max_ms\n"));
    let (ok, _, err) = ghm(&["report", k, "--out", report.to_str().unwrap()]);
    assert!(ok, "{err}");
    let (ok, _, err) = ghm(&["report", "examples", "--out", report.to_str().unwrap()]);
    assert!(!ok && err.contains("study.json"), "{err}");

    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&killed);
}

#[test]
fn a_bad_study_or_shard_is_refused_with_a_clear_message() {
    let dir = temp_dir("study-bad");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "models = [\"m.ghm\"]\nhorizons = 3\n").unwrap();
    let (ok, _, err) = ghm(&[
        "study",
        bad.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("bad.toml") && err.contains("line 2"),
        "the message names the file and the line: {err}"
    );
    let (ok, _, err) = ghm(&[
        "study",
        "examples/studies/tiny.toml",
        "--shard",
        "2/2",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(!ok && err.contains("--shard 2/2"), "{err}");
    let (ok, _, err) = ghm(&["study", "nowhere.toml"]);
    assert!(!ok && err.contains("nowhere.toml"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn shards_split_the_jobs_and_merged_give_the_tables_of_the_whole_study_to_the_byte() {
    let out = temp_dir("study-shards");
    let study = "examples/studies/tiny.toml";
    let mut folders = Vec::new();
    for shard in ["0/2", "1/2"] {
        let folder = out.join(format!("shard-{}", &shard[..1]));
        let (ok, stdout, err) = ghm(&[
            "study",
            study,
            "--out",
            folder.to_str().unwrap(),
            "--shard",
            shard,
            "--threads",
            "1",
        ]);
        assert!(ok, "{stdout}\n{err}");
        let done = results(&folder).len();
        assert!(0 < done && done < TINY_JOBS, "shard {shard}: {done} jobs");
        folders.push(folder);
    }
    let whole = out.join("whole");
    let (ok, stdout, err) = ghm(&["study", study, "--out", whole.to_str().unwrap()]);
    assert!(ok, "{stdout}\n{err}");

    let merged = out.join("merged-report");
    let (ok, stdout, err) = ghm(&[
        "report",
        folders[1].to_str().unwrap(),
        folders[0].to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(ok, "{stdout}\n{err}");
    let single = out.join("whole-report");
    let (ok, stdout, err) = ghm(&[
        "report",
        whole.to_str().unwrap(),
        "--out",
        single.to_str().unwrap(),
    ]);
    assert!(ok, "{stdout}\n{err}");
    let read = |dir: &Path, file: &str| std::fs::read(dir.join(file)).unwrap();
    // The table of results, byte for byte, though the shards were named in reverse.
    assert_eq!(read(&merged, "lettuce.csv"), read(&single, "lettuce.csv"));
    // Every job's row, in the same order, but for the solve times no two runs share.
    let without_times = |dir: &Path| -> Vec<String> {
        let text = String::from_utf8(read(dir, "results.csv")).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        assert!(header.contains(&"median_ms") && header.contains(&"mean_iterations"));
        text.lines()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                let kept: Vec<&str> = f
                    .iter()
                    .zip(&header)
                    .filter(|(_, name)| !name.ends_with("_ms"))
                    .map(|(v, _)| *v)
                    .collect();
                kept.join(",")
            })
            .collect()
    };
    assert_eq!(without_times(&merged), without_times(&single));
    assert_eq!(without_times(&single).len(), TINY_JOBS + 1);
    let _ = std::fs::remove_dir_all(&out);
}

/// `examples/studies/tiny-agents.toml`: two trainings, three value fits, six seasons.
const AGENT_JOBS: usize = 2 + 3 + 6;

#[test]
fn a_study_trains_its_own_agents_before_the_seasons_that_read_them() {
    let study = "examples/studies/tiny-agents.toml";
    let dir = temp_dir("study-agents");
    let d = dir.to_str().unwrap();
    let (ok, out, err) = ghm(&["study", study, "--out", d, "--threads", "2"]);
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains(&format!(
            "{AGENT_JOBS} jobs: {AGENT_JOBS} run now, 0 done before"
        )),
        "{out}"
    );
    assert_eq!(complete_jobs(&dir), AGENT_JOBS);
    for trained in ["agents/nominal", "agents/stochastic"] {
        assert!(dir
            .join("lettuce")
            .join(trained)
            .join("policy.json")
            .is_file());
    }
    for fitted in [
        "values/nominal-sac",
        "values/stochastic-sac",
        "values/expert",
    ] {
        assert!(dir
            .join("lettuce")
            .join(fitted)
            .join("value.json")
            .is_file());
    }
    // The seasons read the study's agents: the perturbed plant's for the perturbed season.
    let canonical = std::fs::canonicalize(&dir).unwrap();
    let run = |folder: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(dir.join(folder).join("run.json")).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    let spec = &run("lettuce/rl-mpc/1h/stochastic-00")["spec"]["controller"];
    let named = |key: &str| std::path::PathBuf::from(spec[key].as_str().unwrap());
    assert_eq!(named("agent"), canonical.join("lettuce/agents/stochastic"));
    assert_eq!(
        named("value"),
        canonical.join("lettuce/values/stochastic-sac")
    );
    let training = &run("lettuce/agents/stochastic")["spec"];
    assert_eq!(training["stochastic"], true);
    assert_eq!(training["uncertainty"], 0.05);
    // Only the seasons are rows of the results.
    assert_eq!(results(&dir).len(), 6);
    // Every job's time is logged, phase after phase.
    let timings = timing_rows(&dir);
    assert_eq!(timings.len(), AGENT_JOBS, "{timings:?}");
    let phases: Vec<&str> = timings.iter().map(|r| r[2].as_str()).collect();
    let mut in_order = phases.clone();
    in_order.sort_by_key(|p| {
        ["trainings", "value fits", "seasons"]
            .iter()
            .position(|q| q == p)
    });
    assert_eq!(phases, in_order, "{timings:?}");
    assert!(timings
        .iter()
        .all(|r| r[5] == "complete" && r[4].parse::<f64>().unwrap() > 0.0));

    // A training interrupted after its last checkpoint continues from it, and what reads
    // it is not run again.
    let run_json = dir.join("lettuce/agents/nominal/run.json");
    let text = std::fs::read_to_string(&run_json).unwrap();
    std::fs::write(&run_json, text.replace("\"complete\"", "\"running\"")).unwrap();
    let (ok, out, err) = ghm(&["study", study, "--out", d]);
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains(&format!(
            "{AGENT_JOBS} jobs: 1 run now, {} done before",
            AGENT_JOBS - 1
        )),
        "{out}"
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("lettuce/agents/nominal/summary.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(summary["this_session"]["environment_steps"], 0, "{summary}");
    assert_eq!(summary["episodes_done"], 3);
    // The rerun's one job is appended to the timings.
    let timings = timing_rows(&dir);
    assert_eq!(timings.len(), AGENT_JOBS + 1);
    assert_eq!(timings[AGENT_JOBS][0], "lettuce/agents/nominal");
    assert_eq!(timings[AGENT_JOBS][1], "train");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_study_distils_its_own_guides_before_the_seasons_that_read_them() {
    let study = "examples/studies/tiny-distilled.toml";
    let dir = temp_dir("study-distilled");
    let d = dir.to_str().unwrap();
    let (ok, out, err) = ghm(&["study", study, "--out", d, "--threads", "2"]);
    assert!(ok, "{out}\n{err}");
    // 2 distillations, 2 value fits, 2 controllers × 2 scenarios.
    assert!(out.contains("8 jobs: 8 run now, 0 done before"), "{out}");
    assert_eq!(complete_jobs(&dir), 8);
    let run = |folder: &str| -> serde_json::Value {
        let text = std::fs::read_to_string(dir.join(folder).join("run.json")).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    let distillation = &run("lettuce/distillations/stochastic")["spec"];
    assert_eq!(distillation["stochastic"], true);
    assert_eq!(distillation["teacher"]["horizon"], "2h");
    assert!(dir
        .join("lettuce/distillations/stochastic/policy.json")
        .is_file());
    let value: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("lettuce/values/stochastic-distilled/value.json"))
            .unwrap(),
    )
    .unwrap();
    assert_eq!(value["guide"], "distilled");
    // The perturbed seasons read the guide distilled on perturbed plants, and its value.
    let canonical = std::fs::canonicalize(&dir).unwrap();
    let spec = &run("lettuce/rl-mpc-distilled/1h/stochastic-00")["spec"]["controller"];
    let named = |key: &str| std::path::PathBuf::from(spec[key].as_str().unwrap());
    assert_eq!(named("guide"), std::path::PathBuf::from("distilled"));
    assert_eq!(
        named("agent"),
        canonical.join("lettuce/distillations/stochastic")
    );
    assert_eq!(
        named("value"),
        canonical.join("lettuce/values/stochastic-distilled")
    );
    let policy = &run("lettuce/distilled/nominal")["spec"]["controller"];
    assert_eq!(
        std::path::PathBuf::from(policy["agent"].as_str().unwrap()),
        canonical.join("lettuce/distillations/nominal")
    );
    assert_eq!(results(&dir).len(), 4);
    // Run again, nothing is: the distillations are complete.
    let (ok, out, err) = ghm(&["study", study, "--out", d]);
    assert!(ok, "{out}\n{err}");
    assert!(out.contains("8 jobs: 0 run now, 8 done before"), "{out}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The rows of a study's `timings.csv`, its header checked.
fn timing_rows(dir: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(dir.join("timings.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("job,kind,phase,started_unix,wall_s,status")
    );
    lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

/// A season whose model file changed since it ran is run again, not counted as done: a
/// study's spec names the file, its `summary.json` the text it ran on.
#[test]
fn a_study_runs_again_the_seasons_whose_model_changed() {
    let dir = temp_dir("study-model-changed");
    std::fs::create_dir_all(&dir).unwrap();
    let lettuce = std::fs::read_to_string("models/lettuce.ghm").unwrap();
    std::fs::write(dir.join("m.ghm"), &lettuce).unwrap();
    let study = dir.join("s.toml");
    std::fs::write(
        &study,
        "models = [\"m.ghm\"]\n[weather]\ndays = 0.5\n[[controllers]]\nname = \"expert\"\nkind = \"expert\"\n",
    )
    .unwrap();
    let out = dir.join("out");
    let args = [
        "study",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    let (ok, said, err) = ghm(&args);
    assert!(
        ok && said.contains("1 jobs: 1 run now, 0 done before"),
        "{said}\n{err}"
    );
    let (ok, said, err) = ghm(&args);
    assert!(
        ok && said.contains("1 jobs: 0 run now, 1 done before"),
        "{said}\n{err}"
    );

    let priced = lettuce.replace("\nmodel ", "\n# priced anew\nmodel ");
    assert_ne!(priced, lettuce, "models/lettuce.ghm has no `model` line");
    std::fs::write(dir.join("m.ghm"), priced).unwrap();
    let (ok, said, err) = ghm(&args);
    assert!(
        ok && said.contains("1 jobs: 1 run now, 0 done before"),
        "{said}\n{err}"
    );
    assert!(err.contains("its model file changed since it ran"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
