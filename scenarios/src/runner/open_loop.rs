//! Step 1 of an episode, the open-loop pass: render once while the robot cruises, every detector
//! on the same frames, each stateful row's decider on its detector's percepts; ground truth.

use loomlab_agents::{CameraMotionSensor, Decider, LoomingSideEstimator, SelfMotion, SensedCamera};
use loomlab_detector::{Detector, Frame, ImageRegion, Signals};
use loomlab_sim::{CapturedView, EventStream, ObjectTruth, Sim, SubframePlan};

use super::motion::open_loop_motion;
use super::{Ctx, Runner};
use crate::error::RunError;
use crate::schema::DetectorSpec;
use crate::truth::{EpisodeTruth, TruthRecorder};

/// Open-loop steps whose views are rendered in one batch (one submission and readback).
const OPEN_LOOP_BATCH: usize = 16;

/// What a stateful row's decider decided per frame.
#[derive(Debug, Default)]
pub(super) struct Decided {
    /// The decision value.
    pub(super) value: Vec<f64>,
    /// τ̂ (s), where estimated.
    pub(super) tau_s: Vec<Option<f64>>,
    /// Whether the course gate was open.
    pub(super) gate_open: Vec<bool>,
}

/// One detector entry's open-loop record.
pub(super) struct DetectorRecord {
    /// The trigger signal per frame (θ̂ or the output; NaN where the detector gives none).
    pub(super) signal: Vec<f64>,
    /// The primary output per frame.
    pub(super) output: Vec<f64>,
    /// The image region per frame (`None` for detectors that do not localise the object).
    pub(super) regions: Vec<Option<ImageRegion>>,
    /// A stateful row's decider and its decisions (`None`: the decision value is the signal).
    decider: Option<Decider>,
    pub(super) decided: Option<Decided>,
    /// Its first alarm frame.
    pub(super) alarmed_at: Option<usize>,
    /// A copy of its detector right after its first alarm frame ([`Detector::snapshot`]; `None`
    /// when the detector cannot copy itself): its closed-loop tail starts there.
    pub(super) snapshot: Option<Box<dyn Detector>>,
    /// With an event camera: its stream right after the first alarm frame (the tail's camera
    /// continues from it).
    pub(super) events: Option<EventStream>,
}

impl DetectorRecord {
    fn new(spec: &DetectorSpec, ep: &crate::schema::EpisodeSpec, total: usize) -> Self {
        let decider = spec
            .is_stateful()
            .then(|| spec.controller(&ep.controller).decider(&ep.facts));
        Self {
            signal: Vec::with_capacity(total),
            output: Vec::with_capacity(total),
            regions: Vec::with_capacity(total),
            decided: decider.as_ref().map(|_| Decided::default()),
            decider,
            alarmed_at: None,
            snapshot: None,
            events: None,
        }
    }

    /// Frame `k`'s decision value (the decider's for a stateful row, else the signal).
    fn decision_value(&mut self, k: usize, t_s: f64, looming_side: Option<f32>, motion: SelfMotion) -> f64 {
        match (&mut self.decider, &mut self.decided) {
            (Some(decider), Some(decided)) => {
                let d = decider.decide_on_detector(t_s, self.signal[k], looming_side, self.regions[k].as_ref(), motion);
                decided.value.push(d.value);
                decided.tau_s.push(d.tau_s);
                decided.gate_open.push(d.gate_open);
                d.value
            }
            _ => self.signal[k],
        }
    }
}

/// The open-loop pass of an episode (see the module docs of [`super`]).
pub(super) struct OpenLoop {
    /// Frame times (s).
    pub(super) t_s: Vec<f64>,
    /// The rendered frames.
    pub(super) frames: Vec<Frame>,
    /// The looming side per frame (x centroid of the temporal contrast).
    pub(super) sides: Vec<Option<f32>>,
    /// What the deciders knew of the robot's own motion per frame.
    pub(super) motion: Vec<SelfMotion>,
    /// Every object's ground truth per frame.
    pub(super) truth: Vec<Vec<ObjectTruth>>,
    /// Per detector entry.
    pub(super) detectors: Vec<DetectorRecord>,
    /// Per detector entry, the first entry that runs the same detector ([`same_detector_as`]).
    pub(super) runs_as: Vec<usize>,
    /// Per detector entry, whether its detector reads an event camera's events
    /// ([`loomlab_detector::Detector::reads_events`]).
    pub(super) reads_events: Vec<bool>,
    /// Each detector instance's signals per frame (entries that run their own instance only): a
    /// closed-loop tail's agent replays them up to its alarm.
    pub(super) history: Vec<Vec<Signals>>,
    /// The object names, by id.
    pub(super) object_names: Vec<String>,
}

/// The detectors of the open-loop pass: one instance per distinct detector (see
/// [`same_detector_as`]) and the signals each entry got on the current frame.
struct Instances {
    built: Vec<Option<Box<dyn Detector>>>,
    stepped: Vec<Signals>,
}

impl Runner {
    /// The open-loop pass (step 1 of an episode). The cruise command does not depend on the
    /// frames, so physics runs ahead by up to [`OPEN_LOOP_BATCH`] steps, capturing each step's
    /// view, and the views are rendered in one batch (bit-identical to rendering each at its
    /// step), then handed to the detectors in order. Steps past the first collision are never
    /// rendered.
    /// Returns the pass and the episode's ground truth (its threat, contact and reference object).
    pub(super) fn open_loop(&self, c: &Ctx<'_>) -> Result<(OpenLoop, EpisodeTruth), RunError> {
        let ep = c.ep;
        let n = ep.world.camera.n;
        let total = ep.frames();
        let mut renderer = self.renderers.take(&self.ctx, n).map_err(|e| c.sim(e))?;
        let mut sim = Sim::new_physics_only(&ep.world, ep.seed).map_err(|e| c.sim(e))?;
        let object_names = sim.objects().into_iter().map(|(_, name, _)| name).collect();
        // Rows that run the same detector (the same id and parameters, e.g. `hopfield` and
        // `hopfield_tau`, which differ only in their decision rule) share one instance here: a
        // detector's signals depend on nothing but its frames and efference copies.
        let runs_as = same_detector_as(&ep.detectors);
        let mut instances = Instances {
            built: Vec::with_capacity(ep.detectors.len()),
            stepped: vec![Signals::default(); ep.detectors.len()],
        };
        for (i, d) in ep.detectors.iter().enumerate() {
            let own = runs_as[i] == i;
            instances.built.push(if own {
                Some(d.build(n as usize).map_err(|e| c.det(e))?)
            } else {
                None
            });
        }
        let mut pass = OpenLoop {
            t_s: Vec::with_capacity(total),
            frames: Vec::with_capacity(total),
            sides: Vec::with_capacity(total),
            motion: Vec::with_capacity(total),
            truth: Vec::with_capacity(total),
            detectors: ep.detectors.iter().map(|d| DetectorRecord::new(d, ep, total)).collect(),
            history: vec![Vec::new(); ep.detectors.len()],
            reads_events: (0..ep.detectors.len())
                .map(|i| instances.built[runs_as[i]].as_ref().is_some_and(|d| d.reads_events()))
                .collect(),
            runs_as,
            object_names,
        };
        let mut recorder = TruthRecorder::new(&sim);
        // with an event camera, the open loop converts the views it renders itself; when no row
        // reads events (frame rows only), it renders no sub-frames: nothing would read them
        let mut stream = sim.take_event_stream().filter(|_| pass.reads_events.contains(&true));
        let stepped = self.open_loop_steps(
            c,
            (&mut sim, &mut stream),
            &mut renderer,
            &mut instances,
            &mut pass,
            &mut recorder,
        );
        self.renderers.give_back(renderer);
        stepped?;
        Ok((pass, recorder.finish()))
    }

    /// The open loop's frames: physics ahead in batches, rendered together, each frame given to
    /// [`Self::open_loop_frame`], until the first contact or the episode's end.
    fn open_loop_steps(
        &self,
        c: &Ctx<'_>,
        (sim, stream): (&mut Sim, &mut Option<EventStream>),
        renderer: &mut loomlab_sim::Renderer,
        instances: &mut Instances,
        pass: &mut OpenLoop,
        recorder: &mut TruthRecorder,
    ) -> Result<(), RunError> {
        let ep = c.ep;
        let total = ep.frames();
        let mut state = FrameState::default();
        let mut steps = 0;
        let mut ahead = Vec::with_capacity(OPEN_LOOP_BATCH);
        let mut pixels: Vec<Vec<f32>> = Vec::with_capacity(OPEN_LOOP_BATCH);
        let (mut event_buf, mut sub_pixels) = (Vec::new(), Vec::new());
        if let Some(s) = stream.as_mut() {
            // the event camera runs from the episode's start: its first period ends with frame 1
            // (as in the simulator's own steps and the env, which observe frame 0)
            let view = sim.capture_view();
            let mut first = Vec::new();
            renderer.render(&view.desc(), &mut first).map_err(|e| c.sim(e))?;
            s.convert_with(view, &first, sim.step_index(), &[]);
        }
        while steps < total {
            if self.cancelled() {
                return Err(RunError::Interrupted);
            }
            ahead.clear();
            while ahead.len() < OPEN_LOOP_BATCH && steps < total {
                let cmd = ep.cruise.command_at(sim.time());
                let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
                steps += 1;
                let collided = out.first_collision().is_some();
                ahead.push((cmd, out, SensedCamera::of(sim), sim.capture_view()));
                if collided {
                    break;
                }
            }
            let descs: Vec<_> = ahead.iter().map(|a| a.3.desc()).collect();
            pixels.resize_with(descs.len(), Vec::new);
            renderer
                .render_batch(&descs, &mut pixels[..descs.len()])
                .map_err(|e| c.sim(e))?;
            let views: Vec<&CapturedView> = ahead.iter().map(|a| &a.3).collect();
            let plan = render_subframes(
                stream.as_ref(),
                renderer,
                &views,
                &pixels[..views.len()],
                &mut sub_pixels,
            )
            .map_err(|e| c.sim(e))?;
            for (j, ((cmd, mut out, camera, view), px)) in ahead.drain(..).zip(pixels.iter_mut()).enumerate() {
                if self.cancelled() {
                    return Err(RunError::Interrupted);
                }
                let packet = match (stream.as_mut(), &plan) {
                    (Some(s), Some(plan)) => {
                        let subs: Vec<&[f32]> = plan.range(j).map(|i| sub_pixels[i].as_slice()).collect();
                        Some(s.convert_with(view, px, out.frame_index, &subs))
                    }
                    _ => None,
                };
                let events = packet.map(|p| loomlab_agents::event_input(p, &mut event_buf));
                let frame = Frame::from_f32(ep.world.camera.n as usize, std::mem::take(px)).map_err(|e| c.det(e))?;
                // the efference copy: the command applied during this period and the camera's
                // motion and pose, as the escape agent passes it in the closed loop (the same up
                // to the first alarm)
                let efference = state.efference_sensor.sense_frame(out.t_s, cmd, &camera);
                for (i, d) in instances.built.iter_mut().enumerate() {
                    instances.stepped[i] = match (d, &events) {
                        (Some(d), Some(ev)) => d.step_events(&frame, ev, &efference).map_err(|e| c.det(e))?,
                        (Some(d), None) => d.step_moving(&frame, &efference).map_err(|e| c.det(e))?,
                        (None, _) => instances.stepped[pass.runs_as[i]].clone(),
                    };
                }
                pass.t_s.push(out.t_s);
                pass.sides.push(state.side.update(&frame));
                pass.motion
                    .push(open_loop_motion(ep, &pass.t_s, pass.t_s.len() - 1, camera.shake_rad));
                open_loop_decisions(ep, instances, pass, stream.as_ref());
                pass.frames.push(frame);
                let contact = recorder.record(&out).is_some();
                pass.truth.push(std::mem::take(&mut out.truth));
                if contact {
                    return Ok(());
                }
            }
        }
        Ok(())
    }
}

/// With an event camera (`stream`): renders the sub-frames of the periods that end with `views`
/// (rendered as `pixels`) in one batch into `out` ([`EventStream::plan_subframes`]).
fn render_subframes(
    stream: Option<&EventStream>,
    renderer: &mut loomlab_sim::Renderer,
    views: &[&CapturedView],
    pixels: &[Vec<f32>],
    out: &mut Vec<Vec<f32>>,
) -> Result<Option<SubframePlan>, loomlab_sim::SimError> {
    let Some(stream) = stream else { return Ok(None) };
    let frames: Vec<&[f32]> = pixels.iter().map(Vec::as_slice).collect();
    let plan = stream.plan_subframes(views, &frames);
    if !plan.is_empty() {
        let descs = plan.descs(views);
        out.resize_with(out.len().max(descs.len()), Vec::new);
        renderer.render_batch(&descs, &mut out[..descs.len()])?;
    }
    Ok(Some(plan))
}

/// What the open loop carries from frame to frame besides its records.
#[derive(Default)]
struct FrameState {
    side: LoomingSideEstimator,
    efference_sensor: CameraMotionSensor,
}

/// Records the latest frame's signals of every detector entry, runs the stateful rows' deciders
/// on them and notes each entry's first alarm (with a copy of its detector).
fn open_loop_decisions(
    ep: &crate::schema::EpisodeSpec,
    instances: &Instances,
    pass: &mut OpenLoop,
    stream: Option<&EventStream>,
) {
    let k = pass.t_s.len() - 1;
    for (i, (record, spec)) in pass.detectors.iter_mut().zip(&ep.detectors).enumerate() {
        let s = &instances.stepped[i];
        record.signal.push(spec.trigger.value(s).unwrap_or(f64::NAN));
        record.output.push(s.output);
        record.regions.push(s.region);
        if pass.runs_as[i] == i {
            pass.history[i].push(s.clone());
        }
    }
    for (i, (record, spec)) in pass.detectors.iter_mut().zip(&ep.detectors).enumerate() {
        let value = record.decision_value(k, pass.t_s[k], pass.sides[k], pass.motion[k]);
        if record.alarmed_at.is_none() && value >= spec.threshold {
            record.alarmed_at = Some(k);
            record.snapshot = instances.built[pass.runs_as[i]].as_ref().and_then(|d| d.snapshot());
            // a tail continues the event camera for a row that reads it (a frame row's tail
            // renders no sub-frames)
            record.events = stream.filter(|_| pass.reads_events[i]).cloned();
        }
    }
}

/// For each detector entry, the first entry that runs the same detector (the same id and
/// parameters; itself when none before it does).
pub(super) fn same_detector_as(specs: &[DetectorSpec]) -> Vec<usize> {
    (0..specs.len())
        .map(|i| {
            (0..i)
                .find(|&j| specs[j].id == specs[i].id && specs[j].params == specs[i].params)
                .unwrap_or(i)
        })
        .collect()
}
