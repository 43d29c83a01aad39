//! The closed-loop runner: episodes in parallel, ground truth, detector traces, closed-loop
//! escapes and scores.
//!
//! # One episode
//! 1. **Open-loop pass** (ground truth and detection). The simulator renders every frame while the
//!    robot follows its cruise command (no escape); **all detectors of the episode see these same
//!    frames**. It ends at the first contact of any object with the robot's body or after
//!    `episode.duration_s`. A contact makes the episode a **threat**, its exact time (parry time
//!    of impact) is `t_c` and the touching object the *reference object*; without contact the
//!    reference object is the one that came closest to the camera (projectiles and vehicles before
//!    scenery). From each detector's trigger-signal trace (θ̂ for hopfield, the output for the
//!    baselines), the first alarm `t_a` (first frame with `signal >= threshold`) gives
//!    hit / miss / false alarm / correct rejection, the reference object's true TTC and angular
//!    size at the alarm, and the ROC score (`crate::metrics`).
//! 2. **Closed loop, per detector.** Until a detector's first alarm the escape controller only
//!    passes the cruise command through, so the closed-loop trajectory is *identical* to the
//!    open-loop one up to that frame. Hence:
//!    - a detector that never alarms collides iff the episode is a threat;
//!    - one that first alarms at or after the contact frame collides;
//!    - otherwise the runner rebuilds the world without rendering, replays physics up to the alarm
//!      frame (cheap) while feeding a fresh detector the cached open-loop frames (so its state is
//!      exactly the open-loop state), attaches a renderer and continues with rendering, the
//!      detector and the escape controller driving the robot until the first contact
//!      (**collision**) or the end of the episode (**evaded**). Re-triggers (the controller is
//!      level-triggered after its cooldown) are simulated.
//!
//!    So the cost of an episode is one rendered open-loop pass plus the post-alarm tails of the
//!    detectors that alarm, instead of one full rendered pass per detector.
//! 3. **Dodge direction** comes from the image, not from ground truth: at every controller step
//!    the looming side is the x centroid of the temporal contrast |frame(t) − frame(t−1)|
//!    ([`temporal_contrast_centroid_x`]); the controller latches it at the trigger.
//!
//! # Parallelism
//! Episodes run on a rayon pool of `jobs` workers sharing one [`GpuContext`]; renderers are kept in
//! a pool and reused across episodes (at most one per worker and frame size is ever created).
//! Results are handed to a callback as episodes finish (for `episodes.csv` and the progress bar)
//! and returned in suite order; the run is deterministic whatever the number of workers.

use std::sync::{Arc, Mutex};

use loomlab_agents::{EscapeAgent, TriggerSignal};
use loomlab_detector::{Detector, Frame};
use loomlab_sim::{GpuContext, Renderer, Sim, SimError};
use rayon::prelude::*;

use crate::error::RunError;
use crate::metrics::{DetectorEpisode, EpisodeOutcome, GroundTruth, TraceSample, score_detector_episode};
use crate::schema::{DetectorSpec, EpisodeSpec};
use crate::truth::TruthRecorder;

/// Renderers kept between episodes, one per frame size and worker at most.
#[derive(Default)]
struct RendererPool(Mutex<Vec<Renderer>>);

impl RendererPool {
    fn take(&self, ctx: &Arc<GpuContext>, n: u32) -> Result<Renderer, SimError> {
        let found = {
            let mut pool = self.0.lock().unwrap_or_else(|e| e.into_inner());
            pool.iter().position(|r| r.n() == n).map(|i| pool.swap_remove(i))
        };
        match found {
            Some(r) => Ok(r),
            None => Renderer::with_context(Arc::clone(ctx), n),
        }
    }

    fn give_back(&self, r: Renderer) {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).push(r);
    }
}

/// One detector's signals over an episode's open-loop pass.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorTrace {
    /// Detector label.
    pub label: String,
    /// Which signal is compared with the threshold.
    pub trigger: TriggerSignal,
    /// Alarm threshold.
    pub threshold: f64,
    /// Trigger signal per frame (NaN where the detector gives none).
    pub signal: Vec<f64>,
    /// Primary output per frame.
    pub output: Vec<f64>,
}

/// The open-loop pass of an episode, frame by frame.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeTrace {
    /// Frame times (s).
    pub t_s: Vec<f64>,
    /// Name of the reference object (the threat, or the closest object).
    pub reference_object: Option<String>,
    /// True angular size of the reference object per frame (degrees).
    pub angular_size_deg: Vec<f64>,
    /// True time to contact of the reference object per frame (s), when on a collision course.
    pub ttc_s: Vec<Option<f64>>,
    /// Per detector.
    pub detectors: Vec<DetectorTrace>,
}

/// What happened in the closed loop of one detector.
#[derive(Debug, Clone, PartialEq)]
pub struct ClosedLoop {
    /// Detector label.
    pub label: String,
    /// Whether a post-alarm tail was simulated (false: the outcome follows from the open loop).
    pub simulated: bool,
    /// Number of escape manoeuvres started.
    pub triggers: usize,
    /// Time of the robot's first contact (s), if any.
    pub collision_t_s: Option<f64>,
    /// Frames rendered for the tail.
    pub frames_rendered: usize,
}

/// Everything one episode produced.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeRun {
    /// The scores (what `episodes.csv` and the report hold).
    pub outcome: EpisodeOutcome,
    /// Open-loop traces.
    pub trace: EpisodeTrace,
    /// Closed-loop details per detector (same order as `outcome.detectors`).
    pub closed_loop: Vec<ClosedLoop>,
    /// Frames rendered in total (open loop + tails).
    pub frames_rendered: usize,
}

/// Runs episodes on a shared GPU context and a worker pool.
pub struct Runner {
    ctx: Arc<GpuContext>,
    renderers: RendererPool,
    pool: rayon::ThreadPool,
    jobs: usize,
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

    /// A runner on an existing GPU context.
    pub fn with_context(ctx: Arc<GpuContext>, jobs: Option<usize>) -> Result<Self, RunError> {
        let jobs = jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
            .max(1);
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
        })
    }

    /// Number of workers.
    pub fn jobs(&self) -> usize {
        self.jobs
    }

    /// The adapter, e.g. `llvmpipe (…)`.
    pub fn adapter(&self) -> String {
        self.ctx.describe()
    }

    /// Runs `episodes` in parallel. `on_done(i, run)` is called (from a worker thread) as episode
    /// `i` finishes; an error from it stops the run. Returns the runs in the order of `episodes`.
    pub fn run<F>(&self, episodes: &[&EpisodeSpec], on_done: F) -> Result<Vec<EpisodeRun>, RunError>
    where
        F: Fn(usize, &EpisodeRun) -> Result<(), String> + Sync,
    {
        self.pool.install(|| {
            episodes
                .par_iter()
                .enumerate()
                .with_max_len(1)
                .map(|(i, ep)| {
                    let run = self.run_episode(ep)?;
                    on_done(i, &run).map_err(RunError::Callback)?;
                    Ok(run)
                })
                .collect()
        })
    }

    /// Runs one episode on the calling thread (see the module docs).
    pub fn run_episode(&self, ep: &EpisodeSpec) -> Result<EpisodeRun, RunError> {
        let c = Ctx { ep };
        let n = ep.world.camera.n;
        let nn = n as usize;
        let total = ep.frames();
        let nd = ep.detectors.len();

        // ---- open-loop pass: render once, every detector on the same frames ----
        let renderer = self.renderers.take(&self.ctx, n).map_err(|e| c.sim(e))?;
        let mut sim = Sim::with_renderer(&ep.world, ep.seed, renderer).map_err(|e| c.sim(e))?;
        let objects = sim.objects();
        let mut detectors: Vec<Box<dyn Detector>> = Vec::with_capacity(nd);
        for d in &ep.detectors {
            detectors.push(d.build(nn).map_err(|e| c.det(e))?);
        }
        let mut frames: Vec<Frame> = Vec::with_capacity(total);
        let mut t_s = Vec::with_capacity(total);
        let mut signal = vec![Vec::with_capacity(total); nd];
        let mut output = vec![Vec::with_capacity(total); nd];
        // per frame, per object: (ttc, angular size)
        let mut truth: Vec<Vec<(Option<f64>, f64)>> = Vec::with_capacity(total);
        let mut recorder = TruthRecorder::new(&sim);
        let open = (|| -> Result<(), RunError> {
            for _ in 0..total {
                let cmd = ep.cruise.command_at(sim.time());
                let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
                let frame = Frame::from_f32(nn, out.frame.clone()).map_err(|e| c.det(e))?;
                for (i, (d, spec)) in detectors.iter_mut().zip(&ep.detectors).enumerate() {
                    let s = d.step(&frame).map_err(|e| c.det(e))?;
                    signal[i].push(spec.trigger.value(&s).unwrap_or(f64::NAN));
                    output[i].push(s.output);
                }
                t_s.push(out.t_s);
                truth.push(
                    out.truth
                        .iter()
                        .map(|o| (o.ttc_s.map(f64::from), f64::from(o.angular_size_deg)))
                        .collect(),
                );
                frames.push(frame);
                if recorder.record(&out).is_some() {
                    break;
                }
            }
            Ok(())
        })();
        if let Some(r) = sim.into_renderer() {
            self.renderers.give_back(r);
        }
        open?;
        let mut frames_rendered = frames.len();

        // ---- ground truth ----
        let episode_truth = recorder.finish();
        let threat = episode_truth.threat();
        let t_contact_s = episode_truth.t_contact_s();
        let reference = episode_truth.reference;
        let ref_ttc: Vec<Option<f64>> = truth.iter().map(|row| reference.and_then(|id| row[id].0)).collect();
        let ref_theta: Vec<f64> = truth
            .iter()
            .map(|row| reference.map_or(f64::NAN, |id| row[id].1))
            .collect();

        // ---- scores and closed loops ----
        let mut scored: Vec<DetectorEpisode> = Vec::with_capacity(nd);
        let mut closed = Vec::with_capacity(nd);
        for (i, spec) in ep.detectors.iter().enumerate() {
            let samples: Vec<TraceSample> = (0..t_s.len())
                .map(|k| TraceSample {
                    t_s: t_s[k],
                    signal: signal[i][k],
                    ttc_s: ref_ttc[k],
                    angular_size_deg: Some(ref_theta[k]).filter(|v| v.is_finite()),
                })
                .collect();
            let truth = GroundTruth {
                threat,
                t_contact_s,
                collision: false,
            };
            let mut d = score_detector_episode(&spec.label, spec.threshold, &samples, &truth, &ep.scoring).map_err(
                |source| RunError::Scoring {
                    scenario: ep.scenario.clone(),
                    episode: ep.index,
                    source,
                },
            )?;
            let first_alarm = signal[i].iter().position(|&s| s >= spec.threshold);
            let contact_frame = episode_truth.contact.as_ref().map(|c| c.frame);
            let cl = match (first_alarm, contact_frame) {
                (None, _) => ClosedLoop {
                    label: spec.label.clone(),
                    simulated: false,
                    triggers: 0,
                    collision_t_s: t_contact_s,
                    frames_rendered: 0,
                },
                (Some(ka), Some(kc)) if ka >= kc => ClosedLoop {
                    label: spec.label.clone(),
                    simulated: false,
                    triggers: 1,
                    collision_t_s: t_contact_s,
                    frames_rendered: 0,
                },
                (Some(ka), _) => self.closed_loop_tail(&c, spec, &frames, ka)?,
            };
            frames_rendered += cl.frames_rendered;
            d.collision = cl.collision_t_s.is_some();
            scored.push(d);
            closed.push(cl);
        }

        let trace = EpisodeTrace {
            t_s,
            reference_object: reference.map(|id| objects[id].1.clone()),
            angular_size_deg: ref_theta,
            ttc_s: ref_ttc,
            detectors: ep
                .detectors
                .iter()
                .zip(signal.into_iter().zip(output))
                .map(|(spec, (signal, output))| DetectorTrace {
                    label: spec.label.clone(),
                    trigger: spec.trigger,
                    threshold: spec.threshold,
                    signal,
                    output,
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
            frames_rendered,
        })
    }

    /// Closed loop of one detector whose first alarm is open-loop frame `ka` (before any contact).
    fn closed_loop_tail(
        &self,
        c: &Ctx<'_>,
        spec: &DetectorSpec,
        frames: &[Frame],
        ka: usize,
    ) -> Result<ClosedLoop, RunError> {
        let ep = c.ep;
        let n = ep.world.camera.n;
        let nn = n as usize;
        let total = ep.frames();
        let mut sim = Sim::new_physics_only(&ep.world, ep.seed).map_err(|e| c.sim(e))?;
        let detector = spec.build(nn).map_err(|e| c.det(e))?;
        let mut agent =
            EscapeAgent::new(vec![detector], spec.controller(&ep.controller)).map_err(|source| RunError::Controller {
                scenario: ep.scenario.clone(),
                episode: ep.index,
                source,
            })?;
        // Replay up to and including the alarm frame: physics only, the agent on the cached frames.
        let mut cmd = ep.cruise.command_at(0.0);
        for frame in &frames[..=ka] {
            let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
            cmd = agent
                .step(out.t_s, frame, ep.cruise.command_at(out.t_s))
                .map_err(|e| c.det(e))?
                .command;
        }
        // Continue with rendering, the agent in the loop.
        let renderer = self.renderers.take(&self.ctx, n).map_err(|e| c.sim(e))?;
        if let Err(e) = sim.attach_renderer(renderer) {
            return Err(c.sim(e));
        }
        let mut collision_t_s = None;
        let mut rendered = 0;
        let tail = (|| -> Result<(), RunError> {
            for _ in ka + 1..total {
                let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
                rendered += 1;
                if let Some(ct) = out.contacts.first() {
                    collision_t_s = Some(ct.time_s());
                    break;
                }
                let frame = Frame::from_f32(nn, out.frame).map_err(|e| c.det(e))?;
                cmd = agent
                    .step(out.t_s, &frame, ep.cruise.command_at(out.t_s))
                    .map_err(|e| c.det(e))?
                    .command;
            }
            Ok(())
        })();
        if let Some(r) = sim.take_renderer() {
            self.renderers.give_back(r);
        }
        tail?;
        Ok(ClosedLoop {
            label: spec.label.clone(),
            simulated: true,
            triggers: agent.controller().triggers(),
            collision_t_s,
            frames_rendered: rendered,
        })
    }
}
