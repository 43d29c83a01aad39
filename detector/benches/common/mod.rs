//! Input frames shared by the detector benches.

use loomlab_detector::{EfferenceCopy, Frame};

/// Frame k of a checkerboard disk (radius growing with k) over a drifting sine grating.
pub fn frame(n: usize, k: usize) -> Frame {
    let c = n as f64 / 2.0;
    let r = n as f64 * (0.05 + 0.012 * k as f64);
    let data = (0..n * n)
        .map(|p| {
            let (i, j) = ((p / n) as f64 + 0.5, (p % n) as f64 + 0.5);
            let (u, v) = ((j - c) / r, (i - c) / r);
            let value = if u * u + v * v <= 1.0 {
                (((2.0 * (u + 1.0)).floor() + (2.0 * (v + 1.0)).floor()) as i64).rem_euclid(2) as f64
            } else {
                0.5 + 0.5 * (2.0 * std::f64::consts::PI * (8.0 * i / n as f64 - 8.0 * k as f64 / 120.0)).sin()
            };
            value as f32
        })
        .collect();
    Frame::from_f32(n, data).expect("n*n pixels")
}

#[allow(dead_code)] // not every bench that includes this module drives a camera
/// The efference copy of one 120 Hz camera period of a camera turning and driving.
pub fn ego() -> EfferenceCopy {
    let dt = 1.0 / 120.0;
    EfferenceCopy {
        forward_mps: 1.0,
        yaw_rate_rps: 0.3,
        dt_s: dt,
        rotation_rad: [0.0, 0.0, 0.3 * dt],
        translation_m: [dt, 0.0, 0.0],
        height_m: 0.35,
        pitch_rad: -0.03,
        ..EfferenceCopy::default()
    }
}
