//! The ideal reference rows on analytic ground truth.

use loomlab_agents::{EscapeConfig, SelfMotion};
use loomlab_scenarios::reference::{IdealKind, IdealObserver};
use loomlab_sim::{ObjectKind, ObjectTruth};

const HZ: f64 = 120.0;
const RADIUS_M: f64 = 0.2;

/// A ball of radius 0.2 m standing 6 m ahead and 0.3 m to the left until `launch_s`, then flying
/// at 10 m/s to a point 0.6 m left of the camera (which stands still).
fn ball(t_s: f64, launch_s: f64) -> ObjectTruth {
    let (start, end) = ([-0.3, 6.0], [-0.6, 0.0]);
    let flight_s = 0.6;
    let f = ((t_s - launch_s) / flight_s).clamp(0.0, 1.0);
    let [x, z] = [start[0] + f * (end[0] - start[0]), start[1] + f * (end[1] - start[1])];
    let d = x.hypot(z);
    let theta = 2.0 * (RADIUS_M / d).asin().to_degrees();
    let az = x.atan2(z).to_degrees();
    let half = theta / 2.0;
    ObjectTruth {
        id: 0,
        name: "ball".into(),
        kind: ObjectKind::Projectile,
        distance_m: (d - RADIUS_M) as f32,
        center_distance_m: d as f32,
        angular_size_deg: theta as f32,
        angular_rate_deg_s: if t_s > launch_s { 1.0 } else { 0.0 },
        tau_s: None,
        ttc_s: None,
        on_collision_course: false,
        bearing: (az.to_radians().tan() / 30f64.to_radians().tan()) as f32,
        bearing_deg: az as f32,
        elevation_deg: 0.0,
        azimuth_extent_deg: [(az - half) as f32, (az + half) as f32],
        elevation_extent_deg: [-half as f32, half as f32],
        in_view: true,
        in_contact: false,
    }
}

#[test]
fn ideal_tau_alarms_within_three_frames_of_a_late_launch_and_dodges_from_where_the_ball_will_pass() {
    let controller = EscapeConfig::default();
    let threshold = 1.0 / controller.decision.tau_threshold_s;
    let launch_s = 0.5;
    let mut observer = IdealObserver::new(
        IdealKind::Tau,
        &controller,
        loomlab_agents::RobotFacts::default(),
        10.0,
        1.0 / HZ,
    );
    let mut alarm = None;
    for k in 0..120 {
        let t = f64::from(k) / HZ;
        let (value, side, _) = observer.update(t, &[ball(t, launch_s)], SelfMotion::default());
        if t < launch_s {
            assert!(value < threshold, "no alarm before the launch (t = {t}, value {value})");
        } else if value >= threshold {
            alarm = Some((t, side));
            break;
        }
    }
    let (t, side) = alarm.expect("ideal_tau never alarmed");
    // launched 0.6 s before arrival (τ < 1 s at once): the τ fit over three frames sees it at the
    // third frame after the launch
    assert!(
        t - launch_s <= 3.0 / HZ + 1e-9,
        "alarm {:.1} frames after the launch",
        (t - launch_s) * HZ
    );
    // the ball will pass on the left (and is seen on the left): dodge right, away from it
    assert!(side.is_some_and(|s| s < 0.0), "side {side:?}");
}
