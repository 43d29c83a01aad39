//! The event camera (`[world.camera] kind = "events"`, `loomlab_sim::events`): threshold crossings
//! of a uniform brightening, the noise rates of a still scene, events only at an approaching
//! disk's edge (the converter on analytic images), a ball at 20 m/s leaving a trail without gaps
//! where frame differencing leaves gaps, and the same seed giving the same events (the simulator's
//! renders).

use loomlab_sim::{Command, EventCamera, EventCameraDesc, EventPacket, Sim, WorldDesc};

use crate::common;

const HZ: f64 = 120.0;

/// An event camera without mismatch, refractory period or noise.
fn noiseless(contrast: f64) -> EventCameraDesc {
    EventCameraDesc {
        contrast_on: contrast,
        contrast_off: contrast,
        mismatch_sigma: 0.0,
        refractory_s: 0.0,
        leak_rate_hz: 0.0,
        shot_rate_hz: 0.0,
        log_offset: 1e-9,
        ..EventCameraDesc::default()
    }
}

/// Runs `camera` over `periods` camera periods of the analytic image sequence `image(t_s)` (the
/// first frame at t = 0 starts it); returns every period's packet.
fn convert(camera: &mut EventCamera, periods: usize, image: impl Fn(f64) -> Vec<f32>) -> Vec<EventPacket> {
    let dt = 1.0 / HZ;
    let mut out = EventPacket::default();
    camera
        .period(&image(0.0), 0.0, 0, &mut |_, _| Ok::<(), ()>(()), &mut out)
        .unwrap();
    (1..=periods)
        .map(|k| {
            let (t0, t1) = ((k - 1) as f64 * dt, k as f64 * dt);
            let mut render = |alpha: f64, buf: &mut Vec<f32>| {
                *buf = image(t0 + alpha * (t1 - t0));
                Ok::<(), ()>(())
            };
            camera.period(&image(t1), t1, k as u64, &mut render, &mut out).unwrap();
            out.clone()
        })
        .collect()
}

/// A uniform brightening by a factor k gives ⌊ln k / C⌋ ON events per pixel (±1) and no OFF event,
/// whether the brightening takes one period or many, and a darkening by k as many OFF events.
#[test]
fn a_uniform_brightening_by_k_gives_floor_ln_k_over_c_events() {
    let c = 0.2;
    for (k, periods) in [(2.0f64, 1usize), (5.0, 1), (10.5, 6), (0.25, 3)] {
        let mut camera = EventCamera::new(&noiseless(c), 20, 1).unwrap();
        let l0 = 0.08f32;
        let t_end = periods as f64 / HZ;
        let packets = convert(&mut camera, periods, |t| vec![l0 * (k.powf(t / t_end)) as f32; 400]);
        let expected = (k.ln().abs() / c).floor() as i64;
        for p in 0..400 {
            let on: i64 = packets.iter().map(|q| i64::from(q.on_counts[p])).sum();
            let off: i64 = packets.iter().map(|q| i64::from(q.off_counts[p])).sum();
            let (got, other) = if k > 1.0 { (on, off) } else { (off, on) };
            assert!(
                (got - expected).abs() <= 1 && other == 0,
                "k {k}: pixel {p} has {on} ON and {off} OFF events, expected ⌊ln k / C⌋ = {expected}"
            );
        }
        // events are time-stamped within their period, in time order
        for q in &packets {
            assert!(q.events.windows(2).all(|w| w[0].t_s <= w[1].t_s));
            assert!(q.events.iter().all(|e| e.t_s > q.t_start_s && e.t_s <= q.t_end_s));
        }
    }
}

/// A still scene gives only noise events, at the configured rates: over 32² pixels × 100 periods
/// (102 400 pixel-periods) the count is within 10 % of `(leak + shot) · period` per pixel-period,
/// and the ON share within 0.05 of `(leak + shot / 2) / (leak + shot)`.
#[test]
fn a_still_scene_gives_noise_events_at_the_configured_rate() {
    let (leak, shot) = (2.0, 4.0);
    let desc = EventCameraDesc {
        leak_rate_hz: leak,
        shot_rate_hz: shot,
        ..EventCameraDesc::default()
    };
    let mut camera = EventCamera::new(&desc, 32, 5).unwrap();
    let packets = convert(&mut camera, 100, |_| vec![0.5; 32 * 32]);
    let events: usize = packets.iter().map(|q| q.events.len()).sum();
    let on: usize = packets
        .iter()
        .flat_map(|q| &q.events)
        .filter(|e| e.polarity > 0)
        .count();
    let expected = 102_400.0 * (leak + shot) / HZ;
    assert!(
        (events as f64 / expected - 1.0).abs() < 0.10,
        "{events} noise events, expected {expected}"
    );
    let share = on as f64 / events as f64;
    assert!(
        (share - (leak + shot / 2.0) / (leak + shot)).abs() < 0.05,
        "ON share {share}"
    );
    // a still scene renders once per period (no sub-frames)
    assert!(packets.iter().all(|q| q.renders == 1));
    // and without noise gives nothing
    let mut quiet = EventCamera::new(&noiseless(0.2), 32, 5).unwrap();
    assert!(
        convert(&mut quiet, 10, |_| vec![0.5; 32 * 32])
            .iter()
            .all(|q| q.events.is_empty())
    );
}

/// A dark disk approaching (its radius growing as 1 / time to contact) on a bright background:
/// every event lies within a pixel of the disk's edge at the event's time, and every pixel the
/// edge swept over has an event (no gaps).
#[test]
fn an_approaching_disk_gives_events_only_at_its_edge() {
    let n = 64usize;
    let radius = |t: f64| 3.0 / (1.0 - t / 0.25); // px; 3 px at t = 0, 12 px at t = 0.1875 s
    let image = |t: f64| {
        let r = radius(t);
        (0..n * n)
            .map(|p| {
                let (x, y) = ((p % n) as f64 + 0.5 - 32.0, (p / n) as f64 + 0.5 - 32.0);
                if x.hypot(y) < r { 0.1 } else { 0.8 }
            })
            .collect()
    };
    let desc = EventCameraDesc {
        max_renders: 16,
        ..noiseless(0.2)
    };
    let mut camera = EventCamera::new(&desc, n as u32, 2).unwrap();
    let periods = 22;
    let packets = convert(&mut camera, periods, image);
    let mut hit = vec![false; n * n];
    for e in packets.iter().flat_map(|q| &q.events) {
        let d = (f64::from(e.x) + 0.5 - 32.0).hypot(f64::from(e.y) + 0.5 - 32.0);
        let r = radius(e.t_s);
        assert!(
            (d - r).abs() <= 1.0,
            "an event at {d:.2} px from the centre, the edge at {r:.2} px"
        );
        assert_eq!(e.polarity, -1, "a dark disk growing darkens pixels only");
        hit[e.y as usize * n + e.x as usize] = true;
    }
    let (r0, r1) = (radius(0.0), radius(periods as f64 / HZ));
    for (p, &got) in hit.iter().enumerate() {
        let d = ((p % n) as f64 + 0.5 - 32.0).hypot((p / n) as f64 + 0.5 - 32.0);
        if d >= r0 && d < r1 {
            assert!(got, "pixel {p} at {d:.2} px was swept by the edge but has no event");
        }
    }
    assert!(
        packets.iter().any(|q| q.renders > 1),
        "the moving edge asks for sub-frames"
    );
}

/// A world whose view is a ball (radius 3.5 cm, luminance 0.1) crossing 2 m ahead from left to
/// right at 20 m/s in front of the sky, at the camera's height `z_m`; an event camera.
fn crossing_ball(z_m: f32, events: EventCameraDesc) -> WorldDesc {
    let toml = format!(
        r#"
physics = "analytic"
camera_hz = 120.0
physics_substeps = 2
sky_luminance = 0.8
[ground]
enabled = false
[camera]
n = 64
kind = "events"
[[vehicles]]
name = "ball"
start = [2.25, 0.6]
heading_deg = -90.0
speed_mps = 20.0
parts = [ {{ shape = {{ kind = "sphere", radius_m = 0.035 }}, offset = [0.0, 0.0, {z_m}], texture = {{ kind = "uniform", luminance = 0.1 }} }} ]
"#
    );
    let mut desc: WorldDesc = toml::from_str(&toml).expect("world");
    desc.camera.events = events;
    desc
}

/// The ball's world at the camera's height.
fn ball_world(events: EventCameraDesc) -> WorldDesc {
    let probe = Sim::new_physics_only(&crossing_ball(0.3, events), 1).expect("world");
    crossing_ball(probe.camera_pose().position.z as f32, events)
}

/// Steps the ball's world `steps` periods: the frames and the event packets.
fn run_ball(desc: &WorldDesc, seed: u64, steps: usize) -> (Vec<Vec<f32>>, Vec<EventPacket>) {
    let mut sim = common::rendering_sim(desc, seed);
    let mut frames = vec![sim.observe().expect("observe").frame];
    let mut packets = vec![sim.events().expect("an event camera").clone()];
    for _ in 0..steps {
        frames.push(sim.step(&Command::default()).expect("step").frame);
        packets.push(sim.events().expect("an event camera").clone());
    }
    (frames, packets)
}

/// A ball at 20 m/s 2 m ahead moves ~5 px per frame at 120 Hz on a 64-pixel, 60° image, more than
/// its ~2 px diameter: plain frame differencing (pixels that changed from one frame to the next)
/// leaves gaps along its path; the event camera's adaptive sub-frames leave a trail without gaps
/// on the row through its centre.
#[test]
fn a_ball_at_20_mps_leaves_a_trail_without_gaps_where_frame_differencing_leaves_gaps() {
    let desc = ball_world(noiseless(0.2));
    let (frames, packets) = run_ball(&desc, 4, 10);
    let n = 64usize;
    // the ball's row: the darkest pixel of the first frame
    let first = &frames[0];
    let darkest = (0..n * n).min_by(|&a, &b| first[a].total_cmp(&first[b])).unwrap();
    assert!(first[darkest] < 0.5, "the ball is in view at the start");
    let row = darkest / n;
    let mut by_events = vec![false; n];
    for e in packets.iter().flat_map(|q| &q.events) {
        if e.y as usize == row {
            by_events[e.x as usize] = true;
        }
    }
    let mut by_differences = vec![false; n];
    for w in frames.windows(2) {
        for (x, d) in by_differences.iter_mut().enumerate() {
            *d |= w[0][row * n + x] != w[1][row * n + x];
        }
    }
    let path: Vec<usize> = (0..n).filter(|&x| by_events[x]).collect();
    let (start, end) = (path[0], path[path.len() - 1]);
    assert!(end - start > 30, "the trail spans {start}..={end}");
    let gaps = |marked: &[bool]| (start..=end).filter(|&x| !marked[x]).count();
    assert_eq!(gaps(&by_events), 0, "the event trail has gaps: {by_events:?}");
    assert!(
        gaps(&by_differences) > 0,
        "frame differencing should leave gaps at 20 m/s: {by_differences:?}"
    );
    assert!(
        packets[1..].iter().all(|q| q.renders > 1),
        "a fast ball asks for sub-frames"
    );
}

/// The same seed gives the same events (thresholds, crossings and noise); another seed other
/// noise and thresholds; the first frame gives none.
#[test]
fn the_same_seed_gives_the_same_events() {
    let desc = ball_world(EventCameraDesc {
        leak_rate_hz: 5.0,
        shot_rate_hz: 5.0,
        ..EventCameraDesc::default()
    });
    let (_, a) = run_ball(&desc, 9, 4);
    let (_, b) = run_ball(&desc, 9, 4);
    let (_, c) = run_ball(&desc, 10, 4);
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert!(a[0].events.is_empty());
    assert!(a[1..].iter().all(|q| !q.events.is_empty()));
}

/// The event camera's table needs `kind = "events"`, and the error names the key and the fix.
#[test]
fn event_parameters_without_the_event_kind_are_refused() {
    let mut desc = ball_world(EventCameraDesc::default());
    desc.camera.kind = loomlab_sim::CameraKind::Frames;
    desc.camera.events.contrast_on = 0.3;
    let e = Sim::new_physics_only(&desc, 1).unwrap_err().to_string();
    assert!(
        e.contains("world.camera.events") && e.contains("kind = \"events\""),
        "{e}"
    );
    desc.camera.kind = loomlab_sim::CameraKind::Events;
    desc.camera.events.contrast_on = -1.0;
    let e = Sim::new_physics_only(&desc, 1).unwrap_err().to_string();
    assert!(e.contains("world.camera.events.contrast_on"), "{e}");
}

/// Stepping several simulators in a batch (their sub-frames rendered together,
/// `EventStream::plan_subframes`) gives the events each one gives stepped alone (its sub-frames
/// rendered one by one), with noise and mismatch.
#[test]
fn batched_and_single_steps_give_the_same_events() {
    let desc = ball_world(EventCameraDesc {
        leak_rate_hz: 5.0,
        shot_rate_hz: 5.0,
        max_renders: 6,
        ..EventCameraDesc::default()
    });
    let (_, alone) = run_ball(&desc, 3, 5);
    let mut renderer = loomlab_sim::Renderer::new(64).expect("renderer");
    let mut a = Sim::new_physics_only(&desc, 3).unwrap();
    let mut b = Sim::new_physics_only(&desc, 3).unwrap();
    let first = Sim::observe_batch(&mut [&mut a, &mut b], &mut renderer).unwrap();
    assert_eq!(first[0].frame, first[1].frame);
    for packet in &alone[1..] {
        Sim::step_batch(&mut [&mut a, &mut b], &[Command::default(); 2], &mut renderer).unwrap();
        assert_eq!(a.events().unwrap(), packet);
        assert_eq!(b.events().unwrap(), packet);
        assert!(packet.renders > 1);
    }
}
