//! Where each nominal season's EPI comes from: one row per controller and horizon, with
//! each stage term's total, the hours outside each soft band and each input's mean, as the
//! seasons' `summary.json` records them ([`crate::sim::metrics::Metrics`]). Seasons written
//! before those figures existed have none and are left out.

use super::report::JobRow;
use crate::job::output::figure;

/// A season's figures by name, in the model's order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Breakdown {
    /// Each stage term's total over the season (rewards positive, costs negative).
    pub terms: Vec<(String, f64)>,
    /// Each soft band's hours outside it.
    pub band_hours: Vec<(String, f64)>,
    /// Each input's mean over the season.
    pub input_means: Vec<(String, f64)>,
}

impl Breakdown {
    /// The figures in a season's `metrics` (its `summary.json`); empty where it has no
    /// `terms`.
    pub fn from_metrics(metrics: &serde_json::Value) -> Breakdown {
        let pairs = |list: &str, name: &str, value: &str| -> Vec<(String, f64)> {
            metrics[list]
                .as_array()
                .into_iter()
                .flatten()
                .map(|entry| {
                    (
                        entry[name].as_str().unwrap_or_default().to_string(),
                        entry[value].as_f64().unwrap_or(f64::NAN),
                    )
                })
                .collect()
        };
        let terms = pairs("terms", "name", "total");
        if terms.is_empty() {
            return Breakdown::default();
        }
        Breakdown {
            terms,
            band_hours: pairs("bands", "output", "hours_outside"),
            input_means: pairs("inputs", "name", "mean"),
        }
    }

    fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
}

/// The nominal seasons of one model's `rows` that have a breakdown, in their order.
fn nominal<'a>(rows: &[&'a JobRow]) -> Vec<&'a JobRow> {
    rows.iter()
        .copied()
        .filter(|r| r.uncertainty == 0.0 && !r.breakdown.is_empty())
        .collect()
}

fn season_name(r: &JobRow) -> String {
    if r.horizon.is_empty() {
        r.controller.clone()
    } else {
        format!("{} {}", r.controller, r.horizon)
    }
}

/// The column names: each term, the EPI, each band's hours, each input's mean (taken from
/// the first row: one model's seasons share them).
fn columns(first: &JobRow) -> Vec<String> {
    let b = &first.breakdown;
    let mut names: Vec<String> = b.terms.iter().map(|t| t.0.clone()).collect();
    names.push("EPI".into());
    names.extend(b.band_hours.iter().map(|t| format!("h outside {}", t.0)));
    names.extend(b.input_means.iter().map(|t| format!("mean {}", t.0)));
    names
}

fn cells(r: &JobRow, format: impl Fn(f64, usize) -> String) -> Vec<String> {
    let b = &r.breakdown;
    let mut out: Vec<String> = b.terms.iter().map(|t| format(t.1, 0)).collect();
    out.push(format(r.epi, 0));
    out.extend(b.band_hours.iter().map(|t| format(t.1, 1)));
    out.extend(b.input_means.iter().map(|t| format(t.1, 2)));
    out
}

/// The markdown table of one model's nominal seasons, or nothing where none has a
/// breakdown.
pub(super) fn markdown_table(rows: &[&JobRow]) -> String {
    let seasons = nominal(rows);
    let Some(first) = seasons.first() else {
        return String::new();
    };
    let names = columns(first);
    let mut md = format!(
        "\nWhere the EPI comes from (nominal plant; terms in {}, rewards positive, costs negative; \
hours outside each band; each input's mean over the season):\n\n| season | {} |\n|---|{}\n",
        first.unit,
        names.join(" | "),
        "---|".repeat(names.len())
    );
    for r in seasons {
        let values = cells(r, |v, kind| match kind {
            0 => figure(v, false),
            1 => format!("{v:.1}"),
            _ => format!("{v:.3}"),
        });
        md.push_str(&format!(
            "| {} | {} |\n",
            season_name(r),
            values.join(" | ")
        ));
    }
    md
}

/// The CSV header and records of the same table (full precision), or `None` where no
/// season has a breakdown.
pub(super) fn csv_records(rows: &[&JobRow]) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let seasons = nominal(rows);
    let first = seasons.first()?;
    let mut header = vec!["season".to_string()];
    header.extend(columns(first));
    let records = seasons
        .iter()
        .map(|r| {
            let mut record = vec![season_name(r)];
            record.extend(cells(r, |v, _| format!("{v:e}")));
            record
        })
        .collect();
    Some((header, records))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_summary_without_terms_has_no_breakdown_and_one_with_them_keeps_their_order() {
        let old = serde_json::json!({"epi": 1.0, "bands": [{"output": "t", "hours_outside": 2.0}]});
        assert_eq!(Breakdown::from_metrics(&old), Breakdown::default());
        let new = serde_json::json!({
            "bands": [{"output": "t", "hours_outside": 2.0}],
            "terms": [{"name": "fruit", "total": 3.0}, {"name": "heat", "total": -1.0}],
            "inputs": [{"name": "lamp", "mean": 0.25}],
        });
        let b = Breakdown::from_metrics(&new);
        assert_eq!(
            b.terms,
            [("fruit".to_string(), 3.0), ("heat".to_string(), -1.0)]
        );
        assert_eq!(b.band_hours, [("t".to_string(), 2.0)]);
        assert_eq!(b.input_means, [("lamp".to_string(), 0.25)]);
    }

    fn season(controller: &str, horizon: &str, uncertainty: f64, fruit: f64) -> JobRow {
        JobRow {
            model: "m".into(),
            controller: controller.into(),
            horizon: horizon.into(),
            horizon_h: None,
            scenario: "nominal".into(),
            uncertainty,
            seed: 0,
            epi: fruit - 1.0,
            total_penalty: 0.0,
            cumulative_reward: fruit - 1.0,
            failed_solves: 0,
            fallbacks: 0,
            median_ms: 1.0,
            p95_ms: 1.0,
            max_ms: 1.0,
            mean_iterations: 1.0,
            unit: "€".into(),
            folder: String::new(),
            plan_index: 0,
            runs: 1,
            breakdown: Breakdown {
                terms: vec![("fruit".into(), fruit), ("heat".into(), -1.0)],
                band_hours: vec![("t".into(), 2.5)],
                input_means: vec![("lamp".into(), 0.125)],
            },
        }
    }

    #[test]
    fn the_table_has_a_row_per_nominal_season_and_its_terms_sum_to_the_epi() {
        let mut old = season("Old", "", 0.0, 9.0);
        old.breakdown = Breakdown::default();
        let rows = [
            season("Rules", "", 0.0, 3.0),
            season("MPC", "1h", 0.0, 4.0),
            season("MPC", "1h", 0.1, 5.0),
            old,
        ];
        let refs: Vec<&JobRow> = rows.iter().collect();
        let md = markdown_table(&refs);
        assert!(
            md.contains("| season | fruit | heat | EPI | h outside t | mean lamp |"),
            "{md}"
        );
        assert!(
            md.contains("| Rules | 3.0000 | -1.0000 | 2.0000 | 2.5 | 0.125 |"),
            "{md}"
        );
        assert!(
            md.contains("| MPC 1h | 4.0000 | -1.0000 | 3.0000 |"),
            "{md}"
        );
        assert_eq!(
            md.matches("\n| ").count(),
            3,
            "header and two seasons: {md}"
        );
        let (header, records) = csv_records(&refs).unwrap();
        assert_eq!(header[0], "season");
        assert_eq!(records.len(), 2);
        assert_eq!(records[1][..4], ["MPC 1h", "4e0", "-1e0", "3e0"]);
        assert!(markdown_table(&refs[3..]).is_empty());
        assert!(csv_records(&refs[3..]).is_none());
    }
}
