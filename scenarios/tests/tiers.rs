//! Difficulty tiers: the `tier` key, `require_tier`, `--tier` selection and the default suite's
//! ladder (no GPU needed).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use loomlab_scenarios::tier::{MAX_TIER, parse_tier_list};
use loomlab_scenarios::truth::NEAR_MISS_M;
use loomlab_scenarios::{DEFAULT_SUITE, LoadOptions, load_suite, parse_scenario};

const BASE: &str = r#"
[episode]
duration_s = 1.0
seed = 3
[world]
camera = { n = 32 }
[[world.projectiles]]
speed_mps = 8.0
"#;

fn parse(text: &str) -> Result<loomlab_scenarios::Scenario, String> {
    parse_scenario(text, Path::new("dir/tiered.toml"), None, &LoadOptions::default()).map_err(|e| e.to_string())
}

fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("loomlab-tiers-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn tier_is_optional_and_read_when_given() {
    assert_eq!(parse(BASE).unwrap().tier, None);
    for t in 0..=MAX_TIER {
        assert_eq!(parse(&format!("tier = {t}\n{BASE}")).unwrap().tier, Some(t));
    }
}

#[test]
fn a_bad_tier_names_the_file_the_key_the_value_and_the_fix() {
    for (value, shown) in [("4", "4"), ("-1", "-1"), ("\"1\"", "\"1\""), ("1.0", "1.0")] {
        let e = parse(&format!("tier = {value}\n{BASE}")).unwrap_err();
        assert!(e.starts_with("dir/tiered.toml: `tier`: "), "{e}");
        assert!(e.contains(shown) && e.contains("not a difficulty tier"), "{value}: {e}");
        assert!(e.contains("an integer 0 to 3") || e.contains("0 to 3"), "{value}: {e}");
    }
    let e = parse(&format!("tier = 1\n{BASE}\n[sweep]\ntier = [0, 1]\n")).unwrap_err();
    assert!(e.contains("tier") && e.contains("split the file"), "{e}");
}

fn write_suite(dir: &Path, suite_toml: Option<&str>, files: &[(&str, Option<u8>)]) {
    if let Some(text) = suite_toml {
        std::fs::write(dir.join("suite.toml"), text).unwrap();
    }
    for (name, tier) in files {
        let head = tier.map_or(String::new(), |t| format!("tier = {t}\n"));
        std::fs::write(dir.join(format!("{name}.toml")), format!("{head}{BASE}")).unwrap();
    }
}

#[test]
fn require_tier_makes_the_key_required_with_a_message_that_names_the_fix() {
    let dir = tmp_dir("required");
    write_suite(
        &dir,
        Some("require_tier = true\n"),
        &[("a_first", Some(0)), ("b_untiered", None)],
    );
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("b_untiered.toml: `tier`: missing"), "{e}");
    assert!(e.contains("require_tier = true") && e.contains("add `tier = N`"), "{e}");
    // without require_tier the same files load, and only the tiered one has a tier
    std::fs::write(dir.join("suite.toml"), "description = \"mixed\"\n").unwrap();
    let suite = load_suite(&dir, &LoadOptions::default()).unwrap();
    assert_eq!(suite.tiers(), BTreeMap::from([("a_first".to_string(), 0)]));
    // a tier in [defaults] is refused: it belongs to each file
    std::fs::write(dir.join("suite.toml"), "[defaults]\ntier = 1\n").unwrap();
    let e = load_suite(&dir, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("suite.toml: `defaults.tier`") && e.contains("each scenario file"),
        "{e}"
    );
}

#[test]
fn retain_tiers_keeps_the_scenarios_of_the_tiers_given() {
    let dir = tmp_dir("retain");
    write_suite(
        &dir,
        None,
        &[("t0", Some(0)), ("t2a", Some(2)), ("t2b", Some(2)), ("none", None)],
    );
    let mut suite = load_suite(&dir, &LoadOptions::default()).unwrap();
    suite.retain_tiers(&BTreeSet::from([2])).unwrap();
    let names: Vec<&str> = suite.scenarios.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["t2a", "t2b"]);
    let e = suite.retain_tiers(&BTreeSet::from([3])).unwrap_err().to_string();
    assert!(e.contains("--tier 3") && e.contains("tiers: 2"), "{e}");

    assert_eq!(parse_tier_list("0,2, 2").unwrap(), BTreeSet::from([0, 2]));
    for bad in ["4", "x", "1,,2", ""] {
        let e = parse_tier_list(bad).unwrap_err();
        assert!(
            e.contains(&format!("--tier {bad}")) && e.contains("0 to 3"),
            "{bad}: {e}"
        );
    }
}

/// The default suite is a ladder: every scenario states its tier, and every tier holds at least 30
/// threats, 30 non-threats and some near misses (non-threats whose object passes within
/// `NEAR_MISS_M` of the camera), so that the collision-course gate is tested in every tier. (The
/// share of evadable threats needs the escape replays: `tests/docs.rs` reads it from the
/// committed baseline.)
#[test]
fn default_suite_tiers_hold_threats_non_threats_and_near_misses() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(DEFAULT_SUITE);
    let suite = load_suite(&path, &LoadOptions::default()).unwrap();
    for s in &suite.scenarios {
        assert!(s.tier.is_some(), "{} has no tier", s.file.display());
    }
    let tiers = suite.tiers();
    // tier → (threats, non-threats, near misses)
    let mut counts: BTreeMap<u8, (usize, usize, usize)> = BTreeMap::new();
    for ep in suite.episodes() {
        let ep = ep.unwrap();
        let truth = loomlab_scenarios::truth::open_loop_truth(&ep, ep.seed).unwrap();
        let c = counts.entry(tiers[&ep.scenario]).or_default();
        if truth.threat() {
            c.0 += 1;
        } else {
            c.1 += 1;
        }
        if truth.near_miss() {
            c.2 += 1;
        }
    }
    println!("tier: (threats, non-threats, near misses) = {counts:?}");
    assert_eq!(counts.keys().copied().collect::<Vec<_>>(), [0, 1, 2, 3]);
    for (tier, (threats, non_threats, near)) in &counts {
        assert!(
            *threats >= 30 && *non_threats >= 30 && *near >= 4,
            "tier {tier}: {threats} threats, {non_threats} non-threats, {near} near misses (within {NEAR_MISS_M} m); \
             every tier needs >= 30, >= 30 and >= 4"
        );
    }
}
