//! The robot's own motion as the open-loop deciders and the ideal observers know it.

use loomlab_agents::SelfMotion;
use loomlab_sim::Camera;

use crate::schema::EpisodeSpec;

/// The robot's own motion during the camera period that ends at open-loop frame `k`: the cruise
/// command at the previous frame's time (the escape agent's last command; at the first frame, the
/// cruise command it is given), and `shake_rad`, the camera's shake rotation the inertial sensor on
/// the camera gives for the frame decided on ([`loomlab_agents::SensedCamera`]: for a detector row,
/// the frame it was given, under a perception latency an earlier one; for the reference rows' ideal
/// observers, which read the truth of now, the shake now) — for both alike.
pub(super) fn open_loop_motion(ep: &EpisodeSpec, t_s: &[f64], k: usize, shake_rad: [f64; 3]) -> SelfMotion {
    let command = ep.cruise.command_at(if k == 0 { t_s[0] } else { t_s[k - 1] });
    SelfMotion::of(command, shake_rad)
}

/// The camera's shake rotation at `t_s` (zeros without a camera).
pub(super) fn shake_at(camera: Option<&Camera>, t_s: f64) -> [f64; 3] {
    camera.map_or([0.0; 3], |c| c.shake_rotation(t_s))
}
