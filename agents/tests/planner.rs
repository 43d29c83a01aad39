//! The manoeuvre planner on analytic scenes: objects whose courses are given as the collision-course
//! gate forecasts them, and a robot cruising at 1 m/s.

use loomlab_agents::decision::CourseForecast;
use loomlab_agents::planner::{Odometry, OdometryTrail, PlanContext};
use loomlab_agents::{Candidate, DodgeSide, EscapeConfig, Manoeuvre, Planner, RobotFacts, VelocityCommand};

const CRUISE: VelocityCommand = VelocityCommand {
    forward_mps: 1.0,
    yaw_rate_rps: 0.0,
    lateral_mps: 0.0,
};

/// An object `depth_m` ahead now, its centre `lateral_m` to the right of the camera, closing at
/// `closing_mps` and arriving `arrival_lateral_m` to the right, `half_width_m` wide each side.
fn forecast(
    depth_m: f64,
    lateral_m: f64,
    arrival_lateral_m: f64,
    half_width_m: f64,
    closing_mps: f64,
) -> CourseForecast {
    CourseForecast {
        t_s: 0.0,
        tau_s: depth_m / closing_mps,
        closing_mps,
        lateral_m: [lateral_m - half_width_m, lateral_m + half_width_m],
        arrival_lateral_m: [arrival_lateral_m - half_width_m, arrival_lateral_m + half_width_m],
        arrival_vertical_m: [-0.1, 0.1],
        straight: Some(true),
        // the tests' standing objects close at the robot's 1 m/s
        standing: closing_mps == 1.0,
        closing_measured: false,
    }
}

fn cruising() -> Odometry {
    Odometry {
        velocity: [1.0, 0.0, 0.0],
        ..Odometry::default()
    }
}

/// A trail of a robot that has cruised since the start, at `t_s`.
fn cruised_until(t_s: f64) -> OdometryTrail {
    let mut trail = OdometryTrail::default();
    trail.push(t_s, cruising());
    trail
}

fn planner_with(objects: &[CourseForecast]) -> Planner {
    let mut planner = Planner::new(RobotFacts::default());
    for (id, f) in objects.iter().enumerate() {
        planner.observe(id, f, 0.0, &cruised_until(0.0));
    }
    planner
}

fn ctx(config: &EscapeConfig) -> PlanContext<'_> {
    PlanContext {
        t_s: 0.0,
        odometry: cruising(),
        cruise: CRUISE,
        dodge: loomlab_agents::DodgeOffset::default(),
        config,
    }
}

fn preference(first: DodgeSide) -> [Candidate; 4] {
    let other = if first == DodgeSide::Left {
        DodgeSide::Right
    } else {
        DodgeSide::Left
    };
    [
        Candidate::dodge(first),
        Candidate::dodge(other),
        Candidate::ALL[2],
        Candidate::ALL[3],
    ]
}

fn clearances(planner: &Planner, config: &EscapeConfig) -> Vec<(Candidate, f64)> {
    Candidate::ALL
        .iter()
        .map(|c| (*c, planner.clearance(*c, &ctx(config))))
        .collect()
}

#[test]
fn a_lone_ball_on_course_is_dodged_to_the_preferred_side_and_the_dodge_clears_it() {
    let config = EscapeConfig::default();
    let planner = planner_with(&[forecast(8.0, 0.0, 0.0, 0.1, 10.0)]);
    let chosen = planner
        .choose(&ctx(&config), &preference(DodgeSide::Right), None)
        .unwrap();
    assert_eq!(chosen, Candidate::dodge(DodgeSide::Right));
    let c = clearances(&planner, &config);
    // (the clearance is the smallest under every closing-speed hypothesis)
    assert!(c[0].1 > 0.15 && c[1].1 > 0.15, "{c:?}");
    // standing still does not help against a ball that flies into the robot
    assert!(c[2].1 < 0.0, "{c:?}");
}

#[test]
fn two_balls_from_both_sides_with_one_safe_gap() {
    // ball A on course (arrives at the camera), ball B arriving 0.8 m to the left: the dodge to
    // the left runs into B, the dodge to the right clears both, whatever the preference says
    let config = EscapeConfig::default();
    let planner = planner_with(&[forecast(8.0, 0.5, 0.0, 0.1, 10.0), forecast(9.0, -2.0, -0.8, 0.1, 10.0)]);
    for first in [DodgeSide::Left, DodgeSide::Right] {
        let chosen = planner.choose(&ctx(&config), &preference(first), None).unwrap();
        assert_eq!(chosen, Candidate::dodge(DodgeSide::Right), "preferring {first:?}");
    }
    let c = clearances(&planner, &config);
    assert!(c[0].1 < 0.1, "left into B: {c:?}");
    assert!(c[1].1 > 0.15, "right clears both: {c:?}");
}

#[test]
fn a_threat_with_a_car_passing_beside_is_dodged_away_from_the_car() {
    // a ball on course and, in the next lane to the right, a car (1.8 m wide) coming the other
    // way at 8 m/s: its near side passes 0.9 m right of the camera, so the dodge to the right
    // (0.9 m in 0.6 s) would drive into it
    let config = EscapeConfig::default();
    let car = forecast(14.0, 1.8, 1.8, 0.9, 9.0);
    let planner = planner_with(&[forecast(10.0, 0.0, 0.0, 0.1, 10.0), car]);
    let chosen = planner
        .choose(&ctx(&config), &preference(DodgeSide::Right), None)
        .unwrap();
    assert_eq!(chosen, Candidate::dodge(DodgeSide::Left));
    let c = clearances(&planner, &config);
    assert!(c[1].1 < 0.0, "the dodge to the right hits the car: {c:?}");
}

#[test]
fn a_wall_beside_the_dodge_limits_it_and_the_other_side_is_taken() {
    // the corridor allows 0.3 m to the left (`max_dodge_offset_m`, as a robot that knows its
    // lane sets it): a dodge to the left stops after 0.3 m, too little for a ball that arrives
    // 0.25 m to the right... of the camera's left, so the right is taken
    let config = EscapeConfig {
        max_dodge_offset_m: Some(0.3),
        ..EscapeConfig::default()
    };
    let planner = planner_with(&[forecast(8.0, -0.3, -0.15, 0.2, 10.0)]);
    let chosen = planner
        .choose(&ctx(&config), &preference(DodgeSide::Left), None)
        .unwrap();
    assert_eq!(chosen, Candidate::dodge(DodgeSide::Right));
    // and a pole standing 1 m to the left ahead (closing at the robot's own speed) blocks the
    // left as well when nothing limits the offset
    let config = EscapeConfig::default();
    let planner = planner_with(&[forecast(6.0, 0.0, 0.0, 0.1, 10.0), forecast(1.2, -0.7, -0.7, 0.1, 1.0)]);
    let chosen = planner
        .choose(&ctx(&config), &preference(DodgeSide::Left), None)
        .unwrap();
    assert_eq!(chosen, Candidate::dodge(DodgeSide::Right));
}

#[test]
fn when_both_dodges_run_into_a_ball_the_robot_holds_back() {
    // balls arriving 0.8 m to each side: a 0.9 m dodge to either side runs into one, staying on
    // the path (stopping or reversing) lets both pass
    let config = EscapeConfig::default();
    let planner = planner_with(&[
        forecast(9.0, -1.6, -0.8, 0.15, 10.0),
        forecast(9.0, 1.6, 0.8, 0.15, 10.0),
    ]);
    let chosen = planner
        .choose(&ctx(&config), &preference(DodgeSide::Left), None)
        .unwrap();
    assert!(
        matches!(chosen.manoeuvre, Manoeuvre::Stop | Manoeuvre::Reverse),
        "{chosen:?}: {:?}",
        clearances(&planner, &config)
    );
}

#[test]
fn the_running_manoeuvre_is_kept_unless_another_is_clearly_better() {
    let config = EscapeConfig::default();
    let planner = planner_with(&[forecast(8.0, 0.0, 0.0, 0.1, 10.0)]);
    let running = Candidate::dodge(DodgeSide::Left);
    assert_eq!(
        planner.choose(&ctx(&config), &preference(DodgeSide::Right), Some(running)),
        Some(running)
    );
    // nothing remembered: the planner gives no choice (the fixed rule decides)
    let empty = Planner::new(RobotFacts::default());
    assert_eq!(empty.choose(&ctx(&config), &preference(DodgeSide::Right), None), None);
}

#[test]
fn a_forecast_made_while_the_robot_changed_its_motion_replaces_one_only_when_the_course_changed() {
    let mut planner = Planner::new(RobotFacts::default());
    // remembered from a steady window
    let mut steady = forecast(8.0, 0.0, 0.0, 0.1, 10.0);
    steady.t_s = 0.1;
    planner.observe(1, &steady, 0.2, &cruised_until(0.2));
    assert_eq!(planner.forecast(1).map(|f| f.tau_s), Some(0.8));
    // a window from 0.2 to 0.4 (mean 0.3) over which the robot started a sidestep at 0.25
    let mut trail = cruised_until(0.2);
    let mut dodging = cruising();
    dodging.velocity[1] = 0.5;
    trail.push(0.25, dodging);
    trail.push(0.4, dodging);
    let mut same_course = forecast(6.0, 0.3, 0.3, 0.1, 10.0);
    same_course.t_s = 0.3;
    planner.observe(1, &same_course, 0.4, &trail);
    assert_eq!(
        planner.forecast(1).map(|f| f.tau_s),
        Some(0.8),
        "the steady forecast is kept"
    );
    // thrown meanwhile: it arrives in 0.2 s where the remembered forecast said 0.6 s
    let mut thrown = forecast(2.0, 0.3, 0.3, 0.1, 10.0);
    thrown.t_s = 0.3;
    planner.observe(1, &thrown, 0.4, &trail);
    assert_eq!(planner.forecast(1).map(|f| f.tau_s), Some(0.2));
    // an object not seen before is taken too
    planner.observe(2, &same_course, 0.4, &trail);
    assert!(planner.forecast(2).is_some());
    // forgotten once they have passed
    planner.forget_old(
        5.0,
        &Odometry {
            position_m: [5.0, 0.0],
            ..cruising()
        },
    );
    assert!(!planner.has_objects());
}

#[test]
fn a_standing_box_too_wide_to_sidestep_is_stopped_before_and_waited_out() {
    // a box 3 m wide stands 3 m ahead on the path: a sidestep (0.9 m) cannot clear it, a stop
    // can. A stop's rollout used to drive on after the wait into it (an object standing in the
    // world never passes a robot waiting before it), so every candidate collided and the planner
    // took the sidestep that hit least deep; a robot that had stopped took the box for passed
    // when the cruise would have passed it, or forgot it once no new forecast came (a robot
    // standing before it sees no expansion), and drove on into it
    let config = EscapeConfig::default();
    let mut planner = planner_with(&[forecast(3.0, 0.0, 0.0, 1.5, 1.0)]);
    let c = clearances(&planner, &config);
    assert!(c[0].1 < 0.0 && c[1].1 < 0.0, "the sidesteps hit it: {c:?}");
    assert!(c[2].1 > 0.3, "a stop clears it: {c:?}");
    for first in [DodgeSide::Left, DodgeSide::Right] {
        let chosen = planner.choose(&ctx(&config), &preference(first), None).unwrap();
        assert_eq!(chosen, Candidate::ALL[2], "preferring {first:?}");
    }
    // standing 1.5 m before it 5 s later, long after the cruise would have passed it and its
    // last forecast: it is remembered and the robot keeps standing, however long it has waited
    let stopped = Odometry {
        position_m: [1.5, 0.0],
        ..Odometry::default()
    };
    planner.forget_old(5.0, &stopped);
    assert!(
        planner.has_objects(),
        "the box is forgotten while the robot stands before it"
    );
    let later = PlanContext {
        t_s: 5.0,
        odometry: stopped,
        ..ctx(&config)
    };
    assert!(planner.keeps_waiting(&later, 0.0), "the robot drives on into the box");
    // a robot that drove by it (beside it, its rear past the box's far face) forgets it
    let past = Odometry {
        position_m: [8.0, 3.0],
        ..cruising()
    };
    planner.forget_old(8.0, &past);
    assert!(!planner.has_objects());
}
