//! The robot's view: the parts to draw relative to the camera, rendering it and capturing it to render later.

use super::Sim;
use crate::SimError;
use crate::glam::DVec3;
use crate::render::{FrameDesc, RenderInstance};

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

    /// Captures the current view (what [`Sim::observe`] would render now) to render it later,
    /// e.g. in a batch with other moments of the same episode. Works without a renderer.
    pub fn capture_view(&mut self) -> CapturedView {
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
        }
    }

    pub(super) fn render_current(&mut self) -> Result<(), SimError> {
        let Some(mut renderer) = self.renderer.take() else {
            self.frame.clear();
            return Ok(());
        };
        self.prepare_instances();
        let mut frame = std::mem::take(&mut self.frame);
        let result = renderer.render(&self.frame_desc(), &mut frame);
        self.frame = frame;
        self.renderer = Some(renderer);
        result
    }
}
