//! The closed-loop runner: episodes in parallel, ground truth, escape deadlines, detector traces,
//! closed-loop escapes, reference rows and scores.
//!
//! # One episode
//! 1. **Open-loop pass** (ground truth and detection). The simulator renders every frame while the
//!    robot follows its cruise command (no escape); **all detectors of the episode see these same
//!    frames**. It ends at the first contact of any object with the robot's body or after
//!    `episode.duration_s`. [`crate::truth`] turns it into the threat, its exact contact time
//!    `t_c` and the reference object.
//! 2. **Escape deadline** of a threat ([`crate::deadline`]): physics-only replays of the escape
//!    manoeuvre triggered at candidate frames, with the dodge side each frame's images give.
//! 3. **Scores** ([`crate::metrics`]): from each row's trigger-signal trace (θ̂ for hopfield, the
//!    output for the baselines) the first alarm `t_a` (first frame with `signal >= threshold`)
//!    gives hit / miss / unavoidable / false alarm / correct rejection, the reference object's true
//!    TTC and angular size at the alarm, the ROC score, the l/|v| quantities of a head-on
//!    constant-speed threat ([`crate::lv`]) and the θ̂ accuracy of θ̂-triggered rows.
//! 4. **Closed loop, per row.** Until a row's first alarm the escape controller only passes the
//!    cruise command through, so the closed-loop trajectory is *identical* to the open-loop one up
//!    to that frame. Hence:
//!    - a row that never alarms collides iff the episode is a threat;
//!    - one that first alarms at or after the contact frame collides;
//!    - otherwise a detector's tail rebuilds the world without rendering, replays physics up to
//!      the alarm frame while feeding an [`EscapeAgent`] the cached open-loop frames (so its
//!      state is exactly the open-loop state): its agent gets a copy of the row's detector taken
//!      in the open-loop pass right after the alarm frame ([`Detector::snapshot`]) and replays
//!      the open-loop signals instead of stepping a detector through the prefix again
//!      ([`EscapeAgent::step_posed_with_signals`]; a detector that cannot copy itself is stepped
//!      from a fresh build, as before); then it continues with rendering, the agent driving
//!      the robot until the first contact (**collision**) or the end of the episode (**evaded**).
//!      Re-triggers (the controller is level-triggered after its cooldown) are simulated. The
//!      rendered parts of an episode's tails run in lockstep: each frame index renders the views
//!      of every tail still running in one batch ([`Sim::step_batch`]; each view bit-identical to
//!      rendering it alone, so the results are those of running the tails one by one).
//!
//!    The reference rows ([`crate::reference`], on by default, [`Runner::with_references`]) are
//!    scored by the same code: `null` never alarms; `oracle`'s closed loop is the deadline replay
//!    of its deadline frame; `ideal_theta`'s is physics-only with ground truth as its percept.
//!
//!    So the cost of an episode is one rendered open-loop pass, the deadline replays (physics
//!    only, no ground-truth predictions) and the rendered post-alarm tails of the detectors that
//!    alarm, instead of one full rendered pass per detector.
//! 5. **Dodge direction** comes from the image, not from ground truth: at every controller step
//!    the looming side is the x centroid of the temporal contrast |frame(t) − frame(t−1)|
//!    ([`loomlab_agents::LoomingSideEstimator`]); the controller latches it at the trigger.
//!
//! # Parallelism and batching
//! Episodes run on a rayon pool of `jobs` workers sharing one [`GpuContext`]; renderers are kept in
//! a pool and reused across episodes (at most one per worker and frame size is ever created).
//! Within an episode, frames are rendered in batches (one submission and readback for many views):
//! the open-loop pass, whose cruise commands do not depend on the frames, steps physics up to
//! 16 frames ahead and renders their captured views ([`Sim::capture_view`]) together, and the
//! detectors' tails run in lockstep (above).
//! Results are handed to a callback as episodes finish (for `episodes.csv` and the progress bar)
//! and returned in suite order; the run is deterministic whatever the number of workers.

mod ego;
mod head_on;
mod pool;
mod reference;
mod rows;
mod tails;
mod trace;

pub use pool::{cpus, max_jobs};
pub use reference::ideal_theta_threshold_deg;
pub use trace::{ClosedLoop, DetectorTrace, EpisodeRun, EpisodeTrace, StrategyTrace};

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use loomlab_agents::{Ego, EgoSensor, EscapeConfig, EscapeController, LoomingSideEstimator, Strategy, TriggerSignal};
use loomlab_detector::{Detector, Frame, ImageRegion, Signals};
use loomlab_sim::{GpuContext, ObjectTruth, Sim, SimError};
use rayon::prelude::*;

use crate::deadline::{escape_deadline_cancellable, replay_trigger};
use crate::error::RunError;
use crate::metrics::{
    DetectorEpisode, EpisodeOutcome, GroundTruth, ThetaAccuracy, TraceSample, score_detector_episode,
};
use crate::schema::{DetectorSpec, EpisodeSpec};
use crate::truth::TruthRecorder;
use ego::open_loop_ego;
use head_on::HeadOnApproach;
use pool::RendererPool;
use reference::{ideal_tail, reference_rows};
use rows::{Row, Tail, covers_object};
use tails::TailJob;

// the module docs link to it; the closed-loop tails drive it
#[cfg(doc)]
use loomlab_agents::EscapeAgent;

/// Open-loop steps whose views are rendered in one batch (one submission and readback).
const OPEN_LOOP_BATCH: usize = 16;

/// Runs episodes on a shared GPU context and a worker pool.
pub struct Runner {
    ctx: Arc<GpuContext>,
    renderers: RendererPool,
    pool: rayon::ThreadPool,
    jobs: usize,
    references: bool,
    /// Set (Ctrl-C): episodes in flight give up within about a second ([`RunError::Interrupted`]).
    cancel: Arc<AtomicBool>,
}

impl std::fmt::Debug for Runner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Runner")
            .field("ctx", &self.ctx)
            .field("jobs", &self.jobs)
            .finish()
    }
}

struct Ctx<'a> {
    ep: &'a EpisodeSpec,
}

impl Ctx<'_> {
    fn sim(&self, source: SimError) -> RunError {
        RunError::Sim {
            scenario: self.ep.scenario.clone(),
            episode: self.ep.index,
            source,
        }
    }
    fn det(&self, source: loomlab_detector::DetectorError) -> RunError {
        RunError::Detector {
            scenario: self.ep.scenario.clone(),
            episode: self.ep.index,
            source,
        }
    }
}

impl Runner {
    /// Creates the GPU context (lavapipe without a GPU) and a pool of `jobs` workers (default: the
    /// number of CPUs).
    pub fn new(jobs: Option<usize>) -> Result<Self, RunError> {
        let ctx = GpuContext::new().map_err(RunError::Gpu)?;
        Self::with_context(ctx, jobs)
    }

    /// A runner on an existing GPU context. `jobs` is clamped to [1, [`max_jobs`]] (also the
    /// default).
    pub fn with_context(ctx: Arc<GpuContext>, jobs: Option<usize>) -> Result<Self, RunError> {
        let jobs = jobs
            .unwrap_or(usize::MAX)
            .clamp(1, max_jobs(cpus(), ctx.renders_on_cpu()));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(jobs)
            .thread_name(|i| format!("loomlab-episode-{i}"))
            .build()
            .map_err(|e| RunError::Threads {
                jobs,
                reason: e.to_string(),
            })?;
        Ok(Self {
            ctx,
            renderers: RendererPool::default(),
            pool,
            jobs,
            references: true,
            cancel: Arc::new(AtomicBool::new(false)),
        })
    }

    /// Episodes give up (with [`RunError::Interrupted`]; [`Self::run_until`] reports them as not
    /// run) within about a second of `cancel` being set: checked every frame and within the
    /// escape-deadline replays.
    pub fn with_cancel(mut self, cancel: Arc<AtomicBool>) -> Self {
        self.cancel = cancel;
        self
    }

    fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// Whether episodes also score the reference rows `null`, `oracle` and `ideal_theta` (default
    /// true; see [`crate::reference`]).
    pub fn with_references(mut self, references: bool) -> Self {
        self.references = references;
        self
    }

    /// Number of workers.
    pub fn jobs(&self) -> usize {
        self.jobs
    }

    /// The adapter, e.g. `llvmpipe (…)`.
    pub fn adapter(&self) -> String {
        self.ctx.describe()
    }

    /// Runs `episodes` in parallel. `on_done(i, run)` is called (from a worker thread) for each
    /// episode in the order of `episodes`, as soon as it and every episode before it have finished
    /// (so what a caller writes from it does not depend on the number of workers); an error from it
    /// stops the run. Returns the runs in the order of `episodes`.
    pub fn run<F>(&self, episodes: &[&EpisodeSpec], on_done: F) -> Result<Vec<EpisodeRun>, RunError>
    where
        F: Fn(usize, &EpisodeRun) -> Result<(), String> + Sync,
    {
        let runs = self.run_until(episodes, &AtomicBool::new(false), on_done)?;
        Ok(runs.into_iter().flatten().collect())
    }

    /// [`Self::run`] that can be stopped: once `stop` is set no further episode starts (those in
    /// flight finish). The episodes reported to `on_done` — every one before the first that did not
    /// run — are `Some`, the others `None`.
    pub fn run_until<F>(
        &self,
        episodes: &[&EpisodeSpec],
        stop: &AtomicBool,
        on_done: F,
    ) -> Result<Vec<Option<EpisodeRun>>, RunError>
    where
        F: Fn(usize, &EpisodeRun) -> Result<(), String> + Sync,
    {
        // finished runs wait in their slot until every earlier one is reported
        let slots: Vec<Mutex<Option<EpisodeRun>>> = episodes.iter().map(|_| Mutex::new(None)).collect();
        let reported = Mutex::new(0usize);
        fn lock(m: &Mutex<Option<EpisodeRun>>) -> std::sync::MutexGuard<'_, Option<EpisodeRun>> {
            m.lock().unwrap_or_else(|e| e.into_inner())
        }
        self.pool.install(|| {
            episodes
                .par_iter()
                .enumerate()
                .with_max_len(1)
                .try_for_each(|(i, ep)| -> Result<(), RunError> {
                    if stop.load(Ordering::SeqCst) {
                        return Ok(());
                    }
                    let run = match self.run_episode(ep) {
                        Err(RunError::Interrupted) => return Ok(()),
                        other => other?,
                    };
                    *lock(&slots[i]) = Some(run);
                    let mut next = reported.lock().unwrap_or_else(|e| e.into_inner());
                    while *next < slots.len() {
                        let slot = lock(&slots[*next]);
                        let Some(run) = slot.as_ref() else { break };
                        on_done(*next, run).map_err(RunError::Callback)?;
                        drop(slot);
                        *next += 1;
                    }
                    Ok(())
                })
        })?;
        let reported = reported.into_inner().unwrap_or_else(|e| e.into_inner());
        Ok(slots
            .into_iter()
            .enumerate()
            .map(|(i, slot)| {
                let run = slot.into_inner().unwrap_or_else(|e| e.into_inner());
                run.filter(|_| i < reported)
            })
            .collect())
    }

    /// Runs one episode on the calling thread (see the module docs).
    pub fn run_episode(&self, ep: &EpisodeSpec) -> Result<EpisodeRun, RunError> {
        let c = Ctx { ep };
        let n = ep.world.camera.n;
        let nn = n as usize;
        let total = ep.frames();
        let nd = ep.detectors.len();

        // ---- open-loop pass: render once, every detector on the same frames ----
        // The cruise command does not depend on the frames, so physics runs ahead by up to
        // OPEN_LOOP_BATCH steps, capturing each step's view, and the views are rendered in one
        // batch (bit-identical to rendering each at its step), then handed to the detectors in
        // order. Steps past the first collision are never rendered.
        let mut renderer = self.renderers.take(&self.ctx, n).map_err(|e| c.sim(e))?;
        let mut sim = Sim::new_physics_only(&ep.world, ep.seed).map_err(|e| c.sim(e))?;
        let objects = sim.objects();
        // Rows that run the same detector (the same id and parameters, e.g. `hopfield` and
        // `hopfield_tau`, which differ only in their decision rule) share one instance here: a
        // detector's signals depend on nothing but its frames and efference copies.
        let runs_as = same_detector_as(&ep.detectors);
        let mut detectors: Vec<Option<Box<dyn Detector>>> = Vec::with_capacity(nd);
        for (i, d) in ep.detectors.iter().enumerate() {
            detectors.push(if runs_as[i] == i {
                Some(d.build(nn).map_err(|e| c.det(e))?)
            } else {
                None
            });
        }
        let mut stepped: Vec<Signals> = vec![Signals::default(); nd];
        let mut frames: Vec<Frame> = Vec::with_capacity(total);
        let mut t_s = Vec::with_capacity(total);
        let mut signal = vec![Vec::with_capacity(total); nd];
        let mut output = vec![Vec::with_capacity(total); nd];
        let mut regions: Vec<Vec<Option<ImageRegion>>> = vec![Vec::with_capacity(total); nd];
        // Each detector instance's signals per frame: a closed-loop tail's agent replays them up
        // to its alarm instead of stepping a detector through the prefix again.
        let mut history: Vec<Vec<Signals>> = vec![Vec::new(); nd];
        // Rows with a stateful strategy (τ, course gate): their decision value frame by frame,
        // exactly as the escape agent computes it (the raw trigger signal is kept as `raw`).
        let mut strategies: Vec<Option<(EscapeConfig, Strategy)>> = ep
            .detectors
            .iter()
            .map(|spec| {
                spec.is_strategy().then(|| {
                    let config = spec.controller(&ep.controller);
                    let strategy = config.strategy();
                    (config, strategy)
                })
            })
            .collect();
        let mut decided: Vec<Vec<f64>> = vec![Vec::new(); nd];
        let mut estimates: Vec<(Vec<Option<f64>>, Vec<bool>)> = vec![(Vec::new(), Vec::new()); nd];
        let mut egos: Vec<Ego> = Vec::with_capacity(total);
        // Per row, its first alarm frame and a copy of its detector right after that frame
        // (`Detector::snapshot`; `None` when the detector cannot copy itself): its tail starts there.
        let mut alarmed_at: Vec<Option<usize>> = vec![None; nd];
        let mut snapshots: Vec<Option<Box<dyn Detector>>> = (0..nd).map(|_| None).collect();
        let mut side = LoomingSideEstimator::default();
        let mut sides: Vec<Option<f32>> = Vec::with_capacity(total);
        let mut ego_sensor = EgoSensor::default();
        let mut truth: Vec<Vec<ObjectTruth>> = Vec::with_capacity(total);
        let mut recorder = TruthRecorder::new(&sim);
        let open = (|| -> Result<(), RunError> {
            let mut steps = 0;
            let mut ahead = Vec::with_capacity(OPEN_LOOP_BATCH);
            let mut pixels: Vec<Vec<f32>> = Vec::with_capacity(OPEN_LOOP_BATCH);
            'pass: while steps < total {
                if self.cancelled() {
                    return Err(RunError::Interrupted);
                }
                ahead.clear();
                while ahead.len() < OPEN_LOOP_BATCH && steps < total {
                    let cmd = ep.cruise.command_at(sim.time());
                    let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
                    steps += 1;
                    let collided = out.first_collision().is_some();
                    ahead.push((cmd, out, sim.camera_pose(), sim.capture_view()));
                    if collided {
                        break;
                    }
                }
                let descs: Vec<_> = ahead.iter().map(|a| a.3.desc()).collect();
                pixels.resize_with(descs.len(), Vec::new);
                renderer
                    .render_batch(&descs, &mut pixels[..descs.len()])
                    .map_err(|e| c.sim(e))?;
                for ((cmd, mut out, camera_pose, _), px) in ahead.drain(..).zip(pixels.iter_mut()) {
                    if self.cancelled() {
                        return Err(RunError::Interrupted);
                    }
                    let frame = Frame::from_f32(nn, std::mem::take(px)).map_err(|e| c.det(e))?;
                    // the efference copy: the command applied during this period and the camera's
                    // motion and pose, as the escape agent passes it in the closed loop (the same
                    // up to the first alarm)
                    let ego = ego_sensor.sense(cmd, out.t_s, &camera_pose);
                    for (i, (d, spec)) in detectors.iter_mut().zip(&ep.detectors).enumerate() {
                        stepped[i] = match d {
                            Some(d) => d.step_moving(&frame, &ego).map_err(|e| c.det(e))?,
                            None => stepped[runs_as[i]].clone(),
                        };
                        let s = &stepped[i];
                        signal[i].push(spec.trigger.value(s).unwrap_or(f64::NAN));
                        output[i].push(s.output);
                        regions[i].push(s.region);
                        if runs_as[i] == i {
                            history[i].push(s.clone());
                        }
                    }
                    t_s.push(out.t_s);
                    let k = t_s.len() - 1;
                    sides.push(side.update(&frame));
                    egos.push(open_loop_ego(ep, &t_s, k, Some(sim.camera())));
                    for (i, spec) in ep.detectors.iter().enumerate() {
                        let value = match &mut strategies[i] {
                            Some((config, strategy)) => {
                                let percept = config.percept_of(signal[i][k], sides[k], regions[i][k].as_ref());
                                let decision = strategy.update(t_s[k], percept, egos[k]);
                                decided[i].push(decision.value);
                                estimates[i].0.push(decision.tau_s);
                                estimates[i].1.push(decision.gate_open);
                                decision.value
                            }
                            None => signal[i][k],
                        };
                        if alarmed_at[i].is_none() && value >= spec.threshold {
                            alarmed_at[i] = Some(k);
                            snapshots[i] = detectors[runs_as[i]].as_ref().and_then(|d| d.snapshot());
                        }
                    }
                    frames.push(frame);
                    let contact = recorder.record(&out).is_some();
                    truth.push(std::mem::take(&mut out.truth));
                    if contact {
                        break 'pass;
                    }
                }
            }
            Ok(())
        })();
        self.renderers.give_back(renderer);
        open?;
        let mut frames_rendered = frames.len();

        // ---- ground truth: threat, reference object, escape deadline, l/|v| ----
        let episode_truth = recorder.finish();
        let reference = episode_truth.reference;
        let ref_truth = |k: usize| reference.and_then(|id| truth[k].get(id));
        let ref_ttc: Vec<Option<f64>> = (0..t_s.len())
            .map(|k| ref_truth(k).and_then(|o| o.ttc_s).map(f64::from))
            .collect();
        let ref_theta: Vec<f64> = (0..t_s.len())
            .map(|k| ref_truth(k).map_or(f64::NAN, |o| f64::from(o.angular_size_deg)))
            .collect();
        let mut raw_theta: Vec<Option<Vec<f64>>> = vec![None; nd];
        for (i, strategy) in strategies.iter().enumerate() {
            if strategy.is_some() {
                raw_theta[i] = Some(std::mem::replace(&mut signal[i], std::mem::take(&mut decided[i])));
            }
        }
        let escape = EscapeController::new(ep.controller.clone()).map_err(|source| RunError::Controller {
            scenario: ep.scenario.clone(),
            episode: ep.index,
            source,
        })?;
        let deadline_started = std::time::Instant::now();
        let deadline = match &episode_truth.contact {
            Some(contact) => Some(
                escape_deadline_cancellable(ep, ep.seed, &escape, &sides, &t_s, contact.frame, &self.cancel)
                    .map_err(|e| c.sim(e))?
                    .ok_or(RunError::Interrupted)?,
            ),
            None => None,
        };
        let deadline_s = deadline_started.elapsed().as_secs_f64();
        let approach = episode_truth
            .contact
            .as_ref()
            .and_then(|contact| HeadOnApproach::measure(&truth, contact.object_id, contact.frame, ep.world.dt()));
        let ground_truth = GroundTruth {
            threat: episode_truth.threat(),
            t_contact_s: episode_truth.t_contact_s(),
            t_deadline_s: deadline.as_ref().and_then(|d| d.t_s),
            collision: false,
        };
        let contact_frame = episode_truth.contact.as_ref().map(|c| c.frame);

        // ---- scores and closed loops: the detectors, then the reference rows ----
        let threat_object = episode_truth.contact.as_ref().map(|c| c.object_id);
        let mut rows: Vec<Row> = ep
            .detectors
            .iter()
            .enumerate()
            .map(|(i, spec)| {
                let fov_deg = spec.controller(&ep.controller).camera_fov_deg;
                let covers = threat_object.and_then(|id| covers_object(&regions[i], &truth, id, fov_deg));
                let idle = if spec.trigger.reads_angular_size() {
                    0.0
                } else {
                    f64::NAN
                };
                let localises = regions[i].iter().any(Option::is_some);
                Row {
                    label: spec.label.clone(),
                    trigger: spec.trigger,
                    threshold: spec.threshold,
                    about_threat: covers.as_ref().map(|covers| {
                        covers
                            .iter()
                            .zip(&signal[i])
                            .map(|(&c, &s)| if c { s } else { idle })
                            .collect()
                    }),
                    about_mask: covers,
                    signal: std::mem::take(&mut signal[i]),
                    raw: raw_theta[i].take(),
                    estimates: strategies[i].is_some().then(|| std::mem::take(&mut estimates[i])),
                    regions: localises.then(|| std::mem::take(&mut regions[i])),
                    output: std::mem::take(&mut output[i]),
                    tail: Tail::Detector(spec),
                }
            })
            .collect();
        if self.references {
            rows.extend(reference_rows(ep, &truth, &t_s, deadline.as_ref(), threat_object));
        }
        let first_alarms: Vec<Option<usize>> = rows
            .iter()
            .map(|row| row.signal.iter().position(|&s| s >= row.threshold))
            .collect();
        // the detectors' post-alarm tails, stepped in lockstep (one render batch per frame)
        let mut tail_jobs: Vec<TailJob<'_>> = Vec::new();
        for (r, (row, &alarm)) in rows.iter().zip(&first_alarms).enumerate() {
            if let (Tail::Detector(spec), Some(ka)) = (&row.tail, alarm)
                && contact_frame.is_none_or(|kc| ka < kc)
            {
                // detector rows come first: row r is detector entry r
                // the open-loop pass found the same first alarm (same values, same comparison)
                debug_assert_eq!(alarmed_at[r], Some(ka));
                let start = snapshots[r].take();
                tail_jobs.push(TailJob {
                    row: r,
                    spec,
                    alarm: ka,
                    start,
                    signals: &history[runs_as[r]],
                });
            }
        }
        let tail_rows: Vec<usize> = tail_jobs.iter().map(|j| j.row).collect();
        let tail_runs = self.closed_loop_tails(&c, tail_jobs, &frames, &sides)?;
        let mut tail_runs: Vec<Option<ClosedLoop>> = {
            let mut by_row: Vec<Option<ClosedLoop>> = (0..rows.len()).map(|_| None).collect();
            for (r, cl) in tail_rows.into_iter().zip(tail_runs) {
                by_row[r] = Some(cl);
            }
            by_row
        };
        let mut scored: Vec<DetectorEpisode> = Vec::with_capacity(rows.len());
        let mut closed = Vec::with_capacity(rows.len());
        for (r, row) in rows.iter().enumerate() {
            // a row that names its objects is scored on its alarms about the threat
            let scored_signal = row.about_threat.as_ref().unwrap_or(&row.signal);
            let samples: Vec<TraceSample> = (0..t_s.len())
                .map(|k| TraceSample {
                    t_s: t_s[k],
                    signal: scored_signal[k],
                    ttc_s: ref_ttc[k],
                    angular_size_deg: Some(ref_theta[k]).filter(|v| v.is_finite()),
                })
                .collect();
            let mut d = score_detector_episode(&row.label, row.threshold, &samples, &ground_truth, &ep.scoring)
                .map_err(|source| RunError::Scoring {
                    scenario: ep.scenario.clone(),
                    episode: ep.index,
                    source,
                })?;
            let first_alarm = first_alarms[r];
            let first_alarm_about_threat = scored_signal.iter().position(|&s| s >= row.threshold);
            let cl = match (first_alarm, contact_frame) {
                (None, _) => ClosedLoop {
                    label: row.label.clone(),
                    simulated: false,
                    triggers: 0,
                    collision: episode_truth.impact(),
                    frames_rendered: 0,
                },
                (Some(ka), Some(kc)) if ka >= kc => ClosedLoop {
                    label: row.label.clone(),
                    simulated: false,
                    triggers: 1,
                    collision: episode_truth.impact(),
                    frames_rendered: 0,
                },
                (Some(ka), _) => match &row.tail {
                    Tail::Replay => ClosedLoop {
                        label: row.label.clone(),
                        simulated: true,
                        triggers: 1,
                        collision: replay_trigger(ep, ep.seed, &escape, ka, sides[ka]).map_err(|e| c.sim(e))?,
                        frames_rendered: 0,
                    },
                    Tail::Ideal(kind) => ideal_tail(&c, &row.label, *kind, &truth, ka)?,
                    Tail::Detector(_) => tail_runs[r].take().ok_or(RunError::Interrupted)?,
                },
            };
            frames_rendered += cl.frames_rendered;
            d.collision = cl.collision.is_some();
            d.impact_speed_mps = cl.collision.map(|i| i.impact_speed_mps);
            d.impulse_ns = cl.collision.and_then(|i| i.impulse_ns);
            d.triggers = cl.triggers as u64;
            d.theta_required_deg = deadline
                .as_ref()
                .and_then(|dl| dl.frame)
                .and_then(|k| ref_theta.get(k).copied())
                .filter(|v| v.is_finite());
            if let Some(a) = &approach {
                d.l_over_v_s = Some(a.l_over_v_s);
                d.eye_ttc_at_alarm_s = first_alarm_about_threat.and_then(|k| a.eye_ttc_s(k));
            }
            let theta_hat = match (&row.tail, row.trigger) {
                (Tail::Detector(_), TriggerSignal::AngularSizeDeg | TriggerSignal::Tau) => {
                    Some(row.raw.as_ref().unwrap_or(&row.signal))
                }
                _ => None,
            };
            if ground_truth.threat
                && let Some(theta_hat) = theta_hat
            {
                let pairs: Vec<(f64, f64)> = theta_hat.iter().copied().zip(ref_theta.iter().copied()).collect();
                (
                    d.theta_rel_err_median,
                    d.theta_rel_err_p90,
                    d.theta_at_first_estimate_deg,
                ) = ThetaAccuracy::episode(&pairs);
            }
            scored.push(d);
            closed.push(cl);
        }

        let trace = EpisodeTrace {
            t_s,
            reference_object: reference.map(|id| objects[id].1.clone()),
            angular_size_deg: ref_theta,
            ttc_s: ref_ttc,
            t_deadline_s: ground_truth.t_deadline_s,
            ego: egos,
            looming_side: sides,
            detectors: rows
                .into_iter()
                .map(|row| DetectorTrace {
                    label: row.label,
                    trigger: row.trigger,
                    threshold: row.threshold,
                    strategy: row
                        .raw
                        .zip(row.estimates)
                        .map(|(theta_hat_deg, (tau_s, gate_open))| StrategyTrace {
                            theta_hat_deg,
                            tau_s,
                            gate_open,
                        }),
                    regions: row.regions,
                    about_threat: row.about_mask,
                    signal: row.signal,
                    output: row.output,
                })
                .collect(),
        };
        Ok(EpisodeRun {
            outcome: EpisodeOutcome {
                scenario: ep.scenario.clone(),
                episode: ep.index,
                seed: ep.seed,
                params: ep.params.clone(),
                detectors: scored,
            },
            trace,
            closed_loop: closed,
            deadline,
            deadline_s,
            frames_rendered,
        })
    }
}

/// For each detector entry, the first entry that runs the same detector (the same id and
/// parameters; itself when none before it does).
fn same_detector_as(specs: &[DetectorSpec]) -> Vec<usize> {
    (0..specs.len())
        .map(|i| {
            (0..i)
                .find(|&j| specs[j].id == specs[i].id && specs[j].params == specs[i].params)
                .unwrap_or(i)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use loomlab_sim::ObjectKind;

    /// A ball of half-size 0.15 m on the optical axis whose centre is `distance(k)` away.
    fn ball(distance: f64) -> ObjectTruth {
        let half_deg = (0.15 / distance).asin().to_degrees() as f32;
        ObjectTruth {
            id: 0,
            name: "ball".into(),
            kind: ObjectKind::Projectile,
            distance_m: (distance - 0.15) as f32,
            center_distance_m: distance as f32,
            angular_size_deg: (2.0 * (0.15 / distance).asin()).to_degrees() as f32,
            angular_rate_deg_s: 0.0,
            tau_s: None,
            ttc_s: None,
            on_collision_course: true,
            bearing: 0.0,
            bearing_deg: 0.0,
            elevation_deg: 0.0,
            azimuth_extent_deg: [-half_deg, half_deg],
            elevation_extent_deg: [-half_deg, half_deg],
            in_view: true,
            in_contact: false,
        }
    }

    #[test]
    fn rows_that_differ_only_in_their_decision_rule_share_one_detector() {
        let text = r#"
[world.camera]
n = 32
[[detectors]]
id = "hopfield"
[[detectors]]
id = "soc"
[[detectors]]
id = "hopfield"
label = "hopfield_tau"
trigger = "tau"
[[detectors]]
id = "hopfield"
label = "hopfield_adapted"
params = { front_end = "adapted" }
[[detectors]]
id = "hopfield"
label = "hopfield_adapted_tau"
trigger = "tau"
params = { front_end = "adapted" }
[[detectors]]
id = "soc"
label = "soc_low"
threshold = 1.0
"#;
        let scenario = crate::schema::parse_scenario(
            text,
            std::path::Path::new("shared.toml"),
            None,
            &crate::schema::LoadOptions::default(),
        )
        .unwrap();
        let ep = scenario.episode(0).unwrap();
        assert_eq!(same_detector_as(&ep.detectors), vec![0, 1, 0, 3, 3, 1]);
    }

    #[test]
    fn a_tracked_detector_counts_only_its_alarms_whose_region_overlaps_the_threat() {
        // the threat: a ball on the axis, 5 m away (about ±1.7°); a car far right (id 1)
        let threat = ball(5.0);
        let car = ObjectTruth {
            id: 1,
            bearing_deg: 20.0,
            azimuth_extent_deg: [15.0, 25.0],
            ..ball(5.0)
        };
        let truth = vec![vec![threat.clone(), car.clone()]; 3];
        let region = |x: [f64; 2]| ImageRegion {
            centroid: [(x[0] + x[1]) / 2.0, 0.0],
            x,
            y: [-0.1, 0.1],
            track: Some(1),
        };
        // frame 0: tracking the car (x 0.45..0.8 at a 60° view: 14.6°..24.8°); 1: the ball; 2: none
        let regions = [Some(region([0.45, 0.8])), Some(region([-0.05, 0.05])), None];
        let about = covers_object(&regions, &truth, 0, 60.0).expect("a tracker");
        assert_eq!(about, vec![false, true, false]);
        let about_car = covers_object(&regions, &truth, 1, 60.0).unwrap();
        assert_eq!(about_car, vec![true, false, false]);
        // a detector without tracks: its alarms are all taken to be about the threat
        let untracked = [
            Some(ImageRegion {
                track: None,
                ..region([-0.05, 0.05])
            }),
            None,
            None,
        ];
        assert_eq!(covers_object(&untracked, &truth, 0, 60.0), None);
    }

    #[test]
    fn alarms_before_the_constant_approach_stay_out_of_the_lv_fit() {
        // 100 Hz: 6 m/s for 0.5 s, then 3 m/s until the centre is 0.2 m away (frame 150)
        let dt = 0.01;
        let distance = |k: usize| {
            let k = k as f64;
            if k <= 50.0 {
                0.2 + 3.0 * 1.0 + 6.0 * (50.0 - k) * dt
            } else {
                0.2 + 3.0 * (150.0 - k) * dt
            }
        };
        let truth: Vec<Vec<ObjectTruth>> = (0..=150).map(|k| vec![ball(distance(k))]).collect();
        let a = HeadOnApproach::measure(&truth, 0, 150, dt).expect("constant over the last 0.5 s");
        assert!((a.l_over_v_s - 0.05).abs() < 0.001, "l/|v| = {}", a.l_over_v_s);
        // the constant stretch starts where the speed changes (central differences mix 49–51)
        assert!((50..=52).contains(&a.constant_from), "{}", a.constant_from);
        assert_eq!(
            a.eye_ttc_s(30),
            None,
            "an alarm at 6 m/s is not on the constant approach"
        );
        let eye = a.eye_ttc_s(60).expect("an alarm at 3 m/s");
        assert!((eye - distance(60) / 3.0).abs() < 1e-3, "{eye}");

        // constant only over the last 0.3 s: no l/|v| at all
        let distance = |k: usize| {
            let k = k as f64;
            if k <= 120.0 {
                0.2 + 0.9 + 6.0 * (120.0 - k) * dt
            } else {
                0.2 + 3.0 * (150.0 - k) * dt
            }
        };
        let truth: Vec<Vec<ObjectTruth>> = (0..=150).map(|k| vec![ball(distance(k))]).collect();
        assert!(HeadOnApproach::measure(&truth, 0, 150, dt).is_none());
    }
}
