"""Issue 28: ``docs/rl_result.json`` (written by ``make rl-result``) and the README's and
docs/results.md's RL blocks generated from it (``make rl-table-docs``), as ``loomlab table``
generates the suite's tables from the committed baseline."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from loomlab.rl_result import BEGIN, END, REGENERATE, best_threshold_controller, checks, tables, update_text

ROOT = Path(__file__).resolve().parents[2]
RESULT = ROOT / "docs" / "rl_result.json"
DOCS = [ROOT / "README.md", ROOT / "docs" / "results.md"]
RATES = ("collision_rate", "unnecessary_dodge_rate", "evasion_rate")


def _result() -> dict:
    return json.loads(RESULT.read_text(encoding="utf-8"))


def test_the_result_has_every_row_with_intervals():
    r = _result()
    assert r["physics"] == "dynamic"
    assert r["eval_seeds"] and not set(r["eval_seeds"]) & set(r["calibrate_seeds"]), "held-out seeds"
    rows = r["rows"]
    for label in ["ppo", "ppo_privileged", "null", "oracle", "ideal_course", *r["threshold_rows"]]:
        for key in RATES:
            v, ci = rows[label][key], rows[label][f"{key}_ci"]
            if v is not None:
                assert ci[0] <= v <= ci[1], (label, key)
    assert r["best_threshold_controller"] == best_threshold_controller(rows, r["threshold_rows"])
    assert r["checks"] == checks(r)
    for run in ("ppo", "ppo_privileged"):
        t = r["training"][run]
        assert (
            t["steps"] > 0 and t["wall_s"] > 0 and t["steps_per_s"] == pytest.approx(t["steps"] / t["wall_s"], abs=0.1)
        )
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


def test_checks_follow_the_issue_targets():
    def row(c, u, e):
        return {"collision_rate": c, "unnecessary_dodge_rate": u, "evasion_rate": e}

    rows = {
        "ppo": row(0.20, 0.10, 0.5),
        "ppo_privileged": row(0.05, 0.02, 0.90),
        "soc": row(0.30, 0.10, 0.2),
        "keil2004": row(0.30, 0.12, 0.2),
        "ideal_course": row(0.02, 0.03, 0.95),
    }
    assert best_threshold_controller(rows, ["keil2004", "soc"]) == "soc", "ties: fewer unnecessary dodges"
    c = checks({"rows": rows, "best_threshold_controller": "soc"})
    assert c["privileged_met"] and c["ppo_met"]
    assert c["ppo_collision_reduction_vs_best_threshold"] == pytest.approx(1 / 3)
    rows["ppo"] = row(0.20, 0.11, 0.5)
    rows["ppo_privileged"] = row(0.05, 0.02, 0.85)
    c = checks({"rows": rows, "best_threshold_controller": "soc"})
    assert not c["ppo_met"], "more unnecessary dodges than the best threshold controller"
    assert not c["privileged_met"], "85/95 < 90 %"
