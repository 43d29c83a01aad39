//! The robot's view: the parts to draw relative to the camera, rendering it and capturing it to render later.

use super::Sim;
use crate::SimError;
use crate::glam::DVec3;
use crate::render::{FrameDesc, PastView, RenderInstance, SensorFrame};
use crate::sensor::Sensor;

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
    /// The step index of the view.
    frame_index: u64,
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
        if self.world.perception_delay == 0 {
            return self.capture_current();
        }
        self.sync_views();
        self.views.front_opt().cloned().expect("synced")
    }

    /// With a perception latency, queues the current view unless it is queued already.
    pub(super) fn sync_views(&mut self) {
        if self.world.perception_delay > 0 && self.views.back().is_none_or(|v| v.frame_index != self.step_index) {
            let v = self.capture_current();
            self.views.push(v);
        }
    }

    /// The description of the view to render now: the current one, or with a perception latency
    /// the queued one of that many frames earlier (after [`Self::prepare_instances`] and
    /// [`Self::sync_views`]).
    pub(super) fn view_desc(&self) -> FrameDesc<'_> {
        match self.views.front_opt() {
            Some(v) if self.world.perception_delay > 0 => v.desc(),
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
            frame_index: self.step_index,
            sensor: self
                .world
                .sensor
                .map(|s| (s, self.seed, self.step_index, self.past_view.clone())),
        }
    }

    /// Keeps the current view as the one before the next frame's (before the world advances),
    /// when the sensor blurs over an exposure.
    pub(super) fn keep_past_view(&mut self) {
        if self.world.sensor.is_none_or(|s| s.views_per_frame() == 1) {
            return;
        }
        self.prepare_instances();
        let cam = self.world.camera.pose(&self.robot_pose, self.t);
        let mut past = self.past_view.take().unwrap_or(PastViewOwned {
            camera_position: cam.position,
            camera_rotation: cam.rotation,
            t_s: self.t,
            instances: Vec::new(),
        });
        past.camera_position = cam.position;
        past.camera_rotation = cam.rotation;
        past.t_s = self.t;
        past.instances.clear();
        past.instances.extend_from_slice(&self.instances);
        self.past_view = Some(past);
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
                previous: self.past_view.as_ref().map(PastViewOwned::view),
            }),
        }
    }

    pub(super) fn render_current(&mut self) -> Result<(), SimError> {
        let Some(mut renderer) = self.renderer.take() else {
            self.frame.clear();
            return Ok(());
        };
        self.prepare_instances();
        self.sync_views();
        let mut frame = std::mem::take(&mut self.frame);
        let result = renderer.render(&self.view_desc(), &mut frame);
        self.frame = frame;
        self.renderer = Some(renderer);
        result
    }
}
