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

mod head_on;
mod motion;
mod open_loop;
mod pool;
mod reference;
mod rows;
mod scoring;
mod tails;
mod trace;

pub use pool::{cpus, max_jobs};
pub use reference::ideal_theta_threshold_deg;
pub use trace::{ClosedLoop, DecisionTrace, DetectorTrace, EpisodeRun, EpisodeTrace};

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use loomlab_agents::EscapeController;
use loomlab_sim::{GpuContext, SimError};
use rayon::prelude::*;

use crate::deadline::{EscapeDeadline, escape_deadline_cancellable};
use crate::error::RunError;
use crate::metrics::{DetectorEpisode, EpisodeOutcome, GroundTruth};
use crate::schema::EpisodeSpec;
use crate::truth::EpisodeTruth;
use head_on::HeadOnApproach;
use open_loop::OpenLoop;
use pool::RendererPool;
use reference::reference_rows;
use rows::{Row, Tail, covers_object};
use scoring::EpisodeScoring;
use tails::TailJob;

// the module docs link to it; the closed-loop tails drive it
#[cfg(doc)]
use loomlab_agents::EscapeAgent;
#[cfg(doc)]
use loomlab_detector::Detector;
#[cfg(doc)]
use loomlab_sim::Sim;

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

    /// Runs one episode on the calling thread (see the module docs): the open loop, the ground
    /// truth and escape deadline, the rows, their closed loops and scores, and the trace.
    pub fn run_episode(&self, ep: &EpisodeSpec) -> Result<EpisodeRun, RunError> {
        let c = Ctx { ep };
        let (mut pass, episode_truth) = self.open_loop(&c)?;
        let reference = episode_truth.reference;
        let ref_truth = |k: usize| reference.and_then(|id| pass.truth[k].get(id));
        let ref_ttc: Vec<Option<f64>> = (0..pass.t_s.len())
            .map(|k| ref_truth(k).and_then(|o| o.ttc_s).map(f64::from))
            .collect();
        let ref_theta: Vec<f64> = (0..pass.t_s.len())
            .map(|k| ref_truth(k).map_or(f64::NAN, |o| f64::from(o.angular_size_deg)))
            .collect();
        let escape = EscapeController::new(ep.controller.clone(), ep.facts).map_err(|source| RunError::Controller {
            scenario: ep.scenario.clone(),
            episode: ep.index,
            source,
        })?;
        let (deadline, deadline_s) = self.escape_deadline(&c, &escape, &pass, &episode_truth)?;
        let contact_frame = episode_truth.contact.as_ref().map(|c| c.frame);
        let threat_object = episode_truth.contact.as_ref().map(|c| c.object_id);
        let approach = episode_truth
            .contact
            .as_ref()
            .and_then(|contact| HeadOnApproach::measure(&pass.truth, contact.object_id, contact.frame, ep.world.dt()));
        let ground_truth = GroundTruth {
            threat: episode_truth.threat(),
            t_contact_s: episode_truth.t_contact_s(),
            t_deadline_s: deadline.as_ref().and_then(|d| d.t_s),
            collision: false,
        };

        // ---- scores and closed loops: the detectors, then the reference rows ----
        let mut rows = detector_rows(ep, &mut pass, threat_object);
        if self.references {
            rows.extend(reference_rows(
                ep,
                &pass.truth,
                &pass.t_s,
                deadline.as_ref(),
                threat_object,
            ));
        }
        let first_alarms: Vec<Option<usize>> = rows
            .iter()
            .map(|row| row.signal.iter().position(|&s| s >= row.threshold))
            .collect();
        let mut tails = self.detector_tails(&c, &rows, &first_alarms, contact_frame, &mut pass)?;
        // the threat's first frame in the camera's view, up to its contact
        let t_in_view_s = threat_object.and_then(|id| {
            let until = contact_frame.map_or(pass.t_s.len(), |kc| (kc + 1).min(pass.t_s.len()));
            (0..until)
                .find(|&k| pass.truth[k].get(id).is_some_and(|o| o.in_view))
                .map(|k| pass.t_s[k])
        });
        let scoring = EpisodeScoring {
            t_s: &pass.t_s,
            ref_ttc: &ref_ttc,
            ref_theta: &ref_theta,
            t_in_view_s,
            ground_truth: &ground_truth,
            episode_truth: &episode_truth,
            deadline: deadline.as_ref(),
            approach: approach.as_ref(),
            contact_frame,
            sides: &pass.sides,
        };
        let mut frames_rendered = pass.frames.len();
        let mut scored: Vec<DetectorEpisode> = Vec::with_capacity(rows.len());
        let mut closed = Vec::with_capacity(rows.len());
        for (r, row) in rows.iter().enumerate() {
            let cl = scoring.closed_loop(&c, row, first_alarms[r], &escape, &pass.truth, tails[r].take())?;
            frames_rendered += cl.frames_rendered;
            scored.push(scoring.score(&c, row, &cl)?);
            closed.push(cl);
        }
        let trace = EpisodeTrace {
            reference_object: reference.map(|id| pass.object_names[id].clone()),
            angular_size_deg: ref_theta,
            ttc_s: ref_ttc,
            t_deadline_s: ground_truth.t_deadline_s,
            self_motion: pass.motion,
            looming_side: pass.sides,
            detectors: rows.into_iter().map(Row::into_trace).collect(),
            t_s: pass.t_s,
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

    /// Step 2: the escape deadline of a threat ([`crate::deadline`]) and the wall time its search
    /// took (s).
    fn escape_deadline(
        &self,
        c: &Ctx<'_>,
        escape: &EscapeController,
        pass: &OpenLoop,
        episode_truth: &EpisodeTruth,
    ) -> Result<(Option<EscapeDeadline>, f64), RunError> {
        let ep = c.ep;
        let started = std::time::Instant::now();
        let deadline = match &episode_truth.contact {
            Some(contact) => Some(
                escape_deadline_cancellable(ep, ep.seed, escape, &pass.sides, &pass.t_s, contact.frame, &self.cancel)
                    .map_err(|e| c.sim(e))?
                    .ok_or(RunError::Interrupted)?,
            ),
            None => None,
        };
        Ok((deadline, started.elapsed().as_secs_f64()))
    }

    /// The closed-loop tails of the detector rows that alarm before any contact, simulated in
    /// lockstep ([`Self::closed_loop_tails`]); per row, `None` for the others.
    fn detector_tails(
        &self,
        c: &Ctx<'_>,
        rows: &[Row<'_>],
        first_alarms: &[Option<usize>],
        contact_frame: Option<usize>,
        pass: &mut OpenLoop,
    ) -> Result<Vec<Option<ClosedLoop>>, RunError> {
        let mut jobs: Vec<TailJob<'_>> = Vec::new();
        for (r, (row, &alarm)) in rows.iter().zip(first_alarms).enumerate() {
            if let (Tail::Detector(spec), Some(ka)) = (&row.tail, alarm)
                && contact_frame.is_none_or(|kc| ka < kc)
            {
                // detector rows come first: row r is detector entry r
                // the open-loop pass found the same first alarm (same values, same comparison)
                debug_assert_eq!(pass.detectors[r].alarmed_at, Some(ka));
                jobs.push(TailJob {
                    row: r,
                    spec,
                    alarm: ka,
                    start: pass.detectors[r].snapshot.take(),
                    events: pass.detectors[r].events.take(),
                    signals: &pass.history[pass.runs_as[r]],
                });
            }
        }
        let tail_rows: Vec<usize> = jobs.iter().map(|j| j.row).collect();
        let runs = self.closed_loop_tails(c, jobs, &pass.frames, &pass.sides)?;
        let mut by_row: Vec<Option<ClosedLoop>> = (0..rows.len()).map(|_| None).collect();
        for (r, cl) in tail_rows.into_iter().zip(runs) {
            by_row[r] = Some(cl);
        }
        Ok(by_row)
    }
}

/// The detector rows of an episode from its open-loop records (which they take over): a stateful
/// row's signal is its decider's value, with θ̂ before it as `raw`; a detector that numbers its
/// tracks gets its signal about the threat alone.
fn detector_rows<'a>(ep: &'a EpisodeSpec, pass: &mut OpenLoop, threat_object: Option<usize>) -> Vec<Row<'a>> {
    let pinhole = ep.facts.pinhole;
    ep.detectors
        .iter()
        .zip(&mut pass.detectors)
        .map(|(spec, record)| {
            let (signal, raw, estimates) = match record.decided.take() {
                Some(d) => (
                    d.value,
                    Some(std::mem::take(&mut record.signal)),
                    Some((d.tau_s, d.gate_open)),
                ),
                None => (std::mem::take(&mut record.signal), None, None),
            };
            let covers = threat_object.and_then(|id| covers_object(&record.regions, &pass.truth, id, &pinhole));
            let idle = if spec.trigger.reads_angular_size() {
                0.0
            } else {
                f64::NAN
            };
            let localises = record.regions.iter().any(Option::is_some);
            Row {
                label: spec.label.clone(),
                trigger: spec.trigger,
                threshold: spec.threshold,
                about_threat: covers.as_ref().map(|covers| {
                    covers
                        .iter()
                        .zip(&signal)
                        .map(|(&c, &s)| if c { s } else { idle })
                        .collect()
                }),
                about_mask: covers,
                signal,
                raw,
                estimates,
                regions: localises.then(|| std::mem::take(&mut record.regions)),
                output: std::mem::take(&mut record.output),
                tail: Tail::Detector(spec),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::open_loop::same_detector_as;
    use super::*;
    use loomlab_detector::{ImageRegion, Pinhole};
    use loomlab_sim::{ObjectKind, ObjectTruth};

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
        let about = covers_object(&regions, &truth, 0, &Pinhole::new(60.0)).expect("a tracker");
        assert_eq!(about, vec![false, true, false]);
        let about_car = covers_object(&regions, &truth, 1, &Pinhole::new(60.0)).unwrap();
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
        assert_eq!(covers_object(&untracked, &truth, 0, &Pinhole::new(60.0)), None);
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
