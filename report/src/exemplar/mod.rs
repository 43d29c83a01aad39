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
//! With an event camera a second GIF shows the same frames' events (those since the previous shown
//! frame: ON brighter, OFF darker than mid-grey), so every frame of the episode is rendered again.
//!
//! Cost: the traces come from the runs the CLI keeps while the suite runs ([`ExemplarRuns`]: at
//! most four per scenario); only an exemplar from an earlier invocation (a resumed run) is run
//! again. The frames are rendered again in one open-loop pass per exemplar that renders only the
//! frames the GIF shows (the physics steps every frame; rendering is most of the cost).

mod capture;
mod choice;
mod gif_palette;
mod runs;
mod trace;
mod view_gif;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use loomlab_scenarios::metrics::Outcome;
use loomlab_scenarios::reference::is_reference;
use loomlab_scenarios::{EpisodeRun, EpisodeSpec};
use loomlab_sim::GpuContext;

use crate::ReportError;
use crate::run_plots::Figure;
use capture::capture;
pub use capture::event_image;
pub use choice::{ExemplarChoice, ExemplarKind, choose};
pub use runs::ExemplarRuns;
pub use trace::trace_figure;
use view_gif::GifEpisode;
pub use view_gif::{MAX_GIF_FRAMES, MAX_GIF_SIZE, gif_frames};

/// Exemplary episodes per scenario at most (first miss, first false alarm, first hit).
pub const PER_SCENARIO: usize = 3;
/// Scenarios with exemplars at most (the first ones of the suite; bounds the page's cost).
pub const MAX_SCENARIOS: usize = 64;

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
    /// With an event camera: the events GIF's path relative to the page (the same frames, each
    /// showing the events since the previous one).
    pub events_gif: Option<String>,
    /// Alarm frames marked in the GIF (detector label, frame index in the episode).
    pub alarms: Vec<(String, usize)>,
    /// The trace plot.
    pub trace: Figure,
}

/// First frame whose trigger signal reaches the threshold (the runner's alarm rule).
fn alarm_frame(signal: &[f64], threshold: f64) -> Option<usize> {
    signal.iter().position(|&v| v >= threshold)
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
    let captured = capture(ctx, spec, len, &wanted).map_err(fail)?;
    let labels: Vec<String> = tr.detectors.iter().map(|d| d.label.clone()).collect();
    let featured = labels.iter().position(|l| l == choice.featured());
    let view = GifEpisode {
        n: spec.world.camera.n,
        hz: f64::from(spec.world.camera_hz),
        frames: &captured.frames,
        t_s: &tr.t_s,
        theta_deg: &tr.angular_size_deg,
        labels: &labels,
        alarms: &alarms,
        featured,
    };
    std::fs::create_dir_all(dir).map_err(|e| ReportError::io(dir, e))?;
    let write = |name: &str, episode: GifEpisode<'_>| -> Result<String, ReportError> {
        let path = dir.join(name);
        let bytes = episode.encode().map_err(fail)?;
        std::fs::write(&path, bytes).map_err(|e| ReportError::io(&path, e))?;
        Ok(format!("{gif_rel}/{}", crate::html::url_segment(name)))
    };
    let events_gif = match &captured.events {
        Some(events) => Some(write(&choice.events_gif_name(), GifEpisode { frames: events, ..view })?),
        None => None,
    };
    let view = write(&choice.gif_name(), view)?;
    Ok(Exemplar {
        choice: choice.clone(),
        params: run.outcome.params.clone(),
        detectors: run
            .outcome
            .detectors
            .iter()
            .map(|d| (d.detector.clone(), d.outcome, d.t_alarm_s))
            .collect(),
        gif: view,
        gif_frames: captured.frames.len(),
        events_gif,
        alarms,
        trace: trace_figure(run),
    })
}
