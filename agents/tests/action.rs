//! RL action adapters.

use loomlab_agents::{ActionConfig, AgentError, ContinuousAction, DiscreteAction, VelocityCommand};

const CRUISE: VelocityCommand = VelocityCommand {
    forward_mps: 2.0,
    yaw_rate_rps: 0.1,
    lateral_mps: 0.0,
};

#[test]
fn discrete_actions_map_to_commands() {
    let cfg = ActionConfig {
        dodge_speed_mps: 1.2,
        ..ActionConfig::default()
    };
    assert_eq!(DiscreteAction::None.to_command(CRUISE, &cfg), CRUISE);
    assert_eq!(
        DiscreteAction::DodgeLeft.to_command(CRUISE, &cfg),
        VelocityCommand {
            lateral_mps: 1.2,
            ..CRUISE
        }
    );
    assert_eq!(
        DiscreteAction::DodgeRight.to_command(CRUISE, &cfg),
        VelocityCommand {
            lateral_mps: -1.2,
            ..CRUISE
        }
    );
    assert_eq!(DiscreteAction::Stop.to_command(CRUISE, &cfg), VelocityCommand::STOP);
}

#[test]
fn discrete_index_round_trip_and_errors() {
    for (i, a) in DiscreteAction::ALL.iter().enumerate() {
        assert_eq!(a.index(), i);
        assert_eq!(DiscreteAction::from_index(i as i64).unwrap(), *a);
    }
    for bad in [-1, 4, 100] {
        let e = DiscreteAction::from_index(bad).unwrap_err();
        assert_eq!(e, AgentError::InvalidDiscreteAction { index: bad, count: 4 });
        assert!(e.to_string().contains("0..4"));
    }
}

#[test]
fn continuous_action_scales_by_maxima() {
    let cfg = ActionConfig {
        max_forward_mps: 4.0,
        max_yaw_rate_rps: 2.0,
        max_lateral_mps: 1.0,
        ..Default::default()
    };
    let cmd = ContinuousAction([0.5, -1.0, 0.25]).to_command(&cfg).unwrap();
    assert_eq!(
        cmd,
        VelocityCommand {
            forward_mps: 2.0,
            yaw_rate_rps: -2.0,
            lateral_mps: 0.25
        }
    );
}

#[test]
fn continuous_action_rejects_nan_and_infinity_even_when_clamping() {
    let cfg = ActionConfig::default();
    for (a, idx) in [
        ([f32::NAN, 0.0, 0.0], 0),
        ([0.0, f32::INFINITY, 0.0], 1),
        ([0.0, 0.0, f32::NEG_INFINITY], 2),
    ] {
        for r in [
            ContinuousAction(a).to_command(&cfg),
            ContinuousAction(a).to_command_clamped(&cfg),
        ] {
            match r {
                Err(AgentError::NonFiniteAction { index, .. }) => assert_eq!(index, idx),
                other => panic!("expected NonFiniteAction, got {other:?}"),
            }
        }
    }
}

#[test]
fn continuous_action_out_of_range_errors_or_clamps() {
    let cfg = ActionConfig {
        max_forward_mps: 4.0,
        max_yaw_rate_rps: 2.0,
        max_lateral_mps: 1.0,
        ..Default::default()
    };
    let a = ContinuousAction([1.5, 0.0, -3.0]);
    let e = a.to_command(&cfg).unwrap_err();
    assert!(
        matches!(
            e,
            AgentError::ActionOutOfRange {
                index: 0,
                name: "forward",
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("outside [-1, 1]"));
    let cmd = a.to_command_clamped(&cfg).unwrap();
    assert_eq!(
        cmd,
        VelocityCommand {
            forward_mps: 4.0,
            yaw_rate_rps: 0.0,
            lateral_mps: -1.0
        }
    );
    assert_eq!(a.clamped().unwrap(), ContinuousAction([1.0, 0.0, -1.0]));
}

#[test]
fn action_config_validation_names_the_key() {
    let e = ActionConfig {
        max_lateral_mps: 0.0,
        ..Default::default()
    }
    .validate()
    .unwrap_err();
    assert!(e.to_string().contains("action.max_lateral_mps"), "{e}");
    ActionConfig::default().validate().unwrap();
}
