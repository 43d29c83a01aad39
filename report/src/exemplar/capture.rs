//! Rendering an exemplar episode's frames again, for its GIF.

use std::sync::Arc;

use loomlab_scenarios::EpisodeSpec;
use loomlab_sim::{GpuContext, Sim};

/// Renders the open-loop pass of `spec` for `len` frames, keeping the frames in `wanted`
/// (sorted); the others are stepped physics-only.
pub(super) fn capture(
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
