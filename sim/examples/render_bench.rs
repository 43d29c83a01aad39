//! Render-step throughput of the simulator (physics + ground truth + render + readback), for the peer
//! benchmark (`make bench-peer`, `python/bench/peer_pybullet.py`), which compares it with pybullet's
//! TinyRenderer in the same run.
//!
//! `render_bench [--n N] [--batch B] [--seconds S] [--scene plane_sphere|demo]` steps B simulators in
//! lockstep (B = 1: `Sim::step`, one submission per frame; B > 1: `Sim::step_batch`, one submission
//! for the B views) for about S seconds of wall time after a warm-up (device and pipeline creation,
//! the first frames: the start-up is not timed) and prints one JSON line:
//! `{"n": .., "batch": .., "steps": .., "seconds": .., "steps_per_s": .., "adapter": ".."}`.
//! With B > 1 on lavapipe it sets `LP_NUM_THREADS` as `loomlab run` does (unless it is set:
//! `loomlab_sim::render::llvmpipe_threads`).
//!
//! The `plane_sphere` scene is the peer's: a ground plane (checkered), the sky and one sphere thrown
//! at the camera while the robot drives forward; each simulator starts over every 3 s of simulated
//! time (the restart is timed too).

use std::time::Instant;

use loomlab_sim::render::{LLVMPIPE_THREADS_ENV, llvmpipe_threads};
use loomlab_sim::{Command, GpuContext, Renderer, Sim, WorldDesc};

const PLANE_SPHERE: &str = r#"
sky_luminance = 0.8
camera = { n = 64, fov_deg = 60.0 }
ground = { texture = { kind = "checker", size_m = 1.0, dark = 0.35, light = 0.55 } }

[[projectiles]]
name = "ball"
radius_m = 0.2
target = "camera"
launch_distance_m = 15.0
speed_mps = 10.0
arrival_time_s = 2.5
texture = { kind = "uniform", luminance = 0.05 }
"#;

/// Simulated time after which a simulator starts over (s).
const RESTART_S: f64 = 3.0;

fn main() {
    if let Err(e) = run() {
        eprintln!("render_bench: {e}");
        std::process::exit(2);
    }
}

fn value<T: std::str::FromStr>(args: &[String], i: usize, flag: &str) -> Result<T, String> {
    args.get(i + 1)
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| format!("{flag} needs a value (got {:?})", args.get(i + 1)))
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (mut n, mut batch, mut seconds, mut scene) = (64u32, 1usize, 3.0f64, "plane_sphere".to_string());
    let mut i = 1;
    while i < args.len() {
        match args[i].as_str() {
            "--n" => n = value(&args, i, "--n")?,
            "--batch" => batch = value(&args, i, "--batch")?,
            "--seconds" => seconds = value(&args, i, "--seconds")?,
            "--scene" => scene = value(&args, i, "--scene")?,
            other => return Err(format!("unknown argument {other:?} (see the file's docs)").into()),
        }
        i += 2;
    }
    if batch == 0 || seconds.is_nan() || seconds <= 0.0 {
        return Err("--batch must be >= 1 and --seconds > 0".into());
    }
    let mut desc: WorldDesc = match scene.as_str() {
        "plane_sphere" => toml::from_str(PLANE_SPHERE)?,
        "demo" => WorldDesc::default(),
        other => return Err(format!("unknown scene {other:?}: plane_sphere or demo").into()),
    };
    desc.camera.n = n;
    // The rule of `loomlab run` for lavapipe: a batched step keeps two threads busy (this one
    // stepping a group's physics while lavapipe's queue thread renders the previous group), and
    // llvmpipe's per-pass wake-ups of its own threads cost more than they save at these sizes.
    let cpus = std::thread::available_parallelism().map_or(1, |c| c.get());
    let user_set = std::env::var_os(LLVMPIPE_THREADS_ENV).is_some();
    if let Some(value) = llvmpipe_threads(cpus, batch > 1, user_set) {
        // SAFETY: no other thread exists yet, so nothing reads the environment concurrently.
        unsafe { std::env::set_var(LLVMPIPE_THREADS_ENV, value) };
    }
    let ctx = GpuContext::new()?;
    let mut renderer = Renderer::with_context(ctx.clone(), n)?;
    let mut sims = Vec::with_capacity(batch);
    for b in 0..batch {
        sims.push(if batch == 1 {
            Sim::with_context(&desc, b as u64, ctx.clone())?
        } else {
            Sim::new_physics_only(&desc, b as u64)?
        });
    }
    let cmd = Command::forward(1.0);
    let commands = vec![cmd; batch];
    let mut step = |sims: &mut Vec<Sim>| -> Result<(), Box<dyn std::error::Error>> {
        for (b, sim) in sims.iter_mut().enumerate() {
            if sim.time() > RESTART_S {
                sim.reset(&desc, b as u64)?;
            }
        }
        if batch == 1 {
            std::hint::black_box(sims[0].step(&cmd)?);
        } else {
            let mut refs: Vec<&mut Sim> = sims.iter_mut().collect();
            std::hint::black_box(Sim::step_batch(&mut refs, &commands, &mut renderer)?);
        }
        Ok(())
    };
    // warm-up: pipelines, buffers, the first frames
    let warm = Instant::now();
    while warm.elapsed().as_secs_f64() < 0.3_f64.min(seconds) {
        step(&mut sims)?;
    }
    let t0 = Instant::now();
    let mut iters = 0u64;
    while t0.elapsed().as_secs_f64() < seconds {
        step(&mut sims)?;
        iters += 1;
    }
    let dt = t0.elapsed().as_secs_f64();
    let steps = iters * batch as u64;
    println!(
        "{{\"n\": {n}, \"batch\": {batch}, \"scene\": \"{scene}\", \"steps\": {steps}, \"seconds\": {dt:.4}, \
         \"steps_per_s\": {:.1}, \"adapter\": \"{}\"}}",
        steps as f64 / dt,
        ctx.describe().replace('"', "'")
    );
    Ok(())
}
