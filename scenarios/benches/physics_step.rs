//! The simulator's step cost without rendering (physics + ground truth) in the default suite's
//! worlds, with dynamic and with analytic physics: for each scenario its first episode is stepped
//! under its cruise command for the episode's duration (or until the first collision), and the
//! bench reports the time per step. Target: under 100 µs per step with dynamic physics.
//!
//! Run: `cargo bench -p loomlab-scenarios --bench physics_step` (from the repository root).

use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_scenarios::{DEFAULT_SUITE, LoadOptions, load_suite};
use loomlab_sim::{PhysicsMode, Sim};

fn bench_physics(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let suite = load_suite(&root.join(DEFAULT_SUITE), &LoadOptions::default()).expect("the default suite");
    let mut group = c.benchmark_group("physics_step");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    for scenario in &suite.scenarios {
        let ep = scenario.episode(0).expect("episode 0");
        for physics in [PhysicsMode::Dynamic, PhysicsMode::Analytic] {
            let mut world = ep.world.clone();
            world.physics = physics;
            // the steps one pass takes (it ends at the first collision)
            let run = |world: &loomlab_sim::WorldDesc| {
                let mut sim = Sim::new_physics_only(world, ep.seed).unwrap();
                let mut steps = 0u64;
                for _ in 0..ep.frames() {
                    let cmd = ep.cruise.command_at(sim.time());
                    let out = sim.step(&cmd.to_sim()).unwrap();
                    steps += 1;
                    if black_box(&out).first_collision().is_some() {
                        break;
                    }
                }
                steps
            };
            group.throughput(Throughput::Elements(run(&world)));
            let name = format!(
                "{}/{}",
                scenario.name,
                if physics == PhysicsMode::Dynamic {
                    "dynamic"
                } else {
                    "analytic"
                }
            );
            group.bench_function(name, |b| b.iter(|| run(&world)));
        }
    }
    group.finish();
}

criterion_group!(benches, bench_physics);
criterion_main!(benches);
