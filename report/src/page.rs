//! The run page, `report.html`: what `loomlab run` (and each point of a sweep) shows a person.
//!
//! Sections: the run's facts, the summary table (every detector pooled over the suite, with 95 %
//! Wilson intervals, reference rows after the detectors), the per-tier section when the suite's
//! scenarios state difficulty tiers (the tiers' counts, then one such table per tier; the per-tier
//! evasion and false-alarm plots are among the plots), the comparison with a baseline report
//! (`--baseline`: what got worse beyond the regression tolerances, what improved beyond them, and
//! the pooled rates side by side), the plots (inline SVG), then per scenario its table and its
//! exemplary episodes (GIF of the robot's view with the alarms marked, trace plot, every
//! detector's outcome). Every table sorts by a click on a column header.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use loomlab_scenarios::regression::{Regression, RegressionKind, Tolerances, compare};
use loomlab_scenarios::report::Report;

use crate::exemplar::Exemplar;
use crate::html::{SUMMARY_HEADERS, anchor, cell, escape, num, page, pct, summary_rows, table, text_cell};
use crate::run_plots::Figure;
use crate::{REPORT_HTML, ReportError};

/// Everything the run page shows.
#[derive(Debug)]
pub struct RunPage<'a> {
    /// The run's report.
    pub report: &'a Report,
    /// Page title.
    pub title: String,
    /// Facts shown under the title (`(name, value)`, e.g. the command that made the run).
    pub facts: Vec<(String, String)>,
    /// The plots, drawn inline as SVG.
    pub figures: Vec<Figure>,
    /// The exemplary episodes (see [`crate::exemplar`]).
    pub exemplars: Vec<Exemplar>,
    /// A baseline to compare with: its path as the user gave it, and its report.
    pub baseline: Option<(String, &'a Report)>,
    /// Notes shown above the scenarios (e.g. why there are no exemplars).
    pub notes: Vec<String>,
}

impl RunPage<'_> {
    /// The page's HTML.
    pub fn render(&self) -> Result<String, ReportError> {
        let r = self.report;
        let mut b = String::new();
        let _ = writeln!(b, "<h1>{}</h1>", escape(&self.title));
        let _ = write!(
            b,
            "<p class=\"meta\">suite <code>{}</code> · seed {} · {} episodes · lead margin {} s · wall time {:.1} s · loomlab {}",
            escape(&r.suite),
            r.seed,
            r.episodes,
            r.lead_margin_s,
            r.wall_time_s,
            escape(&r.loomlab_version)
        );
        for (k, v) in &self.facts {
            let _ = write!(b, "<br>{}: <code>{}</code>", escape(k), escape(v));
        }
        b.push_str("</p>\n<nav><a href=\"#summary\">summary</a>");
        if !r.tiers.is_empty() {
            b.push_str("<a href=\"#tiers\">per tier</a>");
        }
        if self.baseline.is_some() {
            b.push_str("<a href=\"#baseline\">against the baseline</a>");
        }
        b.push_str("<a href=\"#plots\">plots</a><a href=\"#scenarios\">scenarios</a></nav>\n");

        b.push_str("<h2 id=\"summary\">Summary: every scenario pooled</h2>\n");
        b.push_str(&table("summary", &SUMMARY_HEADERS, &summary_rows(r.detectors.iter())));
        b.push_str(
            "<p class=\"meta\">Hit: alarm no later than the threat's escape deadline; miss: later or never; \
             false alarm: an alarm without a threat. Collisions caused: the row's own dodges ended in a \
             collision, after a false alarm (the cruising robot would have been untouched) or a hit (the \
             alarm came in time). Reference rows: <code>null</code> never alarms, \
             <code>oracle</code> alarms at each evadable threat's deadline, <code>ideal_theta</code> \
             thresholds the true angular size of the moving objects, <code>ideal_tau</code> alarms on the \
             time to contact estimated from each object's true angular size, <code>ideal_course</code> \
             on the same behind the collision-course gate fed the true bearings.</p>\n",
        );

        if !r.tiers.is_empty() {
            b.push_str(&tier_section(r));
        }

        if let Some((path, base)) = &self.baseline {
            b.push_str(&baseline_section(path, r, base));
        }

        b.push_str("<h2 id=\"plots\">Plots</h2>\n<div class=\"figures\">\n");
        for f in &self.figures {
            let _ = writeln!(
                b,
                "<figure id=\"plot-{}\" class=\"plot\">{}<figcaption>{}</figcaption></figure>",
                f.name,
                f.svg()?,
                escape(&f.caption)
            );
        }
        b.push_str("</div>\n");

        b.push_str("<h2 id=\"scenarios\">Scenarios</h2>\n");
        for n in &self.notes {
            let _ = writeln!(b, "<p class=\"note\">{}</p>", escape(n));
        }
        b.push_str("<p>");
        for name in r.scenarios.keys() {
            let _ = write!(b, "<a href=\"#{}\">{}</a> · ", anchor("scenario", name), escape(name));
        }
        b.push_str("</p>\n");
        for (name, s) in &r.scenarios {
            let _ = writeln!(
                b,
                "<section class=\"scenario\" id=\"{}\"><h3>{} <small class=\"meta\">({} episodes)</small></h3>",
                anchor("scenario", name),
                escape(name),
                s.episodes
            );
            b.push_str(&table(
                "per-scenario",
                &SUMMARY_HEADERS,
                &summary_rows(s.detectors.iter()),
            ));
            let mine: Vec<&Exemplar> = self.exemplars.iter().filter(|e| &e.choice.scenario == name).collect();
            if !mine.is_empty() {
                b.push_str("<div class=\"exemplars\">\n");
                for e in mine {
                    b.push_str(&exemplar_html(e)?);
                }
                b.push_str("</div>\n");
            }
            b.push_str("</section>\n");
        }
        Ok(page(&self.title, &b))
    }

    /// Writes the page to `dir/report.html`; returns its path.
    pub fn write(&self, dir: &Path) -> Result<PathBuf, ReportError> {
        let path = dir.join(REPORT_HTML);
        let html = self.render()?;
        let tmp = dir.join(format!(".{REPORT_HTML}.tmp"));
        std::fs::write(&tmp, html).map_err(|e| ReportError::io(&tmp, e))?;
        std::fs::rename(&tmp, &path).map_err(|e| ReportError::io(&path, e))?;
        Ok(path)
    }
}

fn exemplar_html(e: &Exemplar) -> Result<String, ReportError> {
    let mut b = String::new();
    let c = &e.choice;
    let _ = write!(
        b,
        "<div class=\"exemplar\" id=\"{}\"><div><img class=\"view\" src=\"{}\" alt=\"robot's view, {} episode {}\" \
         data-frames=\"{}\" data-alarms=\"{}\">",
        anchor("exemplar", &format!("{}_{}", c.scenario, c.episode)),
        escape(&e.gif),
        escape(&c.scenario),
        c.episode,
        e.gif_frames,
        e.alarms.len(),
    );
    if let Some(events) = &e.events_gif {
        let _ = write!(
            b,
            "<img class=\"view events\" src=\"{}\" alt=\"event camera, {} episode {} (ON brighter, OFF darker)\">",
            escape(events),
            escape(&c.scenario),
            c.episode
        );
    }
    let _ = write!(b, "<div class=\"facts\"><b>episode {}</b><br>", c.episode);
    for (kind, det) in &c.reasons {
        let class = match kind {
            crate::exemplar::ExemplarKind::Miss => "miss",
            crate::exemplar::ExemplarKind::FalseAlarm => "false_alarm",
            crate::exemplar::ExemplarKind::Hit => "hit",
            crate::exemplar::ExemplarKind::First => "first",
        };
        let _ = write!(
            b,
            "<span class=\"tag {class}\">{} ({})</span>",
            kind.title(),
            escape(det)
        );
    }
    if !e.params.is_empty() {
        let p: Vec<String> = e.params.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        let _ = write!(b, "<br><small>{}</small>", escape(&p.join(", ")));
    }
    b.push_str("<table><tr><th>detector</th><th>outcome</th><th>alarm (s)</th></tr>");
    for (label, outcome, t) in &e.detectors {
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(label),
            outcome.as_str(),
            num(*t, 3)
        );
    }
    b.push_str("</table>");
    if e.alarms.is_empty() {
        b.push_str("<small>no detector alarmed in the open loop</small>");
    } else {
        b.push_str("<small>GIF: a thick border in a detector's colour marks its alarm frame</small>");
    }
    let _ = writeln!(
        b,
        "</div></div><figure class=\"trace\">{}</figure></div>",
        e.trace.svg()?
    );
    Ok(b)
}

/// The per-tier section: the tiers' counts, then one table per tier (every row of the summary
/// table, pooled over that tier's episodes).
fn tier_section(r: &Report) -> String {
    let mut b = String::from(
        "<h2 id=\"tiers\">Per difficulty tier</h2>\n<p class=\"meta\">Each scenario file states its tier \
         (<code>tier = 0..3</code>); a row of a tier pools every episode of that tier's scenarios. The plots \
         <a href=\"#plot-tier_evasion\">evasion rate</a> and <a href=\"#plot-tier_false_alarms\">false-alarm \
         rate</a> per tier are under Plots.</p>\n",
    );
    let rows: Vec<(String, Vec<String>)> = r
        .tier_summaries()
        .map(|(t, s)| {
            (
                String::new(),
                vec![
                    text_cell(&format!("tier {t} ({})", loomlab_scenarios::tier::tier_name(t))),
                    text_cell(
                        loomlab_scenarios::tier::TIER_DESCRIPTIONS
                            .get(t as usize)
                            .copied()
                            .unwrap_or_default(),
                    ),
                    cell(&s.episodes.to_string(), Some(s.episodes as f64)),
                    cell(&s.threats.to_string(), Some(s.threats as f64)),
                    cell(&s.evadable_threats.to_string(), Some(s.evadable_threats as f64)),
                    cell(&s.non_threats.to_string(), Some(s.non_threats as f64)),
                ],
            )
        })
        .collect();
    b.push_str(&table(
        "tier-counts",
        &[
            "tier",
            "conditions",
            "episodes",
            "threats",
            "evadable threats",
            "non-threats",
        ],
        &rows,
    ));
    for (t, s) in r.tier_summaries() {
        let _ = writeln!(
            b,
            "<h3 id=\"tier-{t}\">Tier {t}: {} <small class=\"meta\">({} episodes)</small></h3>",
            escape(loomlab_scenarios::tier::tier_name(t)),
            s.episodes
        );
        b.push_str(&table("per-tier", &SUMMARY_HEADERS, &summary_rows(s.detectors.iter())));
    }
    b
}

/// The regressions of `from` against `to`, as rows (`better`: `from` is the baseline, `to` this
/// run, so a "regression" of the baseline is an improvement of the run).
fn change_rows(list: &[Regression], better: bool) -> Vec<(String, Vec<String>)> {
    list.iter()
        .map(|r| {
            let scope = match (&r.scenario, r.tier) {
                (Some(s), _) => s.clone(),
                (None, Some(t)) => format!("tier {t}"),
                (None, None) => "all scenarios".into(),
            };
            let det = r.detector.clone().unwrap_or_default();
            let (metric, base, cur, tol) = match &r.kind {
                RegressionKind::MissingScenario => (
                    if better { "new scenario" } else { "missing scenario" }.to_string(),
                    None,
                    None,
                    None,
                ),
                RegressionKind::MissingTier => (
                    if better { "new tier" } else { "missing tier" }.to_string(),
                    None,
                    None,
                    None,
                ),
                RegressionKind::MissingDetector => (
                    if better { "new detector" } else { "missing detector" }.to_string(),
                    None,
                    None,
                    None,
                ),
                RegressionKind::Metric {
                    metric,
                    baseline,
                    current,
                    tolerance,
                } => {
                    // compare(baseline, run) swaps the roles
                    let (b, c) = if better {
                        (*current, Some(*baseline))
                    } else {
                        (Some(*baseline), *current)
                    };
                    (metric.to_string(), b, c, Some(*tolerance))
                }
            };
            let delta = match (base, cur) {
                (Some(b), Some(c)) => Some(c - b),
                _ => None,
            };
            (
                if better { "better" } else { "worse" }.to_string(),
                vec![
                    text_cell(&scope),
                    text_cell(&det),
                    text_cell(&metric),
                    cell(&num(base, 3), base),
                    cell(&num(cur, 3), cur),
                    cell(&num(delta, 3), delta),
                    cell(&num(tol, 3), tol),
                ],
            )
        })
        .collect()
}

fn baseline_section(path: &str, run: &Report, base: &Report) -> String {
    let tol = Tolerances::default();
    let worse = compare(run, base, &tol);
    let better = compare(base, run, &tol);
    let mut b = format!(
        "<h2 id=\"baseline\">Against the baseline <code>{}</code></h2>\n<p>{} regression(s), {} improvement(s) \
         beyond the tolerances (a rate change larger than max(0.05, the baseline's Wilson half-width), an AUC \
         change larger than 0.05; pooled and per scenario).</p>\n",
        escape(path),
        worse.len(),
        better.len()
    );
    let headers = [
        "scope",
        "detector",
        "metric",
        "baseline",
        "this run",
        "change",
        "tolerance",
    ];
    if !worse.is_empty() {
        b.push_str("<h3 id=\"worse\">What got worse</h3>\n");
        b.push_str(&table("worse", &headers, &change_rows(&worse, false)));
    }
    if !better.is_empty() {
        b.push_str("<h3 id=\"better\">What improved</h3>\n");
        b.push_str(&table("better", &headers, &change_rows(&better, true)));
    }
    // the pooled rates side by side
    let mut rows = Vec::new();
    for (label, s) in &run.detectors {
        let bs = base.detectors.get(label);
        let pair = |cur: Option<f64>, old: Option<f64>| -> Vec<String> {
            let d = match (cur, old) {
                (Some(c), Some(o)) => Some(c - o),
                _ => None,
            };
            vec![
                cell(&pct(old), old),
                cell(&pct(cur), cur),
                cell(&num(d.map(|d| d * 100.0), 1), d),
            ]
        };
        let mut cells = vec![text_cell(label)];
        cells.extend(pair(s.hit_rate, bs.and_then(|b| b.hit_rate)));
        cells.extend(pair(s.false_alarm_rate, bs.and_then(|b| b.false_alarm_rate)));
        cells.extend(pair(s.collision_rate, bs.and_then(|b| b.collision_rate)));
        rows.push((String::new(), cells));
    }
    b.push_str("<h3>Pooled rates, baseline → this run</h3>\n");
    b.push_str(&table(
        "pooled-change",
        &[
            "detector",
            "hit rate (baseline)",
            "hit rate",
            "Δ (points)",
            "false-alarm rate (baseline)",
            "false-alarm rate",
            "Δ (points)",
            "collision rate (baseline)",
            "collision rate",
            "Δ (points)",
        ],
        &rows,
    ));
    b
}
