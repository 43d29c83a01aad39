//! Times rendering: `rtime N [empty|demo] [steps]`.
use loomlab_sim::{Command, Sim, WorldDesc};
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    let n: u32 = a.get(1).map(|s| s.parse().unwrap()).unwrap_or(128);
    let mut desc = if a.get(2).map(|s| s == "empty").unwrap_or(false) {
        WorldDesc::empty()
    } else {
        WorldDesc::default()
    };
    let steps: u32 = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(500);
    desc.camera.n = n;
    if let Ok(g) = std::env::var("GROUND") {
        desc.ground.texture = match g.as_str() {
            "uniform" => loomlab_sim::Texture::uniform(0.4),
            "noise" => loomlab_sim::Texture::Noise {
                cell_m: 0.2,
                dark: 0.2,
                light: 0.6,
                binary: false,
                seed: None,
            },
            "sine" => loomlab_sim::Texture::SineGrating(loomlab_sim::GratingDesc::default()),
            _ => desc.ground.texture,
        };
    }
    let mut sim = Sim::new(&desc, 1)?;
    for _ in 0..20 {
        sim.step(&Command::forward(1.0))?;
    }
    let before = sim.render_timings().unwrap();
    let t0 = std::time::Instant::now();
    for _ in 0..steps {
        sim.step(&Command::forward(1.0))?;
    }
    let dt = t0.elapsed().as_secs_f64();
    let after = sim.render_timings().unwrap();
    let f = (after.frames - before.frames) as f64;
    println!(
        "n={n} {:.0} steps/s; per frame: encode {:.0} us, submit {:.0} us, wait {:.0} us, readback {:.0} us",
        steps as f64 / dt,
        (after.encode_s - before.encode_s) / f * 1e6,
        (after.submit_s - before.submit_s) / f * 1e6,
        (after.wait_s - before.wait_s) / f * 1e6,
        (after.readback_s - before.readback_s) / f * 1e6
    );
    Ok(())
}
