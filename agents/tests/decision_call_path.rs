//! The decision step has exactly one call path: [`loomlab_agents::Decider`] (`agents/src/decision/`)
//! is the only place where a percept becomes a decision, and the five places that decide — the
//! escape controller, the runner's open-loop pass, the trace replays, the reference rows' ideal
//! observers and the Gymnasium env — all call it. This test reads the workspace's sources and
//! fails when a decider call appears anywhere else, when one of those places stops calling it, or
//! when a stage of the pipeline (or the old `Strategy` API) is written again outside the module.

use std::path::{Path, PathBuf};

/// The decider's entry points, as called.
const ENTRY_POINTS: [&str; 2] = [".decide(", ".decide_on_detector("];

/// The files (outside `agents/src/decision/`) that call the decider, and nothing else does.
const CALL_SITES: [&str; 5] = [
    "agents/src/escape.rs",
    "scenarios/src/runner/open_loop.rs",
    "scenarios/src/replay.rs",
    "scenarios/src/reference.rs",
    "env/src/episode/observe.rs",
];

/// What only the decision module may write: its stages' markers and the names it replaced.
const DECISION_ONLY: [&str; 10] = [
    "fn surface_factor",
    "fn parabola",
    "JUMP_RATIO",
    "STOPPING_TAU_RATE",
    "STANDING_TOLERANCE",
    "STRAIGHT_COURSE_MAX_RADII",
    "Strategy::new",
    "StrategyParams",
    ".strategy()",
    "percept_of(",
];

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("agents/ has a parent")
        .to_path_buf()
}

/// Every `.rs` file of the workspace's crates, as `(path relative to the root, text)`.
fn sources(root: &Path) -> Vec<(String, String)> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<(String, String)>) {
        let Ok(entries) = std::fs::read_dir(dir) else { return };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().to_string();
            if path.is_dir() {
                if !["target", "out", "shared", "node_modules"].contains(&name.as_str()) && !name.starts_with('.') {
                    walk(&path, root, out);
                }
            } else if name.ends_with(".rs") {
                let rel = path
                    .strip_prefix(root)
                    .expect("under the root")
                    .to_string_lossy()
                    .replace('\\', "/");
                out.push((rel, std::fs::read_to_string(&path).expect("a readable source file")));
            }
        }
    }
    let mut out = Vec::new();
    walk(root, root, &mut out);
    out
}

/// Code outside tests and benchmarks (whose analytic checks call the decider directly).
fn is_library_code(rel: &str) -> bool {
    !rel.contains("/tests/") && !rel.starts_with("tests/") && !rel.contains("/benches/") && !rel.ends_with("tests.rs")
}

#[test]
fn the_decider_is_called_from_its_five_call_sites_only() {
    let root = workspace_root();
    let files = sources(&root);
    assert!(
        files.iter().any(|(rel, _)| rel == "agents/src/decision/mod.rs"),
        "the walk must find the decision module under {}",
        root.display()
    );
    let mut strays = Vec::new();
    for (rel, text) in &files {
        if rel.starts_with("agents/src/decision/") || !is_library_code(rel) {
            continue;
        }
        let calls = ENTRY_POINTS.iter().any(|e| text.contains(e));
        if calls && !CALL_SITES.contains(&rel.as_str()) {
            strays.push(rel.clone());
        }
    }
    assert!(strays.is_empty(), "decider calls outside the call sites: {strays:?}");
    for site in CALL_SITES {
        let (_, text) = files
            .iter()
            .find(|(rel, _)| rel == site)
            .unwrap_or_else(|| panic!("call site {site} is gone: update CALL_SITES"));
        assert!(
            ENTRY_POINTS.iter().any(|e| text.contains(e)),
            "{site} no longer calls the decider"
        );
    }
}

#[test]
fn no_stage_of_the_decision_is_written_outside_its_module() {
    let files = sources(&workspace_root());
    let mut found = Vec::new();
    for (rel, text) in &files {
        if rel.starts_with("agents/src/decision/") || rel == "agents/tests/decision_call_path.rs" {
            continue;
        }
        for marker in DECISION_ONLY {
            if text.contains(marker) {
                found.push(format!("{rel}: {marker}"));
            }
        }
    }
    assert!(
        found.is_empty(),
        "decision code outside agents/src/decision/: {found:?}"
    );
}
