//! The documentation holds: the README is short, its results tables equal what the committed
//! baseline report generates (`make readme-table`), every relative link points to a file that
//! exists, and the tutorial's commands run (the cheap ones marked `<!-- smoke-run -->`).

use std::path::{Path, PathBuf};

use loomlab_report::markdown::{
    REGENERATE, best_detector_row, render_compare_block, stale_compare_blocks, stale_tagged_blocks,
};
use loomlab_scenarios::report::Report;

use crate::common::{loomlab, s, text, tmp};

const BASELINE: &str = "scenarios/baseline/default-report.json";
/// The held-out suite's committed report; its blocks are tagged `@heldout`.
const HELDOUT_BASELINE: &str = "scenarios/suites/heldout/baseline/report.json";
/// The default suite's committed report under the `robot` sensor profile (the `results-robot`
/// block sets it beside [`BASELINE`]).
const ROBOT_BASELINE: &str = "scenarios/baseline/default-robot-report.json";
/// The default suite's committed report on the event camera (`make events`: every registered
/// row, the event rows among them); its blocks are tagged `@events`.
const EVENTS_BASELINE: &str = "scenarios/baseline/default-events-report.json";
/// Documents with generated blocks (the Makefile's `DOC_TABLES`).
const GENERATED: [&str; 2] = ["README.md", "docs/results.md"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> String {
    std::fs::read_to_string(root().join(rel)).unwrap_or_else(|e| panic!("{rel}: {e}"))
}

fn baseline() -> Report {
    Report::read_json(&root().join(BASELINE)).unwrap()
}

/// The generated block `name` (with its tag, e.g. `results-brief@heldout`) of document `doc`,
/// from its begin marker to its end marker.
fn generated_block(doc: &str, name: &str) -> String {
    let text = read(doc);
    let begin = text
        .find(&format!("<!-- {name}:begin -->"))
        .unwrap_or_else(|| panic!("{doc} lacks the block {name}"));
    let end = text.find(&format!("<!-- {name}:end -->")).unwrap();
    text[begin..end].to_string()
}

/// Every generated block of suite tag `tag` in `docs` agrees with `report` (read from `baseline`).
fn assert_blocks_fresh(docs: &[&str], report: &Report, tag: Option<&str>, baseline: &str) {
    for doc in docs {
        let stale = stale_tagged_blocks(&read(doc), report, tag).unwrap_or_else(|e| panic!("{doc}: {e}"));
        assert!(
            stale.is_empty(),
            "{doc}: the generated block(s) {stale:?} disagree with {baseline}; regenerate them with `{REGENERATE}`"
        );
    }
}

/// `table` has a row for every row of `report`.
fn assert_every_row(table: &str, report: &Report, what: &str) {
    for label in report.detectors.keys() {
        assert!(table.contains(&format!("| `{label}`")), "{what} lacks the row {label}");
    }
}

#[test]
fn generated_tables_match_the_baseline() {
    let report = baseline();
    assert_blocks_fresh(&GENERATED, &report, None, BASELINE);
    // The README's table is one of them, and it carries the reference rows beside the detectors.
    assert_every_row(&generated_block("README.md", "results-table"), &report, "README table");
    assert!(!report.references.is_empty());
}

#[test]
fn generated_robot_comparison_matches_both_baselines() {
    let (ideal, robot) = (baseline(), Report::read_json(&root().join(ROBOT_BASELINE)).unwrap());
    assert_eq!(robot.sensor_profile.as_deref(), Some("robot"), "{ROBOT_BASELINE}");
    for doc in GENERATED {
        let stale = stale_compare_blocks(&read(doc), &ideal, &robot).unwrap_or_else(|e| panic!("{doc}: {e}"));
        assert!(
            stale.is_empty(),
            "{doc}: the block(s) {stale:?} disagree with {BASELINE} and {ROBOT_BASELINE}; regenerate them with \
             `{REGENERATE}`"
        );
    }
    // in the README (every row, as the robot profile's issue asks) and in docs/results.md
    for doc in ["README.md", "docs/results.md"] {
        let block = generated_block(doc, "results-robot");
        assert!(block.contains(&render_compare_block("results-robot", &ideal, &robot).unwrap()));
        // every row, with both profiles' rates and the change in percentage points
        for (label, s) in &ideal.detectors {
            let line = block
                .lines()
                .find(|l| l.starts_with(&format!("| `{label}`")))
                .unwrap_or_else(|| panic!("results-robot lacks the row {label}"));
            let r = &robot.detectors[label];
            if let (Some(a), Some(b)) = (s.evasion_rate, r.evasion_rate) {
                assert!(
                    line.contains(&format!("| {a:.2} | {b:.2} | {:+.1} |", 100.0 * (b - a))),
                    "{label}: {line}"
                );
            }
        }
        // a stale block is found: the block with another report's numbers
        let swapped = stale_compare_blocks(&read(doc), &robot, &ideal).unwrap();
        assert_eq!(swapped, ["results-robot"]);
    }
}

#[test]
fn generated_events_tables_match_the_events_baseline() {
    let report = Report::read_json(&root().join(EVENTS_BASELINE)).unwrap();
    assert_eq!(report.sensor_profile.as_deref(), Some("events"), "{EVENTS_BASELINE}");
    let ideal = baseline();
    assert_eq!(
        (report.episodes, report.seed),
        (ideal.episodes, ideal.seed),
        "the default suite's episodes"
    );
    assert_blocks_fresh(
        &["README.md", "docs/events.md"],
        &report,
        Some("events"),
        EVENTS_BASELINE,
    );
    // the README's table on events has every row, the event rows among them; the frame rows read
    // the same frames as without the event camera, so they equal the default baseline's
    let table = generated_block("README.md", "results-table@events");
    assert_every_row(&table, &report, "the events table");
    for label in ["event_soc", "event_lgmd"] {
        assert!(report.detectors.contains_key(label), "{EVENTS_BASELINE} lacks {label}");
    }
    for (label, frames) in &ideal.detectors {
        let events = &report.detectors[label];
        assert_eq!(
            (events.hits, events.false_alarms, events.evaded, events.collisions),
            (frames.hits, frames.false_alarms, frames.evaded, frames.collisions),
            "{label}: a frame row's outcome on the event camera differs from the frames baseline's"
        );
    }
}

#[test]
fn generated_heldout_tables_match_the_heldout_baseline() {
    let report = Report::read_json(&root().join(HELDOUT_BASELINE)).unwrap();
    assert_blocks_fresh(&GENERATED, &report, Some("heldout"), HELDOUT_BASELINE);
    // the README shows the held-out suite's short table, docs/results.md its full one with every row
    let brief = generated_block("README.md", "results-brief@heldout");
    let (best, _) = best_detector_row(&report).unwrap();
    for label in [best, "ideal_course", "oracle"] {
        assert!(
            brief.contains(&format!("| `{label}`")),
            "README's held-out table lacks {label}"
        );
    }
    assert_every_row(
        &generated_block("docs/results.md", "results-full@heldout"),
        &report,
        "the held-out table",
    );
    assert!(report.suite.ends_with("suites/heldout"), "{}", report.suite);
}

#[test]
fn table_tag_updates_and_checks_only_that_suites_blocks() {
    let dir = tmp("docs", "tagged-table");
    let readme = dir.join("README.md");
    let good = read("README.md");
    // the held-out block emptied: stale for --tag heldout, not for the default suite's check
    let begin =
        good.find("<!-- results-brief@heldout:begin -->\n").unwrap() + "<!-- results-brief@heldout:begin -->\n".len();
    let end = good.find("<!-- results-brief@heldout:end -->").unwrap();
    let bad = format!("{}{}", &good[..begin], &good[end..]);
    std::fs::write(&readme, &bad).unwrap();
    let o = loomlab(&["table", BASELINE, "--update", s(&readme), "--check"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let o = loomlab(&[
        "table",
        HELDOUT_BASELINE,
        "--tag",
        "heldout",
        "--update",
        s(&readme),
        "--check",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("`results-brief@heldout`"),
        "{}",
        text(&o.stderr)
    );
    // --update with the tag restores it, touching nothing else
    let o = loomlab(&["table", HELDOUT_BASELINE, "--tag", "heldout", "--update", s(&readme)]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(std::fs::read_to_string(&readme).unwrap(), good);
    // a bad tag is bad input naming the fix
    let o = loomlab(&["table", HELDOUT_BASELINE, "--tag", "Held Out", "--update", s(&readme)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("--tag `Held Out`"), "{}", text(&o.stderr));
}

/// The scenario files of the suite folder `dir` (not its suite.toml), sorted.
fn scenario_files(dir: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(root().join(dir))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml") && n != "suite.toml")
        .collect();
    names.sort();
    names
}

/// The held-out suite runs the default suite's detector rows, exactly (labels, thresholds,
/// parameters), with the default suite's camera, so that each row's results compare row by row;
/// and none of its scenario files is a default-suite file.
#[test]
fn heldout_suite_runs_the_default_suites_rows_on_other_scenarios() {
    let suite = |dir: &str| -> toml::Table { toml::from_str(&read(&format!("{dir}/suite.toml"))).unwrap() };
    let (default, heldout) = (suite("scenarios/suites/default"), suite("scenarios/suites/heldout"));
    assert_eq!(
        heldout["defaults"], default["defaults"],
        "the [defaults] (rows, camera) must be the default suite's"
    );
    assert_eq!(heldout["require_tier"].as_bool(), Some(true));
    let (ours, theirs) = (
        scenario_files("scenarios/suites/heldout"),
        scenario_files("scenarios/suites/default"),
    );
    assert!(ours.len() >= 5, "{ours:?}");
    for f in &ours {
        assert!(!theirs.contains(f), "{f} is a default-suite scenario");
    }
    let readme = read("scenarios/suites/heldout/README.md");
    assert!(
        readme.contains("Never tuned on"),
        "the held-out README must say it is never tuned on"
    );
    for f in &ours {
        assert!(
            readme.contains(&format!("`{f}`")),
            "the held-out README does not list {f}"
        );
    }
}

/// The development suite's detector rows are default-suite rows, copied exactly, with its camera;
/// its families are neither default nor held-out files; its README lists them and says that it
/// may be tuned on, unlike the held-out suite.
#[test]
fn dev_suite_runs_default_rows_on_families_of_its_own() {
    let suite = |dir: &str| -> toml::Table { toml::from_str(&read(&format!("{dir}/suite.toml"))).unwrap() };
    let (default, dev) = (suite("scenarios/suites/default"), suite("scenarios/suites/dev"));
    let rows = |t: &toml::Table| t["defaults"]["detectors"].as_array().unwrap().clone();
    let default_rows = rows(&default);
    for row in rows(&dev) {
        assert!(default_rows.contains(&row), "{row} is not a default-suite row");
    }
    assert_eq!(
        dev["defaults"]["world"], default["defaults"]["world"],
        "the camera must be the default suite's"
    );
    let ours = scenario_files("scenarios/suites/dev");
    assert!(ours.len() >= 3, "{ours:?}");
    let readme = read("scenarios/suites/dev/README.md");
    assert!(
        readme.contains("may be tuned"),
        "the dev README must say what it is for"
    );
    for f in &ours {
        for other in ["scenarios/suites/default", "scenarios/suites/heldout"] {
            assert!(!scenario_files(other).contains(f), "{f} is also in {other}");
        }
        assert!(readme.contains(&format!("`{f}`")), "the dev README does not list {f}");
    }
}

#[test]
fn table_check_fails_on_a_stale_readme_and_update_fixes_it() {
    let dir = tmp("docs", "stale-table");
    let readme = dir.join("README.md");
    let good = read("README.md");
    let begin = good.find("<!-- results-table:begin -->").unwrap();
    let row = begin + good[begin..].find("| `").unwrap();
    // change one digit of the first row
    let digit = row + good[row..].find(|c: char| c.is_ascii_digit()).unwrap();
    let mut bad = good.clone();
    let d = bad.as_bytes()[digit];
    bad.replace_range(digit..digit + 1, if d == b'9' { "8" } else { "9" });
    std::fs::write(&readme, &bad).unwrap();
    let o = loomlab(&["table", BASELINE, "--update", s(&readme), "--check"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let err = text(&o.stderr);
    assert!(err.contains("results-table") && err.contains(REGENERATE), "{err}");
    assert_eq!(std::fs::read_to_string(&readme).unwrap(), bad, "--check writes nothing");

    let o = loomlab(&["table", BASELINE, "--update", s(&readme)]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert_eq!(std::fs::read_to_string(&readme).unwrap(), good);
    let o = loomlab(&["table", BASELINE, "--update", s(&readme), "--check"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));

    // without --update: the README's table on stdout
    let o = loomlab(&["table", BASELINE]);
    assert_eq!(o.status.code(), Some(0));
    assert!(good.contains(text(&o.stdout).trim_end()));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn readme_is_short_and_starts_with_the_two_commands() {
    let readme = read("README.md");
    let lines = readme.lines().count();
    assert!(
        lines <= 300,
        "README.md has {lines} lines; the limit is 300 (move detail to docs/)"
    );
    for cmd in ["make run", "make test"] {
        assert!(readme.lines().any(|l| l.starts_with(cmd)), "README lacks `{cmd}`");
    }
}

/// Every Markdown file the guide consists of: the README, docs/ and the READMEs of the crates.
fn markdown_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = [
        "README.md",
        "scenarios/README.md",
        "sim/README.md",
        "stimuli/README.md",
        "python/README.md",
    ]
    .iter()
    .map(|f| root().join(f))
    .collect();
    for e in std::fs::read_dir(root().join("docs")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "md") {
            files.push(p);
        }
    }
    files.sort();
    files
}

/// The targets of the inline links `[text](target)` of a Markdown text, outside code.
fn links(md: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut in_fence = false;
    for line in md.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            continue;
        }
        if in_fence {
            continue;
        }
        // drop inline code spans
        let mut plain = String::new();
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                plain += part;
            }
        }
        let mut rest = plain.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(close) = after.find(')') else { break };
            out.push(after[..close].trim().to_string());
            rest = &after[close..];
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces to `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(md: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in md.lines() {
        if let Some(h) = line.strip_prefix('#') {
            out.push(slug(h.trim_start_matches('#')));
        }
        let mut rest = line;
        while let Some(at) = rest.find("id=\"") {
            let after = &rest[at + 4..];
            let Some(end) = after.find('"') else { break };
            out.push(after[..end].to_string());
            rest = &after[end..];
        }
    }
    out
}

#[test]
fn relative_links_point_to_existing_files_and_anchors() {
    let mut broken = Vec::new();
    for file in markdown_files() {
        let md = std::fs::read_to_string(&file).unwrap();
        let dir = file.parent().unwrap();
        let name = file.strip_prefix(root()).unwrap().display().to_string();
        for link in links(&md) {
            if link.contains("://") || link.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = link.split_once('#').unwrap_or((link.as_str(), ""));
            let target = if path.is_empty() { file.clone() } else { dir.join(path) };
            let rel = target.canonicalize().ok().and_then(|t| {
                t.strip_prefix(root().canonicalize().unwrap())
                    .ok()
                    .map(Path::to_path_buf)
            });
            let Some(rel) = rel else {
                broken.push(format!("{name}: ({link}): no such file"));
                continue;
            };
            if !anchor.is_empty() && rel.extension().is_some_and(|x| x == "md") {
                let target_md = std::fs::read_to_string(root().join(&rel)).unwrap();
                if !anchors(&target_md).iter().any(|a| a == anchor) {
                    broken.push(format!(
                        "{name}: ({link}): no heading or id `{anchor}` in {}",
                        rel.display()
                    ));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

/// The fenced blocks of `md` that follow the line `marker`: (first line of the marker, content).
fn marked_blocks<'a>(md: &'a str, marker: &str) -> Vec<(&'a str, String)> {
    let lines: Vec<&str> = md.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if !line.trim_start().starts_with(marker) || i + 1 >= lines.len() || !lines[i + 1].starts_with("```") {
            continue;
        }
        let body: Vec<&str> = lines[i + 2..]
            .iter()
            .take_while(|l| !l.starts_with("```"))
            .copied()
            .collect();
        out.push((*line, body.join("\n") + "\n"));
    }
    out
}

#[test]
fn tutorial_files_are_the_files_in_the_repository() {
    let tutorial = read("docs/tutorial.md");
    let blocks = marked_blocks(&tutorial, "<!-- file: ");
    assert!(!blocks.is_empty(), "the tutorial shows no file");
    for (marker, body) in blocks {
        let path = marker
            .trim()
            .trim_start_matches("<!-- file: ")
            .trim_end_matches("-->")
            .trim();
        assert_eq!(
            body,
            read(path),
            "docs/tutorial.md shows {path} other than it is: copy the file into the page"
        );
    }
}

#[test]
fn tutorial_commands_run() {
    let tutorial = read("docs/tutorial.md");
    let dir = tmp("docs", "tutorial");
    let out = format!("{}/", s(&dir));
    let mut ran = 0;
    for (_, body) in marked_blocks(&tutorial, "<!-- smoke-run -->") {
        for line in body.lines() {
            let cmd = line.split(" #").next().unwrap().trim();
            let Some(args) = cmd.strip_prefix("loomlab ") else {
                continue;
            };
            let args: Vec<String> = args.split_whitespace().map(|a| a.replace("out/", &out)).collect();
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let o = loomlab(&args);
            assert_eq!(
                o.status.code(),
                Some(0),
                "docs/tutorial.md: `{cmd}` failed:\n{}",
                text(&o.stderr)
            );
            ran += 1;
        }
    }
    assert!(ran >= 3, "only {ran} tutorial commands are smoke-run");
    let _ = std::fs::remove_dir_all(&dir);
}
