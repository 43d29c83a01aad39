//! Sweeps: parsing and expansion, shard cuts, fingerprints, ranking, the output folder, and the
//! merged per-point reports against a direct run of each point (needs lavapipe or a GPU).

use std::path::{Path, PathBuf};

use loomlab_scenarios::episodes_csv::HEADER;
use loomlab_scenarios::metrics::DetectorSummary;
use loomlab_scenarios::reference::REFERENCE_LABELS;
use loomlab_scenarios::report::{Report, ReportMeta};
use loomlab_scenarios::schema::load_detector_entries;
use loomlab_scenarios::stats::RocPoint;
use loomlab_scenarios::sweep::{Metric, SweepDir, SweepError, SweepFile, SweepPlan, rank};
use loomlab_scenarios::{LoadOptions, Runner, load_suite};

/// A two-scenario suite of short 32×32 episodes: a ball at the robot or passing it, two speeds.
const SCENARIO: &str = r#"
[episode]
duration_s = 1.2
seed = 3
[world]
sky_luminance = 0.5
camera = { n = 32 }
ground = { enabled = false }
[[world.projectiles]]
name = "ball"
target = "camera"
radius_m = 0.2
speed_mps = 6.0
launch_distance_m = 5.0
texture = { kind = "uniform", luminance = 0.0 }
[sweep]
"world.projectiles.0.miss_distance_m" = [0.0, 2.0]
"world.projectiles.0.speed_mps" = [5.0, 7.0]
"#;

fn suite_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("suite")).unwrap();
    // two difficulty tiers, so that every point is also scored per tier
    for (name, tier) in [("a_ball", 0), ("b_ball", 2)] {
        std::fs::write(
            dir.path().join("suite").join(format!("{name}.toml")),
            format!("tier = {tier}\n{SCENARIO}"),
        )
        .unwrap();
    }
    dir
}

fn sweep_file(dir: &Path, body: &str) -> PathBuf {
    let path = dir.join("sweep.toml");
    std::fs::write(&path, format!("suite = \"suite\"\n{body}")).unwrap();
    path
}

const GRID: &str = r#"
episodes_per_shard = 3
points_per_shard = 2
[[detectors]]
id = "soc"
[detectors.sweep]
threshold = [0.5, 5.0, 1e9]
[[detectors]]
id = "hopfield"
label = "hop"
[detectors.random]
samples = 2
"params.alpha" = { min = 0.7, max = 0.9 }
"#;

fn err_text(r: Result<SweepFile, SweepError>) -> String {
    r.map(|_| ()).expect_err("an invalid sweep file").to_string()
}

#[test]
fn grid_and_random_points_are_labelled_and_valued() {
    let dir = suite_dir();
    let file = SweepFile::load(&sweep_file(dir.path(), GRID)).unwrap();
    let labels: Vec<&str> = file.points.iter().map(|p| p.label.as_str()).collect();
    assert_eq!(labels, ["soc-000", "soc-001", "soc-002", "hop-000", "hop-001"]);
    assert_eq!(file.points[1].detector.threshold, Some(5.0));
    assert_eq!(file.points[1].values["threshold"], "5.0");
    // the random draws: in range, different, and the params table was created for them
    let alphas: Vec<f64> = file.points[3..]
        .iter()
        .map(|p| p.detector.params.as_ref().unwrap()["alpha"].as_float().unwrap())
        .collect();
    assert!(alphas.iter().all(|a| (0.7..0.9).contains(a)) && alphas[0] != alphas[1]);
    assert_eq!(file.points[3].detector.label.as_deref(), Some("hop-000"));
    assert_eq!(file.suite, dir.path().join("suite"));
    assert_eq!(file.name, "sweep");
    // a search seed changes the draws, the same one repeats them
    let again = SweepFile::load(&sweep_file(dir.path(), GRID)).unwrap();
    assert_eq!(again.points, file.points);
    let other = SweepFile::load(&sweep_file(dir.path(), &format!("search_seed = 4\n{GRID}"))).unwrap();
    assert_ne!(other.points[3].detector.params, file.points[3].detector.params);
}

#[test]
fn bad_sweep_files_name_the_file_key_and_point() {
    let dir = suite_dir();
    let cases = [
        ("colour = 1\n[[detectors]]\nid = \"soc\"\n", "unknown field `colour`"),
        ("[[detectors]]\nid = \"soc\"\nspeed = 1\n", "detectors[0]"),
        ("[[detectors]]\nid = \"nope\"\n", "unknown detector `nope`"),
        (
            "[[detectors]]\nid = \"hopfield\"\n[detectors.sweep]\n\"params.alpha\" = [0.5, 1.5]\n",
            "point hopfield-001 (params.alpha = 1.5)",
        ),
        (
            "[[detectors]]\nid = \"soc\"\n[[detectors]]\nid = \"soc\"\n",
            "different `label`s",
        ),
        (
            "episodes_per_shard = 0\n[[detectors]]\nid = \"soc\"\n",
            "episodes_per_shard",
        ),
        (
            "[objective]\nfalse_alarm_budget = 2.0\n[[detectors]]\nid = \"soc\"\n",
            "false_alarm_budget",
        ),
        (
            "[objective]\nmetric = \"speed\"\n[[detectors]]\nid = \"soc\"\n",
            "objective.metric",
        ),
        ("", "no [[detectors]] entries"),
        // names that become folder names (points/<label>/, out/sweep/<name>) stay inside
        (
            "[[detectors]]\nid = \"soc\"\nlabel = \"../../x\"\n",
            "detectors[0].label",
        ),
        ("name = \"a/b\"\n[[detectors]]\nid = \"soc\"\n", "`name`"),
    ];
    for (body, needle) in cases {
        let text = err_text(SweepFile::load(&sweep_file(dir.path(), body)));
        assert!(text.contains("sweep.toml") && text.contains(needle), "{body:?}: {text}");
    }
    let missing = err_text(SweepFile::load(&dir.path().join("missing.toml")));
    assert!(missing.contains("missing.toml"), "{missing}");
}

#[test]
fn shards_cover_every_episode_and_point_once() {
    let dir = suite_dir();
    let plan = SweepPlan::load(&sweep_file(dir.path(), GRID), None).unwrap();
    assert_eq!(plan.episodes.len(), 8);
    // 8 episodes in blocks of 3 (3 blocks) × 5 points in blocks of 2 (3 blocks)
    assert_eq!(plan.shards.len(), 9);
    let mut seen = vec![vec![0; 5]; 8];
    for s in &plan.shards {
        for e in s.episodes.clone() {
            for p in s.points.clone() {
                seen[e][p] += 1;
            }
        }
    }
    assert!(seen.iter().flatten().all(|&c| c == 1));
    // every episode carries every point as a labelled detector
    let labels: Vec<&str> = plan.episodes[0].detectors.iter().map(|d| d.label.as_str()).collect();
    assert_eq!(labels, ["soc-000", "soc-001", "soc-002", "hop-000", "hop-001"]);

    let limited = SweepPlan::load(&sweep_file(dir.path(), GRID), Some(4)).unwrap();
    assert_eq!(limited.episodes.len(), 4);
    assert_ne!(limited.fingerprint, plan.fingerprint);
    assert_eq!(
        SweepPlan::load(&sweep_file(dir.path(), GRID), None)
            .unwrap()
            .fingerprint,
        plan.fingerprint
    );
}

fn summary(hit: f64, fa: f64, roc: &[(f64, f64)]) -> DetectorSummary {
    // an empty summary with the fields the metrics read set by hand (no struct literal, so that
    // fields added to DetectorSummary later keep their defaults)
    let mut s = DetectorSummary::from_episodes(&[]);
    assert_eq!((s.episodes, s.hit_rate, s.auc, s.roc.len()), (0, None, None, 0));
    s.episodes = 10;
    s.hit_rate = Some(hit);
    s.false_alarm_rate = Some(fa);
    s.collision_rate = Some(1.0 - hit);
    s.evasion_rate = Some(hit);
    s.auc = Some(0.5);
    s.roc = roc
        .iter()
        .map(|&(fpr, tpr)| RocPoint {
            threshold: None,
            fpr,
            tpr,
        })
        .collect();
    s
}

#[test]
fn metrics_read_the_summary() {
    let s = summary(0.6, 0.2, &[(0.0, 0.0), (0.05, 0.3), (0.1, 0.5), (0.3, 0.9), (1.0, 1.0)]);
    assert_eq!(Metric::RocHitRate.value(&s, Some(0.1)), Some(0.5));
    assert_eq!(Metric::RocHitRate.value(&s, Some(0.0)), Some(0.0));
    assert_eq!(Metric::RocHitRate.value(&s, None), Some(1.0));
    assert!((Metric::Youden.value(&s, None).unwrap() - 0.4).abs() < 1e-12);
    assert_eq!(Metric::CollisionRate.value(&s, None), Some(0.4));
    assert!(!Metric::CollisionRate.maximise() && Metric::Auc.maximise());
}

#[test]
fn ranking_puts_points_within_the_budget_first() {
    let dir = suite_dir();
    let plan = SweepPlan::load(&sweep_file(dir.path(), GRID), Some(3)).unwrap();
    let runner = Runner::new(Some(2)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    let shards: Vec<_> = (0..plan.shards.len())
        .map(|i| plan.run_shard(&runner, i).unwrap())
        .collect();
    let mut results = plan.merge(&shards, 1.0).unwrap();
    // hand-set scores: the best score is over the budget, two tie, one is undefined
    for (r, (score, feasible)) in results.iter_mut().zip([
        (Some(0.9), false),
        (Some(0.5), true),
        (None, true),
        (Some(0.7), true),
        (Some(0.5), true),
    ]) {
        r.score = score;
        r.feasible = feasible;
    }
    assert_eq!(rank(&results, Metric::HitRate), [3, 1, 4, 2, 0]);
    assert_eq!(rank(&results, Metric::CollisionRate), [1, 4, 3, 2, 0]);
}

#[test]
fn merged_reports_equal_a_direct_run_of_each_point() {
    let dir = suite_dir();
    let path = sweep_file(dir.path(), GRID);
    let plan = SweepPlan::load(&path, None).unwrap();
    let runner = Runner::new(Some(2)).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    let out = dir.path().join("out");
    let sweep_dir = SweepDir::open(&out, &plan, false).unwrap();
    assert!(sweep_dir.done(&plan).iter().all(|d| !d));
    for i in 0..plan.shards.len() {
        let csv = SweepPlan::shard_csv(&plan.run_shard(&runner, i).unwrap());
        sweep_dir.write_shard(&plan, i, &csv).unwrap();
    }
    assert!(sweep_dir.done(&plan).iter().all(|d| *d));
    let results = plan.merge(&sweep_dir.read_shards(&plan).unwrap(), 0.0).unwrap();
    let order = sweep_dir.write_results(&plan, &results).unwrap();
    assert_eq!(order.len(), 5);
    let mut outcomes_seen = 0;
    for r in &results {
        // the point alone, as `loomlab run --detectors-file points/<label>/detectors.toml` runs it
        let entries = load_detector_entries(&out.join("points").join(&r.point.label).join("detectors.toml")).unwrap();
        let suite = load_suite(
            &plan.file.suite,
            &LoadOptions {
                detector_entries: Some(entries),
                ..LoadOptions::default()
            },
        )
        .unwrap();
        let specs: Vec<_> = suite.episodes().collect::<Result<_, _>>().unwrap();
        let episodes: Vec<_> = specs.iter().collect();
        let runs = runner.run(&episodes, |_, _| Ok(())).unwrap();
        let outcomes: Vec<_> = runs.into_iter().map(|r| r.outcome).collect();
        let meta = ReportMeta {
            suite: plan.file.suite.display().to_string(),
            seed: 0,
            wall_time_s: 0.0,
            lead_margin_s: episodes[0].scoring.lead_margin_s,
        };
        let direct = Report::from_tiered_episodes(&meta, &outcomes, &suite.tiers());
        assert_eq!(r.report, direct, "{}", r.point.label);
        // the objective per tier: the metric over each tier's summary of the point
        assert_eq!(direct.tiers.keys().collect::<Vec<_>>(), ["0", "2"]);
        for (t, ts) in &direct.tiers {
            let objective = &plan.file.objective;
            let want = ts
                .detectors
                .get(&r.point.label)
                .and_then(|s| objective.metric.value(s, objective.false_alarm_budget));
            assert_eq!(r.tier_scores.get(t), Some(&want), "{} tier {t}", r.point.label);
        }
        // every point's report carries the reference rows, and only its own detector beside them
        assert_eq!(r.report.references, REFERENCE_LABELS);
        let mut labels: Vec<&str> = r.report.detectors.keys().map(String::as_str).collect();
        labels.sort_by_key(|l| REFERENCE_LABELS.contains(l));
        assert_eq!(labels[0], r.point.label);
        assert_eq!(labels.len(), 1 + REFERENCE_LABELS.len());
        assert_eq!(
            Report::read_json(&out.join("points").join(&r.point.label).join("report.json")).unwrap(),
            direct
        );
        outcomes_seen += direct.detectors[&r.point.label].hits + direct.detectors[&r.point.label].false_alarms;
    }
    // the low soc threshold alarms, so the reports are not all empty
    assert!(outcomes_seen > 0);
    let ranking = std::fs::read_to_string(out.join("ranking.csv")).unwrap();
    assert!(
        ranking.starts_with("rank,label,detector,params.alpha,threshold,score"),
        "{ranking}"
    );
    assert_eq!(ranking.lines().count(), 6);
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for p in summary["ranking"].as_array().unwrap() {
        let tiers: Vec<&String> = p["tier_scores"].as_object().unwrap().keys().collect();
        assert_eq!(tiers, ["0", "2"], "{p}");
    }
}

#[test]
fn the_output_folder_refuses_another_sweep_and_checks_shards() {
    let dir = suite_dir();
    let path = sweep_file(dir.path(), GRID);
    let plan = SweepPlan::load(&path, Some(2)).unwrap();
    let out = dir.path().join("out");
    let d = SweepDir::open(&out, &plan, false).unwrap();
    // a shard's rows must be the shard's
    let rows = HEADER.join(",") + "\n";
    let rows = rows.as_str();
    let e = d.write_shard(&plan, 0, rows).unwrap_err().to_string();
    assert!(
        e.contains("0 episodes, the shard has 2") && e.contains("00000.csv"),
        "{e}"
    );
    assert!(
        d.write_shard(&plan, 99, rows)
            .unwrap_err()
            .to_string()
            .contains("no such shard")
    );
    // same sweep: reopens; another (other limit): refused unless restarted
    SweepDir::open(&out, &plan, false).unwrap();
    let other = SweepPlan::load(&path, Some(3)).unwrap();
    let e = SweepDir::open(&out, &other, false).unwrap_err().to_string();
    assert!(e.contains("--restart") && e.contains(&plan.fingerprint), "{e}");
    SweepDir::open(&out, &other, true).unwrap();
}
