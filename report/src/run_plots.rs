//! The plots of `loomlab run` (`roc.png`, `rates.png`, `collisions.png`, `lv.png`,
//! `theta_required.png`, `theta_hat.png`, `trace.png`) and the per-episode trace CSVs of `--traces`.
//!
//! [`run_figures`] describes every plot once; [`write_plots`] draws them as PNG files and
//! `report.html` draws the same [`Figure`]s as inline SVG.
//!
//! The report's numbers come from every episode; the plots that need per-frame traces (θ̂ against
//! θ, the sample episode) use [`PlotSamples`], collected as episodes finish so that memory stays
//! bounded however many episodes run (a resumed run collects them from the episodes it runs).

use std::collections::BTreeMap;
use std::path::Path;

use loomlab_agents::TriggerSignal;
use loomlab_scenarios::EpisodeRun;
use loomlab_scenarios::metrics::{DetectorSummary, EpisodeOutcome, Outcome};
use loomlab_scenarios::report::Report;

use crate::plot::{LineChart, PlotError, Series, line_chart_grid, line_chart_grid_svg, rate_bars, rate_bars_svg};

/// Most θ̂-against-θ points kept per detector (the plot stays readable and quick to draw).
const THETA_HAT_POINTS: usize = 4000;

/// What the trace plots need, collected from finished episodes in suite order with bounded memory.
#[derive(Debug, Default)]
pub struct PlotSamples {
    /// Per θ̂-triggered detector: (true θ, θ̂) of threat frames with θ ≤ 90°, every `stride`-th.
    theta_hat: BTreeMap<String, ThetaHatPoints>,
    /// The sample episode: the first the first detector hits, else the first threat, else the first.
    sample: Option<EpisodeRun>,
}

#[derive(Debug, Default)]
struct ThetaHatPoints {
    points: Vec<(f64, f64)>,
    /// Keep every `stride`-th point offered (doubles whenever the points overflow).
    stride: usize,
    offered: usize,
}

impl ThetaHatPoints {
    fn offer(&mut self, p: (f64, f64)) {
        self.stride = self.stride.max(1);
        if self.offered % self.stride == 0 {
            self.points.push(p);
            if self.points.len() >= 2 * THETA_HAT_POINTS {
                // keep every other point: the same as having kept every (2·stride)-th
                self.points = self.points.iter().copied().step_by(2).collect();
                self.stride *= 2;
            }
        }
        self.offered += 1;
    }
}

/// What one finished episode contributes to [`PlotSamples`], small enough to keep in the run
/// folder (a resumed run rebuilds its plots from every episode's, see `loomlab run`).
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeSamples {
    /// Scenario name.
    pub scenario: String,
    /// Episode index within the scenario.
    pub episode: usize,
    /// How good a sample episode it is (0: the first detector hits, 1: a threat, 2: other).
    pub rank: u8,
    /// Per θ̂-triggered detector of a threat: its (true θ, θ̂) points with θ ≤ 90°.
    pub theta_hat: Vec<(String, Vec<(f64, f64)>)>,
}

impl EpisodeSamples {
    /// One line of JSON (no newline). Numbers are written as Rust prints them, the shortest text
    /// that reads back to the same `f64`, so plots rebuilt from the line are byte-identical.
    pub fn to_line(&self) -> String {
        let theta: Vec<serde_json::Value> = self
            .theta_hat
            .iter()
            .map(|(label, points)| {
                let text: Vec<String> = points.iter().map(|(t, e)| format!("{t},{e}")).collect();
                serde_json::json!([label, text.join(";")])
            })
            .collect();
        serde_json::json!({
            "scenario": self.scenario,
            "episode": self.episode,
            "rank": self.rank,
            "theta_hat": theta,
        })
        .to_string()
    }

    /// Reads a line written by [`Self::to_line`] (`None`: not such a line, e.g. cut short).
    pub fn from_line(line: &str) -> Option<Self> {
        let v: serde_json::Value = serde_json::from_str(line).ok()?;
        let mut theta_hat = Vec::new();
        for entry in v.get("theta_hat")?.as_array()? {
            let label = entry.get(0)?.as_str()?.to_string();
            let text = entry.get(1)?.as_str()?;
            let mut points = Vec::new();
            for p in text.split(';').filter(|p| !p.is_empty()) {
                let (t, e) = p.split_once(',')?;
                points.push((t.parse().ok()?, e.parse().ok()?));
            }
            theta_hat.push((label, points));
        }
        Some(Self {
            scenario: v.get("scenario")?.as_str()?.to_string(),
            episode: usize::try_from(v.get("episode")?.as_u64()?).ok()?,
            rank: u8::try_from(v.get("rank")?.as_u64()?).ok()?,
            theta_hat,
        })
    }

    /// The samples of a finished episode.
    pub fn of(run: &EpisodeRun) -> Self {
        let first = run.outcome.detectors.first();
        let mut theta_hat = Vec::new();
        if first.is_some_and(|d| d.threat) {
            let tr = &run.trace;
            for d in tr
                .detectors
                .iter()
                .filter(|d| d.trigger == TriggerSignal::AngularSizeDeg)
            {
                let points = tr
                    .angular_size_deg
                    .iter()
                    .zip(&d.signal)
                    .map(|(&t, &e)| (t, e))
                    .filter(|&(t, e)| t.is_finite() && e.is_finite() && t <= 90.0)
                    .collect();
                theta_hat.push((d.label.clone(), points));
            }
        }
        let rank = if first.is_some_and(|d| d.outcome == Outcome::Hit) {
            0
        } else if first.is_some_and(|d| d.threat) {
            1
        } else {
            2
        };
        Self {
            scenario: run.outcome.scenario.clone(),
            episode: run.outcome.episode,
            rank,
            theta_hat,
        }
    }
}

impl PlotSamples {
    /// Takes what the plots need from a finished episode (call in suite order).
    pub fn add(&mut self, run: &EpisodeRun) {
        let s = EpisodeSamples::of(run);
        self.add_points(&s);
        let rank = |r: &EpisodeRun| EpisodeSamples::of(r).rank;
        if self.sample.as_ref().is_none_or(|old| s.rank < rank(old)) {
            self.sample = Some(run.clone());
        }
    }

    /// Takes an episode's θ̂ points (call in suite order; the sample episode is set apart, with
    /// [`Self::set_sample`]).
    pub fn add_points(&mut self, s: &EpisodeSamples) {
        for (label, points) in &s.theta_hat {
            let kept = self.theta_hat.entry(label.clone()).or_default();
            for &p in points {
                kept.offer(p);
            }
        }
    }

    /// Sets the sample episode (the first of the best [`EpisodeSamples::rank`] in suite order).
    pub fn set_sample(&mut self, run: EpisodeRun) {
        self.sample = Some(run);
    }

    /// The sample episode, if set.
    pub fn sample(&self) -> Option<&EpisodeRun> {
        self.sample.as_ref()
    }
}

/// Writes one episode's open-loop trace as CSV: `t_s,theta_true_deg,ttc_true_s`, then
/// `<label>_signal,<label>_output` per row; then what the detectors' decision strategies saw and
/// estimated: `looming_side,ego_forward_mps,ego_yaw_rate_rps,ego_camera_yaw_rad,ego_camera_pitch_rad`
/// (the last two: the camera's shake relative to its mount), per row with a stateful strategy
/// `<label>_theta_hat_deg,<label>_tau_s,<label>_gate_open` (θ̂ before the strategy, τ̂, the
/// course gate as 0/1), per row whose detector localises the object its image region
/// `<label>_left,<label>_right,<label>_bottom,<label>_top` (image x and y in [−1, 1]) and
/// `<label>_track`, and in a threat episode `<label>_about_threat` (1 where the region covers the
/// threat's true image: the frames on whose alarms the row is scored). Empty cells: no value.
pub fn write_trace(dir: &Path, run: &EpisodeRun) -> std::io::Result<()> {
    use std::fmt::Write as _;
    let tr = &run.trace;
    let mut text = String::from("t_s,theta_true_deg,ttc_true_s");
    for d in &tr.detectors {
        let _ = write!(text, ",{0}_signal,{0}_output", d.label);
    }
    text.push_str(",looming_side,ego_forward_mps,ego_yaw_rate_rps,ego_camera_yaw_rad,ego_camera_pitch_rad");
    for d in &tr.detectors {
        if d.decision.is_some() {
            let _ = write!(text, ",{0}_theta_hat_deg,{0}_tau_s,{0}_gate_open", d.label);
        }
        if d.regions.is_some() {
            let _ = write!(text, ",{0}_left,{0}_right,{0}_bottom,{0}_top,{0}_track", d.label);
            if d.about_threat.is_some() {
                let _ = write!(text, ",{0}_about_threat", d.label);
            }
        }
    }
    text.push('\n');
    let opt = |v: Option<f64>| v.filter(|v| v.is_finite()).map_or(String::new(), |v| v.to_string());
    let flag = |b: bool| if b { "1" } else { "0" };
    for k in 0..tr.t_s.len() {
        let _ = write!(
            text,
            "{},{},{}",
            tr.t_s[k],
            opt(Some(tr.angular_size_deg[k])),
            opt(tr.ttc_s[k])
        );
        for d in &tr.detectors {
            let _ = write!(text, ",{},{}", opt(Some(d.signal[k])), opt(Some(d.output[k])));
        }
        let motion = tr.self_motion.get(k).copied().unwrap_or_default();
        let _ = write!(
            text,
            ",{},{},{},{},{}",
            opt(tr.looming_side.get(k).copied().flatten().map(f64::from)),
            motion.forward_mps,
            motion.yaw_rate_rps,
            motion.camera_yaw_rad,
            motion.camera_pitch_rad
        );
        for d in &tr.detectors {
            if let Some(s) = &d.decision {
                let _ = write!(
                    text,
                    ",{},{},{}",
                    opt(Some(s.theta_hat_deg[k])),
                    opt(s.tau_s[k]),
                    flag(s.gate_open[k])
                );
            }
            if let Some(regions) = &d.regions {
                match regions[k] {
                    Some(r) => {
                        let track = r.track.map_or(String::new(), |t| t.to_string());
                        let _ = write!(text, ",{},{},{},{},{track}", r.x[0], r.x[1], r.y[0], r.y[1]);
                    }
                    None => text.push_str(",,,,,"),
                }
                if let Some(about) = &d.about_threat {
                    let _ = write!(text, ",{}", flag(about[k]));
                }
            }
        }
        text.push('\n');
    }
    std::fs::write(
        dir.join(trace_file_name(&run.outcome.scenario, run.outcome.episode)),
        text,
    )
}

/// The file name of an episode's trace CSV (in the `traces/` folder of a run).
pub fn trace_file_name(scenario: &str, episode: usize) -> String {
    format!("{scenario}_{episode:04}.csv")
}

/// Most points per scatter series in an SVG (the PNG draws them all).
pub const SVG_SCATTER_POINTS: usize = 600;

/// One plot of a run: what it shows and how big it is drawn.
#[derive(Debug, Clone)]
pub struct Figure {
    /// File name without extension (`roc` → `roc.png`).
    pub name: &'static str,
    /// A caption for the page.
    pub caption: String,
    /// The drawing.
    pub kind: FigureKind,
}

/// The drawing of a [`Figure`].
#[derive(Debug, Clone)]
pub enum FigureKind {
    /// Line charts in a grid of `cols` columns, each panel `panel` pixels.
    Lines {
        /// The panels.
        charts: Vec<LineChart>,
        /// Panels per row.
        cols: usize,
        /// Size of one panel.
        panel: (u32, u32),
    },
    /// Grouped bars of rates in [0, 1].
    Bars {
        /// Title.
        title: String,
        /// One group per category.
        categories: Vec<String>,
        /// One bar per series in every group.
        series: Vec<(String, Vec<f64>)>,
        /// Size in pixels.
        size: (u32, u32),
    },
}

impl Figure {
    /// Draws the figure as a PNG file.
    pub fn write_png(&self, path: &Path) -> Result<(), PlotError> {
        match &self.kind {
            FigureKind::Lines { charts, cols, panel } => line_chart_grid(path, charts, *cols, *panel),
            FigureKind::Bars {
                title,
                categories,
                series,
                size,
            } => rate_bars(path, title, categories, series, *size),
        }
    }

    /// Draws the figure as SVG text. Scatters keep at most [`SVG_SCATTER_POINTS`] points per
    /// series (evenly thinned), so that the page stays small.
    pub fn svg(&self) -> Result<String, PlotError> {
        match &self.kind {
            FigureKind::Lines { charts, cols, panel } => {
                let mut charts = charts.clone();
                for s in charts.iter_mut().flat_map(|c| c.series.iter_mut()) {
                    if s.scatter.is_some() && s.x.len() > SVG_SCATTER_POINTS {
                        let step = s.x.len().div_ceil(SVG_SCATTER_POINTS);
                        s.x = s.x.iter().copied().step_by(step).collect();
                        s.y = s.y.iter().copied().step_by(step).collect();
                    }
                }
                line_chart_grid_svg(&charts, *cols, *panel)
            }
            FigureKind::Bars {
                title,
                categories,
                series,
                size,
            } => rate_bars_svg(title, categories, series, *size),
        }
    }
}

fn lines(name: &'static str, caption: &str, chart: LineChart, size: (u32, u32)) -> Figure {
    Figure {
        name,
        caption: caption.into(),
        kind: FigureKind::Lines {
            charts: vec![chart],
            cols: 1,
            panel: size,
        },
    }
}

/// Draws every plot of [`run_figures`] into `out` as PNG files (`<name>.png`).
pub fn write_plots(
    out: &Path,
    report: &Report,
    outcomes: &[EpisodeOutcome],
    samples: &PlotSamples,
) -> Result<(), PlotError> {
    for f in run_figures(report, outcomes, Some(samples)) {
        f.write_png(&out.join(format!("{}.png", f.name)))?;
    }
    Ok(())
}

/// Every plot of a run: from the report and `outcomes` (every episode) and, when given, the trace
/// plots from `samples` (θ̂ against θ, the sample episode).
pub fn run_figures(report: &Report, outcomes: &[EpisodeOutcome], samples: Option<&PlotSamples>) -> Vec<Figure> {
    let mut figures = Vec::new();
    // ROC curves.
    let mut series: Vec<Series> = report
        .detectors
        .iter()
        .filter(|(_, s)| !s.roc.is_empty())
        .map(|(id, s)| {
            let auc = s.auc.map_or(String::new(), |a| format!(" (AUC {a:.2})"));
            Series::new(
                format!("{id}{auc}"),
                s.roc.iter().map(|p| p.fpr).collect(),
                s.roc.iter().map(|p| p.tpr).collect(),
            )
        })
        .collect();
    series.push(Series::new("", vec![0.0, 1.0], vec![0.0, 1.0]).dashed());
    figures.push(lines(
        "roc",
        "ROC per detector: every threshold applied to the open-loop signals (AUC in the legend).",
        LineChart {
            title: "ROC: threshold sweep over the open-loop alarms".into(),
            x_label: "false-alarm rate".into(),
            y_label: "hit rate".into(),
            series,
            x_range: Some((0.0, 1.0)),
            y_range: Some((0.0, 1.0)),
        },
        (640, 560),
    ));

    // Rates per scenario.
    let scenarios: Vec<String> = report.scenarios.keys().cloned().collect();
    let labels: Vec<String> = report.detectors.keys().cloned().collect();
    let per = |f: &dyn Fn(&loomlab_scenarios::metrics::DetectorSummary) -> Option<f64>| -> Vec<(String, Vec<f64>)> {
        labels
            .iter()
            .map(|id| {
                let v = scenarios
                    .iter()
                    .map(|s| report.scenarios[s].detectors.get(id).and_then(f).unwrap_or(f64::NAN))
                    .collect();
                (id.clone(), v)
            })
            .collect()
    };
    // wide enough for the (horizontal) scenario names under each group of bars
    let width = (160 + 120 * scenarios.len() as u32).max(640);
    figures.push(Figure {
        name: "rates",
        caption: "Share of correct decisions per scenario and detector.".into(),
        kind: FigureKind::Bars {
            title: "correct decisions (hits + correct rejections) / decidable episodes, per scenario".into(),
            categories: scenarios.clone(),
            series: per(&|s| {
                let decided = s.hits + s.misses + s.false_alarms + s.correct_rejections;
                (decided > 0).then(|| (s.hits + s.correct_rejections) as f64 / decided as f64)
            }),
            size: (width, 520),
        },
    });
    figures.push(Figure {
        name: "collisions",
        caption: "Closed-loop collision rate per scenario and detector (null: the threat rate).".into(),
        kind: FigureKind::Bars {
            title: "closed-loop collision rate per scenario".into(),
            categories: scenarios.clone(),
            series: per(&|s| s.collision_rate),
            size: (width, 520),
        },
    });

    // Per difficulty tier: evasion and false-alarm rate of every row, reference rows included.
    if !report.tiers.is_empty() {
        let tiers: Vec<(String, &loomlab_scenarios::report::TierSummary)> = report
            .tier_summaries()
            .map(|(t, s)| (format!("tier {t} ({})", loomlab_scenarios::tier::tier_name(t)), s))
            .collect();
        let categories: Vec<String> = tiers.iter().map(|(n, _)| n.clone()).collect();
        let rows: Vec<&String> = report
            .detectors
            .keys()
            .filter(|id| !loomlab_scenarios::reference::is_reference(id))
            .chain(
                loomlab_scenarios::reference::REFERENCE_LABELS
                    .iter()
                    .filter_map(|r| report.detectors.get_key_value(*r).map(|(k, _)| k)),
            )
            .collect();
        let per_tier = |f: &dyn Fn(&DetectorSummary) -> Option<f64>| -> Vec<(String, Vec<f64>)> {
            rows.iter()
                .map(|id| {
                    let v = tiers
                        .iter()
                        .map(|(_, t)| t.detectors.get(*id).and_then(f).unwrap_or(f64::NAN))
                        .collect();
                    ((*id).clone(), v)
                })
                .collect()
        };
        let width = (160 + 22 * (rows.len() * tiers.len()) as u32).max(640);
        figures.push(Figure {
            name: "tier_evasion",
            caption: "Evasion rate (evaded / evadable threats) per difficulty tier and row, reference rows included."
                .into(),
            kind: FigureKind::Bars {
                title: "evasion rate per difficulty tier".into(),
                categories: categories.clone(),
                series: per_tier(&|s| s.evasion_rate),
                size: (width, 520),
            },
        });
        figures.push(Figure {
            name: "tier_false_alarms",
            caption: "False-alarm rate (alarms on non-threats) per difficulty tier and row, reference rows included."
                .into(),
            kind: FigureKind::Bars {
                title: "false-alarm rate per difficulty tier".into(),
                categories,
                series: per_tier(&|s| s.false_alarm_rate),
                size: (width, 520),
            },
        });
    }

    // The l/|v| analysis: alarm time to collision against half-size / closing speed, with the fit.
    let lv: Vec<Series> = report
        .detectors
        .iter()
        .map(|(id, s)| {
            let (x, y): (Vec<f64>, Vec<f64>) = loomlab_scenarios::report::detector_episodes(outcomes, id)
                .filter_map(|d| Some((d.l_over_v_s?, d.eye_ttc_at_alarm_s?)))
                .unzip();
            let name = match &s.lv_fit {
                Some(f) => format!(
                    "{id}: θ_th {} δ {:.3} s R² {:.2} (n={})",
                    f.theta_th_deg.map_or("n/a".into(), |t| format!("{t:.1}°")),
                    f.delay_s,
                    f.r2,
                    f.episodes
                ),
                None => format!("{id}: no fit ({} alarms)", x.len()),
            };
            Series::new(name, x, y).scatter(s.lv_fit.map(|f| (f.slope, f.intercept_s)))
        })
        .collect();
    figures.push(lines(
        "lv",
        "l/|v| analysis: time to collision at the alarm against half-size / closing speed, with each detector's fit.",
        LineChart {
            title: "l/|v| analysis: constant-speed head-on threats".into(),
            x_label: "l/|v|: half-size / closing speed (s)".into(),
            y_label: "time to collision at the alarm (s)".into(),
            series: lv,
            x_range: None,
            y_range: None,
        },
        (760, 600),
    ));
    // The angular size a threat required: θ at the escape deadline against l/|v|, and each row's
    // true θ at its alarm (evadable constant-speed head-on threats).
    let required: Vec<(f64, f64)> = outcomes
        .iter()
        .filter_map(|e| {
            let d = e.detectors.first()?;
            Some((d.l_over_v_s?, d.theta_required_deg?))
        })
        .collect();
    if !required.is_empty() {
        let mut series = vec![
            Series::new(
                "θ required: true θ at the escape deadline",
                required.iter().map(|p| p.0).collect(),
                required.iter().map(|p| p.1).collect(),
            )
            .scatter(None),
        ];
        for id in report.detectors.keys() {
            let (x, y): (Vec<f64>, Vec<f64>) = loomlab_scenarios::report::detector_episodes(outcomes, id)
                .filter(|d| d.theta_required_deg.is_some())
                .filter_map(|d| Some((d.l_over_v_s?, d.angular_size_at_alarm_deg?)))
                .unzip();
            if !x.is_empty() {
                series.push(Series::new(format!("{id}: true θ at its alarm"), x, y).scatter(None));
            }
        }
        figures.push(lines(
            "theta_required",
            "The angular size each evadable head-on threat required (its true θ at the escape deadline: an \
             alarm at a smaller θ is in time) against l/|v|, with each row's true θ at its alarm.",
            LineChart {
                title: "θ required at the escape deadline vs θ at each row's alarm".into(),
                x_label: "l/|v|: half-size / closing speed (s)".into(),
                y_label: "true angular size (deg)".into(),
                series,
                x_range: None,
                y_range: None,
            },
            (760, 600),
        ));
    }
    let Some(samples) = samples else {
        return figures;
    };

    // θ̂ against the true angular size of the threat, every frame of every threat episode.
    let mut theta_hat: Vec<Series> = report
        .detectors
        .keys()
        .filter(|id| !loomlab_scenarios::reference::is_reference(id))
        .filter_map(|id| {
            let (x, y): (Vec<f64>, Vec<f64>) = samples.theta_hat.get(id)?.points.iter().copied().unzip();
            let acc = report.detectors[id].theta_accuracy.map_or(String::new(), |a| {
                format!(" (median |θ̂−θ|/θ {:.2}, p90 {:.2})", a.median_rel_err, a.p90_rel_err)
            });
            (!x.is_empty()).then(|| Series::new(format!("{id}{acc}"), x, y).scatter(None))
        })
        .collect();
    if !theta_hat.is_empty() {
        theta_hat.push(Series::new("θ̂ = θ", vec![0.0, 90.0], vec![0.0, 90.0]).dashed());
        figures.push(lines(
            "theta_hat",
            "θ̂ against the threat's true angular size θ, every frame of the threat episodes run (subsampled).",
            LineChart {
                title: "angular-size estimate θ̂ against the threat's true angular size (threat episodes)".into(),
                x_label: "true angular size θ (deg)".into(),
                y_label: "θ̂ (deg)".into(),
                series: theta_hat,
                x_range: Some((0.0, 90.0)),
                y_range: Some((0.0, 90.0)),
            },
            (760, 640),
        ));
    }

    // The sample episode.
    if let Some(run) = &samples.sample {
        let tr = &run.trace;
        let object = tr.reference_object.clone().unwrap_or_else(|| "object".into());
        let mut over_time = vec![
            Series::new(
                format!("true θ ({object})"),
                tr.t_s.clone(),
                tr.angular_size_deg.clone(),
            )
            .dashed(),
        ];
        for d in &tr.detectors {
            if d.trigger == TriggerSignal::AngularSizeDeg {
                over_time.push(Series::new(format!("{} θ̂", d.label), tr.t_s.clone(), d.signal.clone()));
                over_time.push(
                    Series::new(
                        format!("{} threshold", d.label),
                        vec![tr.t_s[0], *tr.t_s.last().unwrap_or(&tr.t_s[0])],
                        vec![d.threshold; 2],
                    )
                    .dashed(),
                );
            }
        }
        let y_max = tr
            .detectors
            .iter()
            .filter(|d| d.trigger == TriggerSignal::AngularSizeDeg)
            .flat_map(|d| d.signal.iter().copied())
            .chain(tr.angular_size_deg.iter().copied())
            .filter(|v| v.is_finite())
            .fold(1.0f64, f64::max)
            .min(90.0);
        let responses: Vec<Series> = tr
            .detectors
            .iter()
            .map(|d| {
                let max = d
                    .output
                    .iter()
                    .copied()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, f64::max);
                let y = d.output.iter().map(|v| if max > 0.0 { v / max } else { 0.0 }).collect();
                Series::new(d.label.clone(), tr.angular_size_deg.clone(), y)
            })
            .collect();
        let title = format!(
            "{} episode {} ({})",
            run.outcome.scenario,
            run.outcome.episode,
            if run.outcome.detectors.first().is_some_and(|d| d.threat) {
                "threat"
            } else {
                "no threat"
            }
        );
        let caption = format!("A sample episode ({title}): angular size over time and every detector's response.");
        figures.push(Figure {
            name: "trace",
            caption,
            kind: FigureKind::Lines {
                charts: vec![
                    LineChart {
                        title: format!("{title}: angular size"),
                        x_label: "time (s)".into(),
                        y_label: "degrees".into(),
                        series: over_time,
                        y_range: Some((0.0, y_max * 1.05)),
                        x_range: None,
                    },
                    LineChart {
                        title: "detector responses vs true angular size".into(),
                        x_label: "true angular size (deg)".into(),
                        y_label: "response / episode maximum".into(),
                        series: responses,
                        y_range: Some((0.0, 1.05)),
                        x_range: Some((0.0, y_max)),
                    },
                ],
                cols: 2,
                panel: (640, 480),
            },
        });
    }
    figures
}
