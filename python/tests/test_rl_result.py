"""Issues 28 and 54: ``docs/rl_result.json`` (written by ``make rl-result``: both policies on held-out
seeds of the default and the held-out suites, per tier, beside the suites' rows) and the README's and
docs/results.md's RL blocks generated from it (``make rl-table-docs``), as ``loomlab table``
generates the suite's tables from the committed baseline."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from loomlab.rl_result import (
    BEGIN,
    END,
    REGENERATE,
    best_threshold_controller,
    checks,
    markdown,
    tables,
    update_text,
)

ROOT = Path(__file__).resolve().parents[2]
RESULT = ROOT / "docs" / "rl_result.json"
DOCS = [ROOT / "README.md", ROOT / "docs" / "results.md"]
RATES = ("collision_rate", "unnecessary_dodge_rate", "evasion_rate")


def _result() -> dict:
    return json.loads(RESULT.read_text(encoding="utf-8"))


def test_the_result_has_every_row_with_intervals_per_suite_and_tier():
    r = _result()
    assert r["physics"] == "dynamic"
    assert [b["name"] for b in r["suites"]] == ["default", "heldout"], "both suites"
    for block in r["suites"]:
        rows = block["rows"]
        assert block["eval_seeds"] and not set(block["eval_seeds"]) & set(block["calibrate_seeds"] or [])
        for label in ["ppo", "ppo_privileged", "null", "oracle", "ideal_course", *block["threshold_rows"]]:
            for key in RATES:
                v, ci = rows[label][key], rows[label][f"{key}_ci"]
                if v is not None:
                    assert ci[0] <= v <= ci[1], (block["name"], label, key)
        assert block["tiers"], "per tier"
        for tier in block["tiers"].values():
            assert set(tier) == set(rows), "every row in every tier"
        for label in rows:
            assert sum(t[label]["episodes"] for t in block["tiers"].values()) == rows[label]["episodes"]
        assert block["best_threshold_controller"] == best_threshold_controller(rows, block["threshold_rows"])
        assert block["checks"] == checks(block)
    for run in ("ppo", "ppo_privileged"):
        t = r["training"][run]
        assert (
            t["steps"] > 0 and t["wall_s"] > 0 and t["steps_per_s"] == pytest.approx(t["steps"] / t["wall_s"], abs=0.1)
        )
    assert r["training"]["ppo"]["obs"] == "decision", "the policy on the rows' decision features"
    assert (ROOT / "docs" / "rl_learning_curve.png").exists()


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_committed_rl_blocks_match_the_result(doc):
    text = doc.read_text(encoding="utf-8")
    new, n = update_text(text, _result())
    assert n == 1, f"{doc.name} has one `{BEGIN}` block"
    assert new == text, (
        f"{doc.name}: the RL block disagrees with docs/rl_result.json; regenerate it with `{REGENERATE}`"
    )


def test_a_stale_block_is_found_and_regenerating_fixes_it(tmp_path, capsys):
    doc = tmp_path / "README.md"
    shutil.copy(DOCS[0], doc)
    good = doc.read_text(encoding="utf-8")
    begin, end = good.index(BEGIN), good.index(END)
    digit = begin + next(i for i, c in enumerate(good[begin:end]) if c.isdigit())
    bad = good[:digit] + ("8" if good[digit] == "9" else "9") + good[digit + 1 :]
    doc.write_text(bad, encoding="utf-8")
    assert tables([str(doc)], str(RESULT), check=True) == 1
    assert REGENERATE in capsys.readouterr().err
    assert doc.read_text(encoding="utf-8") == bad, "--check writes nothing"
    assert tables([str(doc)], str(RESULT), check=False) == 0
    assert doc.read_text(encoding="utf-8") == good


def _rows(**rates):
    return {k: {"collision_rate": c, "unnecessary_dodge_rate": u, "evasion_rate": e} for k, (c, u, e) in rates.items()}


def test_checks_follow_the_issue_targets():
    rows = _rows(
        ppo=(0.08, 0.10, 0.8),
        ppo_privileged=(0.03, 0.02, 0.95),
        tracker_tau=(0.12, 0.24, 0.75),
        soc=(0.12, 0.30, 0.2),
        ideal_course=(0.02, 0.03, 0.97),
    )
    assert best_threshold_controller(rows, ["soc", "tracker_tau"]) == "tracker_tau", "ties: fewer unnecessary dodges"
    block = {"rows": rows, "best_threshold_controller": "tracker_tau"}
    c = checks(block)
    assert c["privileged_met"] and c["ppo_met"] and c["best_threshold_avoids"]
    assert c["ppo_collision_reduction_vs_best_threshold"] == pytest.approx(1 / 3)
    rows["ppo"]["unnecessary_dodge_rate"] = 0.25
    assert not checks(block)["ppo_met"], "more unnecessary dodges than the best threshold row"
    rows["ppo"]["unnecessary_dodge_rate"] = 0.10
    rows["tracker_tau"]["evasion_rate"] = 0.45
    c = checks(block)
    assert not c["best_threshold_avoids"] and not c["ppo_met"], "the best threshold row must be one that avoids"
    rows["ppo_privileged"]["evasion_rate"] = 0.92
    assert not checks(block)["privileged_met"], "0.92 / 0.97 < 95 %"


def test_the_compact_block_shows_the_policies_the_best_rows_and_the_bounds():
    rows = _rows(
        ppo=(0.2, 0.1, 0.5),
        ppo_privileged=(0.1, 0.1, 0.8),
        soc=(0.3, 0.1, 0.1),
        tracker_tau=(0.12, 0.24, 0.75),
        tracker_tau_persistent=(0.15, 0.08, 0.68),
        null=(0.4, 0.0, 0.0),
        oracle=(0.0, 0.0, 1.0),
        ideal_tau=(0.0, 1.0, 1.0),
        ideal_course=(0.02, 0.01, 0.97),
    )
    for r in rows.values():
        r.update({f"{k}_ci": None for k in RATES}, collisions_caused=0, episodes=10)
    block = {
        "name": "default",
        "suite": "scenarios/suites/default",
        "episodes": 10,
        "eval_seeds": [2000],
        "calibrate_seeds": None,
        "threshold_rows": ["soc", "tracker_tau", "tracker_tau_persistent"],
        "reference_rows": ["null", "oracle", "ideal_tau", "ideal_course"],
        "rows": rows,
        "tiers": {"0": rows},
        "best_threshold_controller": "tracker_tau",
    }
    block["checks"] = checks(block)
    result = {"physics": "dynamic", "suites": [block], "training": {}}
    table = lambda text: [ln.split(" | ")[0][2:] for ln in text.splitlines() if ln.startswith("| `")]  # noqa: E731
    assert table(markdown(result, compact=True)) == [
        "`ppo`",
        "`ppo_privileged`",
        "`tracker_tau` (best threshold row)",
        "`null`",
        "`oracle`",
        "`ideal_course`",
    ], "the best threshold row is also the one that evades most here"
    rows["tracker_tau_persistent"]["evasion_rate"] = 0.8
    assert "`tracker_tau_persistent`" in table(markdown(result, compact=True)), "the best avoiding row joins"
    assert len(table(markdown(result))) == len(rows), "the full block has every row"
