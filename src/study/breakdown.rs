//! Where each nominal season's EPI comes from: one row per controller and horizon, with
//! each stage term's total, the hours outside each soft band and each input's mean, as the
//! seasons' `summary.json` records them ([`crate::sim::metrics::Metrics`]). Seasons written
//! before those figures existed have none and are left out. The report
//! ([`super::report`]) names the seasons; this module reads their figures and lays out
//! the table.

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

/// One season's row of the table: its name (controller and horizon), EPI and breakdown.
#[derive(Debug, Clone)]
pub struct Season<'a> {
    /// The controller, and its horizon where it has one (`MPC 1h`).
    pub name: String,
    /// Its EPI, the sum of its terms.
    pub epi: f64,
    /// Where the EPI comes from.
    pub breakdown: &'a Breakdown,
}

/// The column names: each term, the EPI, each band's hours, each input's mean (taken from
/// the first season: one model's seasons share them).
fn columns(first: &Breakdown) -> Vec<String> {
    let mut names: Vec<String> = first.terms.iter().map(|t| t.0.clone()).collect();
    names.push("EPI".into());
    names.extend(
        first
            .band_hours
            .iter()
            .map(|t| format!("h outside {}", t.0)),
    );
    names.extend(first.input_means.iter().map(|t| format!("mean {}", t.0)));
    names
}

fn cells(season: &Season, format: impl Fn(f64, usize) -> String) -> Vec<String> {
    let b = season.breakdown;
    let mut out: Vec<String> = b.terms.iter().map(|t| format(t.1, 0)).collect();
    out.push(format(season.epi, 0));
    out.extend(b.band_hours.iter().map(|t| format(t.1, 1)));
    out.extend(b.input_means.iter().map(|t| format(t.1, 2)));
    out
}

/// The seasons of `seasons` that have a breakdown.
fn with_breakdown<'a, 'b>(seasons: &'b [Season<'a>]) -> Vec<&'b Season<'a>> {
    seasons.iter().filter(|s| !s.breakdown.is_empty()).collect()
}

/// The markdown table of one model's nominal `seasons` (money in `unit`), or nothing
/// where none has a breakdown.
pub(super) fn markdown_table(seasons: &[Season], unit: &str) -> String {
    let seasons = with_breakdown(seasons);
    let Some(first) = seasons.first() else {
        return String::new();
    };
    let names = columns(first.breakdown);
    let mut md = format!(
        "\nWhere the EPI comes from (nominal plant; terms in {unit}, rewards positive, costs \
negative; hours outside each band; each input's mean over the season):\n\n| season | {} |\n|---|{}\n",
        names.join(" | "),
        "---|".repeat(names.len())
    );
    for season in seasons {
        let values = cells(season, |v, kind| match kind {
            0 => figure(v, false),
            1 => format!("{v:.1}"),
            _ => format!("{v:.3}"),
        });
        md.push_str(&format!("| {} | {} |\n", season.name, values.join(" | ")));
    }
    md
}

/// The CSV header and records of the same table (full precision), or `None` where no
/// season has a breakdown.
pub(super) fn csv_records(seasons: &[Season]) -> Option<(Vec<String>, Vec<Vec<String>>)> {
    let seasons = with_breakdown(seasons);
    let first = seasons.first()?;
    let mut header = vec!["season".to_string()];
    header.extend(columns(first.breakdown));
    let records = seasons
        .iter()
        .map(|season| {
            let mut record = vec![season.name.clone()];
            record.extend(cells(season, |v, _| format!("{v:e}")));
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

    fn breakdown(fruit: f64) -> Breakdown {
        Breakdown {
            terms: vec![("fruit".into(), fruit), ("heat".into(), -1.0)],
            band_hours: vec![("t".into(), 2.5)],
            input_means: vec![("lamp".into(), 0.125)],
        }
    }

    #[test]
    fn the_table_has_a_row_per_season_with_figures_and_its_terms_sum_to_the_epi() {
        let (rules, mpc, none) = (breakdown(3.0), breakdown(4.0), Breakdown::default());
        let season = |name: &str, epi: f64, breakdown| Season {
            name: name.into(),
            epi,
            breakdown,
        };
        let seasons = [
            season("Rules", 2.0, &rules),
            season("MPC 1h", 3.0, &mpc),
            season("Old", 8.0, &none),
        ];
        let md = markdown_table(&seasons, "€");
        assert!(md.contains("terms in €"), "{md}");
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
        let (header, records) = csv_records(&seasons).unwrap();
        assert_eq!(header[0], "season");
        assert_eq!(records.len(), 2);
        assert_eq!(records[1][..4], ["MPC 1h", "4e0", "-1e0", "3e0"]);
        assert!(markdown_table(&seasons[2..], "€").is_empty());
        assert!(csv_records(&seasons[2..]).is_none());
    }
}
