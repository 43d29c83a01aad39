//! Vector-environment throughput, batched against unbatched rendering, side by side in one run:
//! `cargo run --release -p loomlab-env --example vector_bench -- [--num-envs 16] [--n 64] [--seconds 5] [--rounds 2] [--only batched|unbatched]`.
//!
//! Steps `EscapeVectorEnv` on the Gymnasium environment's default scenario (all five of its
//! detectors, `python/python/loomlab/scenarios/escape_default.toml`) with a constant continuous
//! action, once with each camera period's views rendered in one batch (the default) and once with
//! every environment rendering its own (`set_batched(false)`, the path before batching; `--only` runs one of them); the two
//! alternate for `--rounds` rounds and the best steps/s of each (environment steps, N per call,
//! auto-resets included) is printed with the ratio. A benchmark, not a test.

use std::time::Instant;

use loomlab_env::{Action, EnvOptions, EnvScenario, EscapeVectorEnv};

fn value<T: std::str::FromStr>(args: &[String], i: usize, flag: &str) -> Result<T, String> {
    args.get(i + 1)
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| format!("{flag} needs a value"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (mut num_envs, mut n, mut seconds, mut rounds) = (16usize, 64u32, 5.0f64, 2usize);
    let mut modes = vec![false, true];
    let mut i = 1;
    while i < args.len() {
        match args[i].as_str() {
            "--num-envs" => num_envs = value(&args, i, "--num-envs")?,
            "--n" => n = value(&args, i, "--n")?,
            "--seconds" => seconds = value(&args, i, "--seconds")?,
            "--rounds" => rounds = value(&args, i, "--rounds")?,
            "--only" => {
                modes = match args.get(i + 1).map(String::as_str) {
                    Some("batched") => vec![true],
                    Some("unbatched") => vec![false],
                    _ => return Err("--only needs `batched` or `unbatched`".into()),
                }
            }
            other => return Err(format!("unknown argument {other:?} (see the file's docs)").into()),
        }
        i += 2;
    }
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/python/loomlab/scenarios/escape_default.toml");
    let scenario = EnvScenario::from_file(&path)?;
    let options = EnvOptions {
        frame_size: Some(n),
        ..Default::default()
    };
    let mut best = [0.0f64; 2];
    for _ in 0..rounds {
        for &batched in &modes {
            let k = usize::from(batched);
            let mut env = EscapeVectorEnv::new(scenario.clone(), options.clone(), num_envs)?;
            env.set_batched(batched);
            env.reset(Some(0))?;
            let actions = vec![Action::Continuous([0.3, 0.0, 0.0]); num_envs];
            for _ in 0..5 {
                env.step(&actions)?;
            }
            let t0 = Instant::now();
            let mut calls = 0u64;
            while t0.elapsed().as_secs_f64() < seconds {
                env.step(&actions)?;
                calls += 1;
            }
            let sps = (calls * num_envs as u64) as f64 / t0.elapsed().as_secs_f64();
            best[k] = best[k].max(sps);
            println!(
                "{} N={num_envs} n={n}: {sps:.0} steps/s",
                if batched { "batched  " } else { "unbatched" }
            );
        }
    }
    if modes.len() == 2 {
        println!(
            "best: unbatched {:.0} steps/s, batched {:.0} steps/s, ratio {:.2}x",
            best[0],
            best[1],
            best[1] / best[0]
        );
    } else {
        println!("best: {:.0} steps/s", best[usize::from(modes[0])]);
    }
    Ok(())
}
