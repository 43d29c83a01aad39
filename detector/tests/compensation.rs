//! Ego-motion compensation (`loomlab_detector::compensation`) and the `tracker` on analytic camera
//! motions: frames ray-cast here from a known camera pose over a textured ground plane (z = 0) and
//! a textured sky, so the true image motion is known exactly.

use loomlab_detector::baselines::{Tracker, TrackerConfig};
use loomlab_detector::compensation::{CompensatedDifference, Mat3, rotation_matrix};
use loomlab_detector::{Detector, EfferenceCopy, Frame, Registry};

const N: usize = 96;
const FOV_DEG: f64 = 60.0;
const DT: f64 = 1.0 / 120.0;

/// A camera in the world: `rotation` has the camera's axes (x forward, y left, z up) as columns.
#[derive(Clone, Copy)]
struct Pose {
    rotation: Mat3,
    position: [f64; 3],
}

fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

fn apply(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| a[i][0] * v[0] + a[i][1] * v[1] + a[i][2] * v[2])
}

fn apply_t(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| a[0][i] * v[0] + a[1][i] * v[1] + a[2][i] * v[2])
}

/// A camera at `height` with pitch `pitch` (rad, up) and yaw `yaw` (rad, left) at `(x, y)`.
fn pose(x: f64, y: f64, height: f64, yaw: f64, pitch: f64) -> Pose {
    Pose {
        rotation: mat_mul(&rotation_matrix([0.0, 0.0, yaw]), &rotation_matrix([0.0, -pitch, 0.0])),
        position: [x, y, height],
    }
}

/// A smooth texture on the ground (period ~0.5 m, its contrast fading with the distance `dist` from
/// the camera like haze, so that it stays smooth in the image up to the horizon) and on the sky (a
/// function of the direction, fading into the horizon's 0.4).
fn ground(x: f64, y: f64, dist: f64) -> f64 {
    0.4 + 0.15 * (x * 12.0).sin() * (y * 9.0).cos() * (-dist / 2.0).exp()
}

fn sky(d: [f64; 3]) -> f64 {
    let az = d[1].atan2(d[0]);
    let el = d[2].atan2(d[0].hypot(d[1]));
    0.4 + el.sin() * (0.8 + 0.3 * (az * 20.0).sin())
}

/// A sphere of `radius` at `centre` (luminance 0.1), or none.
type Ball = Option<([f64; 3], f64)>;

/// The frame seen from `p`.
fn render(p: &Pose, ball: Ball) -> Frame {
    let t = (FOV_DEG / 2.0).to_radians().tan();
    let mut data = Vec::with_capacity(N * N);
    for i in 0..N {
        let yi = 1.0 - (2 * i + 1) as f64 / N as f64;
        for j in 0..N {
            let xi = (2 * j + 1) as f64 / N as f64 - 1.0;
            let d = apply(&p.rotation, [1.0, -xi * t, yi * t]);
            let hit_ball = ball.is_some_and(|(c, r)| {
                let oc = [p.position[0] - c[0], p.position[1] - c[1], p.position[2] - c[2]];
                let a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let b = 2.0 * (oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2]);
                let cc = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - r * r;
                b * b - 4.0 * a * cc >= 0.0 && b < 0.0
            });
            let v = if hit_ball {
                0.1
            } else if d[2] < 0.0 {
                let s = -p.position[2] / d[2];
                let dist = s * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                ground(p.position[0] + s * d[0], p.position[1] + s * d[1], dist)
            } else {
                sky(d)
            };
            data.push(v as f32);
        }
    }
    Frame::from_f32(N, data).unwrap()
}

/// The efference copy of the motion from `a` to `b` whose rotation vector is `w` (in `a`'s axes).
fn ego(a: &Pose, b: &Pose, w: [f64; 3], pitch: f64) -> EfferenceCopy {
    let d = [0, 1, 2].map(|k| b.position[k] - a.position[k]);
    EfferenceCopy {
        dt_s: DT,
        rotation_rad: w,
        translation_m: apply_t(&a.rotation, d),
        height_m: b.position[2],
        pitch_rad: pitch,
        ..EfferenceCopy::default()
    }
}

/// Mean and max |residual| over the pixels, after `frames` (each with its efference copy).
fn residual_stats(frames: &[(Frame, EfferenceCopy)], baseline: usize) -> (f64, f64) {
    let mut c = CompensatedDifference::new(N, FOV_DEG, baseline);
    let mut r = vec![0.0f32; N * N];
    for (f, e) in frames {
        c.step(f.data(), e, &mut r);
    }
    let mean = r.iter().map(|v| f64::from(v.abs())).sum::<f64>() / (N * N) as f64;
    let max = r.iter().map(|v| f64::from(v.abs())).fold(0.0, f64::max);
    (mean, max)
}

/// Frames of a camera turning at `yaw_rate` (rad/s) and pitching at `pitch_rate` while standing.
fn rotating(yaw_rate: f64, pitch_rate: f64, known: bool) -> Vec<(Frame, EfferenceCopy)> {
    let h = 0.35;
    (0..9)
        .map(|k| {
            let (yaw, pitch) = (yaw_rate * DT * k as f64, -0.05 + pitch_rate * DT * k as f64);
            let p = pose(0.0, 0.0, h, yaw, pitch);
            let prev = pose(0.0, 0.0, h, yaw - yaw_rate * DT, pitch - pitch_rate * DT);
            // the rotation from the previous camera to this one, in the previous camera's axes
            let rel = mat_mul(&[0, 1, 2].map(|i| [0, 1, 2].map(|j| prev.rotation[j][i])), &p.rotation);
            let w = log_rotation(&rel);
            let e = if known && k > 0 {
                ego(&prev, &p, w, pitch)
            } else {
                EfferenceCopy::default()
            };
            (render(&p, None), e)
        })
        .collect()
}

/// The rotation vector of a rotation matrix (angles < π).
fn log_rotation(r: &Mat3) -> [f64; 3] {
    let c = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
    let angle = c.acos();
    let v = [r[2][1] - r[1][2], r[0][2] - r[2][0], r[1][0] - r[0][1]];
    let s = if angle < 1e-12 {
        0.5
    } else {
        angle / (2.0 * angle.sin())
    };
    v.map(|x| x * s)
}

#[test]
fn pure_rotation_of_a_static_scene_leaves_no_residual() {
    // 0.5 rad/s of yaw and 0.2 rad/s of pitch over 8 frames (67 ms): the image shifts ~6 pixels
    let (mean_raw, max_raw) = residual_stats(&rotating(0.5, 0.2, false), 8);
    let (mean, max) = residual_stats(&rotating(0.5, 0.2, true), 8);
    assert!(
        mean_raw > 0.01 && max_raw > 0.05,
        "the uncompensated difference is large: {mean_raw} {max_raw}"
    );
    // what remains is the bilinear interpolation of the texture (largest near the horizon); the
    // documented bound (compensation module docs)
    assert!(
        mean < 2e-3 && max < 0.04,
        "residual after compensating a rotation: mean {mean}, max {max}"
    );
}

#[test]
fn forward_translation_over_a_textured_plane_leaves_a_bounded_residual() {
    // 2 m/s forward with camera shake-like roll-free pitch -3°, 8 frames back: the ground near the
    // image bottom moves several pixels
    let (h, v, pitch) = (0.35, 2.0, -0.05);
    let frames = |known: bool| -> Vec<(Frame, EfferenceCopy)> {
        (0..9)
            .map(|k| {
                let p = pose(v * DT * k as f64, 0.0, h, 0.0, pitch);
                let prev = pose(v * DT * (k as f64 - 1.0), 0.0, h, 0.0, pitch);
                let e = if known && k > 0 {
                    ego(&prev, &p, [0.0; 3], pitch)
                } else {
                    EfferenceCopy::default()
                };
                (render(&p, None), e)
            })
            .collect()
    };
    let (mean_raw, max_raw) = residual_stats(&frames(false), 8);
    let (mean, max) = residual_stats(&frames(true), 8);
    assert!(
        mean_raw > 0.01 && max_raw > 0.1,
        "the uncompensated difference is large: {mean_raw} {max_raw}"
    );
    // the documented bound (compensation module docs): interpolation error of the ground texture
    assert!(
        mean < 4e-3 && max < 0.06,
        "residual after compensating a translation: mean {mean}, max {max}"
    );
}

/// The registered `tracker`, built as a suite row builds it.
fn tracker() -> Box<dyn Detector> {
    Registry::builtin()
        .get("tracker")
        .unwrap()
        .default_params(N)
        .unwrap()
        .build(N)
        .unwrap()
}

/// A camera cruising at 1 m/s over the textured ground, optionally with a ball flying at it from
/// 10 m at 8 m/s; returns per frame (true angular size, θ̂, region centre x).
fn cruise(with_ball: bool) -> Vec<(f64, f64, Option<f64>)> {
    cruise_with(tracker(), with_ball)
}

/// [`cruise`] with the detector `d`.
fn cruise_with(mut d: Box<dyn Detector>, with_ball: bool) -> Vec<(f64, f64, Option<f64>)> {
    let (h, v, pitch, u) = (0.35, 1.0, -0.03, 8.0);
    let frames = 110; // the ball reaches 10 − 9·110/120 ≈ 0.8 m
    (0..frames)
        .map(|k| {
            let t = k as f64 * DT;
            let p = pose(v * t, 0.0, h, 0.0, pitch);
            let prev = pose(v * (t - DT), 0.0, h, 0.0, pitch);
            let centre = [10.0 - u * t, 0.3, h + 0.1];
            let radius = 0.2;
            let ball = with_ball.then_some((centre, radius));
            let e = if k > 0 {
                ego(&prev, &p, [0.0; 3], pitch)
            } else {
                EfferenceCopy::default()
            };
            let s = d.step_moving(&render(&p, ball), &e).unwrap();
            let dist = ((centre[0] - p.position[0]).powi(2)
                + (centre[1] - p.position[1]).powi(2)
                + (centre[2] - p.position[2]).powi(2))
            .sqrt();
            let theta = 2.0 * (radius / dist).asin().to_degrees();
            let x = s.region.map(|r| (r.x[0] + r.x[1]) / 2.0);
            (theta, s.angular_size_deg.unwrap(), x)
        })
        .collect()
}

#[test]
fn the_tracker_sees_an_approaching_ball_early_while_the_camera_cruises() {
    let run = cruise(true);
    // θ̂ leaves 0 for good (the frame after the last 0) by a true angular size of 7° (the issue asks
    // for 10°; a track is reported once it has lasted `confirm_frames`)
    let onset = run.iter().rposition(|&(_, est, _)| est <= 0.0).map_or(0, |k| k + 1);
    assert!(onset < run.len() && run[onset].0 <= 7.0, "θ̂ leaves 0 at frame {onset}");
    // and tracks θ within 20 % (median) from 7° on
    let mut errs: Vec<f64> = run
        .iter()
        .filter(|&&(th, _, _)| th >= 7.0)
        .map(|&(th, est, _)| (est - th).abs() / th)
        .collect();
    errs.sort_by(f64::total_cmp);
    let median = errs[errs.len() / 2];
    assert!(median < 0.2, "median relative error of θ̂: {median:.3}");
    // the ball flies 0.3 m left of the camera (image x < 0): its box says so
    let x = run.last().unwrap().2.unwrap();
    assert!(x < -0.05, "box centre x {x}");
}

#[test]
fn the_tracker_sees_nothing_in_a_static_world_while_the_camera_cruises() {
    let run = cruise(false);
    let worst = run.iter().map(|&(_, est, _)| est).fold(0.0, f64::max);
    assert_eq!(worst, 0.0, "θ̂ of a static world seen from a cruising camera");
}

#[test]
fn a_cruising_camera_measures_the_ball_by_its_appearance_early_and_exactly() {
    // the ball stands out from the sky behind it: measured by its appearance, it is reported
    // earlier and its θ̂ follows θ within a few per cent; from the compensated difference alone
    // (`appearance = false`: the few pixels whose centres its edge crossed) later and coarser
    let with = |appearance: bool| {
        let config = TrackerConfig {
            fov_deg: FOV_DEG,
            appearance,
            ..TrackerConfig::default()
        };
        cruise_with(Box::new(Tracker::new(config).unwrap()), true)
    };
    let onset = |run: &[(f64, f64, Option<f64>)]| {
        let k = run.iter().rposition(|&(_, est, _)| est <= 0.0).map_or(0, |k| k + 1);
        run.get(k).map_or(f64::INFINITY, |r| r.0)
    };
    let worst_error = |run: &[(f64, f64, Option<f64>)]| {
        run.iter()
            .filter(|&&(th, est, _)| est > 0.0 && th <= 20.0)
            .map(|&(th, est, _)| (est - th).abs() / th)
            .fold(0.0, f64::max)
    };
    let (on, off) = (with(true), with(false));
    assert!(
        onset(&on) <= 4.5,
        "with its appearance, θ̂ leaves 0 at θ = {:.2}°",
        onset(&on)
    );
    assert!(
        onset(&on) < onset(&off),
        "onsets {:.2}° and {:.2}°",
        onset(&on),
        onset(&off)
    );
    assert!(
        worst_error(&on) < 0.05,
        "θ̂ within 5 % up to 20°: worst {:.3}",
        worst_error(&on)
    );
}
