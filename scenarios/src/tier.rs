//! Difficulty tiers: the ladder that shows where a detector stops working.
//!
//! Every scenario file may carry a top-level `tier = 0..3` (required in a suite whose `suite.toml`
//! or list file sets `require_tier = true`, as the default suite does):
//!
//! | tier | name | what it holds |
//! |---|---|---|
//! | 0 | paper | the paper's conditions: a standing observer, a uniform or plain background, one object |
//! | 1 | clutter | static clutter, standing observer: textured ground, backdrops, poles |
//! | 2 | ego-motion | the robot cruises over textured ground; objects from ahead and oblique |
//! | 3 | hard | camera shake, drifting gratings, corridors, several objects, vehicles and trains, lobbed and bouncing balls |
//!
//! Reports pool the episodes of each tier (`report.json` key `tiers`, see [`crate::report`]), the
//! regression check compares them ([`crate::regression`]) and `loomlab run --tier N[,M]` runs a
//! subset.

use std::collections::BTreeSet;

use toml::Value;

/// The highest tier.
pub const MAX_TIER: u8 = 3;

/// Short name of each tier, indexed by tier.
pub const TIER_NAMES: [&str; 4] = ["paper", "clutter", "ego-motion", "hard"];

/// One-line description of each tier, indexed by tier.
pub const TIER_DESCRIPTIONS: [&str; 4] = [
    "the paper's conditions: standing observer, uniform or plain background, one object",
    "static clutter, standing observer: textured ground, backdrops, poles",
    "ego-motion: the robot cruises over textured ground; objects from ahead and oblique",
    "hard: camera shake, drifting gratings, corridors, several objects, vehicles and trains, lobbed and bouncing balls",
];

/// What a valid `tier` looks like, for error messages.
pub const TIER_HELP: &str = "an integer 0 to 3 (0 paper's conditions, 1 static clutter, 2 ego-motion, 3 hard; \
                             see scenarios/README.md#difficulty-tiers)";

/// The short name of `tier` (`"?"` beyond [`MAX_TIER`]).
pub fn tier_name(tier: u8) -> &'static str {
    TIER_NAMES.get(tier as usize).copied().unwrap_or("?")
}

/// Checks a scenario file's `tier` value; the error is the reason (with the fix).
pub fn parse_tier_value(value: &Value) -> Result<u8, String> {
    match value {
        Value::Integer(i) if (0..=i64::from(MAX_TIER)).contains(i) => Ok(*i as u8),
        Value::Integer(i) => Err(format!("{i} is not a difficulty tier: use {TIER_HELP}")),
        other => Err(format!(
            "{other} ({}) is not a difficulty tier: use {TIER_HELP}",
            other.type_str()
        )),
    }
}

/// Parses `--tier N[,M...]`: a comma-separated list of tiers (duplicates allowed, order ignored).
pub fn parse_tier_list(spec: &str) -> Result<BTreeSet<u8>, String> {
    let mut out = BTreeSet::new();
    for part in spec.split(',') {
        let part = part.trim();
        match part.parse::<u8>() {
            Ok(t) if t <= MAX_TIER => {
                out.insert(t);
            }
            _ => {
                return Err(format!(
                    "--tier {spec}: {part:?} is not a difficulty tier; give {TIER_HELP}, comma-separated (e.g. --tier 0,1)"
                ));
            }
        }
    }
    Ok(out)
}
