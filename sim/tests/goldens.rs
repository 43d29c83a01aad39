//! Image goldens: a few scenes rendered at n = 128 and compared with committed PNGs under
//! `sim/tests/goldens/` with a tolerance (wgpu-examples style; never byte equality, so that other
//! adapters and drivers pass too). Regenerate with `LOOMLAB_BLESS=1 cargo test -p loomlab-sim --test sim goldens`.

use crate::common;

use std::path::PathBuf;

use loomlab_sim::io::{compare_frames, read_png, write_png};
use loomlab_sim::{Command, WorldDesc};

/// Per-pixel difference that counts as "different" (8-bit goldens quantise to 1/255).
const PIXEL_THRESHOLD: f32 = 0.1;
/// Largest fraction of different pixels (edges may rasterise differently on other adapters).
const MAX_FRACTION_OVER: f32 = 0.02;
/// Largest mean absolute difference.
const MAX_MEAN_ABS: f32 = 0.01;

pub(crate) const TEXTURES: &str = r#"
[world]
sky_luminance = 0.9
ground = { texture = { kind = "checker", size_m = 0.5, dark = 0.25, light = 0.45 } }
camera = { n = 128, fov_deg = 70.0 }

[[world.scenery]]
kind = "wall"
start = [4.0, 3.0]
end = [4.0, -3.0]
height_m = 2.5
texture = { kind = "square_grating", period_m = 0.4, orientation_deg = 90.0, drift_hz = 1.0, dark = 0.1, light = 0.9 }

[[world.scenery]]
kind = "box"
position = [3.0, 1.4]
size = [0.6, 0.6, 0.6]
base_z_m = 0.8
yaw_deg = 30.0
texture = { kind = "noise", cell_m = 0.05, binary = true, seed = 3 }

[[world.scenery]]
kind = "box"
position = [3.0, -1.4]
size = [0.6, 0.6, 0.6]
texture = { kind = "sine_grating", period_m = 0.2, orientation_deg = 45.0 }

[[world.scenery]]
kind = "pole"
position = [2.5, 0.0]
radius_m = 0.12
height_m = 1.5
texture = { kind = "square_grating", period_m = 0.2, dark = 0.0, light = 1.0 }

[[world.projectiles]]
radius_m = 0.3
target = [3.0, 0.6, 0.6]
launch_distance_m = 0.01
launch_time_s = 1000.0
stop_at_ground = false
texture = { kind = "square_grating", cycles = 2.0, dark = 0.0, light = 1.0 }

[[world.projectiles]]
radius_m = 0.25
target = [2.5, -0.7, 1.2]
launch_distance_m = 0.01
launch_time_s = 1000.0
stop_at_ground = false
texture = { kind = "noise", cell_m = 0.04, dark = 0.0, light = 1.0, seed = 9 }
"#;

pub(crate) const STREET: &str = r#"
[world]
sky_luminance = 0.75
camera = { n = 128, fov_deg = 60.0, pitch_deg = 2.0 }
robot = { body = { kind = "cylinder", radius_m = 0.25, height_m = 0.4 } }

[[world.scenery]]
kind = "overpass"
position = [18.0, 0.0]
texture = { kind = "checker", size_m = 0.5, dark = 0.35, light = 0.65 }
pillar_texture = { kind = "uniform", luminance = 0.3 }

[[world.scenery]]
kind = "wall"
start = [0.0, -4.0]
end = [30.0, -4.0]
texture = { kind = "noise", cell_m = 0.25, dark = 0.2, light = 0.7, seed = 1 }

[[world.vehicles]]
name = "truck"
start = [12.0, 9.0]
heading_deg = -90.0
speed_mps = 6.0
curvature_per_m = 0.02
parts = [
  { shape = { kind = "box", size = [2.0, 2.2, 2.4] }, offset = [2.2, 0.0, 1.4], texture = { kind = "uniform", luminance = 0.1 } },
  { shape = { kind = "box", size = [4.5, 2.4, 2.8] }, offset = [-1.2, 0.0, 1.6], texture = { kind = "square_grating", period_m = 0.6, dark = 0.5, light = 0.95 } },
  { shape = { kind = "cylinder", radius_m = 0.5, height_m = 0.4 }, offset = [1.8, 1.25, 0.5], texture = { kind = "uniform", luminance = 0.0 } },
]
"#;

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests").join("goldens")
}

fn check_golden(name: &str, desc: &WorldDesc, steps: u32, command: Command) {
    let mut sim = common::rendering_sim(desc, 7);
    let mut frame = Vec::new();
    for _ in 0..steps {
        frame = sim.step(&command).expect("step").frame;
    }
    let n = sim.n();
    let path = golden_dir().join(format!("{name}.png"));
    if std::env::var("LOOMLAB_BLESS").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(golden_dir()).unwrap();
        write_png(&path, &frame, n).unwrap();
        eprintln!("blessed {}", path.display());
        return;
    }
    let actual_path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("golden-{name}-actual.png"));
    write_png(&actual_path, &frame, n).unwrap();
    let (golden, gn) = read_png(&path).unwrap_or_else(|e| {
        panic!(
            "missing golden {}: {e}; create it with LOOMLAB_BLESS=1 cargo test -p loomlab-sim --test sim goldens",
            path.display()
        )
    });
    assert_eq!(gn, n, "golden {name} has a different size");
    let diff = compare_frames(&frame, &golden, PIXEL_THRESHOLD).unwrap();
    println!(
        "{name}: {diff:?} (adapter {:?}; actual frame in {})",
        sim.adapter(),
        actual_path.display()
    );
    assert!(
        diff.fraction_over <= MAX_FRACTION_OVER && diff.mean_abs <= MAX_MEAN_ABS,
        "{name} differs from its golden: {diff:?}; actual frame written to {}. If the change is intended, \
         re-bless with LOOMLAB_BLESS=1",
        actual_path.display()
    );
}

pub(crate) fn parse(src: &str) -> WorldDesc {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct File {
        world: WorldDesc,
    }
    toml::from_str::<File>(src).expect("golden scene parses").world
}

#[test]
fn golden_demo_scene() {
    check_golden("demo", &WorldDesc::default(), 90, Command::forward(1.0));
}

#[test]
fn golden_textures() {
    check_golden("textures", &parse(TEXTURES), 6, Command::default());
}

#[test]
fn golden_street_with_overpass_and_truck() {
    let cmd = Command {
        forward_mps: 2.0,
        yaw_rate_rps: 0.1,
        lateral_mps: 0.0,
    };
    check_golden("street", &parse(STREET), 120, cmd);
}
