//! Contacts reported by rapier agree with the exact time-of-impact prediction, with analytic and with
//! dynamic physics. rapier reports a contact in the narrow phase that opens a step, so with dynamic
//! physics a contact may be reported one step after the touch; its exact time is found either way.

use crate::common;

use loomlab_sim::{
    Command, NamedTarget, ObjectKind, PartDesc, PhysicsMode, ProjectileDesc, SceneryDesc, ShapeDesc, Sim, Target,
    VehicleDesc, WallDesc, WorldDesc,
};

const MODES: [PhysicsMode; 2] = [PhysicsMode::Analytic, PhysicsMode::Dynamic];

/// How far after the predicted contact time a contact may be reported (s).
fn slack(sim: &Sim) -> f64 {
    match sim.physics() {
        PhysicsMode::Analytic => sim.dt() + 1e-9,
        PhysicsMode::Dynamic => 2.0 * sim.dt() + 1e-9,
    }
}

fn empty(physics: PhysicsMode) -> WorldDesc {
    WorldDesc {
        physics,
        ..WorldDesc::empty()
    }
}

fn projectile_world(miss_m: f32, gravity: bool, physics: PhysicsMode) -> WorldDesc {
    let mut w = empty(physics);
    w.projectiles.push(ProjectileDesc {
        name: Some("ball".into()),
        target: Target::Named(NamedTarget::Robot),
        miss_distance_m: miss_m,
        launch_distance_m: 12.0,
        launch_elevation_deg: if gravity { 10.0 } else { 0.0 },
        speed_mps: if gravity { 15.0 } else { 9.0 },
        launch_time_s: Some(0.25),
        gravity,
        ..Default::default()
    });
    w
}

/// Runs until `t_end`; returns the prediction made at t = 0 and the contacts.
fn run(sim: &mut Sim, cmd: Command, t_end: f64) -> (Option<f32>, Vec<loomlab_sim::Contact>) {
    let predicted = sim.observe().unwrap().truth[0].ttc_s;
    let mut contacts = Vec::new();
    while sim.time() < t_end {
        contacts.extend(sim.step(&cmd).unwrap().contacts);
    }
    (predicted, contacts)
}

#[test]
fn head_on_projectile_hits_at_the_predicted_time() {
    for (gravity, physics) in [false, true].into_iter().flat_map(|g| MODES.map(|m| (g, m))) {
        let desc = projectile_world(0.0, gravity, physics);
        let mut sim = Sim::new_physics_only(&desc, 1).unwrap();
        let (predicted, contacts) = run(&mut sim, Command::default(), 3.0);
        let predicted = f64::from(predicted.expect("on a collision course"));
        assert_eq!(contacts.len(), 1, "gravity={gravity}: {contacts:?}");
        let c = &contacts[0];
        assert_eq!((c.name.as_str(), c.kind), ("ball", ObjectKind::Projectile));
        println!(
            "gravity={gravity} {physics:?}: predicted {predicted:.5} s, rapier {:.5} s, exact {:?}, {:.2} m/s, {:?} N s",
            c.t_s, c.exact_t_s, c.impact_speed_mps, c.impulse_ns
        );
        assert!(
            c.t_s >= predicted && c.t_s - predicted <= slack(&sim),
            "gravity={gravity} {physics:?}: contact at {} vs predicted {predicted}",
            c.t_s
        );
        let exact = c.exact_t_s.expect("exact time inside the step");
        // dynamic: rapier's integration of gravity drifts from the parabola by O(g·h·t)
        let tol = if gravity && physics == PhysicsMode::Dynamic {
            5e-3
        } else {
            1e-3
        };
        assert!(
            (exact - predicted).abs() < tol,
            "{physics:?}: exact {exact} vs predicted {predicted}"
        );
        assert!(!c.harmless && c.impact_speed_mps > 8.0, "{c:?}");
        assert_eq!(c.impulse_ns.is_some(), physics == PhysicsMode::Dynamic, "{c:?}");
        // analytic check without gravity: the ball (r 0.15) meets the front face (x = 0.25) of the box
        if !gravity {
            let analytic = 0.25 + (12.0 - 0.25 - 0.15) / 9.0;
            assert!((predicted - analytic).abs() < 1e-3, "{predicted} vs {analytic}");
        }
    }
}

#[test]
fn projectile_aimed_one_metre_wide_makes_no_contact() {
    for (gravity, physics) in [false, true].into_iter().flat_map(|g| MODES.map(|m| (g, m))) {
        let desc = projectile_world(1.0, gravity, physics);
        let mut sim = Sim::new_physics_only(&desc, 1).unwrap();
        let (predicted, contacts) = run(&mut sim, Command::default(), 3.0);
        assert!(predicted.is_none(), "gravity={gravity}: predicted {predicted:?}");
        assert!(contacts.is_empty(), "gravity={gravity}: {contacts:?}");
    }
}

#[test]
fn moving_robot_meets_projectile_earlier_and_prediction_tracks_it() {
    for physics in MODES {
        let desc = projectile_world(0.0, false, physics);
        let mut sim = Sim::new_physics_only(&desc, 1).unwrap();
        let cmd = Command::forward(2.0);
        let out = sim.step(&cmd).unwrap();
        let predicted = out.t_s + f64::from(out.truth[0].ttc_s.unwrap());
        let (_, contacts) = run(&mut sim, cmd, 3.0);
        assert_eq!(contacts.len(), 1, "{physics:?}");
        assert!((contacts[0].t_s - predicted).abs() <= slack(&sim), "{physics:?}");
        let analytic = (12.0 - 0.4 + 9.0 * 0.25) / (9.0 + 2.0);
        assert!((predicted - analytic).abs() < 1e-3, "{predicted} vs {analytic}");
        let exact = contacts[0].exact_t_s.expect("exact");
        assert!((exact - analytic).abs() < 1e-3, "{physics:?}: {exact} vs {analytic}");
    }
}

#[test]
fn turning_vehicle_and_wall_contacts_are_predicted() {
    for physics in MODES {
        turning_vehicle_and_wall(physics);
    }
}

fn turning_vehicle_and_wall(physics: PhysicsMode) {
    let mut w = empty(physics);
    // a car on a left-turning circle that crosses the robot's position
    w.vehicles.push(VehicleDesc {
        name: Some("car".into()),
        start: [6.0, -6.0],
        heading_deg: Some(90.0),
        curvature_per_m: 1.0 / 6.0,
        speed_mps: 4.0,
        parts: vec![PartDesc {
            shape: ShapeDesc::Box { size: [2.0, 1.0, 1.0] },
            ..Default::default()
        }],
        ..Default::default()
    });
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let (predicted, contacts) = run(&mut sim, Command::default(), 6.0);
    let predicted = f64::from(predicted.expect("the circle passes through the robot"));
    assert_eq!(contacts.len(), 1, "{contacts:?}");
    assert!(
        (contacts[0].t_s - predicted).abs() <= slack(&sim),
        "{physics:?}: {} vs {predicted}",
        contacts[0].t_s
    );

    // the robot drives into a wall 3 m ahead: contact with the scenery item
    let mut w = empty(physics);
    w.scenery.push(SceneryDesc::Wall(WallDesc {
        start: [3.0, -2.0],
        end: [3.0, 2.0],
        ..Default::default()
    }));
    let mut sim = Sim::new_physics_only(&w, 0).unwrap();
    let cmd = Command::forward(1.5);
    let first = sim.step(&cmd).unwrap();
    let predicted = first.t_s + f64::from(first.truth[0].ttc_s.expect("wall ahead"));
    let analytic = (3.0 - 0.1 - 0.25) / 1.5;
    assert!((predicted - analytic).abs() < 1e-3, "{predicted} vs {analytic}");
    let (_, contacts) = run(&mut sim, cmd, 3.0);
    assert_eq!(contacts.len(), 1);
    assert_eq!(contacts[0].kind, ObjectKind::Scenery);
    assert!((contacts[0].t_s - predicted).abs() <= slack(&sim), "{physics:?}");
    let exact = contacts[0].exact_t_s.expect("exact");
    assert!((exact - analytic).abs() < 1e-3, "{physics:?}: {exact} vs {analytic}");
    assert!((contacts[0].impact_speed_mps - 1.5).abs() < 1e-3, "{:?}", contacts[0]);
}

#[test]
fn rendering_does_not_change_contacts() {
    let desc = projectile_world(0.0, true, PhysicsMode::Dynamic);
    let mut a = Sim::new_physics_only(&desc, 3).unwrap();
    let mut b = common::rendering_sim(&desc, 3);
    for _ in 0..200 {
        let x = a.step(&Command::forward(0.5)).unwrap();
        let y = b.step(&Command::forward(0.5)).unwrap();
        assert_eq!(x.truth, y.truth);
        assert_eq!(x.contacts, y.contacts);
        assert!(x.frame.is_empty() && y.frame.len() == 128 * 128);
    }
}

#[test]
fn nearly_straight_turn_predicts_like_a_straight_line() {
    let desc = projectile_world(0.0, false, PhysicsMode::Analytic);
    let sim = Sim::new_physics_only(&desc, 1).unwrap();
    let straight = sim.truth(&Command::forward(2.0))[0].ttc_s.unwrap();
    let tiny = Command {
        forward_mps: 2.0,
        yaw_rate_rps: 1e-7,
        lateral_mps: 0.0,
    };
    let curved = sim.truth(&tiny)[0].ttc_s.unwrap();
    assert!((straight - curved).abs() < 1e-3, "{straight} vs {curved}");
}
