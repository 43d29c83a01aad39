//! Building detectors by id: the ids used everywhere (CLI, CSV columns, reports, Python).

use crate::baselines::BaselineConfigs;
use crate::hopfield::{Hopfield, HopfieldConfig};
use crate::{Detector, DetectorError};

/// Every detector id, in display order.
pub const DETECTOR_IDS: [&str; 5] = ["hopfield", "soc", "keil2004", "cizek2019", "fu2020"];

/// Parameters for every detector kind, as one bundle.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DetectorSet {
    /// Parameters of the Hopfield detector (its `n` is overridden by the frame size at build time).
    pub hopfield: HopfieldConfig,
    /// Parameters of the baselines.
    pub baselines: BaselineConfigs,
}

impl DetectorSet {
    /// Builds detector `id` for n×n frames.
    pub fn build(&self, id: &str, n: usize) -> Result<Box<dyn Detector>, DetectorError> {
        match id {
            "hopfield" => Ok(Box::new(Hopfield::new(HopfieldConfig { n, ..self.hopfield })?)),
            other => self.baselines.build(other),
        }
    }
}

/// Parses a detector list: `all`, or comma-separated ids (duplicates removed, order kept).
pub fn parse_detector_list(spec: &str) -> Result<Vec<&'static str>, DetectorError> {
    let mut ids = Vec::new();
    for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        if part == "all" {
            ids.extend(DETECTOR_IDS);
            continue;
        }
        let id = DETECTOR_IDS
            .iter()
            .find(|&&k| k == part)
            .ok_or_else(|| DetectorError::UnknownDetector(part.to_string()))?;
        ids.push(*id);
    }
    if ids.is_empty() {
        return Err(DetectorError::UnknownDetector(spec.to_string()));
    }
    let mut seen = Vec::new();
    ids.retain(|id| {
        let new = !seen.contains(id);
        seen.push(*id);
        new
    });
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_parse() {
        assert_eq!(parse_detector_list("all").unwrap(), DETECTOR_IDS.to_vec());
        assert_eq!(
            parse_detector_list("soc, hopfield,soc").unwrap(),
            vec!["soc", "hopfield"]
        );
        let e = parse_detector_list("hopfeld").unwrap_err().to_string();
        assert!(e.contains("hopfeld") && e.contains("known ids"), "{e}");
        assert!(parse_detector_list(" , ").is_err());
    }

    #[test]
    fn builds_every_id() {
        let set = DetectorSet::default();
        for id in DETECTOR_IDS {
            let d = set.build(id, 32).unwrap();
            assert_eq!(d.id(), id);
        }
    }
}
