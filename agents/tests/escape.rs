//! Escape controller: every manoeuvre, cooldown, threshold crossing, dodge side.

use loomlab_agents::planner::Odometry;
use loomlab_agents::{
    AgentError, ControllerEvent, DodgeSide, EscapeConfig, EscapeController, Manoeuvre, RobotFacts, TriggerSignal,
    VelocityCommand,
};
use loomlab_detector::Signals;

const CRUISE: VelocityCommand = VelocityCommand {
    forward_mps: 2.0,
    yaw_rate_rps: 0.1,
    lateral_mps: 0.0,
};

fn controller(manoeuvre: Manoeuvre) -> EscapeController {
    EscapeController::new(
        EscapeConfig {
            manoeuvre,
            dodge_speed_mps: 1.5,
            dodge_forward_scale: 0.5,
            dodge_yaw_rate_rps: 0.0,
            reverse_speed_mps: 0.8,
            duration_s: 0.5,
            cooldown_s: 0.25,
            decision: loomlab_agents::DecisionRule {
                threshold: 10.0,
                ..loomlab_agents::DecisionRule::default()
            },
            ..EscapeConfig::default()
        },
        RobotFacts::default(),
    )
    .unwrap()
}

#[test]
fn below_threshold_passes_cruise_through() {
    let mut c = controller(Manoeuvre::DodgeLateral);
    for k in 0..10 {
        let (cmd, ev) = c.step(k as f64 * 0.1, 9.999, Some(0.5), CRUISE);
        assert_eq!(cmd, CRUISE);
        assert_eq!(ev, ControllerEvent::Cruise);
    }
    assert_eq!(c.triggers(), 0);
    assert_eq!(c.first_trigger_s(), None);
}

#[test]
fn equality_with_threshold_triggers() {
    let mut c = controller(Manoeuvre::Stop);
    let (cmd, ev) = c.step(0.0, 10.0, None, CRUISE);
    assert!(ev.is_trigger());
    assert_eq!(cmd, VelocityCommand::STOP);
}

#[test]
fn nan_signal_never_triggers() {
    let mut c = controller(Manoeuvre::Stop);
    let (cmd, ev) = c.step(0.0, f64::NAN, None, CRUISE);
    assert_eq!((cmd, ev), (CRUISE, ControllerEvent::Cruise));
    let s = Signals {
        output: 1e9,
        angular_size_deg: None,
        aux: vec![],
        region: None,
        objects: Vec::new(),
    };
    let (_, ev) = c.step_signals(0.1, &s, None, CRUISE);
    assert_eq!(ev, ControllerEvent::Cruise, "a missing angular size must not trigger");
}

#[test]
fn trigger_signal_selects_the_right_field() {
    let s = Signals {
        output: 50.0,
        angular_size_deg: Some(3.0),
        aux: vec![],
        region: None,
        objects: Vec::new(),
    };
    let mut hop = controller(Manoeuvre::Stop);
    assert!(!hop.step_signals(0.0, &s, None, CRUISE).1.is_trigger(), "θ̂ = 3° < 10°");
    let mut out = EscapeController::new(
        EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                trigger: TriggerSignal::Output,
                threshold: 40.0,
                ..loomlab_agents::DecisionRule::default()
            },
            ..EscapeConfig::default()
        },
        RobotFacts::default(),
    )
    .unwrap();
    assert!(
        out.step_signals(0.0, &s, None, CRUISE).1.is_trigger(),
        "output 50 >= 40"
    );
}

#[test]
fn dodge_lateral_moves_away_from_the_looming_side() {
    // Object on the right of the image → dodge left (+y).
    let mut c = controller(Manoeuvre::DodgeLateral);
    let (cmd, ev) = c.step(1.0, 12.0, Some(0.6), CRUISE);
    assert_eq!(
        ev,
        ControllerEvent::Triggered {
            side: Some(DodgeSide::Left)
        }
    );
    assert_eq!(
        cmd,
        VelocityCommand {
            forward_mps: 1.0,
            yaw_rate_rps: 0.0,
            lateral_mps: 1.5
        }
    );
    // Object on the left → dodge right (−y).
    let mut c = controller(Manoeuvre::DodgeLateral);
    let (cmd, ev) = c.step(1.0, 12.0, Some(-0.6), CRUISE);
    assert_eq!(
        ev,
        ControllerEvent::Triggered {
            side: Some(DodgeSide::Right)
        }
    );
    assert_eq!(cmd.lateral_mps, -1.5);
}

#[test]
fn dodge_unknown_or_central_side_uses_default() {
    for side in [None, Some(0.0), Some(0.05), Some(-0.04), Some(f32::NAN)] {
        let mut c = EscapeController::new(
            EscapeConfig {
                default_side: DodgeSide::Right,
                ..EscapeConfig::default()
            },
            RobotFacts::default(),
        )
        .unwrap();
        let (cmd, ev) = c.step(0.0, 20.0, side, CRUISE);
        assert_eq!(
            ev,
            ControllerEvent::Triggered {
                side: Some(DodgeSide::Right)
            },
            "side {side:?}"
        );
        assert!(cmd.lateral_mps < 0.0);
    }
}

#[test]
fn dodge_yaw_turns_towards_the_dodge_side() {
    let mut c = EscapeController::new(
        EscapeConfig {
            dodge_yaw_rate_rps: 0.7,
            ..EscapeConfig::default()
        },
        RobotFacts::default(),
    )
    .unwrap();
    let (cmd, _) = c.step(0.0, 20.0, Some(-0.9), CRUISE);
    assert_eq!(cmd.yaw_rate_rps, -0.7, "dodging right turns right");
}

#[test]
fn dodge_side_is_latched_for_the_whole_manoeuvre() {
    let mut c = controller(Manoeuvre::DodgeLateral);
    c.step(0.0, 20.0, Some(0.9), CRUISE);
    let (cmd, ev) = c.step(0.2, 20.0, Some(-0.9), CRUISE);
    assert_eq!(
        ev,
        ControllerEvent::Manoeuvring {
            side: Some(DodgeSide::Left)
        }
    );
    assert_eq!(cmd.lateral_mps, 1.5);
}

#[test]
fn stop_manoeuvre_zeroes_the_command() {
    let mut c = controller(Manoeuvre::Stop);
    let (cmd, ev) = c.step(0.0, 11.0, Some(0.9), CRUISE);
    assert_eq!(ev, ControllerEvent::Triggered { side: None });
    assert_eq!(cmd, VelocityCommand::STOP);
    let (cmd, ev) = c.step(0.4, 0.0, None, CRUISE);
    assert_eq!(ev, ControllerEvent::Manoeuvring { side: None });
    assert_eq!(cmd, VelocityCommand::STOP);
}

#[test]
fn reverse_manoeuvre_drives_backwards() {
    let mut c = controller(Manoeuvre::Reverse);
    let (cmd, _) = c.step(0.0, 11.0, None, CRUISE);
    assert_eq!(
        cmd,
        VelocityCommand {
            forward_mps: -0.8,
            yaw_rate_rps: 0.0,
            lateral_mps: 0.0
        }
    );
}

#[test]
fn manoeuvre_lasts_duration_then_cooldown_blocks_retrigger() {
    // duration 0.5 s, cooldown 0.25 s; trigger at t = 1.0.
    let mut c = controller(Manoeuvre::Stop);
    assert!(c.step(1.0, 20.0, None, CRUISE).1.is_trigger());
    let (cmd, ev) = c.step(1.49, 20.0, None, CRUISE);
    assert_eq!(
        (cmd, ev),
        (VelocityCommand::STOP, ControllerEvent::Manoeuvring { side: None })
    );
    // At t0 + duration the manoeuvre is over: cooldown passes cruise through, ignores the signal.
    let (cmd, ev) = c.step(1.5, 20.0, None, CRUISE);
    assert_eq!((cmd, ev), (CRUISE, ControllerEvent::Cooldown));
    let (cmd, ev) = c.step(1.74, 20.0, None, CRUISE);
    assert_eq!((cmd, ev), (CRUISE, ControllerEvent::Cooldown));
    assert_eq!(c.triggers(), 1);
    // At t0 + duration + cooldown it is armed again; level-based trigger fires at once.
    let (cmd, ev) = c.step(1.75, 20.0, None, CRUISE);
    assert!(ev.is_trigger());
    assert_eq!(cmd, VelocityCommand::STOP);
    assert_eq!(c.triggers(), 2);
    assert_eq!(c.first_trigger_s(), Some(1.0));
}

#[test]
fn armed_again_after_cooldown_without_signal() {
    let mut c = controller(Manoeuvre::Stop);
    c.step(0.0, 20.0, None, CRUISE);
    // A long gap skips manoeuvre and cooldown in one step.
    let (cmd, ev) = c.step(5.0, 1.0, None, CRUISE);
    assert_eq!((cmd, ev), (CRUISE, ControllerEvent::Cruise));
}

#[test]
fn zero_cooldown_rearms_right_after_the_manoeuvre() {
    let mut c = EscapeController::new(
        EscapeConfig {
            manoeuvre: Manoeuvre::Stop,
            duration_s: 0.5,
            cooldown_s: 0.0,
            ..EscapeConfig::default()
        },
        RobotFacts::default(),
    )
    .unwrap();
    c.step(0.0, 20.0, None, CRUISE);
    assert!(c.step(0.5, 20.0, None, CRUISE).1.is_trigger());
}

#[test]
fn reset_returns_to_armed() {
    let mut c = controller(Manoeuvre::Stop);
    c.step(0.0, 20.0, None, CRUISE);
    c.reset();
    assert_eq!(c.triggers(), 0);
    assert_eq!(c.first_trigger_s(), None);
    assert!(c.step(0.0, 20.0, None, CRUISE).1.is_trigger());
}

#[test]
fn non_finite_time_changes_nothing() {
    let mut c = controller(Manoeuvre::Stop);
    let (cmd, ev) = c.step(f64::NAN, 20.0, None, CRUISE);
    assert_eq!((cmd, ev), (CRUISE, ControllerEvent::Cruise));
    assert_eq!(c.triggers(), 0);
}

#[test]
fn invalid_config_is_rejected_with_key() {
    let bad = [
        EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                threshold: f64::NAN,
                ..loomlab_agents::DecisionRule::default()
            },
            ..Default::default()
        },
        EscapeConfig {
            duration_s: 0.0,
            ..Default::default()
        },
        EscapeConfig {
            cooldown_s: -1.0,
            ..Default::default()
        },
        EscapeConfig {
            dodge_speed_mps: f64::INFINITY,
            ..Default::default()
        },
        EscapeConfig {
            side_deadband: 1.0,
            ..Default::default()
        },
    ];
    let keys = [
        "escape.threshold",
        "escape.duration_s",
        "escape.cooldown_s",
        "escape.dodge_speed_mps",
        "escape.side_deadband",
    ];
    for (cfg, key) in bad.into_iter().zip(keys) {
        match EscapeController::new(cfg, RobotFacts::default()) {
            Err(e @ AgentError::InvalidConfig { .. }) => assert!(e.to_string().contains(key), "{e}"),
            other => panic!("expected InvalidConfig for {key}, got {other:?}"),
        }
    }
}

#[test]
fn the_robots_facts_are_given_at_construction_and_checked() {
    use loomlab_detector::Pinhole;
    use loomlab_sim::RobotBase;
    let cruise = VelocityCommand::forward(1.0);
    let diff = RobotFacts {
        base: RobotBase::DiffDrive,
        ..RobotFacts::default()
    };
    let mut c = EscapeController::new(EscapeConfig::default(), diff).unwrap();
    assert_eq!(c.facts(), &diff);
    let (cmd, event) = c.step(0.0, 20.0, Some(0.9), cruise);
    assert!(event.is_trigger());
    assert_eq!(
        cmd,
        EscapeConfig::default().manoeuvre_command(DodgeSide::Left, cruise, RobotBase::DiffDrive)
    );
    assert_eq!(
        cmd.lateral_mps, 0.0,
        "a differential drive turns instead of sidestepping"
    );
    let body = |half_width_m, above_camera_m| loomlab_agents::BodyExtent {
        half_width_m,
        above_camera_m,
        below_camera_m: 0.25,
        ..loomlab_agents::BodyExtent::default()
    };
    for (facts, key) in [
        (
            RobotFacts {
                pinhole: Pinhole::new(180.0),
                ..RobotFacts::default()
            },
            "world.camera.fov_deg",
        ),
        (
            RobotFacts {
                pinhole: Pinhole::new(f64::NAN),
                ..RobotFacts::default()
            },
            "world.camera.fov_deg",
        ),
        (
            RobotFacts {
                body: body(-0.1, 0.05),
                ..RobotFacts::default()
            },
            "world.robot.body",
        ),
        (
            RobotFacts {
                body: body(0.2, f64::INFINITY),
                ..RobotFacts::default()
            },
            "world.robot.body",
        ),
    ] {
        let e = EscapeController::new(EscapeConfig::default(), facts)
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{e}");
        let e = loomlab_agents::EscapeAgent::new(Vec::new(), EscapeConfig::default(), facts)
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{e}");
    }
}

#[test]
fn the_controller_table_is_flat_and_round_trips() {
    // the decision rule's keys are keys of the controller's table, first and in their order (run
    // fingerprints hash this serialization)
    let cfg = EscapeConfig {
        decision: loomlab_agents::DecisionRule {
            trigger: TriggerSignal::Tau,
            persistence_window_frames: Some(4),
            ..loomlab_agents::DecisionRule::default()
        },
        duration_s: 0.7,
        ..EscapeConfig::default()
    };
    let json = serde_json::to_string(&cfg).unwrap();
    assert!(
        json.starts_with(r#"{"trigger":"tau","threshold":10.0,"tau_threshold_s":1.0,"min_angular_size_deg":1.0,"tau_window_s":0.1,"course":"off","persistence_frames":1,"persistence_window_frames":4,"course_closing_speed_mps":10.0,"course_window_s":0.25,"side_memory_s":0.5,"#),
        "{json}"
    );
    assert_eq!(serde_json::from_str::<EscapeConfig>(&json).unwrap(), cfg);
}

#[test]
fn config_serde_defaults_and_unknown_keys() {
    let cfg: EscapeConfig =
        serde_json::from_str(r#"{"trigger":"output","threshold":3.5,"manoeuvre":"reverse"}"#).unwrap();
    assert_eq!(cfg.decision.trigger, TriggerSignal::Output);
    assert_eq!(cfg.manoeuvre, Manoeuvre::Reverse);
    assert_eq!(cfg.duration_s, EscapeConfig::default().duration_s);
    let err = serde_json::from_str::<EscapeConfig>(r#"{"threshhold":3.5}"#).unwrap_err();
    assert!(err.to_string().contains("threshhold"), "{err}");
    EscapeConfig::default().validate().unwrap();
}

mod looming_side {
    use loomlab_agents::looming_side::{LoomingSideEstimator, temporal_contrast_centroid_x};
    use loomlab_detector::Frame;

    /// A dark disk of radius `r` centred at column `cx`, row n/2, on a grey background.
    fn disk(n: usize, cx: f32, r: f32) -> Frame {
        let data = (0..n * n)
            .map(|k| {
                let (i, j) = ((k / n) as f32 + 0.5, (k % n) as f32 + 0.5);
                if (i - n as f32 / 2.0).hypot(j - cx) <= r {
                    0.0
                } else {
                    0.5
                }
            })
            .collect();
        Frame::from_f32(n, data).unwrap()
    }

    #[test]
    fn growing_disk_on_the_right_gives_positive_x() {
        let n = 64;
        let x = temporal_contrast_centroid_x(&disk(n, 48.0, 4.0), &disk(n, 48.0, 6.0), 1e-4).unwrap();
        // Column 48 is at image x = 2·48/64 − 1 = 0.5.
        assert!((x - 0.5).abs() < 0.05, "x = {x}");
        let x = temporal_contrast_centroid_x(&disk(n, 16.0, 4.0), &disk(n, 16.0, 6.0), 1e-4).unwrap();
        assert!((x + 0.5).abs() < 0.05, "x = {x}");
    }

    #[test]
    fn no_change_or_size_mismatch_gives_none() {
        let f = disk(32, 10.0, 3.0);
        assert_eq!(temporal_contrast_centroid_x(&f, &f, 1e-4), None);
        assert_eq!(temporal_contrast_centroid_x(&f, &disk(16, 8.0, 3.0), 1e-4), None);
    }

    #[test]
    fn estimator_needs_two_frames_and_resets() {
        let mut e = LoomingSideEstimator::default();
        assert_eq!(e.update(&disk(32, 24.0, 3.0)), None);
        assert!(e.update(&disk(32, 24.0, 5.0)).unwrap() > 0.3);
        e.reset();
        assert_eq!(e.update(&disk(32, 24.0, 7.0)), None);
    }
}

#[test]
fn a_dodge_on_a_differential_drive_turns_away_and_drives_instead_of_sidestepping() {
    let cruise = VelocityCommand::forward(1.0);
    let holonomic = EscapeConfig::default();
    let diff = EscapeConfig::default();
    for side in [DodgeSide::Left, DodgeSide::Right] {
        let h = holonomic.manoeuvre_command(side, cruise, loomlab_sim::RobotBase::Holonomic);
        assert_eq!(h.lateral_mps, side.sign() * holonomic.dodge_speed_mps);
        let d = diff.manoeuvre_command(side, cruise, loomlab_sim::RobotBase::DiffDrive);
        assert_eq!(d.lateral_mps, 0.0);
        assert_eq!(d.yaw_rate_rps, side.sign() * diff.turn_rate_rps);
        assert_eq!(d.forward_mps, diff.dodge_speed_mps.max(1.0));
    }
}

/// Decision strategies on analytic inputs: a sphere of radius `r` moving at constant velocity
/// relative to a camera that may itself drive forward.
mod strategies {
    use loomlab_agents::RobotFacts;
    use loomlab_agents::{
        Course, Decider, Decision, DodgeSide, EscapeConfig, EscapeController, ImageExtent, Percept, SelfMotion,
        TriggerSignal, VelocityCommand,
    };

    const DT: f64 = 1.0 / 120.0;

    /// Camera at (vx·t, 0) looking along +x; the sphere's centre at `p0 + u·t` (x forward, y left).
    struct Approach {
        r: f64,
        p0: [f64; 2],
        u: [f64; 2],
        camera_vx: f64,
    }

    impl Approach {
        fn rel(&self, t: f64) -> [f64; 2] {
            [
                self.p0[0] + self.u[0] * t - self.camera_vx * t,
                self.p0[1] + self.u[1] * t,
            ]
        }
        /// True angular size (degrees) and azimuth (degrees, positive right).
        fn percept(&self, t: f64) -> Percept {
            let [x, y] = self.rel(t);
            let d = x.hypot(y);
            Percept {
                value: 2.0 * (self.r / d).asin().to_degrees(),
                azimuth_deg: Some((-y).atan2(x).to_degrees()),
                elevation_deg: None,
                extent: None,
            }
        }
        /// Time until the surface reaches the camera (head-on approaches only).
        fn surface_ttc(&self, t: f64) -> f64 {
            let [x, y] = self.rel(t);
            let closing = -(self.u[0] - self.camera_vx);
            (x.hypot(y) - self.r) / closing
        }
        fn motion(&self) -> SelfMotion {
            SelfMotion {
                yaw_rate_rps: 0.0,
                forward_mps: self.camera_vx,
                ..SelfMotion::default()
            }
        }
    }

    fn config(course: Course) -> EscapeConfig {
        EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                trigger: TriggerSignal::Tau,
                tau_threshold_s: 1.0,
                min_angular_size_deg: 1.0,
                course,
                ..loomlab_agents::DecisionRule::default()
            },
            ..EscapeConfig::default()
        }
    }

    /// Runs the strategy over the approach until the sphere is within `stop_m` of the camera;
    /// returns (t, θ, decision) per frame.
    fn run(cfg: &EscapeConfig, a: &Approach, stop_m: f64) -> Vec<(f64, f64, loomlab_agents::Decision)> {
        let mut s: Decider = cfg.decider(&RobotFacts::default());
        let mut out = Vec::new();
        for k in 0..2000 {
            let t = k as f64 * DT;
            let [x, y] = a.rel(t);
            if x.hypot(y) - a.r < stop_m || x < 0.0 {
                break;
            }
            let p = a.percept(t);
            out.push((t, p.value, s.decide(t, p, a.motion())));
        }
        out
    }

    #[test]
    fn tau_estimate_is_within_ten_percent_of_the_true_time_to_contact_from_three_degrees_on() {
        for (r, speed, camera_vx) in [(0.2, 8.0, 1.0), (0.1, 15.0, 0.0), (0.4, 4.0, 1.5), (0.05, 12.0, 0.5)] {
            let a = Approach {
                r,
                p0: [20.0, 0.0],
                u: [-speed, 0.0],
                camera_vx,
            };
            let frames = run(&config(Course::Off), &a, 0.05);
            let mut checked = 0;
            let window = config(Course::Off).decision.tau_window_s;
            for (t, theta, d) in &frames {
                let truth = a.surface_ttc(*t);
                // from 3° on, until the last window before contact (where the frames no longer fill
                // the estimation window; no decision is made that late)
                if *theta < 3.0 || *t < window || truth < window {
                    continue;
                }
                let est = d.tau_s.expect("τ̂ on a looming sphere");
                assert!(
                    (est - truth).abs() <= 0.1 * truth,
                    "r {r} speed {speed}: θ {theta:.1}°, τ̂ {est:.4} s vs true {truth:.4} s"
                );
                checked += 1;
            }
            assert!(checked > 5, "{checked} frames checked");
        }
    }

    #[test]
    fn a_one_frame_jump_of_theta_out_of_nothing_is_no_time_to_contact() {
        // a detector whose θ̂ decays towards 0 (10⁻²⁹°) and jumps to 5° for one frame (the
        // compensated Hopfield read-out in car_oncoming): no estimate followed by one, not an
        // expansion; ln θ̂ across the jump would give τ̂ ≈ 1 ms and an alarm
        let cfg = config(Course::Off);
        let mut s = cfg.decider(&RobotFacts::default());
        let mut theta: f64 = 1e-3;
        for k in 0..60 {
            theta /= 2.0;
            let d = s.decide(
                k as f64 * DT,
                Percept {
                    value: theta.max(1e-30),
                    ..Percept::default()
                },
                SelfMotion::default(),
            );
            assert_eq!(d.value, 0.0);
        }
        for (k, theta) in [(60, 5.0), (61, 2.5), (62, 1.25), (63, 0.6)] {
            let d = s.decide(
                k as f64 * DT,
                Percept {
                    value: theta,
                    ..Percept::default()
                },
                SelfMotion::default(),
            );
            assert_eq!(d.value, 0.0, "frame {k}: θ̂ {theta}°, τ̂ {:?}", d.tau_s);
        }
    }

    #[test]
    fn a_jump_of_theta_starts_the_window_afresh() {
        // a tracked region that merges with another one: θ̂ grows slowly (τ ≈ 3 s), then doubles
        // in one frame. Across the jump ln θ̂ would give τ̂ of a few frames and an alarm; after it
        // the window holds only the new hypothesis's frames
        let cfg = config(Course::Off);
        let mut s = cfg.decider(&RobotFacts::default());
        let theta = |k: usize| 5.0 * (k as f64 * DT / 3.0).exp();
        for k in 0..40 {
            let d = s.decide(
                k as f64 * DT,
                Percept {
                    value: theta(k),
                    ..Percept::default()
                },
                SelfMotion::default(),
            );
            assert!(d.value < cfg.alarm_threshold(), "frame {k}: τ̂ {:?}", d.tau_s);
        }
        for k in 40..80 {
            let d = s.decide(
                k as f64 * DT,
                Percept {
                    value: 2.0 * theta(k),
                    ..Percept::default()
                },
                SelfMotion::default(),
            );
            assert!(d.value < cfg.alarm_threshold(), "frame {k}: τ̂ {:?}", d.tau_s);
            if k >= 40 + loomlab_agents::decision::MIN_SAMPLES + 2 {
                let tau = d.tau_s.expect("an estimate from the new frames");
                assert!((tau - 3.0).abs() < 0.5, "frame {k}: τ̂ {tau}");
            }
        }
        // a jump just below the ratio is growth: it is fitted (τ̂ of a few frames)
        let mut s = cfg.decider(&RobotFacts::default());
        let mut last = f64::NAN;
        for k in 0..45 {
            let value = if k < 40 { theta(k) } else { theta(k) * 1.25 };
            last = s
                .decide(
                    k as f64 * DT,
                    Percept {
                        value,
                        ..Percept::default()
                    },
                    SelfMotion::default(),
                )
                .value;
        }
        assert!(last >= cfg.alarm_threshold(), "urgency {last}");
    }

    #[test]
    fn tau_alarm_comes_at_the_threshold_and_not_before() {
        let a = Approach {
            r: 0.2,
            p0: [20.0, 0.0],
            u: [-8.0, 0.0],
            camera_vx: 1.0,
        };
        let cfg = config(Course::Off);
        let frames = run(&cfg, &a, 0.05);
        let first = frames
            .iter()
            .find(|(_, _, d)| d.value >= cfg.alarm_threshold())
            .expect("an alarm");
        let ttc = a.surface_ttc(first.0);
        assert!((ttc - 1.0).abs() < 0.05, "alarm at true TTC {ttc:.3} s");
        // θ̂ below min_angular_size_deg never alarms, whatever τ̂
        let cfg = EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                min_angular_size_deg: 30.0,
                ..cfg.decision
            },
            ..cfg
        };
        for (_, theta, d) in run(&cfg, &a, 0.05) {
            assert!(theta >= 30.0 || d.value == 0.0);
        }
    }

    #[test]
    fn course_gate_closed_for_a_pass_at_two_body_widths() {
        let cfg = config(Course::Image);
        let w = RobotFacts::default().body.half_width_m;
        for (r, speed, camera_vx, side) in [(0.2, 8.0, 1.0, 1.0), (0.1, 10.0, 1.0, -1.0), (0.25, 6.0, 0.0, 1.0)] {
            // passes 2 body widths (4 half-widths) from the camera, beside it
            let a = Approach {
                r,
                p0: [20.0, side * 4.0 * w],
                u: [-speed, 0.0],
                camera_vx,
            };
            let frames = run(&cfg, &a, 0.0);
            assert!(frames.len() > 100);
            for (t, theta, d) in &frames {
                assert!(
                    d.value < cfg.alarm_threshold(),
                    "r {r}: alarm at t {t:.3} (θ {theta:.1}°, μ {:?}, τ̂ {:?})",
                    d.miss_radii,
                    d.tau_s
                );
            }
            // without the gate the same pass alarms (τ falls below 1 s)
            assert!(
                run(&config(Course::Off), &a, 0.0)
                    .iter()
                    .any(|(_, _, d)| d.value >= cfg.alarm_threshold())
            );
        }
    }

    /// The approach's second axis taken as height: the object is seen straight ahead in azimuth,
    /// at the elevation of its centre.
    fn run_vertical(cfg: &EscapeConfig, a: &Approach) -> Vec<(f64, f64, loomlab_agents::Decision)> {
        let mut s: Decider = cfg.decider(&RobotFacts::default());
        let mut out = Vec::new();
        for k in 0..2000 {
            let t = k as f64 * DT;
            let [x, z] = a.rel(t);
            if x.hypot(z) - a.r < 0.05 || x < 0.0 {
                break;
            }
            let p = Percept {
                value: 2.0 * (a.r / x.hypot(z)).asin().to_degrees(),
                azimuth_deg: Some(0.0),
                elevation_deg: Some(z.atan2(x).to_degrees()),
                extent: None,
            };
            out.push((t, p.value, s.decide(t, p, a.motion())));
        }
        out
    }

    #[test]
    fn course_gate_closed_for_a_pass_overhead_and_open_for_a_hit_in_the_vertical() {
        let cfg = config(Course::Image);
        let above = RobotFacts::default().body.above_camera_m;
        for (r, speed) in [(0.2, 8.0), (0.1, 12.0)] {
            // the centre passes one radius plus 0.4 m over the top of the body
            let over = Approach {
                r,
                p0: [20.0, above + r + 0.4],
                u: [-speed, 0.0],
                camera_vx: 1.0,
            };
            let frames = run_vertical(&cfg, &over);
            assert!(frames.len() > 100);
            for (t, theta, d) in &frames {
                assert!(
                    d.value < cfg.alarm_threshold(),
                    "r {r}: alarm at t {t:.3} (θ {theta:.1}°, vertical miss {:?} radii)",
                    d.vertical_miss_radii
                );
            }
            // the same object aimed at the camera, descending towards it from above, is let through
            let hit = Approach {
                r,
                p0: [20.0, 1.0],
                u: [-speed, -(speed + 1.0) / 20.0],
                camera_vx: 1.0,
            };
            let alarm = run_vertical(&cfg, &hit)
                .into_iter()
                .find(|(_, _, d)| d.value >= cfg.alarm_threshold())
                .expect("the gate lets the hit through");
            assert!(alarm.2.vertical_miss_radii.expect("a straight course").abs() < 0.2);
        }
    }

    #[test]
    fn the_gate_predicts_the_side_a_crossing_object_will_arrive_on() {
        let cfg = config(Course::Image);
        // seen on the left (y > 0), arriving 0.5 m to the right of the camera 2 s later
        let a = Approach {
            r: 0.2,
            p0: [16.0, 1.5],
            u: [-7.0, -1.0],
            camera_vx: 1.0,
        };
        let frames = run(&cfg, &a, 0.3);
        // one second before arrival (x = 8 m, y = 0.5 m)
        let (t, _, d) = frames.iter().find(|(t, _, _)| *t >= 1.0).expect("a frame at 1 s");
        let [x, y] = a.rel(*t);
        assert!(y > 0.0 && x > 0.0, "still on the left at t {t:.2}");
        assert_eq!(d.pass_side, Some(1.0), "arrives on the right: μ {:?}", d.miss_radii);
    }

    /// A percept of a box with centre `c` (camera frame: x forward, y left, z up) and half sizes
    /// `h`, from its eight corners: the largest angle between two of them, the centre's direction
    /// and the corners' azimuth and elevation extremes.
    fn box_percept(c: [f64; 3], h: [f64; 3]) -> Percept {
        let corners: Vec<[f64; 3]> = (0..8)
            .map(|i| {
                let s = |b: usize, k: usize| if i & b == 0 { c[k] - h[k] } else { c[k] + h[k] };
                [s(1, 0), s(2, 1), s(4, 2)]
            })
            .collect();
        let unit = |p: &[f64; 3]| {
            let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            [p[0] / n, p[1] / n, p[2] / n]
        };
        let mut theta = 0.0f64;
        for a in &corners {
            for b in &corners {
                let (u, v) = (unit(a), unit(b));
                theta = theta.max((u[0] * v[0] + u[1] * v[1] + u[2] * v[2]).clamp(-1.0, 1.0).acos());
            }
        }
        let az = |p: &[f64; 3]| (-p[1]).atan2(p[0]).to_degrees();
        let el = |p: &[f64; 3]| p[2].atan2(p[0].hypot(p[1])).to_degrees();
        let span = |f: &dyn Fn(&[f64; 3]) -> f64| {
            corners
                .iter()
                .map(f)
                .fold([f64::INFINITY, f64::NEG_INFINITY], |m, v| [m[0].min(v), m[1].max(v)])
        };
        Percept {
            value: theta.to_degrees(),
            azimuth_deg: Some(az(&c)),
            elevation_deg: Some(el(&c)),
            extent: Some(ImageExtent {
                azimuth_deg: span(&az),
                elevation_deg: span(&el),
            }),
        }
    }

    /// Runs the gate on a box driving at `speed` along −x, its centre `lateral_m` to the side of
    /// the camera (positive left) and `height_m` above it; the camera stands.
    fn run_box(cfg: &EscapeConfig, lateral_m: f64, height_m: f64, h: [f64; 3], speed: f64) -> Vec<(f64, Decision)> {
        let mut s: Decider = cfg.decider(&RobotFacts::default());
        let mut out = Vec::new();
        for k in 0..2000 {
            let t = k as f64 * DT;
            let x = 20.0 - speed * t;
            if x - h[0] < 0.3 {
                break;
            }
            out.push((
                t,
                s.decide(t, box_percept([x, lateral_m, height_m], h), SelfMotion::default()),
            ));
        }
        out
    }

    /// The decisions about a ball of radius 0.2 m that stands 12 m ahead, `lateral_m` to the side
    /// (positive left), while the robot drives at 1 m/s, and from `launch_s` on flies at 12 m/s
    /// along the robot's heading towards it (`None`: it stands throughout).
    fn run_thrown_along_heading(mut s: Decider, lateral_m: f64, launch_s: Option<f64>) -> Vec<(f64, Decision)> {
        let cruise = SelfMotion {
            forward_mps: 1.0,
            ..SelfMotion::default()
        };
        let mut out = Vec::new();
        for k in 0..2000 {
            let t = k as f64 * DT;
            let flight = launch_s.map_or(0.0, |l| 12.0 * (t - l).max(0.0));
            let x = 12.0 - t - flight;
            if x < 0.5 {
                break;
            }
            out.push((t, s.decide(t, box_percept([x, lateral_m, 0.0], [0.2; 3]), cruise)));
        }
        out
    }

    #[test]
    fn a_ball_seen_standing_then_thrown_along_the_heading_is_judged_at_its_speed() {
        let cfg = config(Course::Image);
        let facts = RobotFacts::default();
        let alarms =
            |frames: &[(f64, Decision)]| frames.iter().filter(|(_, d)| d.value >= cfg.alarm_threshold()).count();
        // it passes 0.7 m beside the camera, 0.3 m clear of the body: its edges expand about the
        // heading as a standing object's would, 13× nearer and smaller
        let driving = cfg.decider(&facts);
        let bound = cfg.decider(&facts).for_one_object();
        let near_miss = run_thrown_along_heading(bound.clone(), 0.7, Some(0.5));
        assert_eq!(
            alarms(&near_miss),
            0,
            "seen standing before the throw: judged as moving"
        );
        // its height, measured while it stood, gives its distance after the throw: the closing
        // speed is measured (13 m/s: 12 of its own and the robot's 1; within 3 % on this box's
        // corner elevations), and so are the metres
        let after: Vec<_> = near_miss
            .iter()
            .filter(|(t, _)| (0.6..1.05).contains(t))
            .filter_map(|(_, d)| d.forecast)
            .collect();
        assert!(!after.is_empty());
        for f in &after {
            assert!(!f.standing && f.closing_measured, "{f:?}");
            assert!((f.closing_mps - 13.0).abs() < 0.4, "closing {:.2} m/s", f.closing_mps);
            let centre = (f.arrival_lateral_m[0] + f.arrival_lateral_m[1]) / 2.0;
            assert!((centre.abs() - 0.7).abs() < 0.05, "arrives {centre:.2} m beside");
        }
        // the frames across the throw are forgotten: no forecast until the window refills
        assert!(
            near_miss
                .iter()
                .any(|(t, d)| (0.5..0.6).contains(t) && d.forecast.is_none()),
            "the window restarts when the ball is seen to move"
        );
        // a decider not bound to one object has no memory of it, but the ground tells: read as
        // standing 13× nearer, its bottom would float 1.5 cm below the horizon
        assert_eq!(alarms(&run_thrown_along_heading(driving.clone(), 0.7, Some(0.5))), 0);
        // a throw at the body still alarms, and a ball that stands on the path alarms as before
        assert!(alarms(&run_thrown_along_heading(bound.clone(), 0.1, Some(0.5))) > 0);
        let standing = run_thrown_along_heading(bound, 0.1, None);
        assert!(alarms(&standing) > 0);
        assert!(
            standing.iter().filter_map(|(_, d)| d.forecast).all(|f| f.standing),
            "a standing object stays standing"
        );
    }

    /// The decisions of `s` about a box of half sizes `h` whose centre starts at `p0` (camera frame:
    /// x forward, y left, z up) and moves at `v` (m/s, x and y) over the ground while the robot
    /// drives at `forward_mps`; until its near face is 0.3 m ahead of the camera.
    fn run_moving_box(mut s: Decider, p0: [f64; 3], v: [f64; 2], h: [f64; 3], forward_mps: f64) -> Vec<Decision> {
        let motion = SelfMotion {
            forward_mps,
            ..SelfMotion::default()
        };
        (0..2000)
            .map(|k| k as f64 * DT)
            .map(|t| (t, [p0[0] + (v[0] - forward_mps) * t, p0[1] + v[1] * t, p0[2]]))
            .take_while(|(_, c)| c[0] - h[0] >= 0.3)
            .map(|(t, c)| s.decide(t, box_percept(c, h), motion))
            .collect()
    }

    #[test]
    fn a_car_coming_along_the_next_lane_is_not_read_as_standing_nearer() {
        let cfg = config(Course::Image);
        let facts = RobotFacts::default();
        // a vehicle's flat front (1.8 × 1.5 m, its bottom 0.15 m below the camera) comes at 10 m/s
        // in the next lane, its side 1.1 m beside the camera's line, towards a robot cruising at
        // 1 m/s: its edges expand about the heading as those of an object standing 11× nearer and
        // smaller, on the robot's path; read so, its bottom would float 1 cm below the horizon
        let car = [0.25, 0.9, 0.75];
        for decider in [cfg.decider(&facts), cfg.decider(&facts).for_one_object()] {
            let oncoming = run_moving_box(decider, [25.0, 2.0, 0.6], [-10.0, 0.0], car, 1.0);
            assert!(oncoming.iter().all(|d| d.value < cfg.alarm_threshold()), "no alarm");
            let forecasts: Vec<_> = oncoming.iter().filter_map(|d| d.forecast).collect();
            assert!(!forecasts.is_empty() && forecasts.iter().all(|f| !f.standing));
        }
        // a box standing on the ground (its bottom a body's reach below the camera) ahead on the
        // path stands, and alarms
        let standing = run_moving_box(cfg.decider(&facts), [12.0, 0.1, -0.05], [0.0, 0.0], [0.2; 3], 1.0);
        assert!(standing.iter().filter_map(|d| d.forecast).all(|f| f.standing));
        assert!(standing.iter().any(|d| d.value >= cfg.alarm_threshold()));
        // and so does one on a raised surface, its bottom 0.1 m below the camera: only a bottom
        // nearly at the horizon is taken for an object coming from afar
        let raised = run_moving_box(cfg.decider(&facts), [12.0, 0.1, 0.1], [0.0, 0.0], [0.2; 3], 1.0);
        assert!(raised.iter().filter_map(|d| d.forecast).all(|f| f.standing));
        assert!(raised.iter().any(|d| d.value >= cfg.alarm_threshold()));
    }

    #[test]
    fn an_oblique_ball_that_passes_the_camera_beside_the_body_but_strikes_its_flank_alarms() {
        let cfg = config(Course::Image);
        let facts = RobotFacts::default();
        let behind = facts.body.behind_camera_m;
        assert!(behind >= 0.5);
        // crossing from the left at 3 m/s while closing at 8 m/s: at the camera's depth its right
        // edge is 0.3 m beside the camera (0.1 m clear of the body), but 0.5 m further back its
        // right edge is 0.11 m beside it, within the body's 0.2 m half-width
        let hits_flank = run_moving_box(cfg.decider(&facts), [12.0, 5.0, 0.0], [-8.0, -3.0], [0.2; 3], 0.0);
        assert!(hits_flank.iter().any(|d| d.value >= cfg.alarm_threshold()));
        // 0.4 m further left it clears the whole body
        let passes = run_moving_box(cfg.decider(&facts), [12.0, 5.4, 0.0], [-8.0, -3.0], [0.2; 3], 0.0);
        assert!(passes.iter().all(|d| d.value < cfg.alarm_threshold()));
    }

    #[test]
    fn course_gate_judges_wide_and_tall_objects_by_their_image_edges() {
        let cfg = config(Course::Image);
        let w = RobotFacts::default().body.half_width_m;
        // a car (4 × 1.8 × 1.4 m) in the next lane, its side 1 m beside the body: its angular size
        // (the diagonal) is much larger than its width, but its edges pass beside the body
        let car = [2.0, 0.9, 0.7];
        let passing_car = run_box(&cfg, w + 1.0 + car[1], 0.4, car, 6.0);
        assert!(passing_car.iter().all(|(_, d)| d.value < cfg.alarm_threshold()));
        // judged as a sphere of its angular size (no image extent, as for a detector row) it passes
        let mut sphere = cfg.decider(&RobotFacts::default());
        let sphere_alarms = (0..2000).any(|k| {
            let t = k as f64 * DT;
            let x = 20.0 - 6.0 * t;
            let p = Percept {
                extent: None,
                ..box_percept([x, w + 1.0 + car[1], 0.4], car)
            };
            x - car[0] >= 0.3 && sphere.decide(t, p, SelfMotion::default()).value >= cfg.alarm_threshold()
        });
        assert!(
            sphere_alarms,
            "the sphere model gates the car out too: the test shows nothing"
        );
        // the same car in the robot's lane is let through
        assert!(
            run_box(&cfg, 0.3, 0.4, car, 6.0)
                .iter()
                .any(|(_, d)| d.value >= cfg.alarm_threshold())
        );
        // a tall pole (2 m high, 0.3 m thick) the robot passes 0.3 m from its side
        let pole = [0.15, 0.15, 1.0];
        let passing_pole = run_box(&cfg, -(w + 0.3 + pole[1]), 0.7, pole, 3.0);
        assert!(passing_pole.iter().all(|(_, d)| d.value < cfg.alarm_threshold()));
        assert!(
            run_box(&cfg, 0.1, 0.7, pole, 3.0)
                .iter()
                .any(|(_, d)| d.value >= cfg.alarm_threshold())
        );
    }

    #[test]
    fn course_gate_closes_for_an_object_braking_to_a_stop_before_it_arrives() {
        let cfg = config(Course::Image);
        let r = 0.9;
        // drives at 6 m/s from 25 m, brakes at 3 m/s² from t = 1 s: stops 25 − 6 − 6 = 13 m away
        // at t = 3 s; the same object without braking arrives
        let position = |t: f64, brake: bool| {
            let tb = t.clamp(0.0, 1.0);
            let after = if brake {
                (t - 1.0).clamp(0.0, 2.0)
            } else {
                (t - 1.0).max(0.0)
            };
            25.0 - 6.0 * tb - 6.0 * after + if brake { 1.5 * after * after } else { 0.0 }
        };
        for brake in [true, false] {
            let mut s = cfg.decider(&RobotFacts::default());
            let mut alarm = false;
            let mut rate = None;
            for k in 0..480 {
                let t = k as f64 * DT;
                let d = position(t, brake);
                if d < 1.5 {
                    break;
                }
                let p = Percept {
                    value: 2.0 * (r / d).asin().to_degrees(),
                    azimuth_deg: Some(0.0),
                    elevation_deg: None,
                    extent: None,
                };
                let decision = s.decide(t, p, SelfMotion::default());
                alarm |= decision.value >= cfg.alarm_threshold();
                if (1.4..1.5).contains(&t) {
                    rate = decision.tau_rate;
                }
            }
            let rate = rate.expect("dτ/dt estimated");
            if brake {
                // dτ/dt = −1 + a·d/v² > −0.5 once it brakes hard enough to stop short
                assert!(!alarm, "braking: no alarm");
                assert!(rate > -0.5, "dτ/dt {rate}");
            } else {
                assert!(alarm, "constant speed: an alarm");
                assert!((rate + 1.0).abs() < 0.05, "dτ/dt {rate}");
            }
        }
    }

    #[test]
    fn course_gate_follows_a_lob_and_removes_the_cameras_own_shake() {
        let cfg = config(Course::Image);
        const G: f64 = 9.81;
        // a ball lobbed from 12 m ahead, 2 s flight, landing on the camera: x = 12 − 6t,
        // z = vz·t − g·t²/2 with vz = g (so z = 0 at t = 2 s); the camera pitches ±1.5° at 4 Hz
        let r = 0.2;
        let run = |aim_z: f64, shake: bool| {
            let mut s = cfg.decider(&RobotFacts::default());
            let mut first = None;
            for k in 0..240 {
                let t = k as f64 * DT;
                let (x, z) = (12.0 - 6.0 * t, aim_z * t / 2.0 + G * t - G * t * t / 2.0);
                if x.hypot(z) - r < 0.5 {
                    break;
                }
                let pitch = if shake {
                    1.5f64.to_radians() * (std::f64::consts::TAU * 4.0 * t).sin()
                } else {
                    0.0
                };
                let d = x.hypot(z);
                let half = (r / d).asin().to_degrees();
                let el = z.atan2(x).to_degrees() - pitch.to_degrees();
                let p = Percept {
                    value: 2.0 * half,
                    azimuth_deg: Some(0.0),
                    elevation_deg: Some(el),
                    extent: Some(ImageExtent {
                        azimuth_deg: [-half, half],
                        elevation_deg: [el - half, el + half],
                    }),
                };
                let motion = SelfMotion {
                    camera_pitch_rad: pitch,
                    ..SelfMotion::default()
                };
                let d = s.decide(t, p, motion);
                if d.value >= cfg.alarm_threshold() && first.is_none() {
                    first = Some(t);
                }
            }
            first
        };
        // τ̂ from θ: the alarm comes when the ball's image says it is 1 s away (a lob's distance
        // shrinks slowly while it rises: later than 1 s before it lands, 2 s)
        let hit = run(0.0, false).expect("a lob onto the camera is let through");
        assert!(hit < 1.5, "alarm at {hit:.3} s");
        // the same lob passing 1.5 m over the camera is not
        assert_eq!(run(1.5, false), None);
        // a shaking camera that knows its own rotation sees the same
        let shaken = run(0.0, true).expect("let through with camera shake");
        assert!((shaken - hit).abs() < 0.02, "{shaken:.3} vs {hit:.3}");
        assert_eq!(run(1.5, true), None);
    }

    #[test]
    fn course_gate_open_for_head_on_and_oblique_constant_bearing_collisions() {
        let cfg = config(Course::Image);
        // head-on, robot driving
        let head_on = Approach {
            r: 0.15,
            p0: [20.0, 0.0],
            u: [-9.0, 0.0],
            camera_vx: 1.0,
        };
        // oblique: arrives at the camera at t = 2 s from 35° to the right while the robot drives at
        // 1.5 m/s: relative position (2 − t)·w, a constant bearing
        let (t_hit, bearing) = (2.0f64, 35f64.to_radians());
        let (vx, rel_speed) = (1.5, 7.0);
        let w = [-rel_speed * bearing.cos(), rel_speed * bearing.sin()];
        let oblique = Approach {
            r: 0.2,
            p0: [-w[0] * t_hit, -w[1] * t_hit],
            u: [w[0] + vx, w[1]],
            camera_vx: vx,
        };
        for a in [head_on, oblique] {
            let frames = run(&cfg, &a, 0.05);
            let alarm = frames
                .iter()
                .find(|(_, _, d)| d.value >= cfg.alarm_threshold())
                .expect("the gate lets the collision course through");
            let [x, y] = a.rel(alarm.0);
            let ttc = (x.hypot(y) - a.r) / (a.u[0] - a.camera_vx).hypot(a.u[1]);
            assert!((ttc - 1.0).abs() < 0.05, "alarm at true TTC {ttc:.3}");
            assert!(alarm.2.miss_radii.unwrap().abs() < 0.2, "μ = {:?}", alarm.2.miss_radii);
        }
    }

    #[test]
    fn the_controller_runs_the_strategy_and_compares_the_urgency() {
        let cfg = config(Course::Off);
        assert_eq!(cfg.alarm_threshold(), 1.0);
        let mut c = EscapeController::new(cfg, RobotFacts::default()).unwrap();
        let a = Approach {
            r: 0.2,
            p0: [12.0, 0.0],
            u: [-8.0, 0.0],
            camera_vx: 1.0,
        };
        let cruise = VelocityCommand::forward(1.0);
        let mut trigger = None;
        for k in 0..200 {
            let t = k as f64 * DT;
            let v = c.perceive(t, a.percept(t), cruise, [0.0; 3]).value;
            if c.step(t, v, Some(0.5), cruise).1.is_trigger() {
                trigger = Some(t);
                break;
            }
        }
        let t = trigger.expect("a trigger");
        assert!((a.surface_ttc(t) - 1.0).abs() < 0.05);
        // reset forgets the window
        c.reset();
        assert_eq!(c.perceive(0.0, a.percept(0.0), cruise, [0.0; 3]).value, 0.0);
    }

    #[test]
    fn invalid_strategy_combinations_are_rejected() {
        let e = EscapeController::new(
            EscapeConfig {
                decision: loomlab_agents::DecisionRule {
                    trigger: TriggerSignal::Output,
                    course: Course::Image,
                    ..loomlab_agents::DecisionRule::default()
                },
                ..EscapeConfig::default()
            },
            RobotFacts::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("escape.course") && e.contains("θ̂"), "{e}");
        for cfg in [
            EscapeConfig {
                decision: loomlab_agents::DecisionRule {
                    tau_threshold_s: 0.0,
                    ..config(Course::Off).decision
                },
                ..config(Course::Off)
            },
            EscapeConfig {
                decision: loomlab_agents::DecisionRule {
                    tau_window_s: f64::NAN,
                    ..config(Course::Off).decision
                },
                ..config(Course::Off)
            },
            EscapeConfig {
                decision: loomlab_agents::DecisionRule {
                    min_angular_size_deg: -1.0,
                    ..config(Course::Off).decision
                },
                ..config(Course::Off)
            },
        ] {
            assert!(EscapeController::new(cfg, RobotFacts::default()).is_err());
        }
        let cfg: EscapeConfig =
            serde_json::from_str(r#"{"trigger":"angular_size","course":"image","tau_threshold_s":0.8}"#).unwrap();
        assert_eq!(cfg.decision.trigger, TriggerSignal::AngularSizeDeg);
        assert_eq!(cfg.decision.course, Course::Image);
        let cfg: EscapeConfig = serde_json::from_str(r#"{"trigger":"tau"}"#).unwrap();
        assert_eq!(cfg.decision.trigger, TriggerSignal::Tau);
    }

    /// A default controller whose manoeuvre lasts `duration_s` and its cooldown `cooldown_s`.
    fn timed_controller(duration_s: f64, cooldown_s: f64) -> EscapeController {
        EscapeController::new(
            EscapeConfig {
                duration_s,
                cooldown_s,
                ..EscapeConfig::default()
            },
            RobotFacts::default(),
        )
        .unwrap()
    }

    #[test]
    fn a_retrigger_while_the_object_still_looms_keeps_the_side() {
        // side_memory_s 0.5 (the default)
        let mut c = timed_controller(0.5, 0.25);
        let cruise = VelocityCommand::forward(1.0);
        // object on the right: dodge left
        assert_eq!(
            c.step(0.0, 20.0, Some(0.6), cruise).1,
            loomlab_agents::ControllerEvent::Triggered {
                side: Some(DodgeSide::Left)
            }
        );
        // still looming when the cooldown ends, now seen left of centre: keep dodging left
        c.step(0.5, 20.0, Some(-0.6), cruise);
        let (cmd, ev) = c.step(0.75, 20.0, Some(-0.6), cruise);
        assert_eq!(
            ev,
            loomlab_agents::ControllerEvent::Triggered {
                side: Some(DodgeSide::Left)
            }
        );
        assert!(cmd.lateral_mps > 0.0);
        // a new looming event (no alarm for longer than side_memory_s) takes the side afresh
        c.step(1.3, 0.0, Some(-0.6), cruise);
        let (_, ev) = c.step(2.5, 20.0, Some(-0.6), cruise);
        assert_eq!(
            ev,
            loomlab_agents::ControllerEvent::Triggered {
                side: Some(DodgeSide::Right)
            }
        );
    }

    #[test]
    fn a_retrigger_soon_after_rearming_does_not_undo_the_dodge() {
        // side_memory_s 0.5 (the default)
        let mut c = timed_controller(0.5, 0.25);
        let cruise = VelocityCommand::forward(1.0);
        let triggered = |side| loomlab_agents::ControllerEvent::Triggered { side: Some(side) };
        // a brief alarm, object seen on the right: dodge left; the alarm clears at once
        assert_eq!(c.step(0.0, 20.0, Some(0.6), cruise).1, triggered(DodgeSide::Left));
        c.step(0.05, 0.0, Some(0.6), cruise);
        // re-armed at 0.75 (no alarm since 0.0, longer ago than side_memory_s); an alarm 0.2 s
        // later with the (noisy) side flipped keeps dodging left instead of undoing the dodge
        c.step(0.75, 0.0, None, cruise);
        let (cmd, ev) = c.step(0.95, 20.0, Some(-0.6), cruise);
        assert_eq!(ev, triggered(DodgeSide::Left));
        assert!(cmd.lateral_mps > 0.0);
        // more than side_memory_s after re-arming (at 1.7), a flipped side is taken afresh
        c.step(1.7, 0.0, None, cruise);
        c.set_object(Some(3));
        let (_, ev) = c.step(2.3, 20.0, Some(-0.6), cruise);
        assert_eq!(ev, triggered(DodgeSide::Right));
        // a different object (both named by the caller) is dodged afresh right after re-arming
        c.step(3.05, 0.0, None, cruise);
        c.set_object(Some(7));
        let (_, ev) = c.step(3.1, 20.0, Some(0.6), cruise);
        assert_eq!(ev, triggered(DodgeSide::Left));
    }

    #[test]
    fn an_alarm_about_another_named_object_preempts_the_manoeuvre_and_its_cooldown() {
        let mut c = timed_controller(0.5, 0.5);
        let cruise = VelocityCommand::forward(1.0);
        let triggered = |side| loomlab_agents::ControllerEvent::Triggered { side: Some(side) };
        c.set_object(Some(1));
        assert_eq!(c.step(0.0, 20.0, Some(0.6), cruise).1, triggered(DodgeSide::Left));
        // the same object alarming during the manoeuvre and the cooldown: no re-trigger
        assert!(matches!(
            c.step(0.2, 20.0, Some(0.6), cruise).1,
            loomlab_agents::ControllerEvent::Manoeuvring { .. }
        ));
        assert_eq!(
            c.step(0.7, 20.0, Some(0.6), cruise).1,
            loomlab_agents::ControllerEvent::Cooldown
        );
        // another object, seen on the left, alarming in the cooldown: dodged at once, to the right
        c.set_object(Some(2));
        assert_eq!(c.step(0.8, 20.0, Some(-0.6), cruise).1, triggered(DodgeSide::Right));
        assert_eq!(c.triggers(), 2);
        // unnamed values are all taken to be about one object: no pre-emption
        let mut c = timed_controller(0.5, 0.5);
        c.step(0.0, 20.0, Some(0.6), cruise);
        assert_eq!(
            c.step(0.8, 20.0, Some(-0.6), cruise).1,
            loomlab_agents::ControllerEvent::Cooldown
        );
    }
}

#[test]
fn repeated_dodges_to_one_side_stop_at_the_maximum_offset() {
    // dodge 1.5 m/s for 0.5 s, 0.25 s cooldown, then the same side again: without a limit the
    // body ends about 1.9 m to the left; with max_dodge_offset_m = 1.0 it sidesteps until the
    // body, braking at the drive's 2.5 m/s², comes to rest at 1.0 m, and then holds its lateral
    // position (forward motion continues). The body, not the commands, keeps within the limit: a
    // rule on the commanded sidestep alone let it run on 0.45 m past it.
    let limited_to = |limit: Option<f64>| {
        EscapeController::new(
            EscapeConfig {
                max_dodge_offset_m: limit,
                ..controller(Manoeuvre::DodgeLateral).config().clone()
            },
            RobotFacts::default(),
        )
        .unwrap()
    };
    let run = |limit: Option<f64>| {
        let mut c = limited_to(limit);
        let dt = 0.01;
        // the body as the drive moves it (its acceleration limit), its sidestep off the cruise
        let mut body = Odometry {
            velocity: [CRUISE.forward_mps, 0.0, CRUISE.yaw_rate_rps],
            ..Odometry::default()
        };
        let mut offset = 0.0;
        let mut held_forward = true;
        for k in 0..300 {
            // the looming side on the right all the time: every trigger dodges left
            let (cmd, _) = c.step(k as f64 * dt, if k < 200 { 20.0 } else { 0.0 }, Some(0.5), CRUISE);
            let before = body.velocity[1];
            body.advance(&cmd, dt, &RobotFacts::default());
            offset += (before + body.velocity[1]) / 2.0 * dt;
            held_forward &= cmd.forward_mps > 0.0;
        }
        assert!(held_forward);
        assert!(body.velocity[1].abs() < 1e-9, "at rest sideways: {body:?}");
        (offset, c.triggers())
    };
    let (free, triggers) = run(None);
    assert_eq!(triggers, 3);
    assert!(free > 1.8, "{free}");
    let (limited, triggers) = run(Some(1.0));
    assert_eq!(triggers, 3, "the limit holds the sidestep, not the triggers");
    // within about one step of the sidestep (1.5 m/s × 10 ms) of the limit
    assert!(limited <= 1.0 + 0.025 && limited > 0.95, "{limited}");
    // a dodge back towards the path is never held
    let mut c = limited_to(Some(0.5));
    for k in 0..130 {
        // one dodge left (held at 0.5 m), then quiet until side memory has passed
        let signal = if k < 50 { 20.0 } else { 0.0 };
        c.step(k as f64 * 0.01, signal, Some(0.5), CRUISE);
    }
    let (cmd, ev) = c.step(1.3, 20.0, Some(-0.5), CRUISE);
    assert!(ev.is_escaping());
    assert!(cmd.lateral_mps < 0.0, "{cmd:?}");
    assert!(matches!(
        EscapeController::new(
            EscapeConfig {
                max_dodge_offset_m: Some(0.0),
                ..EscapeConfig::default()
            },
            RobotFacts::default()
        ),
        Err(AgentError::InvalidConfig {
            key: "escape.max_dodge_offset_m",
            ..
        })
    ));
}

/// The escape agent with a detector that numbers its tracks (`tracker`): an alarm about another
/// track is dodged afresh, during the manoeuvre started for the first.
mod named_tracks {
    use loomlab_agents::RobotFacts;
    use loomlab_agents::{ControllerEvent, DodgeSide, EscapeAgent, EscapeConfig, VelocityCommand};
    use loomlab_detector::{Detector, DetectorError, Frame, ImageRegion, Signals};

    /// Replays a script of (θ̂ in degrees, region x extent, track number), one entry per frame.
    struct Script(std::vec::IntoIter<(f64, [f64; 2], usize)>);

    impl Detector for Script {
        fn id(&self) -> &'static str {
            "script"
        }
        fn reset(&mut self) {}
        fn step(&mut self, _frame: &Frame) -> Result<Signals, DetectorError> {
            let (theta, x, track) = self.0.next().expect("a scripted frame");
            Ok(Signals {
                output: theta,
                angular_size_deg: Some(theta),
                aux: Vec::new(),
                region: Some(ImageRegion {
                    centroid: [(x[0] + x[1]) / 2.0, 0.0],
                    x,
                    y: [-0.1, 0.1],
                    track: Some(track),
                }),
                objects: Vec::new(),
            })
        }
    }

    #[test]
    fn an_alarm_about_another_track_preempts_the_manoeuvre_and_dodges_away_from_it() {
        // track 1 (a passing car) on the right alarms: dodge left; 0.1 s into the manoeuvre track 2,
        // on the left, alarms: dodged at once, to the right
        let right = [0.4, 0.6];
        let left = [-0.6, -0.4];
        let script = vec![
            (5.0, right, 1),
            (20.0, right, 1),
            (20.0, right, 1),
            (20.0, left, 2),
            (20.0, left, 2),
        ];
        let config = EscapeConfig {
            duration_s: 0.6,
            cooldown_s: 0.5,
            decision: loomlab_agents::DecisionRule {
                threshold: 10.0,
                ..loomlab_agents::DecisionRule::default()
            },
            ..EscapeConfig::default()
        };
        let mut agent = EscapeAgent::new(
            vec![Box::new(Script(script.into_iter()))],
            config,
            RobotFacts::default(),
        )
        .unwrap();
        let frame = Frame::from_f32(8, vec![0.5; 64]).unwrap();
        let cruise = VelocityCommand::forward(1.0);
        let events: Vec<ControllerEvent> = (0..5)
            .map(|k| agent.step(k as f64 * 0.05, &frame, cruise).unwrap().event)
            .collect();
        let triggered = |side| ControllerEvent::Triggered { side: Some(side) };
        assert_eq!(events[0], ControllerEvent::Cruise);
        assert_eq!(events[1], triggered(DodgeSide::Left));
        assert_eq!(
            events[2],
            ControllerEvent::Manoeuvring {
                side: Some(DodgeSide::Left)
            }
        );
        assert_eq!(
            events[3],
            triggered(DodgeSide::Right),
            "another track pre-empts the manoeuvre"
        );
        assert_eq!(
            events[4],
            ControllerEvent::Manoeuvring {
                side: Some(DodgeSide::Right)
            }
        );
        assert_eq!(agent.controller().triggers(), 2);
    }
}

/// A detector that localises the object: the escape side comes from the collision-course gate's
/// predicted arrival, not from where the object is now.
mod arrival_side {
    use loomlab_agents::RobotFacts;
    use loomlab_agents::{
        ControllerEvent, Course, DodgeSide, EscapeAgent, EscapeConfig, TriggerSignal, VelocityCommand,
    };
    use loomlab_detector::{Detector, DetectorError, Frame, ImageRegion, Signals};

    const DT: f64 = 1.0 / 120.0;

    /// A ball of radius 0.15 m closing at 10 m/s from 10 m at the camera's height, crossing from
    /// 1 m left of the camera to arrive 0.25 m right of it: its image box, frame after frame.
    struct Crossing(usize);

    impl Detector for Crossing {
        fn id(&self) -> &'static str {
            "crossing"
        }
        fn reset(&mut self) {
            self.0 = 0;
        }
        fn step(&mut self, _frame: &Frame) -> Result<Signals, DetectorError> {
            let t = self.0 as f64 * DT;
            self.0 += 1;
            let (radius, d) = (0.15, 10.0 - 10.0 * t);
            let lateral = -1.0 + 1.25 * t;
            let scale = (30.0f64).to_radians().tan();
            let (x, half) = (lateral / d / scale, radius / d / scale);
            let theta = 2.0 * (radius / d).atan().to_degrees();
            Ok(Signals {
                output: theta,
                angular_size_deg: Some(theta),
                aux: Vec::new(),
                region: Some(ImageRegion {
                    centroid: [x, 0.0],
                    x: [x - half, x + half],
                    y: [-half, half],
                    track: Some(1),
                }),
                objects: Vec::new(),
            })
        }
    }

    #[test]
    fn an_object_seen_on_the_left_that_will_arrive_on_the_right_is_dodged_to_the_left() {
        let config = EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                trigger: TriggerSignal::Tau,
                course: Course::Image,
                ..loomlab_agents::DecisionRule::default()
            },
            ..EscapeConfig::default()
        };
        let mut agent = EscapeAgent::new(vec![Box::new(Crossing(0))], config, RobotFacts::default()).unwrap();
        let frame = Frame::from_f32(8, vec![0.5; 64]).unwrap();
        let cruise = VelocityCommand::forward(0.0);
        let (k, side, looming) = (0..100)
            .find_map(|k| {
                let step = agent.step(k as f64 * DT, &frame, cruise).unwrap();
                match step.event {
                    ControllerEvent::Triggered { side } => Some((k, side, step.looming_side)),
                    _ => None,
                }
            })
            .expect("the crossing ball on a collision course alarms");
        // where the ball is when the alarm comes: left of the axis
        let lateral = -1.0 + 1.25 * k as f64 * DT;
        assert!(lateral < 0.0, "the ball is {lateral:.2} m left at the alarm");
        assert_eq!(looming, Some(1.0), "the side it arrives on");
        assert_eq!(side, Some(DodgeSide::Left));
    }
}

/// The scenario runner's closed-loop tails: an agent replayed on the signals its detector gave up
/// to the alarm frame, then handed a copy of that detector taken there, continues exactly like the
/// agent that stepped its detector all along.
mod replay_on_signals {
    use loomlab_agents::RobotFacts;
    use loomlab_agents::{
        ControllerEvent, EscapeAgent, EscapeConfig, LoomingSideEstimator, TriggerSignal, VelocityCommand,
    };
    use loomlab_detector::{DetectorSet, Frame};

    const N: usize = 32;

    /// A dark disc growing in front of a uniform background, its centre drifting left.
    fn frame(k: usize) -> Frame {
        let radius = 1.5 + 0.25 * k as f64;
        let (ci, cj) = (N as f64 / 2.0, N as f64 / 2.0 - 0.05 * k as f64);
        let data = (0..N * N)
            .map(|p| {
                let (i, j) = ((p / N) as f64 + 0.5, (p % N) as f64 + 0.5);
                if (i - ci).hypot(j - cj) < radius { 0.1 } else { 0.8 }
            })
            .collect();
        Frame::from_f32(N, data).unwrap()
    }

    #[test]
    fn an_agent_replayed_on_signals_then_given_a_detector_copy_continues_identically() {
        let config = EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                trigger: TriggerSignal::AngularSizeDeg,
                threshold: 12.0,
                ..loomlab_agents::DecisionRule::default()
            },
            ..EscapeConfig::default()
        };
        let cruise = VelocityCommand::forward(1.0);
        let dt = 1.0 / 120.0;
        let build = || DetectorSet::default().build("tracker", N).unwrap();
        let mut stepping = EscapeAgent::new(vec![build()], config.clone(), RobotFacts::default()).unwrap();
        let steps: Vec<_> = (0..80)
            .map(|k| stepping.step_posed(k as f64 * dt, &frame(k), cruise, None).unwrap())
            .collect();
        let alarm = steps
            .iter()
            .position(|s| matches!(s.event, ControllerEvent::Triggered { .. }))
            .expect("the growing disc alarms");
        // the same detector stepped on the same frames, copied right after the alarm frame
        // (until the alarm the agent applies the cruise command: that is its efference copy)
        let mut open_loop = build();
        let mut side = LoomingSideEstimator::default();
        let sides: Vec<Option<f32>> = (0..=alarm).map(|k| side.update(&frame(k))).collect();
        for (k, step) in steps.iter().enumerate().take(alarm + 1) {
            let signals = open_loop.step_moving(&frame(k), &cruise.efference_copy()).unwrap();
            // (Debug strings: bit for bit, NaN included)
            let (bare, agents) = (format!("{signals:?}"), format!("{:?}", step.signals[0]));
            assert_eq!(
                bare, agents,
                "frame {k}: the agent's detector sees what a bare one sees"
            );
        }
        let copy = open_loop.snapshot().expect("the tracker copies itself");
        let mut replayed = EscapeAgent::new(vec![copy], config, RobotFacts::default()).unwrap();
        for (k, step) in steps.iter().enumerate() {
            let got = if k <= alarm {
                let signals = step.signals.clone();
                replayed.step_posed_with_signals(k as f64 * dt, &frame(k), cruise, None, signals, sides[k])
            } else {
                replayed.step_posed(k as f64 * dt, &frame(k), cruise, None).unwrap()
            };
            assert_eq!(
                format!("{got:?}"),
                format!("{step:?}"),
                "frame {k} (alarm at frame {alarm})"
            );
        }
    }
}

/// The decision values of a persistence rule (K, window M) over raw values, one frame at 120 Hz.
fn persisted(trigger: TriggerSignal, k: usize, m: Option<usize>, raw: &[f64]) -> Vec<f64> {
    use loomlab_agents::{Percept, SelfMotion};
    let cfg = EscapeConfig {
        decision: loomlab_agents::DecisionRule {
            trigger,
            persistence_frames: k,
            persistence_window_frames: m,
            ..loomlab_agents::DecisionRule::default()
        },
        ..Default::default()
    };
    cfg.validate().unwrap();
    let mut s = cfg.decider(&RobotFacts::default());
    raw.iter()
        .enumerate()
        .map(|(i, &v)| {
            let p = Percept {
                value: v,
                ..Default::default()
            };
            s.decide(i as f64 / 120.0, p, SelfMotion::default()).value
        })
        .collect()
}

/// `persistence_frames = K`: the decision value is the smallest of the last K values (the idle
/// value before K frames), so for every threshold it alarms exactly where the raw value was at or
/// above it on K consecutive frames; K = 1 passes the value through.
#[test]
fn persistence_is_the_minimum_of_the_last_frames_for_any_threshold() {
    let raw = [5.0, 5.0, 1.0, 5.0, 5.0, 5.0, 2.0, 7.0, 7.0, 7.0];
    for (trigger, idle) in [(TriggerSignal::Output, f64::NAN), (TriggerSignal::AngularSizeDeg, 0.0)] {
        let run = |k: usize| persisted(trigger, k, None, &raw);
        assert_eq!(run(1), raw.to_vec());
        let three = run(3);
        let expected = [idle, idle, 1.0, 1.0, 1.0, 5.0, 2.0, 2.0, 2.0, 7.0];
        for (got, want) in three.iter().zip(expected) {
            assert!(got == &want || (got.is_nan() && want.is_nan()), "{three:?}");
        }
        for threshold in [0.5, 1.0, 2.0, 3.0, 5.0, 6.0, 7.0, 8.0] {
            for k in 2..raw.len() {
                let held = raw[k - 2..=k].iter().all(|&v| v >= threshold);
                assert_eq!(three[k] >= threshold, held, "threshold {threshold}, frame {k}");
            }
        }
    }
    // bounded, and named in the error
    for k in [0, loomlab_agents::decision::MAX_PERSISTENCE_FRAMES + 1] {
        let e = EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                persistence_frames: k,
                ..loomlab_agents::DecisionRule::default()
            },
            ..Default::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("escape.persistence_frames"), "{e}");
    }
}

/// `persistence_window_frames = M > K`: the decision value is the K-th largest of the last M
/// values that are numbers (idle while fewer than K are), so for every threshold it alarms exactly
/// where the raw value was at or above it on at least K of the last M frames; M = K is the
/// consecutive rule, value for value.
#[test]
fn a_persistence_window_alarms_on_any_k_of_the_last_m_frames_for_any_threshold() {
    let raw = [5.0, 1.0, 5.0, 5.0, f64::NAN, 6.0, 2.0, 7.0, 0.5, 7.0, 7.0, 3.0];
    for (trigger, idle) in [(TriggerSignal::Output, f64::NAN), (TriggerSignal::AngularSizeDeg, 0.0)] {
        let run = |k: usize, m: Option<usize>| persisted(trigger, k, m, &raw);
        let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
        for k in 1..5 {
            assert!(same(&run(k, None), &run(k, Some(k))), "M = K = {k}");
        }
        let (k, m) = (3, 5);
        let values = run(k, Some(m));
        for (i, v) in values.iter().enumerate() {
            let window: Vec<f64> = raw[i.saturating_sub(m - 1)..=i]
                .iter()
                .copied()
                .filter(|v| !v.is_nan())
                .collect();
            if window.len() < k {
                assert!(v == &idle || (v.is_nan() && idle.is_nan()), "frame {i}: {values:?}");
                continue;
            }
            for threshold in [0.5, 1.0, 2.0, 3.0, 5.0, 6.0, 7.0, 8.0] {
                let held = window.iter().filter(|&&x| x >= threshold).count() >= k;
                assert_eq!(*v >= threshold, held, "threshold {threshold}, frame {i}: {values:?}");
            }
        }
        // a one-frame dip does not restart the count, as it does for consecutive frames
        assert!(values[7] >= 5.0 && run(k, None)[7] < 5.0, "{values:?}");
    }
    // at least K and bounded, named in the error
    for (k, m) in [(3, 2), (3, loomlab_agents::decision::MAX_PERSISTENCE_FRAMES + 1)] {
        let e = EscapeConfig {
            decision: loomlab_agents::DecisionRule {
                persistence_frames: k,
                persistence_window_frames: Some(m),
                ..loomlab_agents::DecisionRule::default()
            },
            ..Default::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("escape.persistence_window_frames") && e.contains("persistence_frames (3)"),
            "{e}"
        );
    }
}
