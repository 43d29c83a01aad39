//! The escape deadline of a threat: the latest trigger time from which the episode's own escape
//! manoeuvre still avoids every contact.
//!
//! # Definition
//! For open-loop frame `k` (0-based; the frame at time `t_s[k]`), a **replay** rebuilds the
//! episode's world without rendering, lets the robot cruise through step `k` exactly as in the
//! open-loop pass, then triggers the escape controller at `t_s[k]` (same controller
//! configuration as every detector's closed loop, the dodge side latched from the looming side the
//! open-loop frames `k − 1, k` show, exactly what a detector alarming at frame `k` would latch) and
//! runs the rest of the episode physics-only: one manoeuvre, its cooldown, then the cruise
//! command again (no re-trigger: a replay has no detector). Trigger frame `k` **evades** if no
//! object touches the robot before the episode ends.
//!
//! The **deadline** is the latest evading frame before the open-loop contact frame; a threat
//! without any evading frame is **unavoidable**.
//!
//! # Search
//! Evasion need not be monotone in the trigger time: the looming-side estimate changes from frame
//! to frame (a frame whose change is too small or central leaves the side unknown, and the
//! controller dodges to its default side, possibly into the object), dodging early can lead into a
//! second object, and a manoeuvre that ends too early can be caught up with. So no bisection: the
//! search replays the frames **backwards** from the last one before contact and stops at the first
//! that evades, which is the deadline by definition, whatever evasion does at earlier frames
//! ([`escape_deadline`]). Its cost is (contact frame − deadline frame + 1) replays: the lead a
//! dodge needs (tens of frames), not the episode's length (an unavoidable threat still replays
//! every frame). Every replay shares the cruise up to its trigger frame, so one physics-only pass
//! of the cruise keeps a copy of the simulator every [`CHECKPOINT_INTERVAL`] frames
//! ([`Sim::fork_physics_only`]; at most [`MAX_CHECKPOINTS`], further apart for long episodes),
//! and a replay starts from a copy of the latest checkpoint at or before its trigger frame: it
//! simulates fewer than `CHECKPOINT_INTERVAL` frames of cruise plus the manoeuvre to the episode's
//! end, and gives what a replay from `t = 0` gives (a fork steps exactly as its original; the
//! search and the exhaustive scan below, which replays from `t = 0`, agree in the tests). On the
//! default suite (2 CPUs) this cut the whole run from 225 to 206 s of CPU time, 128 to 119 s wall.
//! [`escape_deadline_exhaustive`] replays every frame from 0 to the contact frame and gives the
//! exact set of evading trigger frames as ranges (the two agree on the deadline: tested, including
//! non-monotone cases). A replay is one physics-only pass without ground-truth predictions.
//!
//! A search can be cancelled (Ctrl-C): [`escape_deadline_cancellable`] checks its flag between
//! replays and every [`CANCEL_CHECK_STEPS`] steps within one.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

use loomlab_agents::{Candidate, DodgeSide, EscapeAgent, EscapeController, Manoeuvre, VelocityCommand};
use loomlab_sim::{Sim, SimError};

use crate::schema::EpisodeSpec;
use crate::truth::Impact;

/// The escape deadline of one threat episode (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct EscapeDeadline {
    /// The deadline frame: the latest open-loop frame whose trigger evades; `None`: unavoidable.
    pub frame: Option<usize>,
    /// Its time (s).
    pub t_s: Option<f64>,
    /// The evading trigger frames among [`Self::searched`], as ascending disjoint ranges (every
    /// evading frame for [`escape_deadline_exhaustive`]; the deadline alone for
    /// [`escape_deadline`], which stops there).
    pub evading: Vec<Range<usize>>,
    /// The trigger frames replayed.
    pub searched: Range<usize>,
    /// Physics-only replays run.
    pub replays: usize,
    /// The manoeuvre that evades from the deadline frame (the first of the set that does).
    pub manoeuvre: Option<Candidate>,
}

impl EscapeDeadline {
    /// Whether some trigger time evades.
    pub fn evadable(&self) -> bool {
        self.frame.is_some()
    }

    /// Whether evasion is monotone in the trigger time: every trigger up to the deadline evades
    /// (true for an unavoidable threat). Only known from an exhaustive search
    /// ([`Self::searched`] from frame 0); a search that stopped at the deadline says `false`
    /// unless the deadline is frame 0.
    pub fn monotone(&self) -> bool {
        match self.evading.as_slice() {
            [] => true,
            [only] => only.start == 0,
            _ => false,
        }
    }

    /// Whether a trigger at open-loop frame `k` evades (from the ranges found).
    pub fn evades_at(&self, k: usize) -> bool {
        self.evading.iter().any(|r| r.contains(&k))
    }
}

/// The manoeuvres a replay tries at a trigger frame whose looming side is `side`: with
/// `manoeuvre = "plan"` every candidate of the planner's set ([`Candidate::ALL`]), the dodge away
/// from `side` first; else the controller's one manoeuvre towards that side. Each comes with the
/// looming side that makes the controller run it.
pub fn manoeuvre_set(controller: &EscapeController, side: Option<f32>) -> Vec<(Candidate, Option<f32>)> {
    let config = controller.config();
    let rule_side = DodgeSide::away_from(side, config.side_deadband, config.default_side);
    let looming = |c: Candidate| match c.manoeuvre {
        Manoeuvre::DodgeLateral => Some(-c.side.sign() as f32),
        _ => side,
    };
    if config.manoeuvre != Manoeuvre::Plan {
        return vec![(config.fixed_candidate(rule_side), side)];
    }
    let first = Candidate::dodge(rule_side);
    std::iter::once(first)
        .chain(Candidate::ALL.into_iter().filter(|c| !c.same_as(&first)))
        .map(|c| (c, looming(c)))
        .collect()
}

/// `controller` running `candidate` as its one manoeuvre (the controller itself when it already
/// runs a fixed manoeuvre).
pub fn controller_for(controller: &EscapeController, candidate: Candidate) -> EscapeController {
    if controller.config().manoeuvre != Manoeuvre::Plan {
        return controller.clone();
    }
    let mut config = controller.config().clone();
    config.manoeuvre = candidate.manoeuvre;
    EscapeController::new(config, *controller.facts()).expect("a valid controller with another manoeuvre stays valid")
}

/// Replays episode `ep` with simulator seed `seed` and the escape controller `controller`
/// triggered at open-loop frame `trigger_frame` with looming side `side`; returns the first
/// collision (`None`: evaded).
pub fn replay_trigger(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    trigger_frame: usize,
    side: Option<f32>,
) -> Result<Option<Impact>, SimError> {
    let never = AtomicBool::new(false);
    Ok(replay(ep, seed, controller, trigger_frame, side, &never)?.expect("never cancelled"))
}

/// Steps between two looks at the cancel flag within a replay.
pub const CANCEL_CHECK_STEPS: usize = 256;

/// [`replay_trigger`] that gives up (`Ok(None)`) once `cancel` is set.
fn replay(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    trigger_frame: usize,
    side: Option<f32>,
    cancel: &AtomicBool,
) -> Result<Option<Option<Impact>>, SimError> {
    replay_from(
        ep,
        Checkpoint::start(ep, seed)?,
        controller,
        trigger_frame,
        side,
        cancel,
    )
}

/// The cruise prefix's state before open-loop frame `frame` is stepped: the simulator after
/// frames `0..frame` and the cruise command for frame `frame`.
struct Checkpoint {
    frame: usize,
    sim: Sim,
    command: VelocityCommand,
}

impl Checkpoint {
    /// The start of the episode: a physics-only simulator without ground-truth predictions.
    fn start(ep: &EpisodeSpec, seed: u64) -> Result<Self, SimError> {
        let mut sim = Sim::new_physics_only(&ep.world, seed)?;
        sim.set_ground_truth(false);
        Ok(Self {
            frame: 0,
            sim,
            command: ep.cruise.command_at(0.0),
        })
    }
}

/// Continues a replay from `start` (a point of the cruise prefix at or before `trigger_frame`):
/// cruise up to the trigger, then the manoeuvre, to the episode's end or the first collision.
fn replay_from(
    ep: &EpisodeSpec,
    start: Checkpoint,
    controller: &EscapeController,
    trigger_frame: usize,
    side: Option<f32>,
    cancel: &AtomicBool,
) -> Result<Option<Option<Impact>>, SimError> {
    debug_assert!(start.frame <= trigger_frame);
    let Checkpoint {
        frame,
        mut sim,
        command,
    } = start;
    let mut agent = EscapeAgent::from_parts(Vec::new(), controller.clone());
    let mut cmd = command;
    for k in frame..ep.frames() {
        if k % CANCEL_CHECK_STEPS == 0 && cancel.load(Ordering::Relaxed) {
            return Ok(None);
        }
        let out = sim.step(&cmd.to_sim())?;
        if let Some(c) = out.first_collision() {
            return Ok(Some(Some(Impact::from(c))));
        }
        let cruise = ep.cruise.command_at(out.t_s);
        cmd = if k < trigger_frame {
            cruise
        } else if k == trigger_frame {
            agent.act_on_value(out.t_s, side, f64::INFINITY, None, cruise).command
        } else {
            agent.act_on_value(out.t_s, None, f64::NAN, None, cruise).command
        };
    }
    Ok(Some(None))
}

/// Most checkpoints of the cruise prefix one deadline search keeps (module docs, "Search").
pub const MAX_CHECKPOINTS: usize = 256;

/// Checkpoints of the cruise prefix of frames `0..end`, every `interval` frames (at least
/// [`CHECKPOINT_INTERVAL`], more for long prefixes so that at most [`MAX_CHECKPOINTS`] are kept):
/// one physics-only pass, the copies taken with [`Sim::fork_physics_only`]. `None` when cancelled.
fn checkpoints(
    ep: &EpisodeSpec,
    seed: u64,
    end: usize,
    cancel: &AtomicBool,
) -> Result<Option<(usize, Vec<Checkpoint>)>, SimError> {
    let interval = CHECKPOINT_INTERVAL.max(end.div_ceil(MAX_CHECKPOINTS));
    let Checkpoint {
        mut sim,
        command: mut cmd,
        ..
    } = Checkpoint::start(ep, seed)?;
    let mut kept = Vec::with_capacity(end / interval + 1);
    for k in 0..end {
        if k % CANCEL_CHECK_STEPS == 0 && cancel.load(Ordering::Relaxed) {
            return Ok(None);
        }
        if k % interval == 0 {
            kept.push(Checkpoint {
                frame: k,
                sim: sim.fork_physics_only(),
                command: cmd,
            });
        }
        let out = sim.step(&cmd.to_sim())?;
        if out.first_collision().is_some() {
            // no frame at or after a contact of the cruise is replayed
            break;
        }
        cmd = ep.cruise.command_at(out.t_s);
    }
    Ok(Some((interval, kept)))
}

/// Frames between two checkpoints of the cruise prefix (the fewest; module docs, "Search").
pub const CHECKPOINT_INTERVAL: usize = 8;

/// The escape deadline of a threat (episode `ep`, simulator seed `seed`) whose open-loop contact
/// happened during frame `contact_frame`; `sides[k]` is the looming side at open-loop frame `k`
/// and `t_s[k]` its time (see the module docs): the backward search, which stops at the deadline.
pub fn escape_deadline(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    sides: &[Option<f32>],
    t_s: &[f64],
    contact_frame: usize,
) -> Result<EscapeDeadline, SimError> {
    let never = AtomicBool::new(false);
    Ok(escape_deadline_cancellable(ep, seed, controller, sides, t_s, contact_frame, &never)?.expect("never cancelled"))
}

/// [`escape_deadline`] that gives up (`Ok(None)`) within a replay's [`CANCEL_CHECK_STEPS`] steps
/// once `cancel` is set.
pub fn escape_deadline_cancellable(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    sides: &[Option<f32>],
    t_s: &[f64],
    contact_frame: usize,
    cancel: &AtomicBool,
) -> Result<Option<EscapeDeadline>, SimError> {
    let end = contact_frame.min(sides.len());
    search(ep, seed, controller, |k| Ok(sides[k]), t_s, end, cancel)
}

/// [`escape_deadline`] with the looming side of open-loop frame `k` given by `side_at(k)` on
/// demand: the search asks for frames from the contact backwards and stops at the deadline, so a
/// caller that renders the open-loop views to find the sides renders only those frames (and the
/// one before each, for the temporal contrast) instead of the whole pass.
pub fn escape_deadline_with(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    side_at: impl FnMut(usize) -> Result<Option<f32>, SimError>,
    t_s: &[f64],
    contact_frame: usize,
) -> Result<EscapeDeadline, SimError> {
    let never = AtomicBool::new(false);
    Ok(search(ep, seed, controller, side_at, t_s, contact_frame, &never)?.expect("never cancelled"))
}

/// The backward search of frames `0..end` (module docs, "Search").
fn search(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    mut side_at: impl FnMut(usize) -> Result<Option<f32>, SimError>,
    t_s: &[f64],
    end: usize,
    cancel: &AtomicBool,
) -> Result<Option<EscapeDeadline>, SimError> {
    let end = end.min(t_s.len());
    let Some((interval, kept)) = checkpoints(ep, seed, end, cancel)? else {
        return Ok(None);
    };
    let mut replays = 0;
    let mut frame = None;
    let mut manoeuvre = None;
    // one controller per manoeuvre of the set, built once
    let set: Vec<(Manoeuvre, EscapeController)> = Candidate::ALL
        .iter()
        .map(|c| (c.manoeuvre, controller_for(controller, *c)))
        .collect();
    for k in (0..end).rev() {
        replays += 1;
        // the cruise prefix up to k from its latest checkpoint (a fork of it: the checkpoint may
        // serve the next frames down too)
        let Some(c) = kept.get(k / interval) else {
            // the cruise collided before frame k: no trigger at or after it evades
            continue;
        };
        let side = side_at(k)?;
        for (i, (candidate, looming)) in manoeuvre_set(controller, side).into_iter().enumerate() {
            if i > 0 {
                replays += 1;
            }
            let start = Checkpoint {
                frame: c.frame,
                sim: c.sim.fork_physics_only(),
                command: c.command,
            };
            let runner = &set[set.iter().position(|(m, _)| *m == candidate.manoeuvre).unwrap_or(0)].1;
            match replay_from(ep, start, runner, k, looming, cancel)? {
                None => return Ok(None),
                Some(Some(_)) => {}
                Some(None) => {
                    frame = Some(k);
                    manoeuvre = Some(candidate);
                    break;
                }
            }
        }
        if frame.is_some() {
            break;
        }
    }
    Ok(Some(EscapeDeadline {
        frame,
        t_s: frame.map(|k| t_s[k]),
        evading: frame.map(|k| k..k + 1).into_iter().collect(),
        searched: frame.unwrap_or(0)..end,
        replays,
        manoeuvre,
    }))
}

/// The escape deadline from a replay of **every** frame before contact (see the module docs):
/// the exact set of evading trigger frames. Costs (contact frame) replays: for tests and checks
/// of [`escape_deadline`], which gives the same deadline.
pub fn escape_deadline_exhaustive(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    sides: &[Option<f32>],
    t_s: &[f64],
    contact_frame: usize,
) -> Result<EscapeDeadline, SimError> {
    let end = contact_frame.min(sides.len()).min(t_s.len());
    let mut evading: Vec<Range<usize>> = Vec::new();
    let mut replays = 0;
    let mut manoeuvre = None;
    for (k, &side) in sides[..end].iter().enumerate() {
        let mut evades = None;
        for (candidate, looming) in manoeuvre_set(controller, side) {
            replays += 1;
            let runner = controller_for(controller, candidate);
            if replay_trigger(ep, seed, &runner, k, looming)?.is_none() {
                evades = Some(candidate);
                break;
            }
        }
        let Some(candidate) = evades else { continue };
        manoeuvre = Some(candidate);
        match evading.last_mut() {
            Some(r) if r.end == k => r.end = k + 1,
            _ => evading.push(k..k + 1),
        }
    }
    let frame = evading.last().map(|r| r.end - 1);
    Ok(EscapeDeadline {
        frame,
        t_s: frame.map(|k| t_s[k]),
        evading,
        searched: 0..end,
        replays,
        manoeuvre,
    })
}
