//! A distillation's files: the labels of each iteration (written, and read back when a
//! job continues), the curve of its students against the teacher, and the summary.

use super::roll_outs::Labelled;
use super::{best_of, IterationRecord, Job};
use crate::job::output::{io_err, model_hash, write_atomically, write_summary};
use crate::job::JobError;
use crate::report::plot::{draw_xy, Line};
use crate::report::table::csv_text;
use crate::rl::imitation::Demonstrations;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

impl Job<'_> {
    fn labels_path(&self, iteration: usize) -> PathBuf {
        self.out
            .join("labels")
            .join(format!("iteration-{iteration:02}.csv"))
    }

    /// `labels/iteration-NN.csv`: the roll-out, the observation (its `step` is the season's)
    /// and the teacher's action.
    pub(super) fn write_labels(
        &self,
        iteration: usize,
        names: &[String],
        labelled: &Labelled,
    ) -> Result<(), JobError> {
        let path = self.labels_path(iteration);
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        }
        let header: Vec<String> = std::iter::once("roll_out".to_string())
            .chain(names.iter().cloned())
            .chain(
                self.plant
                    .model
                    .inputs
                    .iter()
                    .map(|u| format!("action_{}", u.info.name)),
            )
            .collect();
        let d = &labelled.demonstrations;
        let rows = (0..d.len()).map(|i| {
            std::iter::once(labelled.roll_out[i].to_string())
                .chain(
                    d.observations[i * d.width..(i + 1) * d.width]
                        .iter()
                        .chain(&d.actions[i * d.actions_per_row..(i + 1) * d.actions_per_row])
                        .map(|v| v.to_string()),
                )
                .collect::<Vec<_>>()
        });
        write_atomically(&path, |p| std::fs::write(p, csv_text(header, rows)?))
    }

    /// Reads back the labels of a finished iteration (a resumed job).
    pub(super) fn read_labels(
        &self,
        iteration: usize,
        width: usize,
        nu: usize,
    ) -> Result<Demonstrations, JobError> {
        let path = self.labels_path(iteration);
        let fail = |message: String| JobError::Resume {
            path: path.clone(),
            message,
        };
        let text = std::fs::read_to_string(&path).map_err(|e| fail(e.to_string()))?;
        let mut data = Demonstrations::new(width, nu);
        for (line, row) in text.lines().enumerate().skip(1) {
            let values: Vec<f64> = row
                .split(',')
                .skip(1)
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|e| fail(format!("line {}: {e}", line + 1)))?;
            if values.len() != width + nu {
                return Err(fail(format!(
                    "line {}: {} values, expected {}",
                    line + 1,
                    values.len(),
                    width + nu
                )));
            }
            data.push(&values[..width], &values[width..])?;
        }
        Ok(data)
    }

    /// `distill_curve.csv` and `distill_curve.png`.
    pub(super) fn write_curve(
        &self,
        curve: &[IterationRecord],
        unit: &str,
    ) -> Result<(), JobError> {
        let header = [
            "iteration",
            "labels",
            "roll_out_reward",
            "student_reward",
            "fit_loss",
            "failed_labels",
            "label_s",
            "fit_s",
        ];
        let rows = curve.iter().map(|r| {
            [
                r.iteration.to_string(),
                r.labels.to_string(),
                r.roll_out_reward.to_string(),
                r.student_reward.to_string(),
                r.fit_loss.to_string(),
                r.failed_labels.to_string(),
                format!("{:.3}", r.label_s),
                format!("{:.3}", r.fit_s),
            ]
        });
        write_atomically(&self.out.join("distill_curve.csv"), |p| {
            std::fs::write(p, csv_text(header, rows)?)
        })?;
        let x: Vec<f64> = curve.iter().map(|r| r.iteration as f64).collect();
        let teacher = curve.first().map_or(f64::NAN, |r| r.roll_out_reward);
        let lines = [
            Line {
                label: "student".into(),
                values: curve.iter().map(|r| r.student_reward).collect(),
            },
            Line {
                label: "teacher".into(),
                values: vec![teacher; curve.len()],
            },
        ];
        write_atomically(&self.out.join("distill_curve.png"), |p| {
            draw_xy(
                "Policy distillation (DAgger)",
                "iteration",
                &format!("cumulative reward [{unit}]"),
                &x,
                &lines,
                p,
            )
        })
    }

    pub(super) fn write_summary(
        &self,
        curve: &[IterationRecord],
        started: &Instant,
    ) -> Result<(), JobError> {
        let model = &self.plant.model;
        let best = best_of(curve);
        let summary = json!({
            "command": std::env::args().collect::<Vec<_>>(),
            "model": self.spec.model.display().to_string(),
            "model_name": model.name,
            "model_sha256": model_hash(&self.plant),
            "weather": self.spec.weather.describe(model),
            "episode_steps": self.steps,
            "spec": self.spec,
            "finished": curve.len() == self.spec.iterations,
            "iterations_done": curve.len(),
            "teacher_reward": curve.first().map(|r| r.roll_out_reward),
            "best": best.map(|b| json!({ "iteration": b.iteration, "student_reward": b.student_reward })),
            "labels": curve.last().map_or(0, |r| r.labels),
            "label_s": curve.iter().map(|r| r.label_s).sum::<f64>(),
            "fit_s": curve.iter().map(|r| r.fit_s).sum::<f64>(),
            "this_session_s": started.elapsed().as_secs_f64(),
            "curve": curve,
        });
        write_summary(self.out, &summary)
    }
}
