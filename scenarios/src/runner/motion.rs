//! The robot's own motion as the open-loop deciders and the ideal observers know it.

use loomlab_agents::SelfMotion;
use loomlab_sim::Camera;

use crate::schema::EpisodeSpec;

/// The robot's own motion during the camera period that ends at open-loop frame `k`: the cruise
/// command at the previous frame's time (the escape agent's last command; at the first frame, the
/// cruise command it is given), and the camera's shake rotation at that frame (the inertial sensor
/// on the camera, [`loomlab_agents::SensedCamera`]; none without a camera) — for the reference rows'
/// ideal observers and the detector rows' deciders alike.
pub(super) fn open_loop_motion(ep: &EpisodeSpec, t_s: &[f64], k: usize, camera: Option<&Camera>) -> SelfMotion {
    let command = ep.cruise.command_at(if k == 0 { t_s[0] } else { t_s[k - 1] });
    SelfMotion::of(command, camera.map_or([0.0; 3], |c| c.shake_rotation(t_s[k])))
}
