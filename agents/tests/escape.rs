//! Escape controller: every manoeuvre, cooldown, threshold crossing, dodge side.

use loomlab_agents::{
    AgentError, ControllerEvent, DodgeSide, EscapeConfig, EscapeController, Manoeuvre, TriggerSignal, VelocityCommand,
};
use loomlab_detector::Signals;

const CRUISE: VelocityCommand = VelocityCommand {
    forward_mps: 2.0,
    yaw_rate_rps: 0.1,
    lateral_mps: 0.0,
};

fn controller(manoeuvre: Manoeuvre) -> EscapeController {
    EscapeController::new(EscapeConfig {
        manoeuvre,
        threshold: 10.0,
        dodge_speed_mps: 1.5,
        dodge_forward_scale: 0.5,
        dodge_yaw_rate_rps: 0.0,
        reverse_speed_mps: 0.8,
        duration_s: 0.5,
        cooldown_s: 0.25,
        ..EscapeConfig::default()
    })
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
    };
    let mut hop = controller(Manoeuvre::Stop);
    assert!(!hop.step_signals(0.0, &s, None, CRUISE).1.is_trigger(), "θ̂ = 3° < 10°");
    let mut out = EscapeController::new(EscapeConfig {
        trigger: TriggerSignal::Output,
        threshold: 40.0,
        ..EscapeConfig::default()
    })
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
        let mut c = EscapeController::new(EscapeConfig {
            default_side: DodgeSide::Right,
            ..EscapeConfig::default()
        })
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
    let mut c = EscapeController::new(EscapeConfig {
        dodge_yaw_rate_rps: 0.7,
        ..EscapeConfig::default()
    })
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
    let mut c = EscapeController::new(EscapeConfig {
        manoeuvre: Manoeuvre::Stop,
        duration_s: 0.5,
        cooldown_s: 0.0,
        ..EscapeConfig::default()
    })
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
            threshold: f64::NAN,
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
        match EscapeController::new(cfg) {
            Err(e @ AgentError::InvalidConfig { .. }) => assert!(e.to_string().contains(key), "{e}"),
            other => panic!("expected InvalidConfig for {key}, got {other:?}"),
        }
    }
}

#[test]
fn config_serde_defaults_and_unknown_keys() {
    let cfg: EscapeConfig =
        serde_json::from_str(r#"{"trigger":"output","threshold":3.5,"manoeuvre":"reverse"}"#).unwrap();
    assert_eq!(cfg.trigger, TriggerSignal::Output);
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
    let diff = EscapeConfig {
        base: loomlab_sim::RobotBase::DiffDrive,
        ..EscapeConfig::default()
    };
    for side in [DodgeSide::Left, DodgeSide::Right] {
        let h = holonomic.manoeuvre_command(side, cruise);
        assert_eq!(h.lateral_mps, side.sign() * holonomic.dodge_speed_mps);
        let d = diff.manoeuvre_command(side, cruise);
        assert_eq!(d.lateral_mps, 0.0);
        assert_eq!(d.yaw_rate_rps, side.sign() * diff.turn_rate_rps);
        assert_eq!(d.forward_mps, diff.dodge_speed_mps.max(1.0));
    }
}
