//! The robot's own motion as the open-loop decision strategies and the ideal observers know it.

use loomlab_agents::Ego;
use loomlab_sim::Camera;

use crate::schema::EpisodeSpec;

/// The robot's own motion during the camera period that ends at open-loop frame `k`: the cruise
/// command at the previous frame's time (the escape agent's last command; at the first frame, the
/// cruise command it is given).
pub(super) fn open_loop_ego(ep: &EpisodeSpec, t_s: &[f64], k: usize) -> Ego {
    Ego::of(ep.cruise.command_at(if k == 0 { t_s[0] } else { t_s[k - 1] }), [0.0; 3])
}

/// What the robot knows of its own motion at time `t_s` beside its command: the camera's shake
/// rotation (the inertial sensor on the camera, [`loomlab_agents::CameraSense`]) — for the reference
/// rows' ideal observers and the detector rows' decision strategies alike.
pub(super) fn with_camera_rotation(ego: Ego, camera: Option<&Camera>, t_s: f64) -> Ego {
    let [yaw, pitch, _] = camera.map_or([0.0; 3], |c| c.shake_rotation(t_s));
    Ego {
        camera_yaw_rad: yaw,
        camera_pitch_rad: pitch,
        ..ego
    }
}
