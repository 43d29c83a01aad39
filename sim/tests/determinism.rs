//! Same description and seed ⇒ same trajectory, ground truth and frame hashes (on the same adapter).

use crate::common;

use common::{frame_hash, rendering_sim};
use loomlab_sim::{Command, Renderer, ShakeDesc, Sim, Texture, WorldDesc};

fn world() -> WorldDesc {
    let mut w = WorldDesc::default();
    w.camera.shake = Some(ShakeDesc {
        rotation_deg: 1.0,
        translation_m: 0.01,
        frequency_hz: 6.0,
    });
    w.ground.texture = Texture::Noise {
        cell_m: 0.3,
        dark: 0.2,
        light: 0.6,
        binary: false,
        seed: None,
    };
    w
}

fn commands(k: u32) -> Command {
    Command {
        forward_mps: 1.0 + 0.5 * (k as f32 * 0.05).sin(),
        yaw_rate_rps: 0.3 * (k as f32 * 0.02).cos(),
        lateral_mps: 0.1,
    }
}

fn trace(sim: &mut Sim, steps: u32) -> (Vec<u64>, Vec<String>) {
    let mut hashes = Vec::new();
    let mut states = Vec::new();
    for k in 0..steps {
        let out = sim.step(&commands(k)).unwrap();
        hashes.push(frame_hash(&out.frame));
        states.push(format!("{:?} {:?} {:?}", out.robot, out.truth, out.contacts));
    }
    (hashes, states)
}

#[test]
fn same_seed_same_frames_and_truth() {
    let desc = world();
    let (h1, s1) = trace(&mut rendering_sim(&desc, 42), 150);
    let (h2, s2) = trace(&mut rendering_sim(&desc, 42), 150);
    assert_eq!(s1, s2, "trajectories or ground truth differ");
    assert_eq!(h1, h2, "frame hashes differ");
    // a reused renderer gives the same frames as a fresh one
    let first = rendering_sim(&desc, 42);
    let renderer: Renderer = first.into_renderer().unwrap();
    let (h3, _) = trace(&mut Sim::with_renderer(&desc, 42, renderer).unwrap(), 150);
    assert_eq!(h1, h3, "reused renderer changed the frames");
    // another seed changes shake and noise, hence the frames, but not the trajectory
    let (h4, s4) = trace(&mut rendering_sim(&desc, 43), 150);
    assert_ne!(h1, h4);
    let robot = |s: &[String]| {
        s.iter()
            .map(|x| x.split(" [").next().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(robot(&s1), robot(&s4));
}

#[test]
fn physics_only_matches_rendering_truth_and_reset_restarts() {
    let desc = world();
    let (_, s1) = trace(&mut Sim::new_physics_only(&desc, 5).unwrap(), 100);
    let mut sim = rendering_sim(&desc, 5);
    let (_, s2) = trace(&mut sim, 100);
    assert_eq!(s1, s2);
    sim.reset(&desc, 5).unwrap();
    assert_eq!(sim.time(), 0.0);
    let (_, s3) = trace(&mut sim, 100);
    assert_eq!(s1, s3);
}

#[test]
fn renderer_size_mismatch_is_an_error() {
    let desc = WorldDesc::default();
    let sim = rendering_sim(&desc, 0);
    let r = sim.into_renderer().unwrap();
    let mut other = desc.clone();
    other.camera.n = 64;
    let err = Sim::with_renderer(&other, 0, r).unwrap_err();
    assert!(err.to_string().contains("n = 128"), "{err}");
}

#[test]
fn a_fork_steps_as_its_original() {
    // dynamic physics with a ball that bounces off the ground and hits the robot while it drives
    // and turns: a fork taken mid-flight (contacts and warm-start caches alive) must continue
    // exactly as the original
    let mut desc = world();
    desc.projectiles.push(loomlab_sim::ProjectileDesc {
        name: Some("ball".into()),
        speed_mps: 6.0,
        launch_distance_m: 5.0,
        launch_elevation_deg: 12.0,
        ..Default::default()
    });
    let mut original = Sim::new_physics_only(&desc, 7).unwrap();
    for k in 0..40 {
        original.step(&commands(k)).unwrap();
    }
    let mut fork = original.fork_physics_only();
    let mut contacts = 0;
    for k in 40..240 {
        let (a, b) = (original.step(&commands(k)).unwrap(), fork.step(&commands(k)).unwrap());
        assert_eq!(a, b, "step {k}");
        contacts += a.contacts.len();
    }
    assert!(contacts > 0, "the ball reached the robot");
    // a fork of a fork, and forks taken at every step, too
    let mut again = fork.fork_physics_only();
    for k in 240..260 {
        let mut each = again.fork_physics_only();
        assert_eq!(
            again.step(&commands(k)).unwrap(),
            each.step(&commands(k)).unwrap(),
            "step {k}"
        );
    }
}
