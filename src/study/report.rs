//! `ghm report`: the tables and figures of one or more study folders (runs or shards of
//! the same study, or different studies), merged: per model, each controller's EPI and
//! cumulative reward against the horizon on the nominal plant, and their mean, minimum and
//! maximum over the stochastic scenarios, with failed solves and solve times; the season
//! optimum and the controllers without a horizon beside them. Every table is a CSV, every
//! figure a PNG and an SVG drawn from the same rows, and `report.md` puts them together.

use crate::job::folder;
use crate::job::output::{io_err, write_atomically};
use crate::report::atomic;
use crate::report::plot::{draw_png, draw_svg, Figure, Line, Panel, Spread};
use crate::report::table::csv_text;
use crate::study::breakdown::{self, Breakdown, Season};
use crate::study::markdown::model_section;
use crate::study::table::{spread, TableLine};
use crate::study::StudyError;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// One complete job's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRow {
    /// The model's file stem.
    pub model: String,
    /// The controller's name in the study.
    pub controller: String,
    /// The horizon as written (empty: none).
    pub horizon: String,
    /// The horizon in hours, from the job's summary (`None`: none).
    pub horizon_h: Option<f64>,
    /// `nominal` or `stochastic-NN`.
    pub scenario: String,
    /// The plant's δ (0: nominal).
    pub uncertainty: f64,
    /// The seed of the plant's draws.
    pub seed: u64,
    /// Σ economic terms.
    pub epi: f64,
    /// Σ soft-band penalties.
    pub total_penalty: f64,
    /// EPI − penalties.
    pub cumulative_reward: f64,
    /// Failed solves over the season.
    pub failed_solves: u64,
    /// Steps whose input came from a fallback (a retry or a stand-in input).
    pub fallbacks: u64,
    /// Median solve time, ms.
    pub median_ms: f64,
    /// 95th percentile of the solve times, ms.
    pub p95_ms: f64,
    /// Largest solve time, ms.
    pub max_ms: f64,
    /// Solver iterations per step, on average (0 without a solver).
    pub mean_iterations: f64,
    /// The unit of money.
    pub unit: String,
    /// The job's folder, relative to its study folder.
    pub folder: String,
    /// Its place in its study's plan (`study.json`): rows are reported in plan order.
    pub plan_index: usize,
    /// How many of the folders held this season (repeats of one study, for timing): its
    /// solve times are the median over them.
    pub runs: usize,
    /// Where its EPI comes from (empty for seasons written before the figures existed).
    pub breakdown: Breakdown,
}

/// The complete jobs of the study folders `dirs` (each with its `study.json`), in the
/// order of their plans: the shards of a study, merged, give the rows of the study run
/// whole, in the same order. Where several folders hold the same (model, controller,
/// horizon, scenario) — the same study run again to time it — the first folder's figures
/// are kept and the solve times (median, 95th percentile, largest) are each the median
/// over the runs.
pub fn gather(dirs: &[PathBuf]) -> Result<Vec<JobRow>, StudyError> {
    let mut rows: Vec<JobRow> = Vec::new();
    let mut index: HashMap<(String, String, String, String), usize> = HashMap::new();
    let mut times: Vec<Vec<[f64; 3]>> = Vec::new();
    for dir in dirs {
        let plan_path = dir.join("study.json");
        let plan: serde_json::Value = std::fs::read_to_string(&plan_path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .ok_or_else(|| StudyError::File {
                path: plan_path.clone(),
                message: "no readable study.json: is this the --out folder of `ghm study`?".into(),
            })?;
        for (plan_index, job) in plan["jobs"].as_array().into_iter().flatten().enumerate() {
            let text = |key: &str| job[key].as_str().unwrap_or_default().to_string();
            // Trainings and value fits have no season's figures (plans before them: seasons).
            if job["kind"].as_str().is_some_and(|k| k != "season") {
                continue;
            }
            let job_dir = dir.join(text("folder"));
            if !matches!(folder::recorded(&job_dir), Some((s, _)) if s == "complete") {
                continue;
            }
            let Some(summary) = folder::summary(&job_dir) else {
                continue;
            };
            let m = &summary["metrics"];
            let number = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
            let row = JobRow {
                model: text("model"),
                controller: text("controller"),
                horizon: text("horizon"),
                horizon_h: summary["horizon_h"].as_f64(),
                scenario: text("scenario"),
                uncertainty: job["spec"]["plant"]["uncertainty"].as_f64().unwrap_or(0.0),
                seed: job["spec"]["plant"]["seed"].as_u64().unwrap_or(0),
                epi: number(&m["epi"]),
                total_penalty: number(&m["total_penalty"]),
                cumulative_reward: number(&m["cumulative_reward"]),
                failed_solves: m["solve"]["failed_solves"].as_u64().unwrap_or(0),
                fallbacks: m["solve"]["fallbacks"].as_u64().unwrap_or(0),
                median_ms: number(&m["solve"]["median_ms"]),
                p95_ms: number(&m["solve"]["p95_ms"]),
                max_ms: number(&m["solve"]["max_ms"]),
                mean_iterations: number(&m["solve"]["mean_iterations"]),
                unit: summary["unit"].as_str().unwrap_or_default().to_string(),
                folder: text("folder"),
                plan_index,
                runs: 1,
                breakdown: Breakdown::from_metrics(m),
            };
            let key = (
                row.model.clone(),
                row.controller.clone(),
                row.horizon.clone(),
                row.scenario.clone(),
            );
            let timing = [row.median_ms, row.p95_ms, row.max_ms];
            match index.get(&key) {
                Some(&i) => times[i].push(timing),
                None => {
                    index.insert(key, rows.len());
                    times.push(vec![timing]);
                    rows.push(row);
                }
            }
        }
    }
    for (row, runs) in rows.iter_mut().zip(&times) {
        if runs.len() > 1 {
            let median = |k: usize| {
                let mut v: Vec<f64> = runs.iter().map(|t| t[k]).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            (row.median_ms, row.p95_ms, row.max_ms) = (median(0), median(1), median(2));
            row.runs = runs.len();
        }
    }
    // Stable: where plans differ, a folder's rows stay before the next folder's at equal
    // places.
    rows.sort_by_key(|r| r.plan_index);
    Ok(rows)
}

/// The table lines of one model, in the order the rows first name them.
fn table(rows: &[&JobRow]) -> Vec<TableLine> {
    let mut lines: Vec<TableLine> = Vec::new();
    let mut medians: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
    for r in rows {
        let i = match lines
            .iter()
            .position(|l| l.controller == r.controller && l.horizon == r.horizon)
        {
            Some(i) => i,
            None => {
                lines.push(TableLine {
                    controller: r.controller.clone(),
                    horizon: r.horizon.clone(),
                    horizon_h: r.horizon_h,
                    nominal: None,
                    stochastic: Vec::new(),
                    failed_solves: 0,
                    median_ms: 0.0,
                    max_ms: 0.0,
                });
                lines.len() - 1
            }
        };
        let line = &mut lines[i];
        if r.scenario == "nominal" {
            line.nominal = Some((r.epi, r.cumulative_reward));
            line.median_ms = r.median_ms;
        } else {
            line.stochastic.push((r.epi, r.cumulative_reward));
            // Without a nominal season, the median step of the stochastic ones (their
            // seasons' medians, middle one).
            if line.nominal.is_none() {
                medians.entry(i).or_default().push(r.median_ms);
            }
        }
        line.failed_solves += r.failed_solves;
        line.max_ms = line.max_ms.max(r.max_ms);
    }
    for (i, mut m) in medians {
        if lines[i].nominal.is_none() {
            m.sort_by(f64::total_cmp);
            lines[i].median_ms = m[m.len() / 2];
        }
    }
    lines
}

/// The nominal seasons of one model's `rows`, named for the breakdown table.
fn nominal_seasons<'a>(rows: &[&'a JobRow]) -> Vec<Season<'a>> {
    rows.iter()
        .filter(|r| r.uncertainty == 0.0)
        .map(|r| Season {
            name: if r.horizon.is_empty() {
                r.controller.clone()
            } else {
                format!("{} {}", r.controller, r.horizon)
            },
            epi: r.epi,
            breakdown: &r.breakdown,
        })
        .collect()
}

/// What `ghm report` wrote.
#[derive(Debug, Clone, Default)]
pub struct ReportOutcome {
    /// Complete jobs merged.
    pub jobs: usize,
    /// Models reported.
    pub models: Vec<String>,
    /// The files written, relative to the report's folder, `report.md` first.
    pub files: Vec<String>,
}

/// The report of `rows` as markdown, per model in the paper's layout
/// ([`super::markdown`]); `images` is the path from the document that shows it to the
/// report's folder (with its trailing `/`, or empty for `report.md` itself).
pub fn report_markdown(rows: &[JobRow], images: &str) -> String {
    let mut models: BTreeMap<&str, Vec<&JobRow>> = BTreeMap::new();
    for r in rows {
        models.entry(r.model.as_str()).or_default().push(r);
    }
    let runs = rows.iter().map(|r| r.runs).max().unwrap_or(1);
    let repeats = if runs > 1 {
        format!(" Solve times: the median over the {runs} runs of each season.")
    } else {
        String::new()
    };
    let mut md = format!(
        "\n{} complete seasons. Rewards and EPI in {}; in brackets, the gap to the season optimum \
(negative: below it); stochastic: mean [min, max] over the scenarios.{repeats} Generated by `ghm report`.\n",
        rows.len(),
        rows.first()
            .map_or("the model's unit of money", |r| r.unit.as_str())
    );
    for (model, model_rows) in &models {
        md.push_str(&model_section(model, &table(model_rows), images));
        let unit = model_rows.first().map_or("", |r| r.unit.as_str());
        md.push_str(&breakdown::markdown_table(
            &nominal_seasons(model_rows),
            unit,
        ));
    }
    md
}

/// Writes the report of `rows` into `out`: `results.csv` (every job), per model
/// `<model>.csv` (its table), `<model>-solve-times.csv`, `<model>-breakdown.csv` (where
/// each nominal season's EPI comes from, [`breakdown`]) and `<model>.png` and `.svg` (its
/// figure), and `report.md`.
pub fn write_report(rows: &[JobRow], out: &Path) -> Result<ReportOutcome, StudyError> {
    std::fs::create_dir_all(out).map_err(io_err(out))?;
    let mut models: BTreeMap<&str, Vec<&JobRow>> = BTreeMap::new();
    for r in rows {
        models.entry(r.model.as_str()).or_default().push(r);
    }
    let mut files = vec!["report.md".to_string(), "results.csv".to_string()];
    for (model, model_rows) in &models {
        let lines = table(model_rows);
        write_model_csv(out, model, &lines)?;
        files.extend([format!("{model}.csv"), format!("{model}-solve-times.csv")]);
        if let Some((header, records)) = breakdown::csv_records(&nominal_seasons(model_rows)) {
            let name = format!("{model}-breakdown.csv");
            let path = out.join(&name);
            let text = csv_text(header, records).map_err(io_err(&path))?;
            atomic::write(&path, text).map_err(io_err(&path))?;
            files.push(name);
        }
        let unit = model_rows.first().map_or("", |r| r.unit.as_str());
        draw_model(out, model, &lines, unit)?;
        files.extend([format!("{model}.png"), format!("{model}.svg")]);
    }
    let markdown = format!("# Study report\n{}", report_markdown(rows, ""));
    write_results(out, rows)?;
    let md = out.join("report.md");
    atomic::write(&md, markdown).map_err(io_err(&md))?;
    Ok(ReportOutcome {
        jobs: rows.len(),
        models: models.keys().map(|m| m.to_string()).collect(),
        files,
    })
}

fn number(v: f64) -> String {
    if v.is_finite() {
        format!("{v:e}")
    } else {
        String::new()
    }
}

/// `results.csv`: every job of `rows`, one row each, in their order.
pub fn write_results(out: &Path, rows: &[JobRow]) -> Result<(), StudyError> {
    let header = [
        "model",
        "controller",
        "horizon",
        "horizon_h",
        "scenario",
        "uncertainty",
        "seed",
        "epi",
        "total_penalty",
        "cumulative_reward",
        "failed_solves",
        "fallbacks",
        "median_ms",
        "p95_ms",
        "max_ms",
        "mean_iterations",
        "folder",
    ];
    let records = rows.iter().map(|r| {
        [
            r.model.clone(),
            r.controller.clone(),
            r.horizon.clone(),
            r.horizon_h.map_or(String::new(), |h| format!("{h}")),
            r.scenario.clone(),
            format!("{}", r.uncertainty),
            format!("{}", r.seed),
            number(r.epi),
            number(r.total_penalty),
            number(r.cumulative_reward),
            r.failed_solves.to_string(),
            r.fallbacks.to_string(),
            number(r.median_ms),
            number(r.p95_ms),
            number(r.max_ms),
            number(r.mean_iterations),
            r.folder.clone(),
        ]
    });
    let path = out.join("results.csv");
    let text = csv_text(header, records).map_err(io_err(&path))?;
    atomic::write(&path, text).map_err(io_err(&path))?;
    Ok(())
}

/// `<model>.csv`: the model's table of results, which the same seasons reproduce to the
/// byte (shards merged or the study run whole); `<model>-solve-times.csv`: the solve
/// times beside it, which no two runs share.
fn write_model_csv(out: &Path, model: &str, lines: &[TableLine]) -> Result<(), StudyError> {
    let header = [
        "controller",
        "horizon",
        "horizon_h",
        "epi",
        "cumulative_reward",
        "stochastic_seasons",
        "epi_mean",
        "epi_min",
        "epi_max",
        "reward_mean",
        "reward_min",
        "reward_max",
        "failed_solves",
    ];
    let records = lines.iter().map(|l| {
        let (epi, reward) = l.nominal.unwrap_or((f64::NAN, f64::NAN));
        let e = spread(l.stochastic.iter().map(|s| s.0)).unwrap_or((f64::NAN, f64::NAN, f64::NAN));
        let r = spread(l.stochastic.iter().map(|s| s.1)).unwrap_or((f64::NAN, f64::NAN, f64::NAN));
        [
            l.controller.clone(),
            l.horizon.clone(),
            l.horizon_h.map_or(String::new(), |h| format!("{h}")),
            number(epi),
            number(reward),
            l.stochastic.len().to_string(),
            number(e.0),
            number(e.1),
            number(e.2),
            number(r.0),
            number(r.1),
            number(r.2),
            l.failed_solves.to_string(),
        ]
    });
    let path = out.join(format!("{model}.csv"));
    let text = csv_text(header, records).map_err(io_err(&path))?;
    atomic::write(&path, text).map_err(io_err(&path))?;
    let header = ["controller", "horizon", "horizon_h", "median_ms", "max_ms"];
    let records = lines.iter().map(|l| {
        [
            l.controller.clone(),
            l.horizon.clone(),
            l.horizon_h.map_or(String::new(), |h| format!("{h}")),
            number(l.median_ms),
            number(l.max_ms),
        ]
    });
    let path = out.join(format!("{model}-solve-times.csv"));
    let times = csv_text(header, records).map_err(io_err(&path))?;
    atomic::write(&path, times).map_err(io_err(&path))?;
    Ok(())
}

/// `<model>.png` and `<model>.svg`: EPI and cumulative reward against the horizon on the
/// nominal plant and (where there are stochastic scenarios) their mean, shaded from the
/// minimum to the maximum; a controller without a horizon (the optimum, a policy) is a
/// flat line.
fn draw_model(
    out: &Path,
    model: &str,
    lines: &[TableLine],
    lines_unit: &str,
) -> Result<(), StudyError> {
    let mut hours: Vec<f64> = lines.iter().filter_map(|l| l.horizon_h).collect();
    hours.sort_by(f64::total_cmp);
    hours.dedup();
    if hours.is_empty() {
        hours.push(0.0);
    }
    let mut controllers: Vec<&str> = Vec::new();
    for l in lines {
        if !controllers.contains(&l.controller.as_str()) {
            controllers.push(&l.controller);
        }
    }
    // One series per controller: its value at each horizon of the x axis.
    let series = |value: &dyn Fn(&TableLine) -> Option<f64>| -> Vec<Line> {
        controllers
            .iter()
            .map(|c| {
                let mine: Vec<&TableLine> = lines.iter().filter(|l| l.controller == *c).collect();
                let values = hours
                    .iter()
                    .map(|h| {
                        let at = mine
                            .iter()
                            .find(|l| l.horizon_h.is_none_or(|lh| (lh - h).abs() < 1e-9));
                        at.and_then(|l| value(l)).unwrap_or(f64::NAN)
                    })
                    .collect();
                Line {
                    label: c.to_string(),
                    values,
                }
            })
            .collect()
    };
    let unit = lines_unit.to_string();
    let nominal_panel = |title: &str, pick: fn((f64, f64)) -> f64| Panel {
        title: title.into(),
        unit: unit.clone(),
        lines: series(&|l| l.nominal.map(pick)),
        band: None,
        spreads: Vec::new(),
    };
    let mut panels = Vec::new();
    if lines.iter().any(|l| l.nominal.is_some()) {
        panels.push(nominal_panel("EPI, nominal plant", |n| n.0));
        panels.push(nominal_panel("cumulative reward, nominal plant", |n| n.1));
    }
    if lines.iter().any(|l| !l.stochastic.is_empty()) {
        // Each controller's mean over the scenarios, shaded from its minimum to its maximum.
        let stochastic_panel = |title: &str, pick: fn((f64, f64)) -> f64| {
            let stat = |which: usize| {
                move |l: &TableLine| {
                    spread(l.stochastic.iter().map(|s| pick(*s))).map(|m| [m.0, m.1, m.2][which])
                }
            };
            let lower = series(&stat(1));
            let upper = series(&stat(2));
            Panel {
                title: title.into(),
                unit: unit.clone(),
                lines: series(&stat(0)),
                band: None,
                spreads: lower
                    .into_iter()
                    .zip(upper)
                    .enumerate()
                    .map(|(line, (lo, hi))| Spread {
                        line,
                        lower: lo.values,
                        upper: hi.values,
                    })
                    .collect(),
            }
        };
        panels.push(stochastic_panel(
            "EPI, stochastic: mean, shaded from minimum to maximum",
            |s| s.0,
        ));
        panels.push(stochastic_panel(
            "cumulative reward, stochastic: mean, shaded from minimum to maximum",
            |s| s.1,
        ));
    }
    let fig = Figure {
        title: format!("{model}: against the prediction horizon"),
        x_label: "horizon (h)".into(),
        x: hours,
        panels,
    };
    write_atomically(&out.join(format!("{model}.png")), |path| {
        draw_png(&fig, path)
    })?;
    write_atomically(&out.join(format!("{model}.svg")), |path| {
        draw_svg(&fig, path)
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(controller: &str, horizon: Option<f64>, scenario: &str, reward: f64) -> JobRow {
        JobRow {
            model: "m".into(),
            controller: controller.into(),
            horizon: horizon.map_or(String::new(), |h| format!("{h}h")),
            horizon_h: horizon,
            scenario: scenario.into(),
            uncertainty: 0.0,
            seed: 0,
            epi: reward + 1.0,
            total_penalty: 1.0,
            cumulative_reward: reward,
            failed_solves: 1,
            fallbacks: 1,
            median_ms: 2.0,
            p95_ms: 3.0,
            max_ms: 4.0,
            mean_iterations: 9.0,
            unit: "€".into(),
            folder: String::new(),
            plan_index: 0,
            runs: 1,
            breakdown: Breakdown::default(),
        }
    }

    /// A study folder with one complete season of `median_ms` / `max_ms` and `reward`.
    fn study_folder(dir: &Path, median_ms: f64, max_ms: f64, reward: f64) {
        let job = dir.join("m/mpc-1h/nominal");
        std::fs::create_dir_all(&job).unwrap();
        let plan = serde_json::json!({"jobs": [{"kind": "season", "model": "m",
            "controller": "MPC", "horizon": "1h", "scenario": "nominal",
            "folder": "m/mpc-1h/nominal", "spec": {}}]});
        std::fs::write(dir.join("study.json"), plan.to_string()).unwrap();
        std::fs::write(
            job.join("run.json"),
            r#"{"status": "complete", "spec": {}}"#,
        )
        .unwrap();
        let summary = serde_json::json!({"horizon_h": 1.0, "unit": "€", "metrics": {
            "epi": reward + 1.0, "total_penalty": 1.0, "cumulative_reward": reward,
            "solve": {"failed_solves": 0, "fallbacks": 0, "median_ms": median_ms,
                "p95_ms": median_ms, "max_ms": max_ms, "mean_iterations": 9.0}}});
        std::fs::write(job.join("summary.json"), summary.to_string()).unwrap();
    }

    #[test]
    fn a_season_run_several_times_reports_the_median_of_its_solve_times() {
        let root = std::env::temp_dir().join(format!("ghm-report-repeats-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dirs: Vec<PathBuf> = (0..3).map(|r| root.join(format!("r{r}"))).collect();
        study_folder(&dirs[0], 2.0, 30.0, 3.0);
        study_folder(&dirs[1], 1.0, 9.0, 3.5);
        study_folder(&dirs[2], 1.5, 8.0, 3.0);
        let rows = gather(&dirs).unwrap();
        assert_eq!(rows.len(), 1);
        let r = &rows[0];
        assert_eq!((r.median_ms, r.max_ms, r.runs), (1.5, 9.0, 3));
        assert_eq!(
            r.cumulative_reward, 3.0,
            "the first folder's figures are kept"
        );
        assert!(report_markdown(&rows, "").contains("the median over the 3 runs"));
        let single = gather(&dirs[1..2]).unwrap();
        assert_eq!((single[0].max_ms, single[0].runs), (9.0, 1));
        assert!(!report_markdown(&single, "").contains("median over"));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_table_line_holds_the_nominal_season_and_the_spread_of_the_others() {
        let rows = [
            row("MPC", Some(1.0), "nominal", 3.0),
            row("MPC", Some(1.0), "stochastic-00", 2.0),
            row("MPC", Some(1.0), "stochastic-01", 4.5),
            row("MPC", Some(2.0), "nominal", 3.5),
            row("optimum", None, "nominal", 5.0),
        ];
        let refs: Vec<&JobRow> = rows.iter().collect();
        let lines = table(&refs);
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0].nominal, Some((4.0, 3.0)));
        assert_eq!(lines[0].failed_solves, 3);
        let (mean, lo, hi) = spread(lines[0].stochastic.iter().map(|s| s.1)).unwrap();
        assert_eq!((mean, lo, hi), (3.25, 2.0, 4.5));
        assert!(lines[2].stochastic.is_empty());
        let md = model_section("m", &lines, "");
        assert!(
            md.contains("| MPC reward | 3.2500 [2.000, 4.500] · 3 failed solves | — |"),
            "{md}"
        );
        assert!(
            md.contains("Season optimum: EPI 6.0000, cumulative reward 5.0000."),
            "{md}"
        );
    }

    #[test]
    fn csv_fields_with_commas_are_quoted() {
        let text = csv_text(["c"], [["MPC"], ["RL-MPC (sac, 6h)"], ["a\"b"]]).unwrap();
        assert_eq!(text, "c\nMPC\n\"RL-MPC (sac, 6h)\"\n\"a\"\"b\"\n");
    }
}
