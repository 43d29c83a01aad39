//! The robot's view: the parts to draw relative to the camera, rendering it and capturing it to render later.

use super::Sim;
use crate::SimError;
use crate::events::{EventCamera, EventPacket};
use crate::glam::DVec3;
use crate::render::{FrameDesc, PastView, RenderInstance, Renderer, SensorFrame};
use crate::sensor::Sensor;

/// An event camera's stream over one episode ([`crate::events`]): the camera's state, the last
/// period's events and the view that period ended with, so that the adaptive sub-frames can be
/// rendered between it and the next view. A simulator with `[world.camera] kind = "events"` keeps
/// one and converts every frame it renders ([`Sim::events`]); the scenario runner, which renders
/// captured views in batches, takes it ([`Sim::take_event_stream`]) and converts them itself
/// ([`EventStream::convert`]), and gives a copy to a closed-loop tail ([`Sim::set_event_stream`]).
#[derive(Clone, Debug)]
pub struct EventStream {
    camera: EventCamera,
    packet: EventPacket,
    /// The last converted view, with its frame index.
    previous: Option<(u64, CapturedView)>,
    /// Scratch instances of the sub-frames.
    instances: Vec<RenderInstance>,
}

impl EventStream {
    /// A stream for an event camera of validated parameters `desc`, `n × n` pixels, seeded with the
    /// simulator's seed.
    pub fn new(desc: &crate::events::EventCameraDesc, n: u32, seed: u64) -> Result<EventStream, SimError> {
        Ok(EventStream {
            camera: EventCamera::new(desc, n, seed)?,
            packet: EventPacket::default(),
            previous: None,
            instances: Vec::new(),
        })
    }

    /// The event camera.
    pub fn camera(&self) -> &EventCamera {
        &self.camera
    }

    /// The events of the last converted period (empty before the second frame).
    pub fn packet(&self) -> &EventPacket {
        &self.packet
    }

    /// Whether a frame was converted.
    pub fn started(&self) -> bool {
        self.previous.is_some()
    }

    /// Converts the camera period that ended with `view` (rendered as `frame`, frame index
    /// `frame_index`): the adaptive sub-frames are rendered with `renderer`, interpolated between
    /// the previous converted view and `view`. The first view only starts the camera (an empty
    /// packet); the same frame index again gives an empty packet.
    pub fn convert(
        &mut self,
        renderer: &mut Renderer,
        view: CapturedView,
        frame: &[f32],
        frame_index: u64,
    ) -> Result<&EventPacket, SimError> {
        let desc = view.desc();
        let n = renderer.n();
        if self.previous.as_ref().is_some_and(|(i, _)| *i == frame_index) {
            self.packet.clear(n, desc.t_s, desc.t_s);
            return Ok(&self.packet);
        }
        let previous = self.previous.take();
        let past = previous
            .as_ref()
            .map(|(_, v)| v.past())
            .filter(|p| p.instances.len() == desc.instances.len());
        let mut instances = std::mem::take(&mut self.instances);
        let mut render = |alpha: f64, buf: &mut Vec<f32>| -> Result<(), SimError> {
            let Some(past) = past else {
                return renderer.render(&FrameDesc { sensor: None, ..desc }, buf);
            };
            let (camera_position, camera_rotation, t_s) = desc.between(&past, 1.0 - alpha, &mut instances);
            renderer.render(
                &FrameDesc {
                    camera_position,
                    camera_rotation,
                    t_s,
                    instances: &instances,
                    sensor: None,
                    ..desc
                },
                buf,
            )
        };
        let result = self
            .camera
            .period(frame, desc.t_s, frame_index, &mut render, &mut self.packet);
        self.instances = instances;
        self.previous = Some((frame_index, view));
        result.map(|()| &self.packet)
    }
}

/// The view one camera period earlier, kept for the sensor's exposure blur ([`PastView`]).
#[derive(Clone, Debug)]
pub(super) struct PastViewOwned {
    camera_position: DVec3,
    camera_rotation: crate::glam::DQuat,
    t_s: f64,
    instances: Vec<RenderInstance>,
}

impl PastViewOwned {
    fn view(&self) -> PastView<'_> {
        PastView {
            camera_position: self.camera_position,
            camera_rotation: self.camera_rotation,
            t_s: self.t_s,
            instances: &self.instances,
        }
    }
}

/// What determines the view at one step, kept (cheaply) for a later frame: with a perception
/// latency or an exposure ([`Sim::tracks_views`]).
#[derive(Clone, Debug)]
pub(super) struct ViewState {
    step_index: u64,
    t: f64,
    robot_pose: crate::trajectory::Pose64,
    /// The poses of the dynamic bodies (projectiles), in object order.
    dynamic: Vec<crate::trajectory::Pose64>,
}

/// The robot's view at one moment, captured to be rendered later ([`Sim::capture_view`]): several
/// frames of one open-loop pass can then be rendered in one batch ([`Renderer::render_batch`] of
/// their [`CapturedView::desc`]), each frame bit-identical to the one [`Sim::step`] would have
/// rendered then.
///
/// [`Renderer::render_batch`]: crate::render::Renderer::render_batch
#[derive(Clone, Debug)]
pub struct CapturedView {
    camera_position: DVec3,
    camera_rotation: crate::glam::DQuat,
    fov_rad: f64,
    near_m: f32,
    sky: f32,
    ground: Option<crate::texture::ResolvedTexture>,
    t_s: f64,
    instances: Vec<RenderInstance>,
    /// The sensor, its seed and this frame's index, and the view before (see [`SensorFrame`]).
    sensor: Option<(Sensor, u64, u64, Option<PastViewOwned>)>,
}

impl CapturedView {
    /// The frame description to render.
    pub fn desc(&self) -> FrameDesc<'_> {
        FrameDesc {
            camera_position: self.camera_position,
            camera_rotation: self.camera_rotation,
            fov_rad: self.fov_rad,
            near_m: self.near_m,
            sky: self.sky,
            ground: self.ground.as_ref(),
            t_s: self.t_s,
            instances: &self.instances,
            sensor: self
                .sensor
                .as_ref()
                .map(|(sensor, seed, frame_index, past)| SensorFrame {
                    sensor,
                    seed: *seed,
                    frame_index: *frame_index,
                    previous: past.as_ref().map(PastViewOwned::view),
                }),
        }
    }

    /// Simulation time of the view (s).
    pub fn t_s(&self) -> f64 {
        self.t_s
    }

    /// The view of `desc`, owned (without a sensor).
    pub(super) fn of_desc(desc: &FrameDesc<'_>) -> CapturedView {
        CapturedView {
            camera_position: desc.camera_position,
            camera_rotation: desc.camera_rotation,
            fov_rad: desc.fov_rad,
            near_m: desc.near_m,
            sky: desc.sky,
            ground: desc.ground.copied(),
            t_s: desc.t_s,
            instances: desc.instances.to_vec(),
            sensor: None,
        }
    }

    /// This view as the start of an interpolation ([`FrameDesc::between`]).
    fn past(&self) -> PastView<'_> {
        PastView {
            camera_position: self.camera_position,
            camera_rotation: self.camera_rotation,
            t_s: self.t_s,
            instances: &self.instances,
        }
    }
}

/// The sub-frames a batch of consecutive views needs for their event-camera periods
/// ([`EventStream::plan_subframes`]): render [`Self::descs`] (in one batch), then hand view j its
/// renders [`Self::range`]`(j)` with [`EventStream::convert_with`].
#[derive(Debug, Default)]
pub struct SubframePlan {
    /// Per sub-frame: the view it belongs to, the camera's pose, the time and the instances.
    views: Vec<(usize, DVec3, crate::glam::DQuat, f64, Vec<RenderInstance>)>,
    /// Per view of the batch: its sub-frames' range in `views`.
    ranges: Vec<std::ops::Range<usize>>,
}

impl SubframePlan {
    /// The sub-frames' descriptions, in order (`views` are the batch's views given to
    /// [`EventStream::plan_subframes`]).
    pub fn descs<'a>(&'a self, views: &[&'a CapturedView]) -> Vec<FrameDesc<'a>> {
        self.views
            .iter()
            .map(|(j, camera_position, camera_rotation, t_s, instances)| FrameDesc {
                camera_position: *camera_position,
                camera_rotation: *camera_rotation,
                t_s: *t_s,
                instances,
                sensor: None,
                ..views[*j].desc()
            })
            .collect()
    }

    /// Sub-frames in all.
    pub fn len(&self) -> usize {
        self.views.len()
    }

    /// Whether no view needs a sub-frame.
    pub fn is_empty(&self) -> bool {
        self.views.is_empty()
    }

    /// The positions of view j's sub-frames among [`Self::descs`].
    pub fn range(&self, j: usize) -> std::ops::Range<usize> {
        self.ranges[j].clone()
    }
}

impl EventStream {
    /// The sub-frames of the periods that end with `views` (consecutive views following the last
    /// converted one, rendered as `frames`): as many per period as [`EventCamera::renders_for`]
    /// asks (minus the frame), at the times and poses [`Self::convert`] would render them one by
    /// one, so that converting with them gives the same events.
    pub fn plan_subframes(&self, views: &[&CapturedView], frames: &[&[f32]]) -> SubframePlan {
        let mut plan = SubframePlan::default();
        for (j, view) in views.iter().enumerate() {
            let start = plan.views.len();
            let (previous, k) = if j == 0 {
                (
                    self.previous.as_ref().map(|(_, v)| v),
                    self.camera.renders_after(frames[0]),
                )
            } else {
                (Some(views[j - 1]), self.camera.renders_for(frames[j - 1], frames[j]))
            };
            let desc = view.desc();
            for i in 1..k {
                let alpha = f64::from(i) / f64::from(k);
                let mut instances = Vec::with_capacity(desc.instances.len());
                let past = previous
                    .map(|p| p.past())
                    .filter(|p| p.instances.len() == desc.instances.len());
                let (position, rotation, t_s) = match past {
                    Some(past) => desc.between(&past, 1.0 - alpha, &mut instances),
                    None => {
                        instances.extend_from_slice(desc.instances);
                        (desc.camera_position, desc.camera_rotation, desc.t_s)
                    }
                };
                plan.views.push((j, position, rotation, t_s, instances));
            }
            plan.ranges.push(start..plan.views.len());
        }
        plan
    }

    /// [`Self::convert`] with the period's sub-frames rendered beforehand ([`Self::plan_subframes`]).
    pub fn convert_with(
        &mut self,
        view: CapturedView,
        frame: &[f32],
        frame_index: u64,
        subframes: &[&[f32]],
    ) -> &EventPacket {
        let n = self.camera.n();
        if self.previous.as_ref().is_some_and(|(i, _)| *i == frame_index) {
            self.packet.clear(n, view.t_s, view.t_s);
            return &self.packet;
        }
        self.camera
            .period_with(frame, view.t_s, frame_index, subframes, &mut self.packet);
        self.previous = Some((frame_index, view));
        &self.packet
    }
}

impl Sim {
    /// Fills `instances` with the parts to draw now, relative to the camera.
    pub(super) fn prepare_instances(&mut self) {
        let cam = self.world.camera.pose(&self.robot_pose, self.t);
        let mut instances = std::mem::take(&mut self.instances);
        instances.clear();
        for o in &self.objects {
            let pose = self.pose_now(o);
            for p in &o.spec.parts {
                instances.push(RenderInstance {
                    prim: p.prim.kind,
                    position: (pose.transform_point(p.offset) - cam.position).as_vec3(),
                    rotation: (pose.rotation * p.rotation).normalize().as_quat(),
                    size: p.prim.size,
                    texture: p.texture,
                });
            }
        }
        self.instances = instances;
    }

    /// Captures the view [`Sim::observe`] would render now (with a perception latency, the view of
    /// that many frames earlier: [`crate::latency`]) to render it later, e.g. in a batch with other
    /// moments of the same episode. Works without a renderer.
    pub fn capture_view(&mut self) -> CapturedView {
        if self.tracks_views() {
            self.shown_view()
        } else {
            self.capture_current()
        }
    }

    /// When the frame the robot sees now was taken and the camera's world pose then: with a
    /// perception latency ([`crate::latency`]) the shown view's time and pose, which lag
    /// [`Self::time`] and [`Self::camera_pose`] by the latency; without one, exactly those. What the
    /// robot's time-stamped odometry and inertial sensor report for the frame it is given.
    pub fn shown_camera(&self) -> (f64, crate::trajectory::Pose64) {
        if self.world.perception_delay > 0
            && let Some(shown) = self.views.get(1).or(self.views.front_opt())
        {
            return (shown.t, self.world.camera.pose(&shown.robot_pose, shown.t));
        }
        (self.t, self.camera_pose())
    }

    /// Whether the simulator keeps the states of past views: with a perception latency (the view
    /// shown is an earlier one) or an exposure (a frame blurs from the view before it).
    pub(super) fn tracks_views(&self) -> bool {
        self.world.perception_delay > 0 || self.world.sensor.is_some_and(|s| s.views_per_frame() > 1)
    }

    /// Queues the current view's state unless it is queued already (cheap: the robot's pose and
    /// the dynamic bodies' poses; the instances are computed when a view is rendered).
    pub(super) fn sync_views(&mut self) {
        if self.tracks_views() && self.views.back().is_none_or(|v| v.step_index != self.step_index) {
            let state = ViewState {
                step_index: self.step_index,
                t: self.t,
                robot_pose: self.robot_pose,
                dynamic: self
                    .objects
                    .iter()
                    .filter(|o| o.dynamic)
                    .map(|o| super::pose64(self.physics.bodies[o.body].position()))
                    .collect(),
            };
            self.views.push(state);
        }
    }

    /// The parts to draw in the view of `state` (relative to its camera) into `out`; returns the
    /// camera's pose then. The same as [`Self::prepare_instances`] at that moment.
    fn instances_at(&self, state: &ViewState, out: &mut Vec<RenderInstance>) -> crate::trajectory::Pose64 {
        let cam = self.world.camera.pose(&state.robot_pose, state.t);
        out.clear();
        let mut dynamic = state.dynamic.iter();
        for o in &self.objects {
            let pose = match (o.dynamic, dynamic.clone().next()) {
                (true, Some(p)) => {
                    dynamic.next();
                    *p
                }
                _ => o.spec.trajectory.pose_at(state.t),
            };
            for p in &o.spec.parts {
                out.push(RenderInstance {
                    prim: p.prim.kind,
                    position: (pose.transform_point(p.offset) - cam.position).as_vec3(),
                    rotation: (pose.rotation * p.rotation).normalize().as_quat(),
                    size: p.prim.size,
                    texture: p.texture,
                });
            }
        }
        cam
    }

    /// The view shown now when views are tracked: the queued one of the perception latency's
    /// frames earlier, with the view before it for the exposure's blur (none when the queue holds
    /// nothing earlier: an episode's first frame).
    fn shown_view(&mut self) -> CapturedView {
        self.sync_views();
        let shown = self.views.get(1).or(self.views.front_opt()).cloned().expect("synced");
        let before = self
            .views
            .front_opt()
            .filter(|b| b.step_index + 1 == shown.step_index)
            .cloned();
        let mut instances = Vec::new();
        let cam = self.instances_at(&shown, &mut instances);
        let blur = self.world.sensor.is_some_and(|s| s.views_per_frame() > 1);
        let past = before.filter(|_| blur).map(|b| {
            let mut inst = Vec::new();
            let c = self.instances_at(&b, &mut inst);
            PastViewOwned {
                camera_position: c.position,
                camera_rotation: c.rotation,
                t_s: b.t,
                instances: inst,
            }
        });
        CapturedView {
            camera_position: cam.position,
            camera_rotation: cam.rotation,
            fov_rad: self.world.camera.fov_rad,
            near_m: self.world.camera.near_m,
            sky: self.world.sky,
            ground: self.world.ground,
            t_s: shown.t,
            instances,
            sensor: self.world.sensor.map(|s| (s, self.seed, shown.step_index, past)),
        }
    }

    /// Prepares the view to render now: the current instances, or with tracked views the shown
    /// view ([`Self::view_desc`] describes it).
    pub(super) fn prepare_view(&mut self) {
        if self.tracks_views() {
            self.shown = Some(self.shown_view());
        } else {
            self.prepare_instances();
        }
    }

    /// The description of the view to render now (after [`Self::prepare_view`]).
    pub(super) fn view_desc(&self) -> FrameDesc<'_> {
        match &self.shown {
            Some(v) if self.tracks_views() => v.desc(),
            _ => self.frame_desc(),
        }
    }

    /// The current view, captured.
    fn capture_current(&mut self) -> CapturedView {
        self.prepare_instances();
        let d = self.frame_desc();
        CapturedView {
            camera_position: d.camera_position,
            camera_rotation: d.camera_rotation,
            fov_rad: d.fov_rad,
            near_m: d.near_m,
            sky: d.sky,
            ground: d.ground.copied(),
            t_s: d.t_s,
            instances: d.instances.to_vec(),
            sensor: self.world.sensor.map(|s| (s, self.seed, self.step_index, None)),
        }
    }

    /// The view now (after [`Self::prepare_instances`]).
    pub(super) fn frame_desc(&self) -> FrameDesc<'_> {
        let cam = self.world.camera.pose(&self.robot_pose, self.t);
        FrameDesc {
            camera_position: cam.position,
            camera_rotation: cam.rotation,
            fov_rad: self.world.camera.fov_rad,
            near_m: self.world.camera.near_m,
            sky: self.world.sky,
            ground: self.world.ground.as_ref(),
            t_s: self.t,
            instances: &self.instances,
            sensor: self.world.sensor.as_ref().map(|sensor| SensorFrame {
                sensor,
                seed: self.seed,
                frame_index: self.step_index,
                previous: None,
            }),
        }
    }

    pub(super) fn render_current(&mut self) -> Result<(), SimError> {
        let Some(mut renderer) = self.renderer.take() else {
            self.frame.clear();
            return Ok(());
        };
        self.prepare_view();
        let mut frame = std::mem::take(&mut self.frame);
        let mut result = renderer.render(&self.view_desc(), &mut frame);
        self.frame = frame;
        if result.is_ok() {
            result = self.update_events(&mut renderer);
        }
        self.renderer = Some(renderer);
        result
    }
}

impl Sim {
    /// With an event camera: converts the camera period that ended with the frame just rendered
    /// (the view [`Self::view_desc`] describes) into events, rendering the adaptive sub-frames
    /// with `renderer` ([`EventStream::convert`]). Nothing without one.
    pub(super) fn update_events(&mut self, renderer: &mut Renderer) -> Result<(), SimError> {
        let Some(mut stream) = self.dvs.take() else {
            return Ok(());
        };
        let view = CapturedView::of_desc(&self.view_desc());
        let result = stream.convert(renderer, view, &self.frame, self.step_index).map(|_| ());
        self.dvs = Some(stream);
        result
    }

    /// With `[world.camera] kind = "events"`: the events of the camera period that ended with the
    /// last frame this simulator rendered ([`crate::events`]; empty for an episode's first frame).
    /// `None` without an event camera, or before it converted a frame (a physics-only simulator).
    pub fn events(&self) -> Option<&EventPacket> {
        self.dvs.as_ref().filter(|s| s.started()).map(|s| s.packet())
    }

    /// The event stream, with `kind = "events"` (its camera: parameters and per-pixel thresholds).
    pub fn event_stream(&self) -> Option<&EventStream> {
        self.dvs.as_deref()
    }

    /// Takes the event stream out (the simulator's frames then give no events): for a caller that
    /// renders captured views itself and converts them with [`EventStream::convert`].
    pub fn take_event_stream(&mut self) -> Option<EventStream> {
        self.dvs.take().map(|b| *b)
    }

    /// Replaces the event stream (a closed-loop tail continues the open loop's stream from its
    /// alarm frame on).
    pub fn set_event_stream(&mut self, stream: EventStream) {
        self.dvs = Some(Box::new(stream));
    }
}
