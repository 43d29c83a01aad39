//! Bounds on how long one simulated episode (or `loomlab render`) may run.
//!
//! Every caller that turns a duration into a number of camera frames goes through
//! [`episode_frames`], so a typo such as `duration_s = 1e9` or `--seconds inf` is an error naming the
//! key, the value, the cap and the fix instead of millions of frames.

use crate::SimError;

/// Most camera frames one episode (or one `loomlab render`) may have: 432 000, one hour of simulated
/// time at the default camera rate of 120 Hz (`world.camera_hz`).
///
/// Frames are counted as steps after the first view: a duration of `d` seconds at a camera period
/// of `dt` is `round(d / dt)` steps (frames 0..=steps are observed). Scenario episodes and
/// `loomlab render` share this cap; a longer episode must lower `world.camera_hz` or be split.
pub const MAX_EPISODE_FRAMES: u64 = 432_000;

/// Number of camera steps of an episode of `duration_s` seconds at a camera period of `dt_s`
/// seconds: `round(duration_s / dt_s)`, at least 1.
///
/// `key` names the duration as the user wrote it (`episode.duration_s`, `--seconds`) and is
/// repeated in the error. Errors: the duration is not a finite number > 0, `dt_s` is not a finite
/// number > 0, or the episode would have more than [`MAX_EPISODE_FRAMES`] steps.
pub fn episode_frames(key: &str, duration_s: f64, dt_s: f64) -> Result<u64, SimError> {
    if !(duration_s.is_finite() && duration_s > 0.0) {
        return Err(SimError::Duration {
            key: key.to_string(),
            value: duration_s.to_string(),
            reason: "the duration must be a finite number of seconds > 0, e.g. 3".into(),
        });
    }
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(SimError::Duration {
            key: key.to_string(),
            value: duration_s.to_string(),
            reason: format!("the camera period {dt_s} s is not a finite number > 0; check world.camera_hz"),
        });
    }
    let steps = (duration_s / dt_s).round().max(1.0);
    if steps > MAX_EPISODE_FRAMES as f64 {
        let hz = 1.0 / dt_s;
        return Err(SimError::Duration {
            key: key.to_string(),
            value: duration_s.to_string(),
            reason: format!(
                "that is {steps:.0} frames at {hz} Hz, more than the cap of {MAX_EPISODE_FRAMES} frames per episode \
                 (loomlab_sim::MAX_EPISODE_FRAMES); give at most {:.1} s at this frame rate, or lower world.camera_hz",
                MAX_EPISODE_FRAMES as f64 * dt_s
            ),
        });
    }
    Ok(steps as u64)
}

/// Checks a step count given directly (e.g. `loomlab render --frames`) against
/// [`MAX_EPISODE_FRAMES`]; `key` names it in the error.
pub fn check_frame_count(key: &str, frames: u64) -> Result<u64, SimError> {
    if frames > MAX_EPISODE_FRAMES {
        return Err(SimError::Duration {
            key: key.to_string(),
            value: frames.to_string(),
            reason: format!(
                "more than the cap of {MAX_EPISODE_FRAMES} frames per episode (loomlab_sim::MAX_EPISODE_FRAMES); \
                 give at most {MAX_EPISODE_FRAMES}"
            ),
        });
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_are_bounded() {
        let dt = 1.0 / 120.0;
        assert_eq!(episode_frames("episode.duration_s", 3.0, dt).unwrap(), 360);
        assert_eq!(episode_frames("episode.duration_s", 1e-6, dt).unwrap(), 1);
        assert_eq!(
            episode_frames("episode.duration_s", 3600.0, dt).unwrap(),
            MAX_EPISODE_FRAMES
        );
        for bad in [f64::NAN, f64::INFINITY, -1.0, 0.0, 1e9, 3600.1] {
            let e = episode_frames("--seconds", bad, dt).unwrap_err().to_string();
            assert!(e.contains("--seconds") && e.contains(&bad.to_string()), "{e}");
        }
        let e = episode_frames("episode.duration_s", 1e9, dt).unwrap_err().to_string();
        assert!(
            e.contains("432000") && e.contains("MAX_EPISODE_FRAMES") && e.contains("3600.0 s"),
            "{e}"
        );
        assert!(episode_frames("d", 1.0, 0.0).is_err());
        assert!(check_frame_count("--frames", MAX_EPISODE_FRAMES).is_ok());
        assert!(check_frame_count("--frames", MAX_EPISODE_FRAMES + 1).is_err());
    }
}
