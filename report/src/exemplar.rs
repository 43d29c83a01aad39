//! Exemplary episodes: the evidence beside the numbers.
//!
//! For each scenario the page shows up to [`PER_SCENARIO`] episodes: the first (in suite order) in
//! which some detector **missed**, the first in which some detector **false-alarmed** and the first
//! in which some detector **hit** (one episode can be all three; a scenario with none of them shows
//! its first episode). They are chosen from every episode of the run ([`choose`], from the
//! `episodes.csv` rows, so a resumed run chooses from all its invocations).
//!
//! Each is shown with every detector's open-loop trace ([`trace_figure`]: signal / threshold, the
//! true angular size and time to contact of the reference object) and a short GIF of the robot's
//! view ([`build`]): at most [`MAX_GIF_FRAMES`] frames (subsampled, every detector's alarm frame
//! kept) of at most [`MAX_GIF_SIZE`] pixels, each alarm frame with a thick border in the alarming
//! detector's colour and its label, the frames after the featured detector's alarm with a thin one.
//!
//! Cost: the traces come from the runs the CLI keeps while the suite runs ([`ExemplarRuns`]: at
//! most four per scenario); only an exemplar from an earlier invocation (a resumed run) is run
//! again. The frames are rendered again in one open-loop pass per exemplar that renders only the
//! frames the GIF shows (the physics steps every frame; rendering is most of the cost).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::sync::Arc;

use loomlab_scenarios::metrics::{EpisodeOutcome, Outcome};
use loomlab_scenarios::reference::is_reference;
use loomlab_scenarios::{EpisodeRun, EpisodeSpec};
use loomlab_sim::{GpuContext, Sim};
use plotters::prelude::*;

use crate::ReportError;
use crate::plot::{LineChart, Series, palette, register_font};
use crate::run_plots::{Figure, FigureKind};

/// Exemplary episodes per scenario at most (first miss, first false alarm, first hit).
pub const PER_SCENARIO: usize = 3;
/// Scenarios with exemplars at most (the first ones of the suite; bounds the page's cost).
pub const MAX_SCENARIOS: usize = 64;
/// Frames per GIF at most.
pub const MAX_GIF_FRAMES: usize = 80;
/// Width and height of a GIF's image at most (larger frames are box-downscaled).
pub const MAX_GIF_SIZE: u32 = 96;
/// Height of the caption strip under the image (time, true angular size, alarms).
const CAPTION_PX: u32 = 24;
/// Grey levels of the GIF palette (the rest of its 256 entries are the detectors' colours).
const GREYS: usize = 64;
/// Playback slow-down against real time (a 2.6 s episode plays in about 5 s).
const SLOW_DOWN: f64 = 2.0;
/// How long an alarm frame stays on screen (centiseconds).
const ALARM_DELAY_CS: u16 = 100;

/// Why an episode is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ExemplarKind {
    /// The scenario's first episode in which some detector missed an evadable threat.
    Miss,
    /// The scenario's first episode in which some detector alarmed without a threat.
    FalseAlarm,
    /// The scenario's first episode in which some detector hit.
    Hit,
    /// The scenario has no miss, false alarm or hit: its first episode.
    First,
}

impl ExemplarKind {
    /// Words for the page.
    pub fn title(self) -> &'static str {
        match self {
            Self::Miss => "first miss",
            Self::FalseAlarm => "first false alarm",
            Self::Hit => "first hit",
            Self::First => "first episode",
        }
    }

    fn outcome(self) -> Option<Outcome> {
        match self {
            Self::Miss => Some(Outcome::Miss),
            Self::FalseAlarm => Some(Outcome::FalseAlarm),
            Self::Hit => Some(Outcome::Hit),
            Self::First => None,
        }
    }
}

/// An episode chosen as exemplary, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ExemplarChoice {
    /// Scenario name.
    pub scenario: String,
    /// Episode index within the scenario.
    pub episode: usize,
    /// Each reason with its detector (the first detector with that outcome).
    pub reasons: Vec<(ExemplarKind, String)>,
}

impl ExemplarChoice {
    /// The detector whose alarm the GIF follows: that of the first reason.
    pub fn featured(&self) -> &str {
        self.reasons.first().map_or("", |(_, d)| d.as_str())
    }

    /// File name of the GIF (in [`crate::EXEMPLARS_DIR`]).
    pub fn gif_name(&self) -> String {
        format!("{}_{:04}.gif", self.scenario, self.episode)
    }
}

/// The exemplary episodes of a run, scenario by scenario in suite order, from every episode's
/// outcome (`outcomes` in suite order). Reference rows are not detectors: they choose nothing.
pub fn choose(outcomes: &[EpisodeOutcome]) -> Vec<ExemplarChoice> {
    let mut order: Vec<&str> = Vec::new();
    let mut per: BTreeMap<&str, Vec<ExemplarChoice>> = BTreeMap::new();
    let kinds = [ExemplarKind::Miss, ExemplarKind::FalseAlarm, ExemplarKind::Hit];
    for o in outcomes {
        if !per.contains_key(o.scenario.as_str()) {
            if order.len() >= MAX_SCENARIOS {
                continue;
            }
            order.push(&o.scenario);
        }
        let chosen = per.entry(&o.scenario).or_default();
        for kind in kinds {
            if chosen.iter().any(|c| c.reasons.iter().any(|(k, _)| *k == kind)) {
                continue;
            }
            let Some(d) = o
                .detectors
                .iter()
                .find(|d| !is_reference(&d.detector) && Some(d.outcome) == kind.outcome())
            else {
                continue;
            };
            match chosen.iter_mut().find(|c| c.episode == o.episode) {
                Some(c) => c.reasons.push((kind, d.detector.clone())),
                None => chosen.push(ExemplarChoice {
                    scenario: o.scenario.clone(),
                    episode: o.episode,
                    reasons: vec![(kind, d.detector.clone())],
                }),
            }
        }
    }
    let mut out = Vec::new();
    for s in order {
        let mut chosen = per.remove(s).unwrap_or_default();
        if chosen.is_empty()
            && let Some(o) = outcomes.iter().find(|o| o.scenario == s)
        {
            let first = o.detectors.iter().find(|d| !is_reference(&d.detector));
            chosen.push(ExemplarChoice {
                scenario: o.scenario.clone(),
                episode: o.episode,
                reasons: vec![(ExemplarKind::First, first.map_or(String::new(), |d| d.detector.clone()))],
            });
        }
        chosen.truncate(PER_SCENARIO);
        out.extend(chosen);
    }
    out
}

/// The runs of the episodes that may become exemplars, kept while a suite runs (offered in suite
/// order): per scenario its first episode and the first with each kind of outcome among those
/// offered, so at most four runs per scenario are held.
#[derive(Debug, Default)]
pub struct ExemplarRuns {
    runs: BTreeMap<(String, usize), EpisodeRun>,
    seen: BTreeMap<String, BTreeSet<ExemplarKind>>,
}

impl ExemplarRuns {
    /// Keeps `run` if it is a candidate (call in suite order).
    pub fn offer(&mut self, run: &EpisodeRun) {
        let o = &run.outcome;
        if !self.seen.contains_key(&o.scenario) && self.seen.len() >= MAX_SCENARIOS {
            return;
        }
        let seen = self.seen.entry(o.scenario.clone()).or_default();
        let mut keep = seen.insert(ExemplarKind::First);
        for kind in [ExemplarKind::Miss, ExemplarKind::FalseAlarm, ExemplarKind::Hit] {
            if o.detectors
                .iter()
                .any(|d| !is_reference(&d.detector) && Some(d.outcome) == kind.outcome())
            {
                keep |= seen.insert(kind);
            }
        }
        if keep {
            self.runs.insert((o.scenario.clone(), o.episode), run.clone());
        }
    }

    /// The kept run of an episode.
    pub fn get(&self, scenario: &str, episode: usize) -> Option<&EpisodeRun> {
        self.runs.get(&(scenario.to_string(), episode))
    }

    /// Runs kept.
    pub fn len(&self) -> usize {
        self.runs.len()
    }

    /// Whether no run is kept.
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }
}

/// An exemplary episode ready for the page.
#[derive(Debug, Clone)]
pub struct Exemplar {
    /// Which episode and why.
    pub choice: ExemplarChoice,
    /// The episode's swept / sampled values.
    pub params: BTreeMap<String, String>,
    /// Per detector (reference rows included): label, outcome, alarm time.
    pub detectors: Vec<(String, Outcome, Option<f64>)>,
    /// The GIF's path relative to the page.
    pub gif: String,
    /// Frames in the GIF.
    pub gif_frames: usize,
    /// Alarm frames marked in the GIF (detector label, frame index in the episode).
    pub alarms: Vec<(String, usize)>,
    /// The trace plot.
    pub trace: Figure,
}

/// First frame whose trigger signal reaches the threshold (the runner's alarm rule).
fn alarm_frame(signal: &[f64], threshold: f64) -> Option<usize> {
    signal.iter().position(|&v| v >= threshold)
}

/// The frames a GIF of an episode of `len` frames shows: every `stride`-th and every alarm frame,
/// at most [`MAX_GIF_FRAMES`] in all.
pub fn gif_frames(len: usize, alarms: &[usize]) -> Vec<usize> {
    let alarms: BTreeSet<usize> = alarms
        .iter()
        .copied()
        .filter(|&k| k < len)
        .take(MAX_GIF_FRAMES / 2)
        .collect();
    let room = MAX_GIF_FRAMES - alarms.len();
    let stride = len.div_ceil(room.max(1)).max(1);
    let mut frames: BTreeSet<usize> = (0..len).step_by(stride).collect();
    if len > 0 {
        frames.insert(len - 1);
    }
    while frames.len() + alarms.len() > MAX_GIF_FRAMES {
        // the last frame pushed it over: drop the frame before it
        let Some(&k) = frames.iter().rev().nth(1) else { break };
        frames.remove(&k);
    }
    frames.extend(alarms);
    frames.into_iter().collect()
}

/// Builds an exemplar: the trace plot from `run` and the GIF `dir/<choice.gif_name()>` from
/// frames rendered again on `ctx` (`spec` is the episode's specification; `gif_rel` the folder
/// of the GIF relative to the page).
pub fn build(
    ctx: &Arc<GpuContext>,
    spec: &EpisodeSpec,
    run: &EpisodeRun,
    choice: &ExemplarChoice,
    dir: &Path,
    gif_rel: &str,
) -> Result<Exemplar, ReportError> {
    let fail = |reason: String| ReportError::Exemplar {
        scenario: choice.scenario.clone(),
        episode: choice.episode,
        reason,
    };
    let tr = &run.trace;
    let len = tr.t_s.len();
    let alarms: Vec<(String, usize)> = tr
        .detectors
        .iter()
        .filter(|d| !is_reference(&d.label))
        .filter_map(|d| Some((d.label.clone(), alarm_frame(&d.signal, d.threshold)?)))
        .collect();
    let wanted = gif_frames(len, &alarms.iter().map(|(_, k)| *k).collect::<Vec<_>>());
    let frames = capture(ctx, spec, len, &wanted).map_err(fail)?;
    let labels: Vec<String> = tr.detectors.iter().map(|d| d.label.clone()).collect();
    let featured = labels.iter().position(|l| l == choice.featured());
    let gif = GifEpisode {
        n: spec.world.camera.n,
        hz: f64::from(spec.world.camera_hz),
        frames: &frames,
        t_s: &tr.t_s,
        theta_deg: &tr.angular_size_deg,
        labels: &labels,
        alarms: &alarms,
        featured,
    };
    std::fs::create_dir_all(dir).map_err(|e| ReportError::io(dir, e))?;
    let path = dir.join(choice.gif_name());
    let bytes = gif.encode().map_err(fail)?;
    std::fs::write(&path, bytes).map_err(|e| ReportError::io(&path, e))?;
    Ok(Exemplar {
        choice: choice.clone(),
        params: run.outcome.params.clone(),
        detectors: run
            .outcome
            .detectors
            .iter()
            .map(|d| (d.detector.clone(), d.outcome, d.t_alarm_s))
            .collect(),
        gif: format!("{gif_rel}/{}", crate::html::url_segment(&choice.gif_name())),
        gif_frames: frames.len(),
        alarms,
        trace: trace_figure(run),
    })
}

/// Renders the open-loop pass of `spec` for `len` frames, keeping the frames in `wanted`
/// (sorted); the others are stepped physics-only.
fn capture(
    ctx: &Arc<GpuContext>,
    spec: &EpisodeSpec,
    len: usize,
    wanted: &[usize],
) -> Result<Vec<(usize, Vec<f32>)>, String> {
    let mut sim = Sim::with_context(&spec.world, spec.seed, Arc::clone(ctx)).map_err(|e| e.to_string())?;
    sim.set_ground_truth(false);
    let mut renderer = sim.take_renderer();
    let mut out = Vec::with_capacity(wanted.len());
    let mut next = wanted.iter().peekable();
    for k in 0..len.min(spec.frames()) {
        let render = next.peek() == Some(&&k);
        if render && let Some(r) = renderer.take() {
            sim.attach_renderer(r).map_err(|e| e.to_string())?;
        }
        let cmd = spec.cruise.command_at(sim.time());
        let step = sim.step(&cmd.to_sim()).map_err(|e| e.to_string())?;
        if render {
            next.next();
            out.push((k, step.frame));
            renderer = sim.take_renderer();
        }
    }
    Ok(out)
}

/// What a GIF shows.
struct GifEpisode<'a> {
    n: u32,
    hz: f64,
    frames: &'a [(usize, Vec<f32>)],
    t_s: &'a [f64],
    theta_deg: &'a [f64],
    labels: &'a [String],
    alarms: &'a [(String, usize)],
    featured: Option<usize>,
}

/// The GIF palette: [`GREYS`] grey levels, then the detectors' colours.
fn gif_palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(256 * 3);
    for i in 0..GREYS {
        let g = (i * 255 / (GREYS - 1)) as u8;
        p.extend([g, g, g]);
    }
    for i in 0..8 {
        let c = palette(i);
        p.extend([c.0, c.1, c.2]);
    }
    p
}

fn palette_index(rgb: [u8; 3]) -> u8 {
    let [r, g, b] = rgb;
    if r == g && g == b {
        return ((usize::from(r) * (GREYS - 1) + 127) / 255) as u8;
    }
    let d = |c: RGBColor| {
        let dr = i32::from(c.0) - i32::from(r);
        let dg = i32::from(c.1) - i32::from(g);
        let db = i32::from(c.2) - i32::from(b);
        dr * dr + dg * dg + db * db
    };
    let (best, dist) = (0..8)
        .map(|i| (i, d(palette(i))))
        .min_by_key(|&(_, d)| d)
        .unwrap_or((0, i32::MAX));
    // anti-aliased text edges between a colour and the grey strip: the nearer of the two
    let grey = (u32::from(r) + u32::from(g) + u32::from(b)) / 3;
    let gd = {
        let gg = grey as i32;
        (gg - i32::from(r)).pow(2) + (gg - i32::from(g)).pow(2) + (gg - i32::from(b)).pow(2)
    };
    if gd < dist {
        ((grey as usize * (GREYS - 1) + 127) / 255) as u8
    } else {
        (GREYS + best) as u8
    }
}

impl GifEpisode<'_> {
    fn encode(&self) -> Result<Vec<u8>, String> {
        register_font();
        let factor = self.n.div_ceil(MAX_GIF_SIZE).max(1);
        // small frames (tests, --size 32) are enlarged, pixel for pixel, so the caption fits
        let up = (f64::from(MAX_GIF_SIZE) / f64::from(self.n / factor)).round().max(1.0) as u32;
        let side = self.n / factor * up;
        let (w, h) = (side, side + CAPTION_PX);
        let mut bytes = Vec::new();
        {
            let mut enc =
                gif::Encoder::new(&mut bytes, w as u16, h as u16, &gif_palette()).map_err(|e| e.to_string())?;
            enc.set_repeat(gif::Repeat::Infinite).map_err(|e| e.to_string())?;
            let featured_alarm = self
                .featured
                .and_then(|i| self.alarms.iter().find(|(l, _)| *l == self.labels[i]).map(|(_, k)| *k));
            for (i, (k, frame)) in self.frames.iter().enumerate() {
                let rgb = self.draw_frame(*k, frame, (factor, up), side, featured_alarm)?;
                let indices: Vec<u8> = rgb.chunks_exact(3).map(|p| palette_index([p[0], p[1], p[2]])).collect();
                let here: Vec<&str> = self.alarm_labels(*k);
                let next = self.frames.get(i + 1).map_or(*k + 1, |(n, _)| *n);
                let delay = if here.is_empty() {
                    (100.0 * SLOW_DOWN * (next - k) as f64 / self.hz)
                        .round()
                        .clamp(2.0, 50.0) as u16
                } else {
                    ALARM_DELAY_CS
                };
                let f = gif::Frame {
                    width: w as u16,
                    height: h as u16,
                    delay,
                    buffer: std::borrow::Cow::Owned(indices),
                    ..gif::Frame::default()
                };
                enc.write_frame(&f).map_err(|e| e.to_string())?;
            }
        }
        Ok(bytes)
    }

    fn alarm_labels(&self, k: usize) -> Vec<&str> {
        self.alarms
            .iter()
            .filter(|(_, a)| *a == k)
            .map(|(l, _)| l.as_str())
            .collect()
    }

    fn colour_of(&self, label: &str) -> RGBColor {
        palette(self.labels.iter().position(|l| l == label).unwrap_or(0))
    }

    /// One GIF frame as RGB: the camera frame box-downscaled by `factor`, enlarged by `up` to
    /// `side` pixels, the alarm marks and the caption strip.
    fn draw_frame(
        &self,
        k: usize,
        frame: &[f32],
        (factor, up): (u32, u32),
        side: u32,
        featured_alarm: Option<usize>,
    ) -> Result<Vec<u8>, String> {
        let (w, h) = (side, side + CAPTION_PX);
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        let n = self.n as usize;
        let f = factor as usize;
        let up = up as usize;
        for y in 0..side as usize {
            for x in 0..side as usize {
                let (sy, sx) = (y / up, x / up);
                let mut sum = 0.0f32;
                for dy in 0..f {
                    for dx in 0..f {
                        sum += frame.get((sy * f + dy) * n + sx * f + dx).copied().unwrap_or(0.0);
                    }
                }
                let v = (sum / (f * f) as f32).clamp(0.0, 1.0);
                let g = (v * 255.0).round() as u8;
                let o = (y * side as usize + x) * 3;
                rgb[o..o + 3].copy_from_slice(&[g, g, g]);
            }
        }
        let here = self.alarm_labels(k);
        {
            let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
            let e = |e: DrawingAreaErrorKind<_>| e.to_string();
            let (iw, ih) = (side as i32, side as i32);
            let border = |width: i32, c: RGBColor| {
                (0..width)
                    .map(|i| Rectangle::new([(i, i), (iw - 1 - i, ih - 1 - i)], c.stroke_width(1)))
                    .collect::<Vec<_>>()
            };
            if let Some(first) = here.first() {
                for r in border(4, self.colour_of(first)) {
                    root.draw(&r).map_err(e)?;
                }
            } else if let (Some(a), Some(i)) = (featured_alarm, self.featured)
                && k > a
            {
                for r in border(1, palette(i)) {
                    root.draw(&r).map_err(e)?;
                }
            }
            let t = self.t_s.get(k).copied().unwrap_or(k as f64 / self.hz);
            let theta = self.theta_deg.get(k).copied().filter(|v| v.is_finite());
            let line1 = match theta {
                Some(th) => format!("t {t:.2}s θ {th:.1}°"),
                None => format!("t {t:.2}s"),
            };
            let font = ("sans-serif", 10).into_font();
            root.draw(&Text::new(line1, (2, ih + 1), font.clone().color(&WHITE)))
                .map_err(e)?;
            if let Some(first) = here.first() {
                let more = if here.len() > 1 {
                    format!(" +{}", here.len() - 1)
                } else {
                    String::new()
                };
                let c = self.colour_of(first);
                root.draw(&Text::new(format!("ALARM {first}{more}"), (2, ih + 12), font.color(&c)))
                    .map_err(e)?;
            } else if let (Some(a), Some(i)) = (featured_alarm, self.featured)
                && k > a
            {
                root.draw(&Text::new(
                    format!("{} alarmed", self.labels[i]),
                    (2, ih + 12),
                    font.color(&palette(i)),
                ))
                .map_err(e)?;
            }
            root.present().map_err(e)?;
        }
        Ok(rgb)
    }
}

/// The trace plot of an episode: every detector's trigger signal divided by its threshold (an
/// alarm where it reaches 1; reference rows are not drawn, their outcomes are in the page's
/// table), and the reference object's true angular size and time to contact,
/// with the escape deadline and the contact marked.
pub fn trace_figure(run: &EpisodeRun) -> Figure {
    /// Signal / threshold is drawn up to this (the alarm is at 1).
    const CLIP: f64 = 3.0;
    let tr = &run.trace;
    let t0 = tr.t_s.first().copied().unwrap_or(0.0);
    let t1 = tr.t_s.last().copied().unwrap_or(1.0);
    let contact = run.outcome.detectors.first().and_then(|d| d.t_contact_s);
    let marks = |y_max: f64| {
        let mut v = Vec::new();
        if let Some(dl) = tr.t_deadline_s {
            v.push(Series::new(format!("escape deadline {dl:.2} s"), vec![dl, dl], vec![0.0, y_max]).dashed());
        }
        if let Some(c) = contact {
            v.push(Series::new(format!("contact {c:.2} s"), vec![c, c], vec![0.0, y_max]).dashed());
        }
        v
    };
    let mut signals: Vec<Series> = tr
        .detectors
        .iter()
        .filter(|d| !is_reference(&d.label))
        .map(|d| {
            let y = d
                .signal
                .iter()
                .map(|&v| {
                    if d.threshold > 0.0 {
                        (v / d.threshold).min(CLIP)
                    } else {
                        f64::NAN
                    }
                })
                .collect();
            Series::new(d.label.clone(), tr.t_s.clone(), y)
        })
        .collect();
    signals.push(Series::new("alarm threshold", vec![t0, t1], vec![1.0, 1.0]).dashed());
    signals.extend(marks(CLIP));
    let theta_max = tr
        .angular_size_deg
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(1.0f64, f64::max)
        .min(180.0);
    let object = tr.reference_object.clone().unwrap_or_else(|| "reference object".into());
    let mut theta = vec![Series::new(
        format!("true angular size of {object}"),
        tr.t_s.clone(),
        tr.angular_size_deg.clone(),
    )];
    theta.extend(marks(theta_max * 1.05));
    let ttc: Vec<f64> = tr.ttc_s.iter().map(|v| v.unwrap_or(f64::NAN)).collect();
    let ttc_max = ttc.iter().copied().filter(|v| v.is_finite()).fold(0.0f64, f64::max);
    let mut ttc_series = vec![Series::new(
        format!("true time to contact of {object}"),
        tr.t_s.clone(),
        ttc,
    )];
    let x_range = Some((t0, t1.max(t0 + 1e-3)));
    let mut charts = vec![
        LineChart {
            title: "trigger signal / alarm threshold".into(),
            x_label: "time (s)".into(),
            y_label: "signal / threshold".into(),
            series: signals,
            x_range,
            y_range: Some((0.0, CLIP)),
        },
        LineChart {
            title: "true angular size".into(),
            x_label: "time (s)".into(),
            y_label: "θ (deg)".into(),
            series: theta,
            x_range,
            y_range: Some((0.0, theta_max * 1.05)),
        },
    ];
    if ttc_max > 0.0 {
        ttc_series.extend(marks(ttc_max * 1.05));
        charts.push(LineChart {
            title: "true time to contact".into(),
            x_label: "time (s)".into(),
            y_label: "TTC (s)".into(),
            series: ttc_series,
            x_range,
            y_range: Some((0.0, ttc_max * 1.05)),
        });
    }
    Figure {
        name: "exemplar_trace",
        caption: String::new(),
        kind: FigureKind::Lines {
            charts,
            cols: 1,
            panel: (560, 220),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use loomlab_scenarios::metrics::DetectorEpisode;

    fn det(label: &str, outcome: Outcome) -> DetectorEpisode {
        // the JSON form names every field; only the label and the outcome matter here
        let mut d: DetectorEpisode = serde_json::from_value(serde_json::json!({
            "detector": label, "threat": false, "t_contact_s": null, "t_deadline_s": null,
            "t_alarm_s": null, "outcome": outcome.as_str(), "collision": false, "triggers": 0,
            "ttc_at_alarm_s": null, "angular_size_at_alarm_deg": null, "max_signal": null,
            "l_over_v_s": null, "eye_ttc_at_alarm_s": null, "theta_rel_err_median": null,
            "theta_rel_err_p90": null,
        }))
        .unwrap();
        d.outcome = outcome;
        d
    }

    fn ep(scenario: &str, episode: usize, dets: Vec<DetectorEpisode>) -> EpisodeOutcome {
        EpisodeOutcome {
            scenario: scenario.into(),
            episode,
            seed: 0,
            params: BTreeMap::new(),
            detectors: dets,
        }
    }

    #[test]
    fn chooses_first_miss_false_alarm_and_hit_per_scenario() {
        use Outcome::*;
        let outcomes = vec![
            ep("a", 0, vec![det("x", CorrectRejection), det("null", CorrectRejection)]),
            ep("a", 1, vec![det("x", Hit), det("y", Miss), det("oracle", Hit)]),
            ep("a", 2, vec![det("x", Miss), det("y", Miss)]),
            ep("a", 3, vec![det("x", CorrectRejection), det("y", FalseAlarm)]),
            ep("b", 0, vec![det("x", Unavoidable), det("oracle", Hit)]),
            ep("b", 1, vec![det("x", Unavoidable)]),
        ];
        let c = choose(&outcomes);
        assert_eq!(c.len(), 3, "{c:?}");
        assert_eq!((c[0].scenario.as_str(), c[0].episode), ("a", 1));
        assert_eq!(
            c[0].reasons,
            vec![
                (ExemplarKind::Miss, "y".to_string()),
                (ExemplarKind::Hit, "x".to_string())
            ]
        );
        assert_eq!(c[0].featured(), "y");
        assert_eq!(
            (c[1].episode, c[1].reasons.clone()),
            (3, vec![(ExemplarKind::FalseAlarm, "y".into())])
        );
        // b has neither miss, false alarm nor hit of a detector (the oracle's hit does not count)
        assert_eq!((c[2].scenario.as_str(), c[2].episode), ("b", 0));
        assert_eq!(c[2].reasons, vec![(ExemplarKind::First, "x".to_string())]);
    }

    #[test]
    fn gif_frames_are_bounded_and_keep_the_alarms() {
        for len in [1usize, 5, 79, 80, 81, 312, 10_000] {
            let all: Vec<usize> = (0..200).collect();
            for alarms in [vec![], vec![len / 2, len.saturating_sub(1), 3], all] {
                let f = gif_frames(len, &alarms);
                assert!(f.len() <= MAX_GIF_FRAMES && !f.is_empty(), "len {len}: {}", f.len());
                assert!(f.windows(2).all(|w| w[0] < w[1]) && f.iter().all(|&k| k < len));
                if alarms.len() < 3 {
                    assert!(
                        alarms.iter().filter(|&&a| a < len).all(|a| f.contains(a)),
                        "{len} {alarms:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn palette_maps_greys_and_colours() {
        assert_eq!(palette_index([0, 0, 0]), 0);
        assert_eq!(palette_index([255, 255, 255]), (GREYS - 1) as u8);
        let c = palette(2);
        assert_eq!(palette_index([c.0, c.1, c.2]), (GREYS + 2) as u8);
        assert!(gif_palette().len() <= 256 * 3);
    }
}
