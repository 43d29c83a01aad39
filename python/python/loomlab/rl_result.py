"""``python -m loomlab.rl_result``: the RL result (``docs/rl_result.json``) and the tables generated
from it.

``build`` (what ``make rl-result`` runs after training) takes the two training runs of ``python -m
loomlab.train`` (the policy on the detector features, ``--obs detectors``, and the learnability
check on the privileged percept, ``--obs privileged``), calibrates the threshold controllers on
their own seeds, evaluates both policies on held-out seeds with :func:`loomlab.evaluate` next to
the calibrated threshold controllers and the reference rows (``null``, ``oracle``, ``ideal_theta``,
``ideal_tau``, ``ideal_course``), and writes

- the result JSON: ``{"physics", "eval_seeds", "calibrate_seeds", "thresholds",
  "best_threshold_controller", "rows": {label: {"episodes", "collision_rate",
  "unnecessary_dodge_rate", "evasion_rate", "hit_rate", each rate with "<rate>_ci": [lower,
  upper], the 95 % Wilson interval}}, "training": {run: {steps (decisions), wall_s, steps_per_s,
  ...}}, "checks": {...}}``;
- the learning curves (PNG), with the held-out rows as lines.

``tables`` regenerates the blocks between ``<!-- rl-result:begin -->`` and ``<!-- rl-result:end -->``
of the given Markdown files from the JSON (``--check``: only report stale blocks, exit 1), as
``loomlab table`` does for the suite's tables; ``python/tests/test_rl_result.py`` fails while the
committed README or docs/results.md disagree with the committed ``docs/rl_result.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence, Tuple

BEGIN = "<!-- rl-result:begin -->"
END = "<!-- rl-result:end -->"
REGENERATE = "make rl-table-docs"
RATES = ("collision_rate", "unnecessary_dodge_rate", "evasion_rate", "hit_rate")
PHYSICS = "dynamic"
# must-show thresholds of issue 28
PRIVILEGED_EVASION_SHARE = 0.9
COLLISION_REDUCTION = 0.2


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
    return out


def best_threshold_controller(rows: Dict[str, Dict[str, Any]], threshold_rows: Sequence[str]) -> str:
    """The threshold row with the lowest collision rate (ties: fewer unnecessary dodges, then the label)."""
    usable = [k for k in threshold_rows if rows[k]["collision_rate"] is not None]
    if not usable:
        raise ValueError("no threshold controller row has a collision rate")
    return min(usable, key=lambda k: (rows[k]["collision_rate"], rows[k]["unnecessary_dodge_rate"] or 0.0, k))


def checks(result: Dict[str, Any]) -> Dict[str, Any]:
    """The issue's must-show comparisons, from the rows."""
    rows = result["rows"]
    out: Dict[str, Any] = {}
    priv, ideal = rows.get("ppo_privileged"), rows.get("ideal_course")
    if priv and ideal and ideal["evasion_rate"]:
        share = priv["evasion_rate"] / ideal["evasion_rate"]
        out["privileged_evasion_share_of_ideal_course"] = share
        out["privileged_met"] = bool(
            share >= PRIVILEGED_EVASION_SHARE and priv["unnecessary_dodge_rate"] <= ideal["unnecessary_dodge_rate"]
        )
    ppo, best = rows.get("ppo"), rows.get(result["best_threshold_controller"])
    if ppo and best and best["collision_rate"]:
        reduction = 1.0 - ppo["collision_rate"] / best["collision_rate"]
        out["ppo_collision_reduction_vs_best_threshold"] = reduction
        out["ppo_met"] = bool(
            reduction >= COLLISION_REDUCTION and ppo["unnecessary_dodge_rate"] <= best["unnecessary_dodge_rate"]
        )
    return out


def _training(run: str) -> Dict[str, Any]:
    """Steps, wall time and throughput of a training run folder."""
    with open(os.path.join(run, "config.json")) as f:
        config = json.load(f)
    with open(os.path.join(run, "checkpoints", "latest.json")) as f:
        latest = json.load(f)
    with open(os.path.join(run, "progress.csv")) as f:
        progress = list(csv.DictReader(f))
    repeat = int(config.get("action_repeat", 1))
    steps, wall = int(latest["steps"]), float(latest["wall_s"])
    return {
        "run": os.path.normpath(run),
        "checkpoint": os.path.normpath(latest["path"]),
        "obs": config.get("obs", "detectors"),
        "seed": config["seed"],
        "n_envs": config["n_envs"],
        "action_repeat": repeat,
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


def build(args: argparse.Namespace) -> Dict[str, Any]:
    """Evaluates the two runs and writes the result JSON and the curve PNG (see the module docs)."""
    from . import _native
    from .env import build_options, options_json
    from .evaluation import evaluate, load_policy

    started = time.monotonic()
    runs = {"ppo": args.run, "ppo_privileged": args.privileged_run}
    training = {label: _training(run) for label, run in runs.items()}
    opts = options_json(build_options(frame_size=args.frame_size, action_type="discrete", obs_mode="normalized"))
    cal = _native.calibrate_thresholds(args.suite, args.calibrate_seeds, args.fa_rate, args.limit, opts, args.jobs)
    thresholds = {k: v for k, v in cal.items() if v is not None}
    print(f"rl_result: calibrated thresholds (false-alarm rate <= {args.fa_rate}): {thresholds}", file=sys.stderr)
    reports = {}
    for label, t in training.items():
        reports[label] = evaluate(
            load_policy(t["checkpoint"]),
            args.suite,
            args.seeds,
            limit=args.limit,
            label=label,
            jobs=args.jobs,
            frame_size=args.frame_size,
            action_type="discrete",
            obs_mode="privileged" if t["obs"] == "privileged" else "normalized",
            thresholds=thresholds,
            action_repeat=t["action_repeat"],
            dodge_hold_s=t["dodge_hold_s"],
        )
    base = reports["ppo"]
    refs = list(base.get("references", []))
    threshold_rows = sorted(k for k in base["detectors"] if k not in refs and k not in runs)
    rows: Dict[str, Dict[str, Any]] = {label: _row(reports[label]["detectors"][label]) for label in runs}
    for k in threshold_rows + refs:
        rows[k] = _row(base["detectors"][k])
    result: Dict[str, Any] = {
        "physics": PHYSICS,
        "suite": args.suite or "escape_default",
        "eval_seeds": args.seeds,
        "calibrate_seeds": args.calibrate_seeds,
        "calibration_false_alarm_rate": args.fa_rate,
        "thresholds": thresholds,
        "threshold_rows": threshold_rows,
        "reference_rows": refs,
        "best_threshold_controller": best_threshold_controller(rows, threshold_rows),
        "rows": rows,
        "training": training,
        "evaluation_wall_s": round(time.monotonic() - started, 1),
    }
    result["checks"] = checks(result)
    with open(args.out, "w") as f:
        json.dump(result, f, indent=2)
        f.write("\n")
    plot(result, args.png)
    return result


def plot(result: Dict[str, Any], png: str) -> None:
    """The learning curves of both runs (held-out collision and unnecessary-dodge rates over
    decisions) with the held-out evaluation's rows as dashed lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
    keys = [("collision_rate", "collision rate"), ("unnecessary_dodge_rate", "unnecessary-dodge rate")]
    for label, color in (("ppo", "tab:blue"), ("ppo_privileged", "tab:orange")):
        curve = result["training"][label]["curve"]
        for ax, (key, _) in zip(axes, keys):
            ax.plot([c["steps"] for c in curve], [c[key] for c in curve], marker="o", ms=3, color=color, label=label)
    best = result["best_threshold_controller"]
    for label, color in (("null", "black"), ("oracle", "green"), ("ideal_course", "tab:brown"), (best, "tab:purple")):
        row = result["rows"].get(label)
        if row is None:
            continue
        for ax, (key, _) in zip(axes, keys):
            if row[key] is not None:
                ax.axhline(row[key], ls="--", lw=1, color=color, label=f"{label} (held-out)")
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


def _seeds(seeds: Sequence[int]) -> str:
    s = sorted(seeds)
    return f"{s[0]}–{s[-1]}" if s == list(range(s[0], s[-1] + 1)) else ", ".join(map(str, s))


def markdown(result: Dict[str, Any]) -> str:
    """The generated block: the rows with 95 % intervals, the training runs and the checks."""
    rows = result["rows"]
    best = result["best_threshold_controller"]
    order = ["ppo", "ppo_privileged"] + list(result["threshold_rows"]) + list(result["reference_rows"])
    lines = [
        f"Held-out seeds {_seeds(result['eval_seeds'])} of `{result['suite']}`, {result['physics']} physics; "
        f"threshold controllers calibrated to ≤ {100 * result['calibration_false_alarm_rate']:.0f} % false alarms "
        f"on seeds {_seeds(result['calibrate_seeds'])}; 95 % Wilson intervals.",
        "",
        "| row | episodes | collision rate | unnecessary-dodge rate | evasion rate |",
        "|---|---|---|---|---|",
    ]
    for k in order:
        if k not in rows:
            continue
        r = rows[k]
        name = f"`{k}` (best threshold controller)" if k == best else f"`{k}`"
        lines.append(
            f"| {name} | {r['episodes']} | {_pct(r, 'collision_rate')} | {_pct(r, 'unnecessary_dodge_rate')} | "
            f"{_pct(r, 'evasion_rate')} |"
        )
    lines += ["", "| training run | decisions (steps) | wall time | decisions/s |", "|---|---|---|---|"]
    for label in ("ppo", "ppo_privileged"):
        t = result["training"].get(label)
        if t is None:
            continue
        lines.append(
            f"| `{label}` (`--obs {t['obs']}`, seed {t['seed']}, {t['n_envs']} envs, action repeat "
            f"{t['action_repeat']}, dodge {t['dodge_hold_s']} s) | {t['steps']:,} | {t['wall_s'] / 60:.1f} min | "
            f"{t['steps_per_s']} |"
        )
    c = result.get("checks", {})
    lines.append("")
    if "privileged_evasion_share_of_ideal_course" in c:
        lines.append(
            f"- `ppo_privileged` evades {100 * c['privileged_evasion_share_of_ideal_course']:.0f} % as often as "
            f"`ideal_course` (target ≥ {100 * PRIVILEGED_EVASION_SHARE:.0f} % at no more unnecessary dodges): "
            f"**{'met' if c['privileged_met'] else 'not met'}**."
        )
    if "ppo_collision_reduction_vs_best_threshold" in c:
        lines.append(
            f"- `ppo` collides {100 * c['ppo_collision_reduction_vs_best_threshold']:.0f} % less (relative) than "
            f"`{best}` (target ≥ {100 * COLLISION_REDUCTION:.0f} % at no more unnecessary dodges): "
            f"**{'met' if c['ppo_met'] else 'not met'}**."
        )
    return "\n".join(lines)


def update_text(text: str, result: Dict[str, Any]) -> Tuple[str, int]:
    """``text`` with every rl-result block regenerated, and the number of blocks."""
    out, pos, n = [], 0, 0
    body = markdown(result)
    while True:
        b = text.find(BEGIN, pos)
        if b < 0:
            out.append(text[pos:])
            break
        e = text.find(END, b)
        if e < 0:
            raise ValueError(f"a `{BEGIN}` has no `{END}` after it")
        out.append(text[pos : b + len(BEGIN)] + "\n" + body + "\n")
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
            raise SystemExit(f"{p}: no `{BEGIN}` … `{END}` block; add one where the RL result belongs")
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
    b = sub.add_parser("build", help="evaluate the two training runs and write the result JSON + curve PNG")
    b.add_argument("--run", required=True, help="run folder of the policy on the detector features (--obs detectors)")
    b.add_argument("--privileged-run", required=True, help="run folder of the policy on the privileged percept")
    b.add_argument("--suite", default=None, help="shipped scenario name or suite path (default: escape_default)")
    b.add_argument("--seeds", type=parse_seeds, default="2000-2024", help="held-out seeds (default 2000-2024)")
    b.add_argument(
        "--calibrate-seeds", type=parse_seeds, default="7-14", help="threshold calibration seeds (default 7-14)"
    )
    b.add_argument("--fa-rate", type=float, default=0.1, help="calibration target false-alarm rate (default 0.1)")
    b.add_argument("--limit", type=int, default=None, help="episodes per seed (default: all)")
    b.add_argument("--frame-size", type=int, default=64, help="frame size n (default 64)")
    b.add_argument("--jobs", type=int, default=None, help="runner worker threads (default: one per CPU)")
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
        result = build(args)
        print(markdown(result))
        return
    sys.exit(tables(args.files, args.result, args.check))


if __name__ == "__main__":
    main()
