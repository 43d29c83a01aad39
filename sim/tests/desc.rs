//! World descriptions: TOML round trip, unknown keys rejected, errors name the key, thread safety.

use loomlab_sim::{Sim, WorldDesc};

#[derive(serde::Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
struct File {
    world: WorldDesc,
}

#[test]
fn default_world_round_trips_through_toml() {
    let text = toml::to_string(&File {
        world: WorldDesc::default(),
    })
    .unwrap();
    let back: File = toml::from_str(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(back.world, WorldDesc::default());
    back.world.validate().unwrap();
}

#[test]
fn absent_lists_are_empty_and_defaults_apply() {
    let f: File = toml::from_str("[world]\nsky_luminance = 0.3\n").unwrap();
    assert!(f.world.projectiles.is_empty() && f.world.vehicles.is_empty() && f.world.scenery.is_empty());
    assert_eq!(f.world.camera.n, 128);
    assert_eq!(f.world.camera_hz, 120.0);
}

#[test]
fn unknown_keys_are_errors_at_every_level() {
    for bad in [
        "[world]\ncolour = 1\n",
        "[world.camera]\nfov = 60\n",
        "[world.robot]\nbody = { kind = \"box\", size = [1, 1, 1], mass = 3 }\n",
        "[[world.projectiles]]\nradius = 0.2\n",
        "[[world.vehicles]]\nspeed = 3\n",
        "[[world.scenery]]\nkind = \"wall\"\nlength = 3\n",
        "[[world.scenery]]\nkind = \"tree\"\n",
        "[world.ground]\ntexture = { kind = \"checker\", size = 1 }\n",
    ] {
        assert!(toml::from_str::<File>(bad).is_err(), "accepted: {bad}");
    }
}

#[test]
fn validation_errors_name_the_key() {
    let cases = [
        ("[world]\ncamera_hz = -1\n", "world.camera_hz"),
        ("[world.camera]\nfov_deg = 200\n", "world.camera.fov_deg"),
        (
            "[[world.projectiles]]\nspeed_mps = 0\n",
            "world.projectiles[0].speed_mps",
        ),
        (
            "[[world.projectiles]]\ngravity = true\nspeed_mps = 3\n",
            "world.projectiles[0].speed_mps",
        ),
        (
            "[[world.vehicles]]\nstart = [1, 2]\ntoward = [1, 2]\n",
            "world.vehicles[0].toward",
        ),
        ("[[world.vehicles]]\nbrake_mps2 = 3\n", "world.vehicles[0].brake_mps2"),
        (
            "[[world.vehicles]]\nspeed_mps = 10\ntravel_m = 5\nbrake_mps2 = 3\n",
            "world.vehicles[0].brake_mps2",
        ),
        (
            "[[world.vehicles]]\ntravel_m = 50\nbrake_mps2 = -1\n",
            "world.vehicles[0].brake_mps2",
        ),
        (
            "[[world.vehicles]]\ntravel_m = 50\nbrake_mps2 = 3\ncurvature_per_m = 0.1\n",
            "world.vehicles[0].brake_mps2",
        ),
        (
            "[[world.scenery]]\nkind = \"pole\"\nradius_m = -1\n",
            "world.scenery[0].shape.radius_m",
        ),
        (
            "[[world.scenery]]\nkind = \"wall\"\ntexture = { kind = \"uniform\", luminance = 2 }\n",
            "world.scenery[0].texture.luminance",
        ),
    ];
    for (src, key) in cases {
        let f: File = toml::from_str(src).unwrap_or_else(|e| panic!("{src}: {e}"));
        let err = f.world.validate().unwrap_err().to_string();
        assert!(err.contains(key), "{src}: {err}");
        assert!(Sim::new_physics_only(&f.world, 0).is_err());
    }
}

#[test]
fn sim_can_move_between_threads() {
    fn assert_send<T: Send>() {}
    assert_send::<Sim>();
    assert_send::<loomlab_sim::Renderer>();
}

#[test]
fn readme_example_parses_and_validates() {
    let readme = include_str!("../README.md");
    let start = readme.find("```toml\n").expect("a toml block in the README") + "```toml\n".len();
    let end = start + readme[start..].find("```").unwrap();
    let f: File = toml::from_str(&readme[start..end]).unwrap_or_else(|e| panic!("README example: {e}"));
    f.world.validate().unwrap();
    assert_eq!(f.world.projectiles.len(), 1);
    assert_eq!(f.world.vehicles.len(), 1);
}
