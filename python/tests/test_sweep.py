"""Sweeps (`loomlab.sweep`): merged reports equal the single-process run, 1 and 2 Ray workers give
identical results, interrupted sweeps resume without redoing finished shards, bad input is named."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import loomlab
from loomlab.sweep import EXIT_INCOMPLETE, run_sweep

DATA = Path(__file__).parent / "data"
SWEEP = DATA / "small_sweep.toml"
REPO = Path(__file__).resolve().parents[2]  # python/tests/test_sweep.py -> the repository root
LABELS = ["hopfield-000", "hopfield-001", "soc-000", "soc-001"]
# the runner's reference rows, reported with every detector (scenarios/src/reference.rs)
REFERENCE_ROWS = {"null", "oracle", "ideal_theta", "ideal_tau", "ideal_course"}


def _strip(report: dict) -> dict:
    """A report without its wall-clock time (the one field that differs between runs)."""
    return {k: v for k, v in report.items() if k != "wall_time_s"}


def _results(out: Path) -> dict:
    """Everything a sweep wrote but its timing: point reports, episodes, ranking, summary, shards."""
    files = {}
    for p in sorted(out.rglob("*")):
        # the pages show each point's wall time; they are drawn from the files compared here
        if p.is_file() and p.name != "manifest.json" and p.suffix != ".html":
            text = p.read_text()
            if p.name == "report.json":
                text = json.dumps(_strip(json.loads(text)), sort_keys=True)
            files[str(p.relative_to(out))] = text
    return files


@pytest.fixture(scope="module")
def ray_cluster():
    ray = pytest.importorskip("ray")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


@pytest.fixture(scope="module")
def reference(ray_cluster, tmp_path_factory):
    """The small sweep run once on 2 Ray workers."""
    out = tmp_path_factory.mktemp("sweep") / "two"
    result = run_sweep(SWEEP, out=out, workers=2, progress=False)
    return result


def test_sweep_on_ray_completes_and_equals_single_process(reference):
    r = reference
    assert r.complete and r.shards_total == 8 and r.shards_run == 8 and r.shards_skipped == 0
    assert (r.episodes, r.points) == (8, 4)
    # 4 episode blocks x 2 point blocks: every episode runs twice, each run scores 2 points
    assert (r.episodes_run, r.scores_run) == (16, 32)
    assert [row["label"] for row in r.summary["ranking"]] and r.ranking_table.startswith("rank")
    for label in LABELS:
        swept = r.report(label)
        assert swept["episodes"] == 8
        assert [d for d in swept["detectors"] if d not in REFERENCE_ROWS] == [label], list(swept["detectors"])
        s = swept["detectors"][label]
        # both classes of episode are present, so the rates are real numbers
        assert s["hits"] + s["misses"] > 0 and s["false_alarms"] + s["correct_rejections"] > 0
        single = loomlab.run_suite(
            swept["suite"], size=48, limit=8, detectors_file=r.out / "points" / label / "detectors.toml", jobs=1
        )
        assert _strip(single) == _strip(swept), label


def _loomlab_binary() -> Path:
    """The `loomlab` CLI: ``$LOOMLAB_BIN``, else the newest of ``target/{debug,release}/loomlab`` (in
    ``$CARGO_TARGET_DIR`` or the repository's target folder). A missing binary fails the test (it is
    part of what the sweep must equal), naming how to build it."""
    env = os.environ.get("LOOMLAB_BIN")
    if env:
        if not Path(env).is_file():
            pytest.fail(f"LOOMLAB_BIN={env} is not a file; build the CLI with `cargo build --bin loomlab`")
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    found = [target / profile / "loomlab" for profile in ("debug", "release")]
    found = [p for p in found if p.is_file()]
    if not found:
        pytest.fail(
            f"the loomlab binary is not built (looked for {target}/debug/loomlab and {target}/release/loomlab): "
            "run `cargo build --bin loomlab` in the repository root (`make python-test` does), or set LOOMLAB_BIN"
        )
    return max(found, key=lambda p: p.stat().st_mtime)


def test_sweep_point_equals_loomlab_run_cli(reference, tmp_path):
    exe = _loomlab_binary()
    label = "hopfield-000"
    swept = reference.report(label)
    subprocess.run(
        [
            exe,
            "run",
            swept["suite"],
            "--size",
            "48",
            "--limit",
            "8",
            "--quiet",
            "--no-plots",
            "--out",
            tmp_path,
            "--detectors-file",
            reference.out / "points" / label / "detectors.toml",
        ],
        check=True,
    )
    cli = json.loads((tmp_path / "report.json").read_text())
    assert _strip(cli) == _strip(swept)


def test_sweep_page_has_the_scatter_and_links_every_point_to_its_page(reference):
    out = reference.out
    page = (out / "report.html").read_text()
    assert reference.report_html == out / "report.html"
    assert page.count('<svg id="sweep-scatter"') == 1
    ranking = reference.summary["ranking"]
    assert [p["label"] for p in ranking] and sorted(p["label"] for p in ranking) == LABELS
    for p in ranking:
        link = f'href="points/{p["label"]}/report.html"'
        # a dot in the scatter (when both rates are defined) and a row of the ranking table link to it
        dots = page.count(f'<a class="point" {link}>')
        rates = (p["summary"]["hit_rate"], p["summary"]["false_alarm_rate"])
        assert dots == (0 if None in rates else 1)
        assert page.count(link) == dots + 1, p["label"]
        point_page = out / "points" / p["label"] / "report.html"
        text = point_page.read_text()
        assert '<table class="sortable summary">' in text and p["label"] in text
        assert 'href="../../report.html"' in text and 'id="plot-roc"' in text
    assert "http://" not in page.replace('xmlns="http://www.w3.org/2000/svg"', "")


def test_one_and_two_workers_give_identical_results(reference, tmp_path):
    one = run_sweep(SWEEP, out=tmp_path / "one", workers=1, progress=False)
    assert one.complete and one.shards_run == 8
    assert _results(one.out) == _results(reference.out)


def test_interrupted_sweep_resumes_without_redoing_finished_shards(reference, tmp_path):
    out = tmp_path / "resumed"
    seen = []

    def stop_after_three(i):
        seen.append(i)
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(SWEEP, out=out, workers=2, progress=False, on_shard=stop_after_three)
    done = sorted((out / "shards").glob("*.csv"))
    assert len(done) == 3 and not list((out / "shards").glob("*.tmp"))
    stamps = {p.name: p.stat().st_mtime_ns for p in done}
    again = []
    r = run_sweep(SWEEP, out=out, workers=2, progress=False, on_shard=again.append)
    assert r.complete and r.shards_skipped == 3 and r.shards_run == 5
    assert sorted(again) == sorted(set(range(8)) - set(seen))
    assert {p.name: p.stat().st_mtime_ns for p in done} == stamps
    assert _results(out) == _results(reference.out)


def test_cli_max_shards_stops_and_resumes_locally(reference, tmp_path):
    cmd = [sys.executable, "-m", "loomlab.sweep", str(SWEEP), "--local", "--quiet", "--out", str(tmp_path)]
    first = subprocess.run(cmd + ["--max-shards", "3"], capture_output=True, text=True)
    assert first.returncode == EXIT_INCOMPLETE, first.stderr
    assert "5 of 8 shards left" in first.stdout
    assert len(list((tmp_path / "shards").glob("*.csv"))) == 3
    second = subprocess.run(cmd, capture_output=True, text=True)
    assert second.returncode == 0, second.stderr
    assert "hopfield-000" in second.stdout and (tmp_path / "ranking.csv").is_file()
    # without Ray, on every CPU: the same results
    assert _results(tmp_path) == _results(reference.out)


def test_cli_help():
    r = subprocess.run([sys.executable, "-m", "loomlab.sweep", "--help"], capture_output=True, text=True)
    assert r.returncode == 0 and "--workers" in r.stdout and "resume" in r.stdout


def test_import_loomlab_does_not_import_ray():
    code = "import sys, loomlab, loomlab.sweep, loomlab.rllib; print('ray' in sys.modules)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "False"


def _sweep_file(tmp_path: Path, text: str) -> Path:
    suite = (REPO / "scenarios" / "suites" / "default").as_posix()
    path = tmp_path / "bad.toml"
    path.write_text(f'suite = "{suite}"\nlimit = 2\nsize = 32\n' + text)
    return path


@pytest.mark.parametrize(
    "text, needle",
    [
        ('[[detectors]]\nid = "hopfield"\ncolour = 1\n', "colour"),
        ('[[detectors]]\nid = "nope"\n', "unknown detector `nope`"),
        ('[[detectors]]\nid = "hopfield"\n[detectors.sweep]\n"params.alpha" = [0.5, 1.5]\n', "hopfield-001"),
        ('[objective]\nmetric = "speed"\n[[detectors]]\nid = "soc"\n', "objective.metric"),
        ("episodes_per_shard = 0\n[[detectors]]\nid = 'soc'\n", "episodes_per_shard"),
        ("", "no [[detectors]] entries"),
    ],
)
def test_bad_sweep_files_name_the_key(tmp_path, text, needle):
    with pytest.raises(loomlab.ScenarioError, match="bad.toml") as e:
        run_sweep(_sweep_file(tmp_path, text), out=tmp_path / "out", local=True, progress=False)
    assert needle in str(e.value)


def test_missing_suite_and_missing_file(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('suite = "no/such/suite"\n[[detectors]]\nid = "soc"\n')
    with pytest.raises(loomlab.ScenarioError, match="no/such/suite"):
        run_sweep(path, local=True, progress=False)
    with pytest.raises(loomlab.ScenarioError, match="missing.toml"):
        run_sweep(tmp_path / "missing.toml", local=True, progress=False)


def test_output_folder_of_another_sweep_is_refused(tmp_path):
    out = tmp_path / "out"
    run_sweep(SWEEP, out=out, local=True, progress=False, limit=2)
    with pytest.raises(loomlab.SweepError, match="--restart"):
        run_sweep(SWEEP, out=out, local=True, progress=False, limit=4)
    r = run_sweep(SWEEP, out=out, local=True, progress=False, limit=4, restart=True)
    assert r.complete and r.shards_run == r.shards_total == 4


def test_damaged_shard_file_is_named(tmp_path):
    out = tmp_path / "out"
    run_sweep(SWEEP, out=out, local=True, progress=False, limit=2)
    shard = out / "shards" / "00001.csv"
    shard.write_text(shard.read_text().replace("soc-001", "soc-009"))
    with pytest.raises(loomlab.SweepError, match="00001.csv.*delete the file"):
        run_sweep(SWEEP, out=out, local=True, progress=False, limit=2)
    shard.unlink()
    assert run_sweep(SWEEP, out=out, local=True, progress=False, limit=2).shards_run == 1


def test_run_suite_rejects_unknown_detector():
    with pytest.raises(loomlab.ScenarioError, match="unknown detector `nope`"):
        loomlab.run_suite(REPO / "scenarios" / "suites" / "default", detectors=["nope"], limit=1)
