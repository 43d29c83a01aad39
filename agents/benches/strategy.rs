//! The decision step's cost: one update of the τ + collision-course strategy per camera frame
//! (`cargo bench -p loomlab-agents --bench strategy`; criterion reports frames/s as "elem/s").
//!
//! Input: a ball of radius 0.2 m approaching from 20 m to 4 m every 2 s, drifting in azimuth,
//! sampled at the 120 Hz camera rate: as a detector row sees it (θ̂ and an azimuth), and as the
//! ideal rows see each object (elevation and image extent too).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use loomlab_agents::{Course, DecisionRule, EscapeConfig, ImageExtent, Percept, SelfMotion, TriggerSignal};

fn strategy_update(c: &mut Criterion) {
    let cfg = EscapeConfig {
        decision: DecisionRule {
            trigger: TriggerSignal::Tau,
            course: Course::Image,
            ..DecisionRule::default()
        },
        ..EscapeConfig::default()
    };
    let mut strategy = cfg.decider(&loomlab_agents::RobotFacts::default());
    let mut k = 0u64;
    let mut group = c.benchmark_group("strategy");
    group.throughput(Throughput::Elements(1));
    group.bench_function("tau_course_update", |b| {
        b.iter(|| {
            let t = k as f64 / 120.0;
            k += 1;
            let d = 20.0 - (t % 2.0) * 8.0;
            let p = Percept {
                value: 2.0 * (0.2f64 / d).asin().to_degrees(),
                azimuth_deg: Some(0.1 * t),
                elevation_deg: None,
                extent: None,
            };
            black_box(strategy.decide(t, black_box(p), SelfMotion::default()).value)
        })
    });
    // the ideal rows' percept: elevation and image extent too (every object, every frame)
    let mut strategy = cfg.decider(&loomlab_agents::RobotFacts::default());
    let mut k = 0u64;
    group.bench_function("tau_course_update_with_extent", |b| {
        b.iter(|| {
            let t = k as f64 / 120.0;
            k += 1;
            let d = 20.0 - (t % 2.0) * 8.0;
            let half = (0.2f64 / d).asin().to_degrees();
            let (az, el) = (0.1 * t, 0.05 * t);
            let p = Percept {
                value: 2.0 * half,
                azimuth_deg: Some(az),
                elevation_deg: Some(el),
                extent: Some(ImageExtent {
                    azimuth_deg: [az - half, az + half],
                    elevation_deg: [el - half, el + half],
                }),
            };
            black_box(strategy.decide(t, black_box(p), SelfMotion::default()).value)
        })
    });
    group.finish();
}

/// The manoeuvre planner's cost per decision: the choice among the four candidates with one, three
/// and eight objects remembered (each rolled out to the last object's passage, under the four
/// closing-speed hypotheses), side by side.
fn planner_choice(c: &mut Criterion) {
    use loomlab_agents::decision::CourseForecast;
    use loomlab_agents::planner::{Odometry, OdometryTrail, PlanContext};
    use loomlab_agents::{Candidate, DodgeSide, Planner, RobotFacts, VelocityCommand};
    let config = EscapeConfig::default();
    let cruising = Odometry {
        velocity: [1.0, 0.0, 0.0],
        ..Odometry::default()
    };
    let mut trail = OdometryTrail::default();
    trail.push(0.0, cruising);
    let ball = |i: usize| {
        let x = i as f64 * 0.7 - 2.0;
        CourseForecast {
            t_s: 0.0,
            tau_s: 0.9 + 0.05 * i as f64,
            closing_mps: 10.0,
            lateral_m: [2.0 * x - 0.1, 2.0 * x + 0.1],
            arrival_lateral_m: [x - 0.1, x + 0.1],
            arrival_vertical_m: [-0.1, 0.1],
            straight: Some(true),
            standing: false,
            closing_measured: false,
        }
    };
    let preference = [
        Candidate::dodge(DodgeSide::Left),
        Candidate::dodge(DodgeSide::Right),
        Candidate::ALL[2],
        Candidate::ALL[3],
    ];
    let mut group = c.benchmark_group("planner");
    group.throughput(Throughput::Elements(1));
    for objects in [1usize, 3, 8] {
        let mut planner = Planner::new(RobotFacts::default());
        for i in 0..objects {
            planner.observe(i, &ball(i), 0.0, &trail);
        }
        let ctx = PlanContext {
            t_s: 0.0,
            odometry: cruising,
            cruise: VelocityCommand::forward(1.0),
            dodge: loomlab_agents::DodgeOffset::default(),
            config: &config,
        };
        group.bench_function(format!("choose_{objects}_objects"), |b| {
            b.iter(|| black_box(planner.choose(black_box(&ctx), &preference, None)))
        });
    }
}

criterion_group!(benches, strategy_update, planner_choice);
criterion_main!(benches);
