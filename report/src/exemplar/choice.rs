//! The choice of exemplary episodes: why an episode is shown, and which ones per scenario.

use std::collections::BTreeMap;

use loomlab_scenarios::metrics::{EpisodeOutcome, Outcome};
use loomlab_scenarios::reference::is_reference;

use super::{MAX_SCENARIOS, PER_SCENARIO};

/// Why an episode is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum ExemplarKind {
    /// The scenario's first episode in which some detector missed an evadable threat.
    Miss,
    /// The scenario's first episode in which some detector alarmed without a threat.
    FalseAlarm,
    /// The scenario's first episode in which some detector hit.
    Hit,
    /// The scenario has no miss, false alarm or hit: its first episode.
    First,
}

impl ExemplarKind {
    /// Words for the page.
    pub fn title(self) -> &'static str {
        match self {
            Self::Miss => "first miss",
            Self::FalseAlarm => "first false alarm",
            Self::Hit => "first hit",
            Self::First => "first episode",
        }
    }

    pub(super) fn outcome(self) -> Option<Outcome> {
        match self {
            Self::Miss => Some(Outcome::Miss),
            Self::FalseAlarm => Some(Outcome::FalseAlarm),
            Self::Hit => Some(Outcome::Hit),
            Self::First => None,
        }
    }
}

/// An episode chosen as exemplary, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ExemplarChoice {
    /// Scenario name.
    pub scenario: String,
    /// Episode index within the scenario.
    pub episode: usize,
    /// Each reason with its detector (the first detector with that outcome).
    pub reasons: Vec<(ExemplarKind, String)>,
}

impl ExemplarChoice {
    /// The detector whose alarm the GIF follows: that of the first reason.
    pub fn featured(&self) -> &str {
        self.reasons.first().map_or("", |(_, d)| d.as_str())
    }

    /// File name of the GIF (in [`crate::EXEMPLARS_DIR`]).
    pub fn gif_name(&self) -> String {
        format!("{}_{:04}.gif", self.scenario, self.episode)
    }

    /// File name of the events GIF (in [`crate::EXEMPLARS_DIR`]), with an event camera.
    pub fn events_gif_name(&self) -> String {
        format!("{}_{:04}_events.gif", self.scenario, self.episode)
    }
}

/// The exemplary episodes of a run, scenario by scenario in suite order, from every episode's
/// outcome (`outcomes` in suite order). Reference rows are not detectors: they choose nothing.
pub fn choose(outcomes: &[EpisodeOutcome]) -> Vec<ExemplarChoice> {
    let mut order: Vec<&str> = Vec::new();
    let mut per: BTreeMap<&str, Vec<ExemplarChoice>> = BTreeMap::new();
    let kinds = [ExemplarKind::Miss, ExemplarKind::FalseAlarm, ExemplarKind::Hit];
    for o in outcomes {
        if !per.contains_key(o.scenario.as_str()) {
            if order.len() >= MAX_SCENARIOS {
                continue;
            }
            order.push(&o.scenario);
        }
        let chosen = per.entry(&o.scenario).or_default();
        for kind in kinds {
            if chosen.iter().any(|c| c.reasons.iter().any(|(k, _)| *k == kind)) {
                continue;
            }
            let Some(d) = o
                .detectors
                .iter()
                .find(|d| !is_reference(&d.detector) && Some(d.outcome) == kind.outcome())
            else {
                continue;
            };
            match chosen.iter_mut().find(|c| c.episode == o.episode) {
                Some(c) => c.reasons.push((kind, d.detector.clone())),
                None => chosen.push(ExemplarChoice {
                    scenario: o.scenario.clone(),
                    episode: o.episode,
                    reasons: vec![(kind, d.detector.clone())],
                }),
            }
        }
    }
    let mut out = Vec::new();
    for s in order {
        let mut chosen = per.remove(s).unwrap_or_default();
        if chosen.is_empty()
            && let Some(o) = outcomes.iter().find(|o| o.scenario == s)
        {
            let first = o.detectors.iter().find(|d| !is_reference(&d.detector));
            chosen.push(ExemplarChoice {
                scenario: o.scenario.clone(),
                episode: o.episode,
                reasons: vec![(ExemplarKind::First, first.map_or(String::new(), |d| d.detector.clone()))],
            });
        }
        chosen.truncate(PER_SCENARIO);
        out.extend(chosen);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use loomlab_scenarios::metrics::DetectorEpisode;

    fn det(label: &str, outcome: Outcome) -> DetectorEpisode {
        // the JSON form names every field; only the label and the outcome matter here
        let mut d: DetectorEpisode = serde_json::from_value(serde_json::json!({
            "detector": label, "threat": false, "t_contact_s": null, "t_deadline_s": null,
            "t_alarm_s": null, "outcome": outcome.as_str(), "collision": false, "triggers": 0,
            "ttc_at_alarm_s": null, "angular_size_at_alarm_deg": null, "max_signal": null,
            "l_over_v_s": null, "eye_ttc_at_alarm_s": null, "theta_rel_err_median": null,
            "theta_rel_err_p90": null,
        }))
        .unwrap();
        d.outcome = outcome;
        d
    }

    fn ep(scenario: &str, episode: usize, dets: Vec<DetectorEpisode>) -> EpisodeOutcome {
        EpisodeOutcome {
            scenario: scenario.into(),
            episode,
            seed: 0,
            params: BTreeMap::new(),
            detectors: dets,
        }
    }

    #[test]
    fn chooses_first_miss_false_alarm_and_hit_per_scenario() {
        use Outcome::*;
        let outcomes = vec![
            ep("a", 0, vec![det("x", CorrectRejection), det("null", CorrectRejection)]),
            ep("a", 1, vec![det("x", Hit), det("y", Miss), det("oracle", Hit)]),
            ep("a", 2, vec![det("x", Miss), det("y", Miss)]),
            ep("a", 3, vec![det("x", CorrectRejection), det("y", FalseAlarm)]),
            ep("b", 0, vec![det("x", Unavoidable), det("oracle", Hit)]),
            ep("b", 1, vec![det("x", Unavoidable)]),
        ];
        let c = choose(&outcomes);
        assert_eq!(c.len(), 3, "{c:?}");
        assert_eq!((c[0].scenario.as_str(), c[0].episode), ("a", 1));
        assert_eq!(
            c[0].reasons,
            vec![
                (ExemplarKind::Miss, "y".to_string()),
                (ExemplarKind::Hit, "x".to_string())
            ]
        );
        assert_eq!(c[0].featured(), "y");
        assert_eq!(
            (c[1].episode, c[1].reasons.clone()),
            (3, vec![(ExemplarKind::FalseAlarm, "y".into())])
        );
        // b has neither miss, false alarm nor hit of a detector (the oracle's hit does not count)
        assert_eq!((c[2].scenario.as_str(), c[2].episode), ("b", 0));
        assert_eq!(c[2].reasons, vec![(ExemplarKind::First, "x".to_string())]);
    }
}
