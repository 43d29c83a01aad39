//! Batched rendering: stepping or observing many simulators with their views rendered in pipelined groups.

use super::{Sim, StepOutput};
use crate::Contact;
use crate::SimError;
use crate::render::{FrameDesc, PendingViews, Renderer};
use crate::robot::Command;

impl Sim {
    /// Steps every simulator `sims[i]` by one camera period under `commands[i]` (as [`Sim::step`]
    /// does) and renders all their new views with `renderer` in one batch: one submission and one
    /// readback ([`Renderer::render_batch`]) instead of one per simulator. The outputs equal what
    /// [`Sim::step`] of each would give, frames included (bit-identical: each view is rendered
    /// exactly as it would be alone); the simulators' own renderers, if any, are not used. Every
    /// command is validated and every simulator's frame size checked against the renderer's before
    /// anything moves.
    pub fn step_batch(
        sims: &mut [&mut Sim],
        commands: &[Command],
        renderer: &mut Renderer,
    ) -> Result<Vec<StepOutput>, SimError> {
        Self::check_steps("step_batch commands", sims, commands, renderer)?;
        // In groups: the device renders one group's views while this thread steps the next
        // group's physics (each simulator's steps and view are independent of the others').
        let layers = sims.iter().map(|s| s.layers_per_frame()).max().unwrap_or(1);
        let group = Self::batch_group_of(sims.len(), layers, renderer);
        let mut submitted = Vec::with_capacity(sims.len().div_ceil(group));
        for (sims, commands) in sims.chunks_mut(group).zip(commands.chunks(group)) {
            submitted.push(Self::step_submit(sims, commands, renderer)?);
        }
        let mut outs = Vec::with_capacity(sims.len());
        for (sims, steps) in sims.chunks_mut(group).zip(submitted) {
            outs.extend(Self::step_collect(sims, renderer, steps)?);
        }
        Ok(outs)
    }

    /// How many views of a batch of `views` [`Sim::step_batch`] submits together (the groups it
    /// pipelines; see [`Sim::step_submit`]).
    pub fn batch_group(views: usize, renderer: &Renderer) -> usize {
        pipeline_group(views, renderer.max_batch())
    }

    /// [`Sim::batch_group`] for views of `layers` renders each (the sensor's sub-frames,
    /// [`Sim::layers_per_frame`]): a group's layers fit one submission.
    pub fn batch_group_of(views: usize, layers: usize, renderer: &Renderer) -> usize {
        pipeline_group(views, renderer.max_batch() / layers.max(1))
    }

    /// Renders per frame: the sensor's sub-frames when it has an exposure, else 1.
    pub fn layers_per_frame(&self) -> usize {
        self.world.sensor.map_or(1, |s| s.views_per_frame())
    }

    /// The first half of [`Sim::step_batch`] for one group of at most [`Renderer::max_batch`]
    /// simulators: steps each one's physics under its command and submits their views; the
    /// device renders them while the caller goes on (stepping the next group, or working on the
    /// outputs of the previous one). [`Sim::step_collect`] with the same simulators finishes the
    /// step. Checked like [`Sim::step_batch`] before anything moves.
    pub fn step_submit(
        sims: &mut [&mut Sim],
        commands: &[Command],
        renderer: &mut Renderer,
    ) -> Result<SubmittedSteps, SimError> {
        Self::check_steps("step_submit commands", sims, commands, renderer)?;
        let contacts = sims
            .iter_mut()
            .zip(commands)
            .map(|(sim, c)| sim.advance(c))
            .collect::<Result<Vec<_>, _>>()?;
        let views = Self::submit_views(sims, renderer)?;
        Ok(SubmittedSteps { contacts, views })
    }

    /// The second half of a step begun with [`Sim::step_submit`]: waits for the views, reads them
    /// back into the simulators' frames and returns each one's output (what [`Sim::step`] gives).
    pub fn step_collect(
        sims: &mut [&mut Sim],
        renderer: &mut Renderer,
        steps: SubmittedSteps,
    ) -> Result<Vec<StepOutput>, SimError> {
        Self::collect_views(sims, renderer, steps.views)?;
        Ok(sims.iter().zip(steps.contacts).map(|(sim, c)| sim.output(c)).collect())
    }

    /// [`Sim::observe`] of every simulator, their views rendered in one batch (see
    /// [`Sim::step_batch`]).
    pub fn observe_batch(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<Vec<StepOutput>, SimError> {
        Self::check_batch(sims, renderer)?;
        Self::render_views(sims, renderer)?;
        Ok(sims.iter().map(|sim| sim.observation()).collect())
    }

    /// One command per simulator, every command valid, every frame size the renderer's.
    fn check_steps(what: &str, sims: &[&mut Sim], commands: &[Command], renderer: &Renderer) -> Result<(), SimError> {
        if commands.len() != sims.len() {
            return Err(SimError::invalid(
                what,
                commands.len(),
                format!("must be one per simulator ({} simulators)", sims.len()),
            ));
        }
        Self::check_batch(sims, renderer)?;
        commands.iter().try_for_each(Command::validate)
    }

    fn check_batch(sims: &[&mut Sim], renderer: &Renderer) -> Result<(), SimError> {
        match sims.iter().find(|s| s.world.camera.n != renderer.n()) {
            Some(s) => Err(SimError::SizeMismatch {
                renderer_n: renderer.n(),
                world_n: s.world.camera.n,
            }),
            None => Ok(()),
        }
    }

    /// Renders the current views of `sims` in one batch into their frames (submissions of at most
    /// [`Renderer::max_batch`] views, read back once all are submitted).
    fn render_views(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<(), SimError> {
        let layers = sims.iter().map(|s| s.layers_per_frame()).max().unwrap_or(1);
        let group = (renderer.max_batch() / layers).max(1);
        let mut pending = Vec::with_capacity(sims.len().div_ceil(group));
        for sims in sims.chunks_mut(group) {
            pending.push(Self::submit_views(sims, renderer)?);
        }
        for (sims, views) in sims.chunks_mut(group).zip(pending) {
            Self::collect_views(sims, renderer, views)?;
        }
        Ok(())
    }

    /// Submits the current views of `sims` (at most [`Renderer::max_batch`]) for rendering.
    fn submit_views(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<PendingViews, SimError> {
        for sim in sims.iter_mut() {
            sim.prepare_view();
        }
        let descs: Vec<FrameDesc<'_>> = sims.iter().map(|s| s.view_desc()).collect();
        renderer.submit_batch(&descs)
    }

    /// Reads the views of [`Sim::submit_views`] back into the simulators' frames.
    fn collect_views(sims: &mut [&mut Sim], renderer: &mut Renderer, views: PendingViews) -> Result<(), SimError> {
        let mut outs: Vec<Vec<f32>> = sims.iter_mut().map(|s| std::mem::take(&mut s.frame)).collect();
        let result = renderer.collect_batch(views, &mut outs);
        for (sim, out) in sims.iter_mut().zip(outs) {
            sim.frame = out;
        }
        result?;
        Self::update_events_batch(sims, renderer)
    }

    /// The event cameras' periods of `sims` that ended with their frames just collected: every
    /// sub-frame of the batch rendered in one batch ([`super::EventStream::plan_subframes`]);
    /// the same events as [`Sim::update_events`] one by one. Nothing without event cameras.
    fn update_events_batch(sims: &mut [&mut Sim], renderer: &mut Renderer) -> Result<(), SimError> {
        if sims.iter().all(|s| s.dvs.is_none()) {
            return Ok(());
        }
        let views: Vec<Option<super::CapturedView>> = sims
            .iter()
            .map(|s| s.dvs.as_ref().map(|_| super::CapturedView::of_desc(&s.view_desc())))
            .collect();
        let plans: Vec<Option<super::SubframePlan>> = sims
            .iter()
            .zip(&views)
            .map(|(s, v)| Some(s.dvs.as_ref()?.plan_subframes(&[v.as_ref()?], &[&s.frame])))
            .collect();
        let mut descs = Vec::new();
        for (plan, view) in plans.iter().zip(&views) {
            if let (Some(plan), Some(view)) = (plan, view) {
                descs.extend(plan.descs(&[view]));
            }
        }
        let mut rendered = vec![Vec::new(); descs.len()];
        if !descs.is_empty() {
            renderer.render_batch(&descs, &mut rendered)?;
        }
        drop(descs);
        let mut at = 0;
        for ((sim, plan), view) in sims.iter_mut().zip(plans).zip(views) {
            let (Some(plan), Some(view), Some(stream)) = (plan, view, sim.dvs.as_mut()) else {
                continue;
            };
            let subs: Vec<&[f32]> = rendered[at..at + plan.len()].iter().map(Vec::as_slice).collect();
            at += plan.len();
            stream.convert_with(view, &sim.frame, sim.step_index, &subs);
        }
        Ok(())
    }
}

/// Simulators stepped and their views submitted ([`Sim::step_submit`]), to be collected with
/// [`Sim::step_collect`].
#[must_use = "collect the steps with Sim::step_collect"]
#[derive(Debug)]
pub struct SubmittedSteps {
    contacts: Vec<Vec<Contact>>,
    views: PendingViews,
}

/// Groups a large batch of [`Sim::step_batch`] is split into: the device renders one group's views
/// while the stepping thread advances the next group's physics. On lavapipe with `LP_NUM_THREADS=0`
/// (its queue thread rasterises) a batch of 64 views at 64² went from 6 130 to 7 214 steps/s
/// (`render_bench`, medians of 3 alternating runs on 2 CPUs; docs/benchmarks.md).
const PIPELINE_GROUPS: usize = 4;

/// The fewest views a group of [`Sim::step_batch`] has: each submission costs a wait and a map, so
/// small batches stay whole (splitting the default suite's closed-loop tails, a few views each, into
/// groups made the suite ~15 s slower).
const MIN_GROUP_VIEWS: usize = 8;

/// How many of a batch's `views` [`Sim::step_batch`] submits together: up to [`PIPELINE_GROUPS`]
/// groups of at least [`MIN_GROUP_VIEWS`], each at most `max_batch` views (the renderer's limit).
fn pipeline_group(views: usize, max_batch: usize) -> usize {
    let groups = (views / MIN_GROUP_VIEWS).clamp(1, PIPELINE_GROUPS);
    views.div_ceil(groups).clamp(1, max_batch.max(1))
}
