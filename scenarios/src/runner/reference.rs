//! The reference rows of an episode and the closed loops of its ideal observers.

use loomlab_agents::{DecisionRule, EscapeAgent, SelfMotion, TriggerSignal, VelocityCommand};
use loomlab_sim::{ObjectTruth, Sim};

use super::Ctx;
use super::motion::{open_loop_motion, shake_at};
use super::rows::{Row, Tail};
use super::trace::ClosedLoop;
use crate::deadline::EscapeDeadline;
use crate::error::RunError;
use crate::reference::{
    IDEAL_COURSE, IDEAL_TAU, IDEAL_THETA, INDICATOR_THRESHOLD, IdealKind, IdealObserver, NULL, ORACLE,
};
use crate::schema::EpisodeSpec;
use crate::truth::Impact;

/// The closed loop of an ideal reference row (see [`crate::reference`]) whose first alarm is
/// open-loop frame `ka`: physics only, the escape agent driven by the ideal observer on ground
/// truth (the open-loop pass's up to the alarm, the simulator's after it).
pub(super) fn ideal_tail(
    c: &Ctx<'_>,
    label: &str,
    kind: IdealKind,
    truth: &[Vec<ObjectTruth>],
    ka: usize,
) -> Result<ClosedLoop, RunError> {
    let ep = c.ep;
    let mut sim = Sim::new_physics_only(&ep.world, ep.seed).map_err(|e| c.sim(e))?;
    sim.set_ground_truth(false);
    let mut observer = IdealObserver::new(
        kind,
        &ep.controller,
        ep.facts,
        ideal_theta_threshold_deg(ep),
        ep.frame_period_s(),
    );
    let mut agent =
        EscapeAgent::new(Vec::new(), observer.config().clone(), ep.facts).map_err(|source| RunError::Controller {
            scenario: ep.scenario.clone(),
            episode: ep.index,
            source,
        })?;
    let camera = sim.camera().clone();
    let mut decide = |agent: &mut EscapeAgent, t: f64, truth: &[ObjectTruth], applied: VelocityCommand| {
        let motion = SelfMotion::of(applied, camera.shake_rotation(t));
        let (value, side, object) = observer.update(t, truth, motion);
        let cruise = ep.cruise.command_at(t);
        for (id, decision) in observer.decisions() {
            agent.observe(t, *id, decision, cruise);
        }
        agent.act_on_value(t, side, value, object, cruise).command
    };
    let mut cmd = ep.cruise.command_at(0.0);
    let mut previous_t = None;
    for row in &truth[..=ka] {
        let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
        // before the alarm the agent cruises: the open loop's ego motion
        let applied = ep.cruise.command_at(previous_t.unwrap_or(out.t_s));
        previous_t = Some(out.t_s);
        cmd = decide(&mut agent, out.t_s, row, applied);
    }
    sim.set_ground_truth(true);
    let mut collision = None;
    for _ in ka + 1..ep.frames() {
        let applied = cmd;
        let out = sim.step(&cmd.to_sim()).map_err(|e| c.sim(e))?;
        if let Some(ct) = out.first_collision() {
            collision = Some(Impact::from(ct));
            break;
        }
        cmd = decide(&mut agent, out.t_s, &out.truth, applied);
    }
    Ok(ClosedLoop {
        label: label.to_string(),
        simulated: true,
        triggers: agent.controller().triggers(),
        collision,
        frames_rendered: 0,
    })
}

/// The reference rows of an episode (see [`crate::reference`]) over its open-loop frames.
pub(super) fn reference_rows<'a>(
    ep: &EpisodeSpec,
    truth: &[Vec<ObjectTruth>],
    t_s: &[f64],
    deadline: Option<&EscapeDeadline>,
    threat_object: Option<usize>,
) -> Vec<Row<'a>> {
    let frames = t_s.len();
    // the world was built for the open-loop pass, so its camera builds
    let camera = ep.world.camera.build(ep.seed).ok();
    let indicator = |k: Option<usize>| -> Vec<f64> {
        (0..frames)
            .map(|i| if Some(i) == k { INDICATOR_THRESHOLD } else { 0.0 })
            .collect()
    };
    let row = |label: &str, trigger, threshold, signal: Vec<f64>, tail| Row {
        label: label.to_string(),
        trigger,
        threshold,
        output: signal.clone(),
        signal,
        raw: None,
        estimates: None,
        about_mask: None,
        regions: None,
        about_threat: None,
        tail,
    };
    let mut rows = vec![
        row(
            NULL,
            TriggerSignal::Output,
            INDICATOR_THRESHOLD,
            indicator(None),
            Tail::Replay,
        ),
        row(
            ORACLE,
            TriggerSignal::Output,
            INDICATOR_THRESHOLD,
            indicator(deadline.and_then(|d| d.frame)),
            Tail::Replay,
        ),
    ];
    for (label, kind) in [
        (IDEAL_THETA, IdealKind::Theta),
        (IDEAL_TAU, IdealKind::Tau),
        (IDEAL_COURSE, IdealKind::Course),
    ] {
        let observer = || {
            IdealObserver::new(
                kind,
                &ep.controller,
                ep.facts,
                ideal_theta_threshold_deg(ep),
                ep.frame_period_s(),
            )
        };
        let config = observer().config().clone();
        // the observer's decision value over the open loop: about every object, or about `only`
        let signal_of = |only: Option<usize>| -> Vec<f64> {
            let mut observer = observer();
            (0..frames)
                .map(|k| {
                    let motion = open_loop_motion(ep, t_s, k, shake_at(camera.as_ref(), t_s[k]));
                    let objects = match only {
                        Some(id) => truth[k]
                            .iter()
                            .find(|o| o.id == id)
                            .map_or(&[][..], std::slice::from_ref),
                        None => &truth[k][..],
                    };
                    observer.update(t_s[k], objects, motion).0
                })
                .collect()
        };
        let mut r = row(
            label,
            config.decision.trigger,
            config.alarm_threshold(),
            signal_of(None),
            Tail::Ideal(kind),
        );
        r.about_threat = threat_object.map(|id| signal_of(Some(id)));
        rows.push(r);
    }
    rows
}

/// The Hopfield trigger threshold of an episode: that of its detector labelled `hopfield`
/// (triggered by θ̂), else the escape controller's default angle (10°; e.g. in sweeps, whose
/// points have other labels, so that every shard scores the same reference row).
pub fn ideal_theta_threshold_deg(ep: &EpisodeSpec) -> f64 {
    ep.detectors
        .iter()
        .find(|d| d.label == "hopfield" && d.trigger == TriggerSignal::AngularSizeDeg)
        .map_or(DecisionRule::default().threshold, |d| d.threshold)
}
