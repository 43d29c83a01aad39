//! Validation of a typed scenario: its world, episode length, cruise, controller, scoring and detector rows.

use loomlab_agents::TriggerSignal;
use loomlab_sim::WorldDesc;

use super::detector::{DetectorSpec, bare, camera_facts, resolve_detector_in};
use super::document::{DetectorDesc, ScenarioDoc};
use super::load::LoadOptions;

/// Validates a typed scenario and builds its world and detector specs.
pub(super) fn resolve(
    doc: &ScenarioDoc,
    opts: &LoadOptions,
) -> Result<(WorldDesc, Vec<DetectorSpec>), (String, String)> {
    let mut world = doc.world.clone();
    if let Some(n) = opts.size {
        world.camera.n = n;
    }
    if let Some(profile) = &opts.sensor {
        profile.apply(&mut world);
    }
    world.validate().map_err(|e| match e {
        loomlab_sim::SimError::InvalidDesc { key, value, reason } => {
            let key = if key.starts_with("world.") {
                key
            } else {
                format!("world.{key}")
            };
            (key, format!("{value}: {reason}"))
        }
        other => ("world".to_string(), other.to_string()),
    })?;
    // one cap on frames per episode, shared with `loomlab render`
    let frames =
        loomlab_sim::episode_frames("episode.duration_s", doc.episode.duration_s, world.dt()).map_err(|e| match e {
            loomlab_sim::SimError::Duration { key, value, reason } => (key, format!("{value}: {reason}")),
            other => ("episode.duration_s".into(), other.to_string()),
        })?;
    let dynamic = world.physics == loomlab_sim::PhysicsMode::Dynamic;
    doc.robot.validate(dynamic.then_some(&world.robot))?;
    doc.controller
        .validate()
        .map_err(|e| ("controller".to_string(), e.to_string()))?;
    if let Some(v) = doc.scoring.lead_min_s {
        return Err((
            "scoring.lead_min_s".into(),
            format!(
                "{v}: the key was removed: a hit is now an alarm no later than the threat's escape deadline \
                 (found by physics-only replays of the escape manoeuvre); delete it, or use \
                 `scoring.lead_margin_s` for an extra margin before the deadline"
            ),
        ));
    }
    let margin = doc.scoring.lead_margin_s;
    if !(margin.is_finite() && margin >= 0.0) {
        return Err((
            "scoring.lead_margin_s".into(),
            format!("{margin} must be a number of seconds >= 0"),
        ));
    }
    let entries = opts.detector_entries.as_ref().or(doc.detectors.as_ref());
    let listed: Vec<(usize, DetectorDesc)> = match entries {
        Some(list) => list.iter().cloned().enumerate().collect(),
        None => Vec::new(),
    };
    let wanted: Vec<(Option<usize>, DetectorDesc)> = match (&opts.detectors, entries) {
        (None, Some(_)) => listed.into_iter().map(|(i, d)| (Some(i), d)).collect(),
        (None, None) => opts.registry.ids().into_iter().map(|id| (None, bare(id))).collect(),
        // a detectors file: --detectors only filters its entries
        (Some(ids), Some(_)) if opts.detector_entries.is_some() => listed
            .into_iter()
            .filter(|(_, d)| ids.contains(&d.id))
            .map(|(i, d)| (Some(i), d))
            .collect(),
        (Some(ids), _) => {
            let mut out = Vec::new();
            for id in ids {
                let mine: Vec<_> = listed.iter().filter(|(_, d)| &d.id == id).cloned().collect();
                if mine.is_empty() {
                    out.push((None, bare(id)));
                } else {
                    out.extend(mine.into_iter().map(|(i, d)| (Some(i), d)));
                }
            }
            out
        }
    };
    let added = opts.added_detectors.iter().map(|d| (None, d.clone()));
    let wanted: Vec<(Option<usize>, DetectorDesc)> = wanted.into_iter().chain(added).collect();
    if wanted.is_empty() {
        return Err((
            "detectors".into(),
            "the list is empty; give at least one detector".into(),
        ));
    }
    let mut specs: Vec<DetectorSpec> = Vec::with_capacity(wanted.len());
    for (i, d) in wanted {
        let key = |k: &str| match i {
            Some(i) => format!("detectors[{i}].{k}"),
            None => format!("detectors.{k}"),
        };
        let spec = resolve_detector_in(&opts.registry, &d, camera_facts(&world)).map_err(|(k, r)| (key(&k), r))?;
        check_can_fire(&spec, frames, f64::from(world.camera.fov_deg)).map_err(|(k, r)| (key(k), r))?;
        if specs.iter().any(|s| s.label == spec.label) {
            return Err((
                key("label"),
                format!(
                    "detector `{}` is listed twice; give the entries different labels",
                    spec.label
                ),
            ));
        }
        specs.push(spec);
    }
    Ok((world, specs))
}

/// Refuses a decision rule that can never alarm in this world: a persistence count longer than the
/// episode, or an angular size larger than the camera's field of view (θ̂ is measured in the image).
fn check_can_fire(spec: &DetectorSpec, frames: u64, fov_deg: f64) -> Result<(), (&'static str, String)> {
    if spec.persistence_frames as u64 > frames {
        return Err((
            "persistence_frames",
            format!(
                "{}: an episode of this scenario has {frames} frames, so the alarm could never fire; \
                 give at most {frames} (or a longer episode.duration_s)",
                spec.persistence_frames
            ),
        ));
    }
    let angle_limit = |what: &str, value: f64| {
        format!(
            "{value}°: an angular size measured in the image is at most the camera's field of view ({fov_deg}°), so \
             the {what} could never be reached and the row would never alarm; give less than {fov_deg}"
        )
    };
    if let Some(m) = spec.min_angular_size_deg
        && m >= fov_deg
    {
        return Err(("min_angular_size_deg", angle_limit("minimum angular size", m)));
    }
    if spec.trigger == TriggerSignal::AngularSizeDeg && spec.threshold >= fov_deg {
        return Err(("threshold", angle_limit("angular-size threshold", spec.threshold)));
    }
    Ok(())
}
