"""Decisions per second of training-like stepping, the old call path and the training step side by side.

Each configuration is stepped by a seeded random policy that mostly cruises (a dodge on 10 % of the
decisions, as a policy early in training), with the vector environment ``python -m loomlab.train``
uses (8 environments, action repeat 8, a dodge held 0.6 s), the same seeds and actions on both paths:

- ``step + reset_envs`` (the path before ``step_train``): ``EscapeVectorEnv.step`` (batched observation
  dict and the info arrays of the vector convention), then ``reset_envs`` for the episodes that ended
  and the per-environment info dicts Stable-Baselines3 wants (what ``loomlab.train``'s adapter did);
- ``step_train``: one native call per decision with same-step auto-reset and flat arrays only.

Run from the repository root (the suites are found there)::

    .venv/bin/python python/bench/vector_throughput.py            # ~3 min on 2 CPU cores
    .venv/bin/python python/bench/vector_throughput.py --decisions 64 --quick

It prints one Markdown table (docs/benchmarks.md quotes it): each path's rate in every round (the
paths alternate, so a change in the machine's load hits both) and the ratio of the medians. The two
paths give the same episodes (checked: the rewards of every decision are equal).
"""

from __future__ import annotations

import argparse
import time
from typing import Any, Callable, Dict, List, Tuple

import numpy as np

from loomlab.vector import EscapeVectorEnv

CONFIGS: List[Tuple[str, Dict[str, Any]]] = [
    (
        "escape_default, n = 64, normalized (make rl-result's ppo)",
        {"scenario": None, "frame_size": 64, "obs_mode": "normalized", "action_type": "discrete"},
    ),
    (
        "default suite tier 0, n = 96, 14 rows, decision, manoeuvre",
        {
            "scenario": "suite:default",
            "frame_size": None,
            "obs_mode": "decision",
            "action_type": "manoeuvre",
            "tiers": [0],
        },
    ),
]


def policy(n_envs: int, n_actions: int, seed: int) -> Callable[[], np.ndarray]:
    rng = np.random.default_rng(seed)

    def act() -> np.ndarray:
        dodge = rng.random(n_envs) < 0.1
        return np.where(dodge, rng.integers(1, n_actions, size=n_envs), 0).astype(np.int64)

    return act


def old_path(venv: EscapeVectorEnv, actions: np.ndarray) -> np.ndarray:
    """One decision the way ``loomlab.train``'s Stable-Baselines3 adapter took it before ``step_train``."""
    obs, rew, term, trunc, _ = venv.step(actions)
    done = np.logical_or(term, trunc)
    infos: List[Dict[str, Any]] = [{} for _ in range(venv.num_envs)]
    if done.any():
        idx = np.flatnonzero(done)
        fresh, _ = venv.reset_envs(idx)
        obs = np.array(obs, copy=True)
        for k, i in enumerate(idx):
            infos[i]["terminal_observation"] = obs[i].copy()
            infos[i]["TimeLimit.truncated"] = bool(trunc[i] and not term[i])
            obs[i] = fresh[k]
    return np.asarray(rew, dtype=np.float32)


def new_path(venv: EscapeVectorEnv, actions: np.ndarray) -> np.ndarray:
    _, rew, _, _, _, _ = venv.step_train(actions)
    return rew


Step = Callable[[EscapeVectorEnv, np.ndarray], np.ndarray]


def measure(kwargs: Dict[str, Any], step: Step, args: argparse.Namespace) -> Tuple[float, np.ndarray]:
    venv = EscapeVectorEnv(args.n_envs, action_repeat=8, dodge_hold_s=0.6, **kwargs)
    try:
        venv.reset(seed=args.seed)
        act = policy(args.n_envs, int(venv.single_action_space.n), args.seed)
        for _ in range(args.warmup):
            step(venv, act())
        rewards = []
        t0 = time.perf_counter()
        for _ in range(args.decisions // args.n_envs):
            rewards.append(step(venv, act()))
        wall = time.perf_counter() - t0
    finally:
        venv.close()
    return args.decisions / wall, np.concatenate(rewards)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n-envs", type=int, default=8)
    p.add_argument("--decisions", type=int, default=512, help="decisions measured per path (default 512)")
    p.add_argument("--warmup", type=int, default=4, help="vector steps before the clock starts (default 4)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--rounds", type=int, default=3, help="alternating rounds of each path; medians (default 3)")
    p.add_argument("--quick", action="store_true", help="the first configuration only")
    args = p.parse_args()
    print("| configuration | step + reset_envs (decisions/s) | step_train (decisions/s) | ratio of medians |")
    print("|---|---|---|---|")
    for name, kwargs in CONFIGS[:1] if args.quick else CONFIGS:
        rates: Dict[str, List[float]] = {"before": [], "after": []}
        same = True
        for _ in range(args.rounds):
            before, r0 = measure(kwargs, old_path, args)
            after, r1 = measure(kwargs, new_path, args)
            rates["before"].append(before)
            rates["after"].append(after)
            same &= bool(np.array_equal(r0, r1))
        b, a = (float(np.median(rates[k])) for k in ("before", "after"))
        shown = {k: " / ".join(f"{v:.1f}" for v in rates[k]) for k in rates}
        flag = "" if same else " (rewards differ!)"
        print(f"| {name} | {shown['before']} | {shown['after']} | {a / b:.2f}×{flag} |", flush=True)


if __name__ == "__main__":
    main()
