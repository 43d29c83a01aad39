//! Rendering an exemplar episode's frames again, for its GIF.

use std::sync::Arc;

use loomlab_scenarios::EpisodeSpec;
use loomlab_sim::{EventPacket, GpuContext, Sim};

/// The frames an exemplar's GIFs show, each with its index in the episode.
pub(super) struct Captured {
    /// The camera's frames (grey levels in [0, 1]).
    pub(super) frames: Vec<(usize, Vec<f32>)>,
    /// With an event camera (`[world.camera] kind = "events"`): per shown frame the events since
    /// the previous shown frame, as an image ([`event_image`]); `None` without one.
    pub(super) events: Option<Vec<(usize, Vec<f32>)>>,
}

/// Net events (ON − OFF) of a pixel at which an event image saturates.
const EVENT_SATURATION: f32 = 4.0;

/// An event image: mid-grey, ON events brighter and OFF darker, saturating at
/// 4 net events of a kind (as `loomlab render`'s `events.gif`).
pub fn event_image(net: &[f32]) -> Vec<f32> {
    net.iter()
        .map(|&v| 0.5 + 0.5 * (v / EVENT_SATURATION).clamp(-1.0, 1.0))
        .collect()
}

/// Renders the open-loop pass of `spec` for `len` frames, keeping the frames in `wanted`
/// (sorted); the others are stepped physics-only, unless the world has an event camera: then
/// every frame is rendered (the events of a period need its views) and the events are kept too.
pub(super) fn capture(
    ctx: &Arc<GpuContext>,
    spec: &EpisodeSpec,
    len: usize,
    wanted: &[usize],
) -> Result<Captured, String> {
    let mut sim = Sim::with_context(&spec.world, spec.seed, Arc::clone(ctx)).map_err(|e| e.to_string())?;
    sim.set_ground_truth(false);
    let with_events = sim.event_stream().is_some();
    let mut renderer = if with_events { None } else { sim.take_renderer() };
    let n = spec.world.camera.n as usize;
    let mut net = vec![0.0f32; if with_events { n * n } else { 0 }];
    let mut out = Captured {
        frames: Vec::with_capacity(wanted.len()),
        events: with_events.then(|| Vec::with_capacity(wanted.len())),
    };
    let mut next = wanted.iter().peekable();
    for k in 0..len.min(spec.frames()) {
        let shown = next.peek() == Some(&&k);
        if shown && let Some(r) = renderer.take() {
            sim.attach_renderer(r).map_err(|e| e.to_string())?;
        }
        let cmd = spec.cruise.command_at(sim.time());
        let step = sim.step(&cmd.to_sim()).map_err(|e| e.to_string())?;
        if let Some(packet) = sim.events() {
            accumulate(&mut net, packet);
        }
        if shown {
            next.next();
            out.frames.push((k, step.frame));
            if let Some(events) = out.events.as_mut() {
                events.push((k, event_image(&net)));
                net.iter_mut().for_each(|v| *v = 0.0);
            } else {
                renderer = sim.take_renderer();
            }
        }
    }
    Ok(out)
}

/// Adds a period's net events (ON − OFF) per pixel to `net`.
fn accumulate(net: &mut [f32], packet: &EventPacket) {
    for ((v, &on), &off) in net.iter_mut().zip(&packet.on_counts).zip(&packet.off_counts) {
        *v += f32::from(on) - f32::from(off);
    }
}
