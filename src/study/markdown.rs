//! `report.md` in the paper's layout, and its splice into a hand-written document.
//!
//! Per model: the figure, the season optimum, the controllers without a horizon, then one
//! table with the horizons as columns — each controller's cumulative reward and EPI on the
//! nominal plant with the gap to the optimum — one of the stochastic scenarios (mean and
//! min–max range), and one of the solve times. Failed solves are named in the cell where
//! they happened, and counted per controller (zeros included) under the tables.
//!
//! `ghm report --into FILE` puts the report into a document between two markers,
//! `<!-- begin ghm report NAME -->` and `<!-- end ghm report NAME -->` (`NAME`: the
//! report's folder as the document's links see it), so that the prose around the tables
//! stays as written and the tables are regenerated with the figures.

use super::table::{spread, TableLine};
use crate::job::output::figure;

/// A model's section: `images` is the path from the document to the report's folder
/// (with its trailing `/`, or empty).
pub(super) fn model_section(model: &str, lines: &[TableLine], images: &str) -> String {
    let mut md = format!(
        "\n### {model}\n\n![{model}: against the prediction horizon]({images}{model}.svg)\n\n"
    );
    let optimum = lines
        .iter()
        .find(|l| l.controller == "optimum" && l.horizon.is_empty())
        .and_then(|l| l.nominal);
    if let Some((epi, reward)) = optimum {
        md.push_str(&format!(
            "Season optimum: EPI {}, cumulative reward {}.\n\n",
            figure(epi, false),
            figure(reward, false)
        ));
    }
    let gap = |reward: f64| match optimum {
        Some((_, best)) => format!(" ({:+.3})", reward - best),
        None => String::new(),
    };
    let failed = |n: u64| match n {
        0 => String::new(),
        1 => " · 1 failed solve".into(),
        n => format!(" · {n} failed solves"),
    };
    for l in lines
        .iter()
        .filter(|l| l.horizon.is_empty() && l.controller != "optimum")
    {
        let mut parts = Vec::new();
        if let Some((epi, reward)) = l.nominal {
            parts.push(format!(
                "EPI {}, cumulative reward {}{}",
                figure(epi, false),
                figure(reward, false),
                gap(reward)
            ));
        }
        if let Some(s) = stochastic_cell(l, |s| s.1) {
            parts.push(format!("stochastic reward {s}"));
        }
        md.push_str(&format!("- {} alone: {}\n", l.controller, parts.join("; ")));
    }

    let horizons = horizons(lines);
    if horizons.is_empty() {
        return md;
    }
    let controllers = controllers_with_horizon(lines);
    let at = |c: &str, h: &str| lines.iter().find(|l| l.controller == c && l.horizon == h);
    let header = |first: &str| {
        let mut head = format!("\n| {first} |");
        let mut rule = String::from("|---|");
        for h in &horizons {
            head.push_str(&format!(" {h} |"));
            rule.push_str("---|");
        }
        format!("{head}\n{rule}\n")
    };
    let row = |name: String, cell: &dyn Fn(&TableLine) -> Option<String>, c: &str| {
        let mut text = format!("| {name} |");
        for h in &horizons {
            let value = at(c, h).and_then(cell).unwrap_or_else(|| "—".into());
            text.push_str(&format!(" {value} |"));
        }
        text.push('\n');
        text
    };

    if lines
        .iter()
        .any(|l| !l.horizon.is_empty() && l.nominal.is_some())
    {
        md.push_str(&header("nominal plant"));
        for c in &controllers {
            md.push_str(&row(
                format!("{c} reward"),
                &|l| {
                    l.nominal.map(|(_, reward)| {
                        format!(
                            "{}{}{}",
                            figure(reward, false),
                            gap(reward),
                            failed(l.failed_solves)
                        )
                    })
                },
                c,
            ));
            md.push_str(&row(
                format!("{c} EPI"),
                &|l| l.nominal.map(|(epi, _)| figure(epi, false)),
                c,
            ));
        }
    }
    if lines.iter().any(|l| !l.stochastic.is_empty()) {
        md.push_str(&header("stochastic: mean [min, max]"));
        for c in &controllers {
            md.push_str(&row(
                format!("{c} reward"),
                &|l| stochastic_cell(l, |s| s.1).map(|s| format!("{s}{}", failed(l.failed_solves))),
                c,
            ));
            md.push_str(&row(
                format!("{c} EPI"),
                &|l| stochastic_cell(l, |s| s.0),
                c,
            ));
        }
    }
    md.push_str(&header("solve time, median / max (ms)"));
    for c in &controllers {
        md.push_str(&row(
            c.to_string(),
            &|l| Some(format!("{:.2} / {:.1}", l.median_ms, l.max_ms)),
            c,
        ));
    }
    md.push_str(&failed_per_controller(lines, &controllers));
    md
}

/// One line that counts each controller's failed solves over all its seasons (every
/// horizon and scenario), zeros included: the tables name only the cells that had one.
fn failed_per_controller(lines: &[TableLine], controllers: &[String]) -> String {
    let counts: Vec<String> = controllers
        .iter()
        .map(|c| {
            let (failed, seasons) = lines
                .iter()
                .filter(|l| &l.controller == c && !l.horizon.is_empty())
                .fold((0, 0), |(f, s), l| {
                    (
                        f + l.failed_solves,
                        s + usize::from(l.nominal.is_some()) + l.stochastic.len(),
                    )
                });
            let plural = if seasons == 1 { "" } else { "s" };
            format!("{c} {failed} ({seasons} season{plural})")
        })
        .collect();
    format!(
        "\nFailed solves per controller, over all its seasons: {}.\n",
        counts.join(", ")
    )
}

/// `mean [min, max]` of one figure over a line's stochastic seasons.
fn stochastic_cell(l: &TableLine, pick: fn((f64, f64)) -> f64) -> Option<String> {
    let (mean, lo, hi) = spread(l.stochastic.iter().map(|s| pick(*s)))?;
    Some(format!("{} [{lo:.3}, {hi:.3}]", figure(mean, false)))
}

/// The horizons of the lines, shortest first.
fn horizons(lines: &[TableLine]) -> Vec<String> {
    let mut hs: Vec<(f64, String)> = lines
        .iter()
        .filter(|l| !l.horizon.is_empty())
        .map(|l| (l.horizon_h.unwrap_or(f64::NAN), l.horizon.clone()))
        .collect();
    hs.sort_by(|a, b| a.0.total_cmp(&b.0));
    hs.dedup_by(|a, b| a.1 == b.1);
    hs.into_iter().map(|(_, h)| h).collect()
}

/// The controllers that have a horizon, in the order the lines first name them.
fn controllers_with_horizon(lines: &[TableLine]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for l in lines.iter().filter(|l| !l.horizon.is_empty()) {
        if !names.contains(&l.controller) {
            names.push(l.controller.clone());
        }
    }
    names
}

/// `document` with the text between its markers for `name` replaced by `generated`; an
/// error says which marker is missing.
pub fn splice(document: &str, name: &str, generated: &str) -> Result<String, String> {
    let begin = format!("<!-- begin ghm report {name} -->");
    let end = format!("<!-- end ghm report {name} -->");
    let missing = |marker: &str| {
        format!("has no line `{marker}`: put the two markers where the report of {name} goes")
    };
    let start = document.find(&begin).ok_or_else(|| missing(&begin))? + begin.len();
    let stop = document[start..]
        .find(&end)
        .map(|i| start + i)
        .ok_or_else(|| missing(&end))?;
    Ok(format!(
        "{}\n{}\n{}",
        &document[..start],
        generated.trim(),
        &document[stop..]
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(controller: &str, horizon: &str, h: Option<f64>, reward: f64) -> TableLine {
        TableLine {
            controller: controller.into(),
            horizon: horizon.into(),
            horizon_h: h,
            nominal: Some((reward + 0.5, reward)),
            stochastic: Vec::new(),
            failed_solves: 0,
            median_ms: 1.0,
            max_ms: 2.0,
        }
    }

    #[test]
    fn horizons_are_columns_with_the_gap_to_the_optimum() {
        let mut mpc2 = line("MPC", "2h", Some(2.0), 4.5);
        mpc2.failed_solves = 3;
        let lines = vec![
            line("optimum", "", None, 4.75),
            line("SAC", "", None, 4.25),
            mpc2,
            line("MPC", "1h", Some(1.0), 3.75),
        ];
        let md = model_section("lettuce", &lines, "results/");
        assert!(md.contains("![lettuce: against the prediction horizon](results/lettuce.svg)"));
        assert!(
            md.contains("Season optimum: EPI 5.2500, cumulative reward 4.7500."),
            "{md}"
        );
        assert!(
            md.contains("- SAC alone: EPI 4.7500, cumulative reward 4.2500 (-0.500)"),
            "{md}"
        );
        assert!(md.contains("| nominal plant | 1h | 2h |"), "{md}");
        assert!(
            md.contains("| MPC reward | 3.7500 (-1.000) | 4.5000 (-0.250) · 3 failed solves |"),
            "{md}"
        );
        assert!(md.contains("| MPC | 1.00 / 2.0 | 1.00 / 2.0 |"), "{md}");
    }

    #[test]
    fn failed_solves_are_counted_per_controller_zeros_included() {
        let mut mpc = line("MPC", "1h", Some(1.0), 3.75);
        mpc.failed_solves = 2;
        mpc.stochastic = vec![(4.0, 3.5), (4.1, 3.6)];
        let mut mpc6 = line("MPC", "6h", Some(6.0), 4.0);
        mpc6.failed_solves = 1;
        let lines = vec![
            line("SAC", "", None, 4.25),
            mpc,
            mpc6,
            line("RL-MPC", "1h", Some(1.0), 4.0),
        ];
        let md = model_section("lettuce", &lines, "");
        assert!(
            md.contains(
                "Failed solves per controller, over all its seasons: MPC 3 (4 seasons), \
                 RL-MPC 0 (1 season)."
            ),
            "{md}"
        );
    }

    #[test]
    fn a_splice_replaces_only_the_marked_block() {
        let doc = "intro\n<!-- begin ghm report r -->\nold\n<!-- end ghm report r -->\noutro\n";
        let out = splice(doc, "r", "\nnew table\n").unwrap();
        assert_eq!(
            out,
            "intro\n<!-- begin ghm report r -->\nnew table\n<!-- end ghm report r -->\noutro\n"
        );
        assert_eq!(splice(&out, "r", "new table").unwrap(), out);
        let err = splice("no markers", "r", "x").unwrap_err();
        assert!(err.contains("<!-- begin ghm report r -->"), "{err}");
    }
}
