//! Dynamic physics: bounces, the robot's drive limits, a differential drive that cannot sidestep,
//! a lobbed ball that bounces before it hits, and balls deflected by the robot.

use loomlab_sim::{Command, ProjectileDesc, RobotBase, Sim, Target, WorldDesc};

/// The robot's body centre height with the default body (0.3 m tall) and clearance (0.05 m).
const ROBOT_CENTER_Z: f32 = 0.2;

/// A ball of radius `r` whose bottom is `height` above the ground at `x`, dropped (a launch speed of
/// 1 cm/s towards a point on the ground 1 mm aside).
fn dropped_ball(x: f32, height: f32, r: f32, restitution: f32) -> ProjectileDesc {
    ProjectileDesc {
        name: Some("ball".into()),
        radius_m: r,
        launch_position: Some([x, 0.0, r + height - ROBOT_CENTER_Z]),
        target: Target::Point([x, 0.001, r - ROBOT_CENTER_Z]),
        speed_mps: 0.01,
        gravity: true,
        restitution,
        ..Default::default()
    }
}

/// Centre height of object 0 per step while the robot holds still.
fn heights(sim: &mut Sim, seconds: f64) -> Vec<f64> {
    let mut z = Vec::new();
    while sim.time() < seconds {
        sim.step(&Command::default()).unwrap();
        z.push(sim.object_pose_now(0).unwrap().position.z);
    }
    z
}

#[test]
fn a_dropped_ball_bounces_to_restitution_squared_times_its_height() {
    for (restitution, substeps) in [(0.6f32, 1), (0.8, 1), (0.5, 4)] {
        let r = 0.15;
        let mut w = WorldDesc::empty();
        w.physics_substeps = substeps;
        w.projectiles.push(dropped_ball(6.0, 1.0, r, restitution));
        let mut sim = Sim::new_physics_only(&w, 0).unwrap();
        let z = heights(&mut sim, 2.5);
        // the first bounce: the lowest point, then the highest after it
        let low = (1..z.len()).find(|&i| z[i] > z[i - 1]).expect("it bounces") - 1;
        let apex = z[low..].iter().cloned().fold(f64::MIN, f64::max) - f64::from(r);
        let expected = f64::from(restitution * restitution);
        println!("e = {restitution}, {substeps} substeps: apex {apex:.4} m, expected {expected:.4} m");
        assert!(
            (apex - expected).abs() <= 0.02 * expected,
            "e = {restitution}: bounced to {apex} m, expected {expected} m (±2 %)"
        );
    }
}

#[test]
fn the_robot_reaches_a_commanded_speed_after_v_over_a_and_never_exceeds_its_limits() {
    let mut w = WorldDesc::empty();
    w.robot.max_accel_mps2 = 2.0;
    w.robot.max_decel_mps2 = 4.0;
    w.robot.max_speed_mps = 1.5;
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let dt = sim.dt();
    let first = sim.step(&Command::default()).unwrap(); // starts at rest
    assert_eq!(first.robot.velocity_mps[0], 0.0);
    let mut speeds = vec![0.0];
    for _ in 0..120 {
        speeds.push(sim.step(&Command::forward(1.0)).unwrap().robot.velocity_mps[0]);
    }
    let reached = speeds
        .iter()
        .position(|&v| (v - 1.0).abs() < 1e-4)
        .expect("reaches 1 m/s");
    let expected = (1.0 / 2.0 / dt).round() as usize;
    assert!(
        reached.abs_diff(expected) <= 1,
        "reached after {reached} frames, v/a = {expected} frames"
    );
    for pair in speeds.windows(2) {
        assert!(
            pair[1] - pair[0] <= 2.0 * dt + 1e-5,
            "accelerated faster than 2 m/s²: {pair:?}"
        );
        assert!(pair[1] <= 1.0 + 1e-5);
    }
    // a command over the speed limit is clamped; braking uses the deceleration limit
    let mut last = speeds[speeds.len() - 1];
    for _ in 0..120 {
        let v = sim.step(&Command::forward(5.0)).unwrap().robot.velocity_mps[0];
        assert!(v <= 1.5 + 1e-5 && v - last <= 2.0 * dt + 1e-5);
        last = v;
    }
    assert!((last - 1.5).abs() < 1e-4);
    let mut braking = 0usize;
    while last > 1e-4 {
        let v = sim.step(&Command::default()).unwrap().robot.velocity_mps[0];
        assert!(last - v <= 4.0 * dt + 1e-5, "braked faster than 4 m/s²");
        last = v;
        braking += 1;
    }
    assert!(
        braking.abs_diff((1.5 / 4.0 / dt).round() as usize) <= 1,
        "{braking} frames to stop"
    );
}

#[test]
fn a_diff_drive_robot_commanded_sideways_does_not_move_sideways() {
    let mut w = WorldDesc::empty();
    w.robot.base = RobotBase::DiffDrive;
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let sideways = Command {
        forward_mps: 0.0,
        yaw_rate_rps: 0.0,
        lateral_mps: 1.5,
    };
    for _ in 0..240 {
        let out = sim.step(&sideways).unwrap();
        assert!(
            out.robot.x_m.abs() < 1e-6 && out.robot.y_m.abs() < 1e-6,
            "{:?}",
            out.robot
        );
    }
    // a holonomic base sidesteps
    w.robot.base = RobotBase::Holonomic;
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    for _ in 0..120 {
        sim.step(&sideways).unwrap();
    }
    assert!(sim.robot_state().y_m > 1.0);
    // a diff drive escapes by turning and driving
    w.robot.base = RobotBase::DiffDrive;
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let turn_and_go = Command {
        forward_mps: 1.5,
        yaw_rate_rps: 2.0,
        lateral_mps: 0.0,
    };
    for _ in 0..120 {
        sim.step(&turn_and_go).unwrap();
    }
    assert!(sim.robot_state().y_m > 0.3, "{:?}", sim.robot_state());
}

#[test]
fn a_lobbed_ball_that_bounces_in_front_of_the_robot_then_hits_it_at_the_predicted_time() {
    // frictionless ball and ground: the bounce keeps the horizontal speed and scales the vertical
    // one by the restitution, so the contact time has a closed form
    let (r, e, g) = (0.1f64, 0.7f64, 9.81f64);
    const SPEED: f64 = 10.0;
    let mut w = WorldDesc::empty();
    w.physics_substeps = 4;
    w.ground.friction = 0.0;
    // launched from 6 m ahead, 1.2 m up, aimed to land 0.9 m in front of the robot's centre
    let launch = [6.0f64, 0.0, 1.2];
    let land_x = 0.9f64;
    w.projectiles.push(ProjectileDesc {
        name: Some("lob".into()),
        radius_m: r as f32,
        launch_position: Some([launch[0] as f32, 0.0, (launch[2] - f64::from(ROBOT_CENTER_Z)) as f32]),
        target: Target::Point([land_x as f32, 0.0, (r - f64::from(ROBOT_CENTER_Z)) as f32]),
        speed_mps: SPEED as f32,
        gravity: true,
        restitution: e as f32,
        friction: 0.0,
        launch_time_s: Some(0.1),
        ..Default::default()
    });
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let mut contact = None;
    let mut bounced = false;
    let mut last_z = f64::MAX;
    while sim.time() < 3.0 && contact.is_none() {
        let out = sim.step(&Command::default()).unwrap();
        let z = sim.object_pose_now(0).unwrap().position.z;
        bounced |= z > last_z && sim.time() > 0.2;
        last_z = z;
        contact = out.first_collision().cloned();
    }
    assert!(bounced, "the ball bounces before it reaches the robot");
    let contact = contact.expect("the bounced ball hits the robot");

    // closed form: the low arc through the landing point, the bounce, then the robot's front face
    let (dx, dz) = (land_x - launch[0], r - launch[2]);
    let (s2, dist) = (SPEED * SPEED, dx.abs());
    let tan = (s2 - (s2 * s2 - g * (g * dist * dist + 2.0 * dz * s2)).sqrt()) / (g * dist);
    let cos = 1.0 / (1.0 + tan * tan).sqrt();
    let (vx, vz0) = (-SPEED * cos, SPEED * tan * cos);
    let t_land = dist / (SPEED * cos);
    let vz_bounce = -e * (vz0 - g * t_land);
    let front = 0.25 + r; // the box's front face at x = 0.25, plus the radius
    let t_after = (land_x - front) / -vx;
    let z_hit = r + vz_bounce * t_after - 0.5 * g * t_after * t_after;
    assert!(
        z_hit > 0.05 && z_hit < 0.35,
        "the test geometry hits the front face: z = {z_hit}"
    );
    let expected = 0.1 + t_land + t_after;
    let exact = contact.exact_t_s.expect("exact contact time");
    println!("contact at {exact:.4} s, closed form {expected:.4} s, {contact:?}");
    assert!(
        (exact - expected).abs() < 5e-3,
        "contact at {exact} s, expected {expected} s"
    );
}

#[test]
fn a_ball_that_hits_the_robot_is_deflected_and_pushes_it() {
    let mut w = WorldDesc::empty();
    w.projectiles.push(ProjectileDesc {
        name: Some("ball".into()),
        speed_mps: 8.0,
        launch_distance_m: 6.0,
        ..Default::default()
    });
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let mut hit = false;
    let mut robot_pushed = 0.0f64;
    for _ in 0..240 {
        let out = sim.step(&Command::default()).unwrap();
        hit |= !out.contacts.is_empty();
        let x = sim.object_pose_now(0).unwrap().position.x;
        // the box's front face is at x = 0.25 (moving back as the robot is pushed): the ball's centre
        // stays in front of it
        assert!(
            x > out.robot.x_m + 0.25 + 0.15 - 0.02,
            "the ball passed into the robot: ball x {x}, robot x {}",
            out.robot.x_m
        );
        robot_pushed = robot_pushed.min(out.robot.velocity_mps[0]);
    }
    assert!(hit);
    assert!(
        sim.object_pose_now(0).unwrap().position.x > 1.0,
        "the ball bounced back"
    );
    assert!(robot_pushed < -0.1, "the impact pushed the robot back: {robot_pushed}");
}

#[test]
fn contacts_below_the_harmless_speed_are_marked_harmless() {
    let mut w = WorldDesc::empty();
    w.harmless_impact_speed_mps = 0.5;
    w.scenery.push(loomlab_sim::SceneryDesc::Box(loomlab_sim::BoxDesc {
        position: [1.0, 0.0],
        size: [0.2, 2.0, 1.0],
        ..Default::default()
    }));
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let mut contacts = Vec::new();
    for _ in 0..600 {
        contacts.extend(sim.step(&Command::forward(0.3)).unwrap().contacts);
    }
    let first = contacts.first().expect("the robot creeps into the box");
    assert!(
        first.harmless && (first.impact_speed_mps - 0.3).abs() < 1e-3,
        "{first:?}"
    );
}

#[test]
fn a_fast_ball_passing_within_rapiers_speculative_margin_is_no_contact() {
    // rapier reports a pair from a margin that grows with the speeds (its speculative contacts):
    // at 12 m/s a ball passing the body's front corner within about 2 cm started a "contact" that
    // neither touched nor pushed (no impulse), and the ground truth made the near miss a threat
    let contacts = |miss_m: f32| {
        let mut w = WorldDesc::empty();
        w.projectiles.push(ProjectileDesc {
            name: Some("ball".into()),
            radius_m: 0.2,
            speed_mps: 12.0,
            launch_distance_m: 6.0,
            miss_distance_m: miss_m,
            ..Default::default()
        });
        let mut sim = Sim::new_physics_only(&w, 0).unwrap();
        let mut contacts = Vec::new();
        let mut touching = 0;
        for _ in 0..120 {
            let out = sim.step(&Command::default()).unwrap();
            contacts.extend(out.contacts);
            touching += usize::from(out.truth.iter().any(|o| o.in_contact));
        }
        (contacts, touching)
    };
    // 0.4 m beside the camera the ball strikes the corner (a time of impact, an impulse)
    let (hit, _) = contacts(0.4);
    assert_eq!(hit.len(), 1, "{hit:?}");
    assert!(
        hit[0].exact_t_s.is_some() && hit[0].impulse_ns.is_some_and(|i| i > 0.0),
        "{hit:?}"
    );
    // 0.435 m beside it, rapier's pair starts without a touch or an impulse: no contact, and no
    // frame shows it touching
    let (passing, touching) = contacts(0.435);
    assert!(passing.is_empty(), "{passing:?}");
    assert_eq!(touching, 0);
}
