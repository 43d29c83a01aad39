//! The window of recent samples the τ estimator and the course gate read (module docs, "Jumps").

use std::collections::VecDeque;

use super::JUMP_RATIO;
use super::percept::{Percept, SelfMotion};

/// One frame of the window: θ and directions in the camera mount's frame (the camera's own
/// rotation removed).
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    pub(super) t: f64,
    pub(super) theta_rad: f64,
    pub(super) azimuth_rad: Option<f64>,
    pub(super) elevation_rad: Option<f64>,
    /// tan of the edge azimuths and elevations `[left, right, bottom, top]`.
    pub(super) edges_tan: Option<[f64; 4]>,
}

impl Sample {
    /// Whether θ is a usable angular size (finite and > 0).
    pub(super) fn has_theta(&self) -> bool {
        self.theta_rad.is_finite() && self.theta_rad > 0.0
    }
}

/// The samples of the last `keep_s` seconds (see [`SampleWindow::push`]).
#[derive(Debug, Clone, Default)]
pub(super) struct SampleWindow {
    samples: VecDeque<Sample>,
}

impl SampleWindow {
    /// Forget every sample.
    pub(super) fn clear(&mut self) {
        self.samples.clear();
    }

    /// Add the frame at `t_s`: a θ that jumps by more than [`JUMP_RATIO`] from the last sample's
    /// starts the window afresh (another percept, not growth); samples older than `keep_s` leave.
    pub(super) fn push(&mut self, t_s: f64, theta_rad: f64, percept: &Percept, motion: &SelfMotion, keep_s: f64) {
        if self.samples.back().is_some_and(|last| {
            last.theta_rad > 0.0 && theta_rad > 0.0 && (theta_rad / last.theta_rad).ln().abs() > JUMP_RATIO.ln()
        }) {
            self.samples.clear();
        }
        while self.samples.front().is_some_and(|s| s.t < t_s - keep_s - 1e-9) {
            self.samples.pop_front();
        }
        let finite = |v: Option<f64>| v.filter(|x| x.is_finite()).map(f64::to_radians);
        // directions in the camera mount's frame: the camera's own rotation removed
        let (yaw, pitch) = (motion.camera_yaw_rad, motion.camera_pitch_rad);
        self.samples.push_back(Sample {
            t: t_s,
            theta_rad,
            azimuth_rad: finite(percept.azimuth_deg).map(|a| a - yaw),
            elevation_rad: finite(percept.elevation_deg).map(|e| e + pitch),
            edges_tan: percept
                .extent
                .map(|e| {
                    let [l, r] = e.azimuth_deg.map(|a| a.to_radians() - yaw);
                    let [b, u] = e.elevation_deg.map(|a| a.to_radians() + pitch);
                    [l, r, b, u].map(|a| a.clamp(-1.55, 1.55).tan())
                })
                .filter(|e| e.iter().all(|v| v.is_finite())),
        });
    }

    /// The samples at or after `t_from`, oldest first.
    pub(super) fn since(&self, t_from: f64) -> impl Iterator<Item = &Sample> + Clone {
        self.samples.iter().filter(move |s| s.t >= t_from)
    }
}
