//! The closed-loop tails of detector rows that alarm before contact, rendered in lockstep.

use loomlab_agents::{EscapeAgent, SensedCamera, VelocityCommand};
use loomlab_detector::{Detector, Frame, Signals};
use loomlab_sim::Sim;

use super::trace::ClosedLoop;
use super::{Ctx, Runner};
use crate::error::RunError;
use crate::schema::DetectorSpec;
use crate::truth::Impact;

impl Runner {
    /// Closed loops of the detectors `jobs`, each alarm before any contact: each a physics-only
    /// replay to its alarm frame with its agent on the cached frames, then rendering with the
    /// agent in the loop (see the module docs). A job that starts from a copy of its detector
    /// taken at the alarm ([`TailJob::start`]) replays its agent on the open-loop signals instead
    /// of stepping a fresh detector through the prefix, and the open-loop looming sides `sides`
    /// instead of estimating them again: the same state, without the work. The rendered parts
    /// run in lockstep: every frame index renders the views of all tails still running in one
    /// batch (each view bit-identical to rendering it alone), so the tails' results are those of
    /// running them one after the other. Returns one [`ClosedLoop`] per job, in order.
    pub(super) fn closed_loop_tails(
        &self,
        c: &Ctx<'_>,
        jobs: Vec<TailJob<'_>>,
        frames: &[Frame],
        sides: &[Option<f32>],
    ) -> Result<Vec<ClosedLoop>, RunError> {
        struct TailRun {
            sim: Sim,
            agent: EscapeAgent,
            cmd: VelocityCommand,
            collision: Option<Impact>,
            rendered: usize,
            done: bool,
        }
        if jobs.is_empty() {
            return Ok(Vec::new());
        }
        let ep = c.ep;
        let n = ep.world.camera.n;
        let nn = n as usize;
        let total = ep.frames();
        let mut runs = Vec::with_capacity(jobs.len());
        let alarms: Vec<usize> = jobs.iter().map(|j| j.alarm).collect();
        let labels: Vec<String> = jobs.iter().map(|j| j.spec.label.clone()).collect();
        for job in jobs {
            let (spec, ka) = (job.spec, job.alarm);
            let mut sim = Sim::new_physics_only(&ep.world, ep.seed).map_err(|e| c.sim(e))?;
            sim.set_ground_truth(false);
            let from_snapshot = job.start.is_some();
            if let Some(stream) = job.events {
                // the event camera continues from its state at the alarm frame
                sim.set_event_stream(stream);
            }
            let detector = match job.start {
                Some(snapshot) => snapshot,
                None => spec.build(nn).map_err(|e| c.det(e))?,
            };
            let mut agent =
                EscapeAgent::new(vec![detector], spec.controller(&ep.controller), ep.facts).map_err(|source| {
                    RunError::Controller {
                        scenario: ep.scenario.clone(),
                        episode: ep.index,
                        source,
                    }
                })?;
            // Replay up to and including the alarm frame: physics only, the agent on the cached frames.
            let mut cmd = ep.cruise.command_at(0.0);
            for (k, frame) in frames[..=ka].iter().enumerate() {
                let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
                let (cruise, camera) = (ep.cruise.command_at(out.t_s), SensedCamera::of(&sim));
                cmd = if from_snapshot {
                    let signals = vec![job.signals[k].clone()];
                    agent.step_posed_with_signals(out.t_s, frame, cruise, Some(&camera), signals, sides[k])
                } else {
                    agent
                        .step_posed(out.t_s, frame, cruise, Some(&camera))
                        .map_err(|e| c.det(e))?
                }
                .command;
            }
            runs.push(TailRun {
                sim,
                agent,
                cmd,
                collision: None,
                rendered: 0,
                done: false,
            });
        }
        // Continue with rendering, the agents in the loop: frame k of every tail whose alarm came
        // before it, in one batch.
        let mut renderer = self.renderers.take(&self.ctx, n).map_err(|e| c.sim(e))?;
        let first = alarms.iter().copied().min().unwrap_or(0);
        let mut event_buf = Vec::new();
        let tails = (|| -> Result<(), RunError> {
            for k in first + 1..total {
                if self.cancelled() {
                    return Err(RunError::Interrupted);
                }
                let mut active: Vec<&mut TailRun> = runs
                    .iter_mut()
                    .zip(&alarms)
                    .filter(|(run, alarm)| !run.done && **alarm < k)
                    .map(|(run, _)| run)
                    .collect();
                if active.is_empty() {
                    if runs.iter().all(|r| r.done) {
                        break;
                    }
                    continue;
                }
                let commands: Vec<loomlab_sim::Command> = active.iter().map(|r| r.cmd.to_sim()).collect();
                let outs = {
                    let mut sims: Vec<&mut Sim> = active.iter_mut().map(|r| &mut r.sim).collect();
                    Sim::step_batch(&mut sims, &commands, &mut renderer).map_err(|e| c.sim(e))?
                };
                for (run, mut out) in active.into_iter().zip(outs) {
                    run.rendered += 1;
                    if let Some(ct) = out.first_collision() {
                        run.collision = Some(Impact::from(ct));
                        run.done = true;
                        continue;
                    }
                    let frame = Frame::from_f32(nn, std::mem::take(&mut out.frame)).map_err(|e| c.det(e))?;
                    let events = run.sim.events().map(|p| loomlab_agents::event_input(p, &mut event_buf));
                    let (cruise, camera) = (ep.cruise.command_at(out.t_s), SensedCamera::of(&run.sim));
                    run.cmd = run
                        .agent
                        .step_posed_events(out.t_s, &frame, events.as_ref(), cruise, Some(&camera))
                        .map_err(|e| c.det(e))?
                        .command;
                }
            }
            Ok(())
        })();
        self.renderers.give_back(renderer);
        tails?;
        Ok(runs
            .into_iter()
            .zip(labels)
            .map(|(run, label)| ClosedLoop {
                label,
                simulated: true,
                triggers: run.agent.controller().triggers(),
                collision: run.collision,
                frames_rendered: run.rendered,
            })
            .collect())
    }
}

/// A detector row's closed-loop tail to simulate (`Runner::closed_loop_tails`).
pub(super) struct TailJob<'a> {
    /// The row (detector entry) index.
    pub(super) row: usize,
    pub(super) spec: &'a DetectorSpec,
    /// The first alarm's open-loop frame.
    pub(super) alarm: usize,
    /// A copy of the row's detector right after the alarm frame, when it could make one.
    pub(super) start: Option<Box<dyn Detector>>,
    /// With an event camera: the open loop's event stream right after the alarm frame.
    pub(super) events: Option<loomlab_sim::EventStream>,
    /// The signals of the row's detector instance on each open-loop frame.
    pub(super) signals: &'a [Signals],
}
