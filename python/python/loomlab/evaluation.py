"""``loomlab.evaluate`` (defined here; CLI ``python -m loomlab.evaluation``): a policy scored on a suite
exactly as ``loomlab run`` scores detectors.

The policy drives the robot through every episode of the suite (expanded with each seed as ``loomlab
run SUITE --seed SEED`` expands it, each episode with its own simulator seed). The episode's
escape deadline and ground truth come from the environment (``loomlab_scenarios::deadline``, the
runner's code); the policy's *alarm* is the first observation on which it departed from the cruise
command, so its row is classified as a detector's is (hit: departed at or before the escape
deadline less the lead margin; miss; false alarm: departed in an episode without a threat; correct
rejection), with its closed-loop collision. The scenario runner then runs the same episodes (the
suite's detectors with their threshold controllers, and the reference rows ``null``, ``oracle``,
``ideal_theta``, ``ideal_tau``, ``ideal_course``) and the policy's row joins them in one report with
the keys of ``report.json``.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any, Callable, Dict, Iterable, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from .env import (
    DISCRETE_ACTIONS,
    MANOEUVRE_ACTIONS,
    _continuous_action,
    _discrete_action,
    build_options,
    options_json,
)

__all__ = ["evaluate", "policy_function"]

Policy = Callable[[Any, Dict[str, Any]], Any]


def policy_function(policy: Any, deterministic: bool = True) -> Policy:
    """``policy`` as a function ``(obs, info) -> action``: a callable is used as it is; an object with
    a Stable-Baselines3-style ``predict(obs, deterministic=...)`` is wrapped."""
    if hasattr(policy, "predict"):

        def act(obs: Any, info: Dict[str, Any]) -> Any:
            action, _ = policy.predict(obs, deterministic=deterministic)
            return action

        return act
    if callable(policy):
        return policy
    raise TypeError(f"policy must be a callable (obs, info) -> action or have .predict(), got {type(policy).__name__}")


def evaluate(
    policy: Any,
    suite: Union[str, None] = None,
    seeds: Iterable[int] = (0,),
    *,
    limit: Optional[int] = None,
    label: str = "policy",
    jobs: Optional[int] = None,
    progress: bool = True,
    detectors: Union[str, Sequence[str], None] = None,
    frame_size: Optional[int] = 64,
    action_type: str = "discrete",
    obs_mode: str = "normalized",
    observe_frames: bool = False,
    thresholds: Optional[Dict[str, float]] = None,
    action_repeat: int = 1,
    dodge_hold_s: float = 0.0,
) -> Dict[str, Any]:
    """Runs ``policy`` on every episode of ``suite`` for each seed and returns the report.

    Args:
        policy: ``(obs, info) -> action`` or an object with ``predict`` (a Stable-Baselines3 model).
        suite: a shipped scenario name (``None``: the environment's default scenario set,
            ``escape_default``) or a path to a suite folder, list file or scenario file.
        seeds: the suite is expanded once per seed (random ranges drawn anew); the report pools them.
        limit: only the first ``limit`` episodes of each expansion.
        label: the policy's row in the report (not a detector or reference label).
        jobs: runner worker threads (``None``: one per CPU).
        progress: print one line per seed.
        detectors, frame_size, action_type, obs_mode, observe_frames, thresholds, action_repeat,
            dodge_hold_s: the environment the policy was trained in (:class:`loomlab.EscapeEnv`'s
            arguments); ``frame_size`` and ``detectors`` are applied to the suite as ``loomlab run
            --size --detectors`` does.

    Returns:
        The report dict (keys of ``report.json``: ``detectors`` holds every detector's, every
        reference row's and the policy's summary), plus ``seeds``.
    """
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds is empty: give at least one seed")
    act = policy_function(policy)
    opts = options_json(
        build_options(
            detectors=detectors,
            thresholds=thresholds,
            frame_size=frame_size,
            observe_frames=observe_frames,
            action_type=action_type,
            obs_mode=obs_mode,
            action_repeat=action_repeat,
            dodge_hold_s=dodge_hold_s,
        )
    )
    rows = []
    for seed in seeds:
        native = _native.EscapeEnv.from_suite(suite, seed, limit, opts)
        discrete = native.action_kind in ("discrete", "manoeuvre")
        try:
            for index in range(native.num_episodes):
                rows.append(_run_episode(native, index, act, discrete))
        finally:
            native.close()
        if progress:
            print(f"evaluate: seed {seed}: {len(rows)} episodes run by the policy so far", file=sys.stderr, flush=True)
    text = _native.evaluation_report(suite, seeds, label, json.dumps(rows), limit, opts, jobs)
    report = json.loads(text)
    report["seeds"] = seeds
    return report


def _run_episode(native: Any, index: int, act: Policy, discrete: bool) -> Dict[str, Any]:
    """Runs episode ``index`` with the policy; returns the environment's scoring of the policy."""
    obs, info = native.reset_to_episode(index)
    while True:
        action = act(obs, info)
        if discrete:
            result = native.step_discrete(_discrete_action(np.asarray(action).reshape(()), _action_names(native)))
        else:
            result = native.step_continuous(*_continuous_action(np.asarray(action, dtype=np.float32).reshape(3)))
        obs, _, terminated, truncated, info = result
        if terminated or truncated:
            return info["outcome"]["agent"]


def _action_names(native: Any) -> Tuple[str, ...]:
    return MANOEUVRE_ACTIONS if native.action_kind == "manoeuvre" else DISCRETE_ACTIONS


def load_policy(path: str, action_type: str = "discrete") -> Policy:
    """A trained policy from ``python -m loomlab.train``: a Stable-Baselines3 PPO ``.zip`` or a CEM
    ``.npz`` checkpoint (``threshold``: the shadow threshold controller, ``info["controller_action"]``)."""
    if path == "threshold":
        return lambda obs, info: info["controller_action"]
    if path.endswith(".zip"):
        try:
            from stable_baselines3 import PPO
        except ImportError as e:
            raise SystemExit(
                f"{path}: loading a PPO model needs stable-baselines3: pip install 'loomlab[rl]' ({e})"
            ) from e
        return policy_function(PPO.load(path, device="cpu"))
    if path.endswith(".npz"):
        z = np.load(path)
        mean = np.asarray(z["mean"])
        out_dim = {"discrete": len(DISCRETE_ACTIONS), "manoeuvre": len(MANOEUVRE_ACTIONS)}.get(action_type, 3)
        w = mean.reshape(-1, out_dim)

        def linear(obs: Any, info: Dict[str, Any]) -> Any:
            v = np.asarray(obs) @ w[:-1] + w[-1]
            return int(np.argmax(v)) if action_type != "continuous" else np.tanh(v).astype(np.float32)

        return linear
    raise SystemExit(f"{path}: not a policy (.zip from PPO, .npz from CEM, or `threshold`)")


TABLE_ROWS = ("collision_rate", "false_alarm_rate", "hit_rate", "evasion_rate")


def _pct(summary: Dict[str, Any], key: str) -> str:
    v = summary.get(key)
    if v is None:
        return "n/a"
    ci = summary.get(f"{key}_ci")
    return f"{100 * v:.1f} % [{100 * ci['lower']:.1f}, {100 * ci['upper']:.1f}]" if ci else f"{100 * v:.1f} %"


def markdown_table(report: Dict[str, Any], policy_label: str) -> str:
    """The report's rows (the policy first, then the detectors, then the reference rows) as a
    Markdown table: collision, unnecessary-dodge (false-alarm), hit and evasion rates with 95 %
    Wilson intervals."""
    refs = list(report.get("references", []))
    dets = report["detectors"]
    order = [policy_label] + sorted(k for k in dets if k != policy_label and k not in refs) + refs
    lines = [
        "| row | episodes | collision rate | unnecessary-dodge rate | hit rate | evasion rate |",
        "|---|---|---|---|---|---|",
    ]
    for k in order:
        s = dets[k]
        lines.append(
            f"| {k} | {s['episodes']} | {_pct(s, 'collision_rate')} | {_pct(s, 'false_alarm_rate')} | "
            f"{_pct(s, 'hit_rate')} | {_pct(s, 'evasion_rate')} |"
        )
    return "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> None:
    import argparse
    import os

    from .train import parse_seeds

    p = argparse.ArgumentParser(
        prog="python -m loomlab.evaluation",
        description="Evaluate a trained policy on held-out seeds next to the threshold controllers and the "
        "reference rows (the report of `loomlab run` plus the policy's row).",
    )
    p.add_argument("policy", help="a PPO .zip or CEM .npz checkpoint of `python -m loomlab.train`, or `threshold`")
    p.add_argument("--suite", default=None, help="shipped scenario name or suite path (default: escape_default)")
    p.add_argument("--seeds", type=parse_seeds, default="2000-2024", help="held-out seeds (default 2000-2024)")
    p.add_argument("--limit", type=int, default=None, help="episodes per seed (default: all)")
    p.add_argument(
        "--env", choices=["discrete", "continuous", "manoeuvre"], default="discrete", help="the policy's action space"
    )
    p.add_argument("--label", default="ppo", help="the policy's row (default ppo)")
    p.add_argument(
        "--obs",
        choices=["detectors", "privileged"],
        default="detectors",
        help="what the policy observes (python -m loomlab.train --obs; default detectors)",
    )
    p.add_argument("--action-repeat", type=int, default=8, help="camera frames per decision (as trained; default 8)")
    p.add_argument("--dodge-hold-s", type=float, default=0.6, help="a dodge's duration (as trained; default 0.6 s)")
    p.add_argument("--frame-size", type=int, default=64, help="frame size n (default 64)")
    p.add_argument(
        "--calibrate-seeds",
        type=parse_seeds,
        default=None,
        help="first calibrate the detectors' thresholds on these seeds (not the held-out ones), e.g. 7-14",
    )
    p.add_argument("--fa-rate", type=float, default=0.1, help="calibration target false-alarm rate (default 0.1)")
    p.add_argument("--jobs", type=int, default=None, help="runner worker threads (default: one per CPU)")
    p.add_argument("--out", default=None, help="write the report JSON here (refuses to overwrite)")
    p.add_argument("--table", default=None, help="write the Markdown table here (refuses to overwrite)")
    args = p.parse_args(argv)
    for path in (args.out, args.table):
        if path and os.path.exists(path):
            raise SystemExit(f"{path} exists: remove it or choose another file (nothing is overwritten)")
    started = time.monotonic()
    thresholds = None
    if args.calibrate_seeds:
        opts = options_json(build_options(frame_size=args.frame_size, action_type=args.env, obs_mode="normalized"))
        cal = _native.calibrate_thresholds(args.suite, args.calibrate_seeds, args.fa_rate, args.limit, opts, args.jobs)
        thresholds = {k: v for k, v in cal.items() if v is not None}
        print(f"calibrated thresholds (false-alarm rate <= {args.fa_rate}): {thresholds}", file=sys.stderr)
    report = evaluate(
        load_policy(args.policy, args.env),
        args.suite,
        args.seeds,
        limit=args.limit,
        label=args.label,
        jobs=args.jobs,
        frame_size=args.frame_size,
        action_type=args.env,
        obs_mode="privileged" if args.obs == "privileged" else "normalized",
        thresholds=thresholds,
        action_repeat=args.action_repeat,
        dodge_hold_s=args.dodge_hold_s,
    )
    report["thresholds"] = thresholds
    report["policy_label"] = args.label
    report["evaluation_wall_s"] = round(time.monotonic() - started, 1)
    table = markdown_table(report, args.label)
    print(table)
    if args.out:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        with open(args.out, "x") as f:
            json.dump(report, f, indent=2)
    if args.table:
        os.makedirs(os.path.dirname(os.path.abspath(args.table)), exist_ok=True)
        with open(args.table, "x") as f:
            f.write(table + "\n")


if __name__ == "__main__":
    main()
