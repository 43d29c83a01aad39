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
//! second object, and a manoeuvre that ends too early can be caught up with. So every frame from 0
//! to the contact frame is replayed, and the result is the exact set of evading trigger frames as
//! ranges. A replay is one physics-only pass without ground-truth predictions (about 0.5 ms for
//! the default suite's 2.5 s episodes), so a threat costs a few hundred of them: under a tenth of
//! its rendered open-loop pass.

use std::ops::Range;

use loomlab_agents::{EscapeAgent, EscapeController};
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
    /// Every evading trigger frame, as ascending disjoint ranges.
    pub evading: Vec<Range<usize>>,
    /// Physics-only replays run.
    pub replays: usize,
}

impl EscapeDeadline {
    /// Whether some trigger time evades.
    pub fn evadable(&self) -> bool {
        self.frame.is_some()
    }

    /// Whether evasion is monotone in the trigger time: every trigger up to the deadline evades
    /// (true for an unavoidable threat).
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
    let mut sim = Sim::new_physics_only(&ep.world, seed)?;
    sim.set_ground_truth(false);
    let mut agent = EscapeAgent::from_parts(Vec::new(), controller.clone());
    let mut cmd = ep.cruise.command_at(0.0);
    for k in 0..ep.frames() {
        let out = sim.step(&cmd.to_sim())?;
        if let Some(c) = out.first_collision() {
            return Ok(Some(Impact::from(c)));
        }
        let cruise = ep.cruise.command_at(out.t_s);
        cmd = if k < trigger_frame {
            cruise
        } else if k == trigger_frame {
            agent.decide(out.t_s, side, f64::INFINITY, cruise).command
        } else {
            agent.decide(out.t_s, None, f64::NAN, cruise).command
        };
    }
    Ok(None)
}

/// The escape deadline of a threat (episode `ep`, simulator seed `seed`) whose open-loop contact
/// happened during frame `contact_frame`; `sides[k]` is the looming side at open-loop frame `k`
/// and `t_s[k]` its time (see the module docs).
pub fn escape_deadline(
    ep: &EpisodeSpec,
    seed: u64,
    controller: &EscapeController,
    sides: &[Option<f32>],
    t_s: &[f64],
    contact_frame: usize,
) -> Result<EscapeDeadline, SimError> {
    let end = contact_frame.min(sides.len()).min(t_s.len());
    let mut evading: Vec<Range<usize>> = Vec::new();
    for (k, &side) in sides[..end].iter().enumerate() {
        if replay_trigger(ep, seed, controller, k, side)?.is_some() {
            continue;
        }
        match evading.last_mut() {
            Some(r) if r.end == k => r.end = k + 1,
            _ => evading.push(k..k + 1),
        }
    }
    let replays = end;
    let frame = evading.last().map(|r| r.end - 1);
    Ok(EscapeDeadline {
        frame,
        t_s: frame.map(|k| t_s[k]),
        evading,
        replays,
    })
}
