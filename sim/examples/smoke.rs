//! Renders the demo world: writes a 3×2 montage of frames (upscaled ×2) to the given PNG path
//! (default /tmp/loomlab-montage.png) and prints timings.
use loomlab_sim::{Command, Sim, WorldDesc};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "/tmp/loomlab-montage.png".into());
    let scene = std::env::args().nth(2);
    let desc: WorldDesc = match scene {
        Some(p) => {
            #[derive(serde::Deserialize)]
            struct F {
                world: WorldDesc,
            }
            toml::from_str::<F>(&std::fs::read_to_string(p)?)?.world
        }
        None => WorldDesc::default(),
    };
    let n = desc.camera.n;
    let mut sim = Sim::new(&desc, 1)?;
    println!("adapter: {:?}", sim.adapter());
    let steps = 240;
    let mut tiles = Vec::new();
    let t0 = std::time::Instant::now();
    for k in 0..steps {
        let out = sim.step(&Command::forward(1.0))?;
        if k % (steps / 6) == 0 {
            tiles.push(out.frame.clone());
        }
        for c in &out.contacts {
            println!("contact {c:?}");
        }
    }
    let dt = t0.elapsed();
    println!(
        "{steps} steps (render) in {dt:?}: {:.0} steps/s",
        steps as f64 / dt.as_secs_f64()
    );
    println!("{:?}", sim.render_timings());
    let mut phys = Sim::new_physics_only(&desc, 1)?;
    let t0 = std::time::Instant::now();
    for _ in 0..steps {
        phys.step(&Command::forward(1.0))?;
    }
    let dt = t0.elapsed();
    println!(
        "{steps} steps (physics only) in {dt:?}: {:.0} steps/s",
        steps as f64 / dt.as_secs_f64()
    );
    let s = 2;
    let (w, h) = (3 * n * s, 2 * n * s);
    let mut img = image::GrayImage::new(w, h);
    for (i, f) in tiles.iter().enumerate() {
        let (ox, oy) = ((i as u32 % 3) * n * s, (i as u32 / 3) * n * s);
        for y in 0..n * s {
            for x in 0..n * s {
                let v = f[((y / s) * n + x / s) as usize];
                img.put_pixel(ox + x, oy + y, image::Luma([(v.clamp(0.0, 1.0) * 255.0).round() as u8]));
            }
        }
    }
    img.save(&path)?;
    Ok(())
}
