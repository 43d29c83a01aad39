//! Markdown tables of a `report.json` for the documentation, so that the numbers the README and
//! `docs/results.md` quote from the default suite are generated from the committed baseline
//! report and cannot go stale.
//!
//! A document holds **generated blocks** between marker comments:
//!
//! ```text
//! <!-- results-table:begin -->
//! …generated Markdown, never edited by hand…
//! <!-- results-table:end -->
//! ```
//!
//! [`update_blocks`] rewrites every block of a document from a report (`loomlab table REPORT
//! --update FILE`, `make readme-table`); [`stale_blocks`] names the blocks that differ (`--check`,
//! and the test `docs::generated_tables_match_the_baseline`). The block names are [`BLOCKS`]; an
//! unknown or unterminated marker is an error, so a typo cannot silently freeze a table.
//!
//! Rows: the report's detector rows (in the report's order, i.e. by label), then its reference rows
//! (in the order of `references`), marked `*`. Nothing here knows which detectors or reference
//! rows exist: re-blessing a baseline with other rows regenerates the tables with them.

use std::fmt::Write as _;

use loomlab_scenarios::metrics::DetectorSummary;
use loomlab_scenarios::report::Report;
use loomlab_scenarios::stats::Interval;

/// The command that regenerates every block of the documentation from the committed baseline.
pub const REGENERATE: &str = "make readme-table";

/// The generated blocks: name and what it holds.
pub const BLOCKS: [(&str, &str); 6] = [
    (
        "results-table",
        "pooled rates of every row, with 95 % intervals (README)",
    ),
    (
        "results-takeaways",
        "three sentences with the numbers they rest on (README)",
    ),
    (
        "results-full",
        "pooled counts, misses, collisions and the l/|v| fit of every row (docs/results.md)",
    ),
    (
        "results-per-scenario",
        "per scenario: threats, non-threats, required angular size, reference and best detector rows",
    ),
    ("results-suite", "one line: suite, seed, episodes, threats"),
    (
        "results-tiers",
        "per difficulty tier: counts, every row's evasion and false-alarm rate, the worst tier",
    ),
];

/// The Markdown of block `name` for `report` (`None`: no such block).
pub fn render_block(name: &str, report: &Report) -> Option<String> {
    Some(match name {
        "results-table" => results_table(report),
        "results-takeaways" => takeaways(report),
        "results-full" => full_table(report),
        "results-per-scenario" => per_scenario_table(report),
        "results-suite" => suite_line(report),
        "results-tiers" => tiers_table(report),
        _ => return None,
    })
}

fn begin_marker(name: &str) -> String {
    format!("<!-- {name}:begin -->")
}

fn end_marker(name: &str) -> String {
    format!("<!-- {name}:end -->")
}

/// A generated block found in a document.
struct Found {
    name: String,
    /// Byte range of the content between the begin marker's line end and the end marker.
    content: std::ops::Range<usize>,
}

/// Every generated block of `text`, in order. Errors: an unknown block name, a begin marker
/// without its end marker.
fn find_blocks(text: &str) -> Result<Vec<Found>, String> {
    let mut found = Vec::new();
    let mut at = 0;
    while let Some(rel) = text[at..].find("<!-- ") {
        let start = at + rel;
        let Some(close) = text[start..].find("-->") else {
            break;
        };
        let comment = &text[start + 5..start + close];
        at = start + close + 3;
        let Some(name) = comment.trim().strip_suffix(":begin") else {
            continue;
        };
        if !BLOCKS.iter().any(|(b, _)| *b == name) {
            let known: Vec<&str> = BLOCKS.iter().map(|(b, _)| *b).collect();
            return Err(format!(
                "unknown generated block `{name}` (known: {})",
                known.join(", ")
            ));
        }
        let content_start = text[at..].find('\n').map_or(text.len(), |n| at + n + 1);
        let end = end_marker(name);
        let Some(end_rel) = text[content_start..].find(&end) else {
            return Err(format!("`{}` has no `{end}`", begin_marker(name)));
        };
        let content_end = content_start + end_rel;
        found.push(Found {
            name: name.to_string(),
            content: content_start..content_end,
        });
        at = content_end + end.len();
    }
    Ok(found)
}

/// `text` with every generated block rewritten from `report`, and the number of blocks.
pub fn update_blocks(text: &str, report: &Report) -> Result<(String, usize), String> {
    let blocks = find_blocks(text)?;
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    for b in &blocks {
        out += &text[at..b.content.start];
        out += &render_block(&b.name, report).expect("find_blocks only returns known names");
        at = b.content.end;
    }
    out += &text[at..];
    Ok((out, blocks.len()))
}

/// The names of the blocks of `text` whose content differs from what `report` generates.
pub fn stale_blocks(text: &str, report: &Report) -> Result<Vec<String>, String> {
    Ok(find_blocks(text)?
        .into_iter()
        .filter(|b| text[b.content.clone()] != render_block(&b.name, report).unwrap_or_default())
        .map(|b| b.name)
        .collect())
}

/// The rows in table order: detector rows, then the reference rows listed in `references`.
fn rows(report: &Report) -> Vec<(&str, &DetectorSummary, bool)> {
    let is_ref = |label: &str| report.references.iter().any(|r| r == label);
    report
        .detectors
        .iter()
        .filter(|(label, _)| !is_ref(label))
        .map(|(label, s)| (label.as_str(), s, false))
        .chain(
            report
                .references
                .iter()
                .filter_map(|r| report.detectors.get_key_value(r))
                .map(|(label, s)| (label.as_str(), s, true)),
        )
        .collect()
}

fn label_cell(label: &str, reference: bool) -> String {
    if reference {
        format!("`{label}` *")
    } else {
        format!("`{label}`")
    }
}

fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".into(), |v| format!("{v:.digits$}"))
}

fn rate_ci(rate: Option<f64>, ci: Option<Interval>) -> String {
    match (rate, ci) {
        (Some(r), Some(ci)) => format!("{r:.2} [{:.2}, {:.2}]", ci.lower, ci.upper),
        (r, _) => num(r, 2),
    }
}

/// Threats, evadable and unavoidable threats, non-threats (the same in every row of a report).
fn counts(s: &DetectorSummary) -> (u64, u64, u64, u64) {
    let threats = s.hits + s.misses + s.unavoidable_threats;
    (
        threats,
        s.evadable_threats,
        s.unavoidable_threats,
        s.false_alarms + s.correct_rejections,
    )
}

fn table(header: &[&str], body: &[Vec<String>]) -> String {
    let mut out = format!("| {} |\n", header.join(" | "));
    out += &format!("|{}\n", "---|".repeat(header.len()));
    for row in body {
        out += &format!("| {} |\n", row.join(" | "));
    }
    out
}

/// `results-suite`: one sentence naming the suite, seed, episodes and threats.
fn suite_line(report: &Report) -> String {
    let Some(s) = report.detectors.values().next() else {
        return format!("`{}`, seed {}: no rows.\n", report.suite, report.seed);
    };
    let (threats, evadable, unavoidable, non_threats) = counts(s);
    format!(
        "`{}`, seed {}: **{} episodes**, {threats} threats ({evadable} evadable, {unavoidable} \
         unavoidable) and {non_threats} non-threats.\n",
        report.suite, report.seed, report.episodes
    )
}

/// `results-table`: the README's table (pooled rates with 95 % Wilson intervals).
fn results_table(report: &Report) -> String {
    let body: Vec<Vec<String>> = rows(report)
        .into_iter()
        .map(|(label, s, reference)| {
            vec![
                label_cell(label, reference),
                rate_ci(s.hit_rate, s.hit_rate_ci),
                rate_ci(s.false_alarm_rate, s.false_alarm_rate_ci),
                rate_ci(s.evasion_rate, s.evasion_rate_ci),
                num(s.collision_rate, 2),
                num(s.auc, 2),
            ]
        })
        .collect();
    let mut out = suite_line(report);
    out.push('\n');
    out += &table(
        &[
            "row",
            "hit rate",
            "false-alarm rate",
            "evasion rate",
            "collision rate",
            "AUC",
        ],
        &body,
    );
    out += "\n`*` reference row computed from ground truth; rates with 95 % Wilson intervals.\n";
    out
}

/// `results-full`: counts, misses, collisions and the l/|v| fit of every row.
fn full_table(report: &Report) -> String {
    let body: Vec<Vec<String>> = rows(report)
        .into_iter()
        .map(|(label, s, reference)| {
            let lv = s.lv_fit.as_ref().map_or_else(
                || "–".to_string(),
                |f| {
                    format!(
                        "{}, {:.3} s, {:.2} (n = {})",
                        f.theta_th_deg.map_or_else(|| "–".into(), |t| format!("{t:.1}°")),
                        f.delay_s,
                        f.r2,
                        f.episodes
                    )
                },
            );
            vec![
                label_cell(label, reference),
                format!("{} / {}", s.hits, s.evadable_threats),
                format!("{} / {}", s.late_misses, s.silent_misses),
                format!("{} / {}", s.false_alarms, s.false_alarms + s.correct_rejections),
                format!("{} / {}", s.evaded, s.evadable_threats),
                num(s.collision_rate, 2),
                num(s.collision_reduction, 2),
                format!("{} ({})", s.hit_collisions, s.retriggered_hit_collisions),
                num(s.auc, 2),
                lv,
            ]
        })
        .collect();
    let mut out = suite_line(report);
    out.push('\n');
    out += &table(
        &[
            "row",
            "hits / evadable",
            "late / silent misses",
            "false alarms / non-threats",
            "evaded / evadable",
            "collision rate",
            "collision reduction vs `null`",
            "hits that collided (re-triggered)",
            "AUC",
            "l/\\|v\\| fit: θ_th, δ, R² (n)",
        ],
        &body,
    );
    out
}

/// `results-per-scenario`: per scenario the episode counts, the angular size a threat required at
/// its deadline, the reference rows' evasions and false alarms and the best detector row.
fn per_scenario_table(report: &Report) -> String {
    let refs: Vec<&str> = report
        .references
        .iter()
        .map(String::as_str)
        .filter(|r| *r != "null" && *r != "oracle")
        .collect();
    let mut header = vec![
        "scenario".to_string(),
        "episodes".into(),
        "threats (evadable)".into(),
        "non-threats".into(),
        "θ required at the deadline: median [p10, p90]".into(),
    ];
    for r in &refs {
        header.push(format!("`{r}` evaded, false alarms"));
    }
    header.push("most evasions among the detector rows".into());
    let body: Vec<Vec<String>> = report
        .scenarios
        .iter()
        .map(|(name, sc)| {
            let any = sc.detectors.values().next();
            let (threats, evadable, _, non_threats) = any.map_or((0, 0, 0, 0), counts);
            let mut row = vec![
                format!("`{name}`"),
                sc.episodes.to_string(),
                format!("{threats} ({evadable})"),
                non_threats.to_string(),
                sc.theta_required_deg.as_ref().map_or_else(
                    || "–".into(),
                    |d| format!("{:.1}° [{:.1}, {:.1}]", d.median, d.p10, d.p90),
                ),
            ];
            for r in &refs {
                row.push(sc.detectors.get(*r).map_or_else(
                    || "–".into(),
                    |s| format!("{} / {evadable}, {} / {non_threats}", s.evaded, s.false_alarms),
                ));
            }
            let detector_rows = || {
                sc.detectors
                    .iter()
                    .filter(|(label, _)| !report.references.contains(label))
            };
            let most = detector_rows().map(|(_, s)| s.evaded).max().unwrap_or(0);
            row.push(if evadable == 0 {
                "–".into()
            } else if most == 0 {
                format!("none (0 / {evadable})")
            } else {
                let best: Vec<String> = detector_rows()
                    .filter(|(_, s)| s.evaded == most)
                    .map(|(label, _)| format!("`{label}`"))
                    .collect();
                format!("{} {most} / {evadable}", best.join(", "))
            });
            row
        })
        .collect();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    table(&header, &body)
}

/// The tier whose detector rows (not the reference rows) evade the smallest share of its evadable
/// threats on average: `(tier, mean evasion rate)`; ties go to the higher tier. `None`: no tier
/// with evadable threats and detector rows.
pub fn worst_tier(report: &Report) -> Option<(u8, f64)> {
    report
        .tier_summaries()
        .filter_map(|(t, s)| {
            let rates: Vec<f64> = s
                .detectors
                .iter()
                .filter(|(label, _)| !report.references.contains(label))
                .filter_map(|(_, d)| d.evasion_rate)
                .collect();
            (!rates.is_empty()).then(|| (t, rates.iter().sum::<f64>() / rates.len() as f64))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
}

/// `results-tiers`: one column per difficulty tier: first its counts, then every row's evasion and
/// false-alarm rate over that tier's episodes; then a sentence naming the worst tier.
fn tiers_table(report: &Report) -> String {
    use loomlab_scenarios::tier::tier_name;
    if report.tiers.is_empty() {
        return "The report has no difficulty tiers (no scenario states `tier`).\n".into();
    }
    let tiers: Vec<(u8, &loomlab_scenarios::report::TierSummary)> = report.tier_summaries().collect();
    let header: Vec<String> = std::iter::once("row".to_string())
        .chain(tiers.iter().map(|(t, _)| format!("tier {t}: {}", tier_name(*t))))
        .collect();
    let counts = std::iter::once("threats (evadable) / non-threats".to_string())
        .chain(
            tiers
                .iter()
                .map(|(_, s)| format!("{} ({}) / {}", s.threats, s.evadable_threats, s.non_threats)),
        )
        .collect();
    let body: Vec<Vec<String>> = std::iter::once(counts)
        .chain(rows(report).into_iter().map(|(label, _, reference)| {
            std::iter::once(label_cell(label, reference))
                .chain(tiers.iter().map(|(_, ts)| {
                    ts.detectors.get(label).map_or_else(
                        || "–".into(),
                        |s| format!("{} / {}", num(s.evasion_rate, 2), num(s.false_alarm_rate, 2)),
                    )
                }))
                .collect()
        }))
        .collect();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut out = table(&header, &body);
    out += "\nCells: evasion rate (evaded / evadable threats) / false-alarm rate (alarms on non-threats) \
            over the tier's episodes; `*` reference row computed from ground truth.";
    if let Some((t, mean)) = worst_tier(report) {
        let _ = write!(
            out,
            " **Worst tier: {t} ({})**, where the detector rows evade {:.0} % of the evadable threats on average.",
            tier_name(t),
            100.0 * mean
        );
    }
    out.push('\n');
    out
}

/// `results-takeaways`: three sentences, each with the numbers it rests on; which rows they name
/// depends only on the report (the best detector row is the one that evades most threats).
fn takeaways(report: &Report) -> String {
    let get = |label: &str| report.detectors.get(label);
    let pct = |v: Option<f64>| v.map_or_else(|| "–".into(), |v| format!("{:.0} %", 100.0 * v));
    let mut out = String::new();
    if let (Some(oracle), Some(null)) = (get("oracle"), get("null")) {
        let _ = writeln!(
            out,
            "1. **An alarm in time is enough to dodge.** `oracle` (an alarm at each escape deadline) \
             evades {} of {} evadable threats and cuts the collision rate from {} (`null`, never \
             alarms) to {}; what remains are the {} unavoidable threats.",
            oracle.evaded,
            oracle.evadable_threats,
            num(null.collision_rate, 2),
            num(oracle.collision_rate, 2),
            oracle.unavoidable_threats
        );
    }
    let ideal: Vec<String> = report
        .references
        .iter()
        .filter(|r| r.starts_with("ideal_"))
        .filter_map(|r| get(r).map(|s| (r, s)))
        .map(|(r, s)| {
            format!(
                "`{r}` evades {} at {} false alarms",
                pct(s.evasion_rate),
                pct(s.false_alarm_rate)
            )
        })
        .collect();
    if !ideal.is_empty() {
        let _ = writeln!(
            out,
            "2. **Perfect perception, imperfect decisions.** The ideal rows run the detectors' \
             decision strategies on the true angular sizes: {}.",
            ideal.join("; ")
        );
    }
    let best = report
        .detectors
        .iter()
        .filter(|(label, _)| !report.references.contains(label))
        .max_by(|a, b| a.1.evaded.cmp(&b.1.evaded).then(b.0.cmp(a.0)));
    if let Some((label, s)) = best {
        let (late, silent): (u64, u64) = report
            .detectors
            .iter()
            .filter(|(label, _)| !report.references.contains(label))
            .fold((0, 0), |(l, q), (_, s)| (l + s.late_misses, q + s.silent_misses));
        let _ = writeln!(
            out,
            "3. **Real detectors.** The detector row that evades most, `{label}`, evades {} of {} \
             evadable threats at {} false alarms; over all detector rows {late} misses came too late \
             and {silent} had no alarm at all.",
            s.evaded,
            s.evadable_threats,
            pct(s.false_alarm_rate)
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report() -> Report {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenarios/baseline/default-report.json"
        ))
        .unwrap();
        Report::from_json(&text, std::path::Path::new("baseline")).unwrap()
    }

    #[test]
    fn blocks_are_rewritten_and_the_rest_is_kept() {
        let r = report();
        let doc = "intro\n<!-- results-table:begin -->\nold\n<!-- results-table:end -->\nmiddle\n\
                   <!-- results-suite:begin -->\n<!-- results-suite:end -->\nend\n";
        let (new, n) = update_blocks(doc, &r).unwrap();
        assert_eq!(n, 2);
        assert!(new.contains("<!-- results-table:begin -->\n`"), "{new}");
        assert!(new.contains("| row |"), "{new}");
        assert!(new.contains("\n<!-- results-table:end -->\nmiddle\n"), "{new}");
        assert!(new.ends_with("<!-- results-suite:end -->\nend\n"), "{new}");
        assert_eq!(stale_blocks(doc, &r).unwrap(), ["results-table", "results-suite"]);
        assert!(stale_blocks(&new, &r).unwrap().is_empty());
        // idempotent
        assert_eq!(update_blocks(&new, &r).unwrap().0, new);
    }

    #[test]
    fn every_row_is_in_the_table_references_last() {
        let r = report();
        let t = results_table(&r);
        let positions: Vec<usize> = rows(&r)
            .iter()
            .map(|(label, _, _)| {
                t.find(&format!("| `{label}`"))
                    .unwrap_or_else(|| panic!("{label}: {t}"))
            })
            .collect();
        assert!(positions.windows(2).all(|w| w[0] < w[1]), "{t}");
        for reference in &r.references {
            assert!(t.contains(&format!("| `{reference}` * |")), "{reference}: {t}");
        }
    }

    #[test]
    fn bad_markers_are_errors() {
        let r = report();
        let e = update_blocks("<!-- results-tabel:begin -->\n<!-- results-tabel:end -->\n", &r).unwrap_err();
        assert!(e.contains("unknown generated block `results-tabel`"), "{e}");
        let e = update_blocks("<!-- results-table:begin -->\n", &r).unwrap_err();
        assert!(e.contains("no `<!-- results-table:end -->`"), "{e}");
        // other comments are left alone
        assert_eq!(
            update_blocks("<!-- a note -->\n", &r).unwrap(),
            ("<!-- a note -->\n".into(), 0)
        );
    }
}
