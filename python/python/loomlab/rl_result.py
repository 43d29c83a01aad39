"""``python -m loomlab.rl_result``: the RL result (``docs/rl_result.json``) and the tables generated
from it.

``build`` (what ``make rl-result`` runs after training) takes the two training runs of ``python -m
loomlab.train`` (the policy on the rows' decision features, ``--obs decision``, and the
learnability check on the privileged percept, ``--obs privileged``) and, for each suite
(``--suite``, repeatable: the default suite and the held-out suite), evaluates both policies on
held-out seeds with :func:`loomlab.evaluate` next to the suite's own rows (its ``[[detectors]]``
with their decision rules and the thresholds its file records; ``--calibrate-seeds`` calibrates
them anew to ``--fa-rate`` on those seeds instead) and the reference rows (``null``, ``oracle``,
``ideal_theta``, ``ideal_tau``, ``ideal_course``), pooled and per tier, and writes

- the result JSON: ``{"physics", "training": {run: {steps (decisions), wall_s, steps_per_s, curve,
  ...}}, "suites": [{"name", "suite", "eval_seeds", "calibrate_seeds", "thresholds",
  "threshold_rows", "reference_rows", "best_threshold_controller", "rows": {label: {"episodes",
  "collision_rate", "unnecessary_dodge_rate", "evasion_rate", "hit_rate", "collisions_caused",
  each rate with "<rate>_ci": [lower, upper], the 95 % Wilson interval}}, "tiers": {tier: {label:
  row}}, "checks": {...}}], "evaluation_wall_s"}``;
- the learning curves (PNG), with the default suite's held-out rows as lines.

``tables`` regenerates the blocks between ``<!-- rl-result:begin -->`` and ``<!-- rl-result:end -->``
of the given Markdown files from the JSON (``<!-- rl-result:begin compact -->``: only the policies,
the best threshold row, the best avoiding row and the reference rows that bound them; ``--check``:
only report stale blocks, exit 1), as ``loomlab table`` does for the suite's tables;
``python/tests/test_rl_result.py`` fails while the committed README or docs/results.md disagree
with the committed ``docs/rl_result.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Dict, List, Optional, Sequence, Tuple

BEGIN = "<!-- rl-result:begin"
END = "<!-- rl-result:end -->"
REGENERATE = "make rl-table-docs"
RATES = ("collision_rate", "unnecessary_dodge_rate", "evasion_rate", "hit_rate")
PHYSICS = "dynamic"
POLICIES = ("ppo", "ppo_privileged")
# must-show thresholds of issue 54
PRIVILEGED_EVASION_SHARE = 0.95
COLLISION_REDUCTION = 0.2
AVOIDING_EVASION = 0.5
"""A threshold row "avoids" when it evades at least this share of the evadable threats."""
COMPACT_REFERENCES = ("null", "oracle", "ideal_course")


def _row(summary: Dict[str, Any]) -> Dict[str, Any]:
    """A report row (``report.json``'s detector summary) in the result's terms: the false-alarm rate
    is the unnecessary-dodge rate (any departure from cruising in an episode without a threat)."""
    out: Dict[str, Any] = {"episodes": summary["episodes"]}
    for key, src in (
        ("collision_rate", "collision_rate"),
        ("unnecessary_dodge_rate", "false_alarm_rate"),
        ("evasion_rate", "evasion_rate"),
        ("hit_rate", "hit_rate"),
    ):
        v = summary.get(src)
        ci = summary.get(f"{src}_ci")
        out[key] = v
        out[f"{key}_ci"] = [ci["lower"], ci["upper"]] if ci else None
    out["collisions_caused"] = summary.get("collisions_caused")
    return out


def best_threshold_controller(rows: Dict[str, Dict[str, Any]], threshold_rows: Sequence[str]) -> str:
    """The threshold row with the lowest collision rate (ties: fewer unnecessary dodges, then the label)."""
    usable = [k for k in threshold_rows if rows[k]["collision_rate"] is not None]
    if not usable:
        raise ValueError("no threshold controller row has a collision rate")
    return min(usable, key=lambda k: (rows[k]["collision_rate"], rows[k]["unnecessary_dodge_rate"] or 0.0, k))


def checks(block: Dict[str, Any]) -> Dict[str, Any]:
    """The issue's must-show comparisons on one suite, from its rows: ``ppo`` collides at least 20 %
    less (relative) than the best threshold row at no more unnecessary dodges, that row being one
    that avoids (evasion ≥ 0.5); ``ppo_privileged`` evades ≥ 95 % as often as ``ideal_course`` at no
    more unnecessary dodges."""
    rows = block["rows"]
    out: Dict[str, Any] = {}
    priv, ideal = rows.get("ppo_privileged"), rows.get("ideal_course")
    if priv and ideal and ideal["evasion_rate"]:
        share = priv["evasion_rate"] / ideal["evasion_rate"]
        out["privileged_evasion_share_of_ideal_course"] = share
        out["privileged_met"] = bool(
            share >= PRIVILEGED_EVASION_SHARE and priv["unnecessary_dodge_rate"] <= ideal["unnecessary_dodge_rate"]
        )
    ppo, best = rows.get("ppo"), rows.get(block["best_threshold_controller"])
    if ppo and best and best["collision_rate"]:
        reduction = 1.0 - ppo["collision_rate"] / best["collision_rate"]
        out["ppo_collision_reduction_vs_best_threshold"] = reduction
        out["best_threshold_avoids"] = bool((best["evasion_rate"] or 0.0) >= AVOIDING_EVASION)
        out["ppo_met"] = bool(
            reduction >= COLLISION_REDUCTION
            and ppo["unnecessary_dodge_rate"] <= best["unnecessary_dodge_rate"]
            and out["best_threshold_avoids"]
        )
    return out


def _relative(path: Optional[str]) -> Optional[str]:
    """A path below the working directory as a relative one (the JSON is committed)."""
    if path and os.path.isabs(path) and os.path.commonpath([path, os.getcwd()]) == os.getcwd():
        return os.path.relpath(path)
    return path


def _training(run: str) -> Dict[str, Any]:
    """Steps, wall time, throughput and the environment of a training run folder."""
    with open(os.path.join(run, "config.json")) as f:
        config = json.load(f)
    with open(os.path.join(run, "checkpoints", "latest.json")) as f:
        latest = json.load(f)
    with open(os.path.join(run, "progress.csv")) as f:
        progress = list(csv.DictReader(f))
    steps, wall = int(latest["steps"]), float(latest["wall_s"])
    return {
        "run": os.path.normpath(run),
        "checkpoint": os.path.normpath(latest["path"]),
        "obs": config.get("obs", "detectors"),
        "env": config.get("env", "discrete"),
        "scenario": _relative(config.get("scenario")),
        "frame_size": config.get("frame_size"),
        "seed": config["seed"],
        "n_envs": config["n_envs"],
        "action_repeat": int(config.get("action_repeat", 1)),
        "dodge_hold_s": float(config.get("dodge_hold_s", 0.0)),
        "steps": steps,
        "wall_s": round(wall, 1),
        "steps_per_s": round(steps / wall, 1) if wall > 0 else None,
        "curve": [
            {
                "steps": int(r["steps"]),
                "collision_rate": float(r["collision_rate"]),
                "unnecessary_dodge_rate": float(r["unnecessary_dodge_rate"]),
            }
            for r in progress
        ],
    }


def _evaluate_run(task: Tuple[str, Dict[str, Any], str, List[int], Dict[str, float], Optional[int], Optional[int]]):
    """One policy on one suite (a process of the pool): its report."""
    from .evaluation import evaluate, load_policy
    from .train import OBS_MODES

    label, t, suite, seeds, thresholds, limit, jobs = task
    return evaluate(
        load_policy(t["checkpoint"], t["env"]),
        suite,
        seeds,
        limit=limit,
        label=label,
        jobs=jobs,
        frame_size=t["frame_size"],
        action_type=t["env"],
        obs_mode=OBS_MODES[t["obs"]],
        thresholds=thresholds,
        action_repeat=t["action_repeat"],
        dodge_hold_s=t["dodge_hold_s"],
    )


def _suite_block(
    name: str, suite: str, args: argparse.Namespace, reports: Dict[str, Any], thresholds: Dict[str, float]
):
    """The result of one suite from the policies' reports (the suite's rows come from ``ppo``'s, which
    ran them at the suite's camera size)."""
    base = reports["ppo"]
    refs = list(base.get("references", []))
    threshold_rows = sorted(k for k in base["detectors"] if k not in refs and k not in POLICIES)
    rows: Dict[str, Dict[str, Any]] = {label: _row(reports[label]["detectors"][label]) for label in POLICIES}
    for k in threshold_rows + refs:
        rows[k] = _row(base["detectors"][k])
    tiers: Dict[str, Dict[str, Any]] = {}
    for tier, t in sorted(base.get("tiers", {}).items()):
        tiers[tier] = {k: _row(t["detectors"][k]) for k in threshold_rows + refs}
        for label in POLICIES:
            tiers[tier][label] = _row(reports[label]["tiers"][tier]["detectors"][label])
    block: Dict[str, Any] = {
        "name": name,
        "suite": os.path.relpath(suite) if os.path.exists(suite) else suite,
        "episodes": rows["ppo"]["episodes"],
        "eval_seeds": args.seeds,
        "calibrate_seeds": args.calibrate_seeds,
        "calibration_false_alarm_rate": args.fa_rate if args.calibrate_seeds else None,
        "thresholds": thresholds,
        "threshold_rows": threshold_rows,
        "reference_rows": refs,
        "rows": rows,
        "tiers": tiers,
    }
    block["best_threshold_controller"] = best_threshold_controller(rows, threshold_rows)
    block["checks"] = checks(block)
    return block


def build(args: argparse.Namespace) -> Dict[str, Any]:
    """Evaluates the two runs on every suite and writes the result JSON and the curve PNG (see the
    module docs)."""
    from . import _native
    from .env import build_options, options_json, suite_path

    started = time.monotonic()
    runs = {"ppo": args.run, "ppo_privileged": args.privileged_run}
    training = {label: _training(run) for label, run in runs.items()}
    suites = [suite_path(s[len("suite:") :]) if s.startswith("suite:") else s for s in args.suite]
    calibrated: Dict[str, Dict[str, float]] = {}
    for suite in suites:
        calibrated[suite] = {}
        if args.calibrate_seeds:
            t = training["ppo"]
            opts = options_json(build_options(frame_size=t["frame_size"], action_type=t["env"], obs_mode="normalized"))
            cal = _native.calibrate_thresholds(suite, args.calibrate_seeds, args.fa_rate, args.limit, opts, args.jobs)
            calibrated[suite] = {k: v for k, v in cal.items() if v is not None}
            print(f"rl_result: {suite}: calibrated thresholds: {calibrated[suite]}", file=sys.stderr)
    tasks = [
        (label, training[label], suite, args.seeds, calibrated[suite] or None, args.limit, args.jobs)
        for suite in suites
        for label in POLICIES
    ]
    spawn = multiprocessing.get_context("spawn")  # the native module runs threads: no fork
    with ProcessPoolExecutor(max_workers=max(1, args.processes), mp_context=spawn) as pool:
        reports = list(pool.map(_evaluate_run, tasks))
    blocks = []
    for i, (suite, name) in enumerate(zip(suites, args.suite)):
        by_label = {label: reports[i * len(POLICIES) + j] for j, label in enumerate(POLICIES)}
        short = name[len("suite:") :] if name.startswith("suite:") else os.path.basename(os.path.normpath(name))
        blocks.append(_suite_block(short, suite, args, by_label, calibrated[suite]))
    result: Dict[str, Any] = {
        "physics": PHYSICS,
        "training": training,
        "suites": blocks,
        "evaluation_wall_s": round(time.monotonic() - started, 1),
    }
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    plot(result, args.png)
    return result


def plot(result: Dict[str, Any], png: str) -> None:
    """The learning curves of both runs (held-out collision and unnecessary-dodge rates over
    decisions) with the first suite's held-out rows as dashed lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
    keys = [("collision_rate", "collision rate"), ("unnecessary_dodge_rate", "unnecessary-dodge rate")]
    for label, color in (("ppo", "tab:blue"), ("ppo_privileged", "tab:orange")):
        curve = result["training"][label]["curve"]
        for ax, (key, _) in zip(axes, keys):
            ax.plot([c["steps"] for c in curve], [c[key] for c in curve], marker="o", ms=3, color=color, label=label)
    block = result["suites"][0]
    best = block["best_threshold_controller"]
    lines = (("null", "black"), ("oracle", "green"), ("ideal_course", "tab:brown"), (best, "tab:purple"))
    for label, color in lines:
        row = block["rows"].get(label)
        if row is None:
            continue
        for ax, (key, _) in zip(axes, keys):
            if row[key] is not None:
                ax.axhline(row[key], ls="--", lw=1, color=color, label=f"{label} ({block['name']}, held-out)")
    for ax, (_, title) in zip(axes, keys):
        ax.set_xlabel("decisions (environment steps)")
        ax.set_ylabel(f"held-out {title}")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


def _pct(row: Dict[str, Any], key: str) -> str:
    v, ci = row.get(key), row.get(f"{key}_ci")
    if v is None:
        return "n/a"
    return f"{100 * v:.1f} % [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}]" if ci else f"{100 * v:.1f} %"


def _less(reduction: float) -> str:
    """A relative collision reduction in words: "24 % less" or "45 % more"."""
    return f"{100 * abs(reduction):.0f} % {'less' if reduction >= 0 else 'more'}"


def _short(v: Optional[float]) -> str:
    return "–" if v is None else f"{100 * v:.0f}"


def _seeds(seeds: Sequence[int]) -> str:
    s = sorted(seeds)
    if len(s) > 1 and s == list(range(s[0], s[-1] + 1)):
        return f"{s[0]}–{s[-1]}"
    return ", ".join(map(str, s))


def best_avoiding_row(block: Dict[str, Any]) -> Optional[str]:
    """The threshold row that evades most (ties: fewer unnecessary dodges), or None."""
    rows = block["rows"]
    usable = [k for k in block["threshold_rows"] if rows[k]["evasion_rate"] is not None]
    return max(
        usable, key=lambda k: (rows[k]["evasion_rate"], -(rows[k]["unnecessary_dodge_rate"] or 0.0), k), default=None
    )


def _order(block: Dict[str, Any], compact: bool) -> List[str]:
    best = block["best_threshold_controller"]
    if compact:
        avoiding = best_avoiding_row(block)
        chosen = [best] + ([avoiding] if avoiding and avoiding != best else [])
        return list(POLICIES) + chosen + [k for k in COMPACT_REFERENCES if k in block["rows"]]
    return list(POLICIES) + list(block["threshold_rows"]) + list(block["reference_rows"])


def _suite_markdown(block: Dict[str, Any], compact: bool) -> List[str]:
    rows, best = block["rows"], block["best_threshold_controller"]
    tiers = sorted(block["tiers"])
    how = (
        f"thresholds calibrated to ≤ {100 * block['calibration_false_alarm_rate']:.0f} % false alarms on seeds "
        f"{_seeds(block['calibrate_seeds'])}"
        if block["calibrate_seeds"]
        else "the suite's rows with the thresholds its file records"
    )
    lines = [
        f"**`{block['name']}`** (`{block['suite']}`): held-out seed(s) {_seeds(block['eval_seeds'])}, "
        f"{block['episodes']} episodes; {how}.",
        "",
        "| row | collision rate | unnecessary-dodge rate | evasion rate | caused | "
        + " | ".join(f"tier {t}" for t in tiers)
        + " |",
        "|---|---|---|---|---|" + "---|" * len(tiers),
    ]
    for k in _order(block, compact):
        r = rows[k]
        name = f"`{k}` (best threshold row)" if k == best else f"`{k}`"
        per_tier = " | ".join(
            f"{_short(block['tiers'][t][k]['collision_rate'])} / {_short(block['tiers'][t][k]['evasion_rate'])}"
            for t in tiers
        )
        lines.append(
            f"| {name} | {_pct(r, 'collision_rate')} | {_pct(r, 'unnecessary_dodge_rate')} | "
            f"{_pct(r, 'evasion_rate')} | {r['collisions_caused']} | {per_tier} |"
        )
    phrases = _check_phrases(block)
    if not phrases:
        return lines
    if compact:
        return lines + ["", "Targets at no more unnecessary dodges: " + "; ".join(phrases) + "."]
    return lines + [""] + [f"- Target at no more unnecessary dodges: {p}." for p in phrases]


def _check_phrases(block: Dict[str, Any]) -> List[str]:
    """The suite's checks (:func:`checks`) in words, with their targets and verdicts."""
    c, best = block.get("checks", {}), block["best_threshold_controller"]
    verdict = lambda key: "met" if c.get(key) else "not met"  # noqa: E731
    out = []
    if "ppo_collision_reduction_vs_best_threshold" in c:
        weak = "" if c["best_threshold_avoids"] else f", a row that does not avoid: evasion < {AVOIDING_EVASION}"
        out.append(
            f"`ppo` collides {_less(c['ppo_collision_reduction_vs_best_threshold'])} than `{best}` "
            f"(≥ {100 * COLLISION_REDUCTION:.0f} % less{weak}): **{verdict('ppo_met')}**"
        )
    if "privileged_evasion_share_of_ideal_course" in c:
        out.append(
            f"`ppo_privileged` evades {100 * c['privileged_evasion_share_of_ideal_course']:.0f} % as often as "
            f"`ideal_course` (≥ {100 * PRIVILEGED_EVASION_SHARE:.0f} %): **{verdict('privileged_met')}**"
        )
    return out


def markdown(result: Dict[str, Any], compact: bool = False) -> str:
    """The generated block: per suite the rows (pooled with 95 % intervals; per tier collision /
    evasion in %), the checks, then the training runs."""
    lines = [
        f"{result['physics'].capitalize()} physics; 95 % Wilson intervals; caused: collisions after the row's own "
        "dodges; tier columns: collision / evasion rate (%)."
    ]
    for block in result["suites"]:
        lines += [""] + _suite_markdown(block, compact)
    if compact:
        runs = [
            f"`{label}` {t['steps']:,} decisions in {t['wall_s'] / 60:.0f} min ({t['steps_per_s']}/s, "
            f"`--obs {t['obs']}`, n = {t['frame_size']})"
            for label, t in ((k, result["training"].get(k)) for k in POLICIES)
            if t is not None
        ]
        return "\n".join(lines + ["", "Training on the default suite: " + "; ".join(runs) + "."])
    lines += ["", "| training run | decisions (steps) | wall time | decisions/s |", "|---|---|---|---|"]
    for label in POLICIES:
        t = result["training"].get(label)
        if t is None:
            continue
        lines.append(
            f"| `{label}` (`--obs {t['obs']}`, `--env {t['env']}`, n = {t['frame_size']}, seed {t['seed']}, "
            f"{t['n_envs']} envs, action repeat {t['action_repeat']}) | {t['steps']:,} | {t['wall_s'] / 60:.1f} min | "
            f"{t['steps_per_s']} |"
        )
    return "\n".join(lines)


def update_text(text: str, result: Dict[str, Any]) -> Tuple[str, int]:
    """``text`` with every rl-result block regenerated (``<!-- rl-result:begin compact -->``: the
    compact rows), and the number of blocks."""
    out, pos, n = [], 0, 0
    while True:
        b = text.find(BEGIN, pos)
        if b < 0:
            out.append(text[pos:])
            break
        marker_end = text.find("-->", b)
        e = text.find(END, b)
        if e < 0 or marker_end < 0:
            raise ValueError(f"a `{BEGIN} -->` has no `{END}` after it")
        compact = "compact" in text[b:marker_end]
        body = markdown(result, compact)
        out.append(text[pos : marker_end + len("-->")] + "\n" + body + "\n")
        pos, n = e, n + 1
    return "".join(out), n


def tables(paths: Sequence[str], result_path: str, check: bool) -> int:
    """Regenerates (or with ``check`` only compares) the rl-result blocks; returns the exit status."""
    with open(result_path) as f:
        result = json.load(f)
    stale: List[str] = []
    for p in paths:
        with open(p, encoding="utf-8") as f:
            text = f.read()
        new, n = update_text(text, result)
        if n == 0:
            raise SystemExit(f"{p}: no `{BEGIN} -->` … `{END}` block; add one where the RL result belongs")
        if new != text:
            stale.append(p)
            if not check:
                with open(p, "w", encoding="utf-8") as f:
                    f.write(new)
    if check and stale:
        print(
            f"stale RL result block(s) in {', '.join(stale)}: they disagree with {result_path}; "
            f"regenerate them with `{REGENERATE}`",
            file=sys.stderr,
        )
        return 1
    return 0


def main(argv: Optional[Sequence[str]] = None) -> None:
    from .train import parse_seeds

    p = argparse.ArgumentParser(prog="python -m loomlab.rl_result", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="evaluate the two training runs on the suites and write the result JSON + PNG")
    b.add_argument("--run", required=True, help="run folder of the policy on the rows' features (--obs decision)")
    b.add_argument("--privileged-run", required=True, help="run folder of the policy on the privileged percept")
    b.add_argument(
        "--suite",
        action="append",
        default=None,
        help="suite folder, list file, shipped scenario or suite:NAME; repeatable (default: suite:default and "
        "suite:heldout)",
    )
    b.add_argument("--seeds", type=parse_seeds, default="2000", help="held-out seeds of every suite (default 2000)")
    b.add_argument(
        "--calibrate-seeds",
        type=parse_seeds,
        default=None,
        help="calibrate the rows' thresholds anew on these seeds (default: the thresholds the suite records)",
    )
    b.add_argument("--fa-rate", type=float, default=0.1, help="calibration target false-alarm rate (default 0.1)")
    b.add_argument("--limit", type=int, default=None, help="episodes per seed (default: all)")
    b.add_argument("--jobs", type=int, default=None, help="runner worker threads per process (default: one per CPU)")
    b.add_argument(
        "--processes", type=int, default=1, help="policy evaluations run side by side (default 1; one per core)"
    )
    b.add_argument("--out", default="docs/rl_result.json", help="the result JSON (default docs/rl_result.json)")
    b.add_argument(
        "--png", default="docs/rl_learning_curve.png", help="the curve PNG (default docs/rl_learning_curve.png)"
    )
    t = sub.add_parser("tables", help="regenerate the rl-result blocks of Markdown files from the result JSON")
    t.add_argument("files", nargs="+", help="Markdown files with `<!-- rl-result:begin -->` blocks")
    t.add_argument("--result", default="docs/rl_result.json", help="the result JSON (default docs/rl_result.json)")
    t.add_argument("--check", action="store_true", help="write nothing; exit 1 when a block is stale")
    args = p.parse_args(argv)
    if args.command == "build":
        args.suite = args.suite or ["suite:default", "suite:heldout"]
        result = build(args)
        print(markdown(result))
        return
    sys.exit(tables(args.files, args.result, args.check))


if __name__ == "__main__":
    main()
