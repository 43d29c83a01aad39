"""Shared by the example agents: run episodes and print collision and false-alarm rates, and the
``--smoke`` mode every example has (``make python-test`` runs each for a few steps)."""

from __future__ import annotations

import argparse
import sys
from typing import Callable, Dict, List

import gymnasium as gym
import numpy as np

SMOKE_STEPS = 20
"""Steps per episode in ``--smoke`` runs (episodes are truncated there)."""


def add_smoke_flag(p: argparse.ArgumentParser) -> None:
    """Adds ``--smoke``: run for a few steps only (1 episode of at most 20 steps at n = 32)."""
    p.add_argument(
        "--smoke",
        action="store_true",
        help=f"a quick check: one short episode ({SMOKE_STEPS} steps, n = 32) instead of the full run",
    )


def skip_missing(example: str, needs: str, install: str, error: ImportError) -> None:
    """Ends a ``--smoke`` run whose optional dependency is missing: says so (never silently) and
    exits 0, everything before the optional import having run."""
    print(f"SKIPPED {example}: needs {needs}, not installed ({error}); `{install}` to run it", flush=True)
    sys.exit(0)


def evaluate(env: gym.Env, policy: Callable[[dict, dict], object], episodes: int, seed: int = 0) -> Dict[str, float]:
    """Runs `episodes` episodes (seeds seed, seed+1, …) and returns the agent's rates.

    - collision rate: episodes in which the robot was touched / episodes;
    - false-alarm rate: episodes **without** a threat in which the agent dodged (deviated from the
      cruise command) / episodes without a threat (n/a when the scenario has none);
    - per detector: the scored hit and false-alarm rates of its alarms (from ``info["outcome"]``).
    """
    collisions = threats = no_threat = false_alarms = 0
    returns: List[float] = []
    det: Dict[str, Dict[str, int]] = {}
    for k in range(episodes):
        obs, info = env.reset(seed=seed + k)
        dodged, ret = False, 0.0
        while True:
            obs, reward, terminated, truncated, info = env.step(policy(obs, info))
            ret += reward
            dodged |= bool(info["dodging"])
            if terminated or truncated:
                break
        # the scored outcome; absent when a wrapper cut the episode (gym.make's max_episode_steps is
        # a TimeLimit wrapper: pass the environment's own max_episode_steps to get it)
        out = info.get("outcome", {"collision": info["collision"], "threat": info["threat"], "detectors": {}})
        returns.append(ret)
        collisions += out["collision"]
        threats += out["threat"]
        if not out["threat"]:
            no_threat += 1
            false_alarms += dodged
        for det_id, d in out["detectors"].items():
            c = det.setdefault(det_id, {"hit": 0, "miss": 0, "false_alarm": 0, "correct_rejection": 0})
            c[d["outcome"]] += 1
    rates = {
        "episodes": episodes,
        "threat_episodes": threats,
        "collision_rate": collisions / episodes,
        "false_alarm_rate": (false_alarms / no_threat) if no_threat else float("nan"),
        "mean_return": float(np.mean(returns)),
    }
    print(f"episodes {episodes} (threats {threats}), mean return {rates['mean_return']:.3f}")
    print(
        f"  agent: collision rate {rates['collision_rate']:.3f}, false-alarm rate "
        + (f"{rates['false_alarm_rate']:.3f}" if no_threat else "n/a (no episode without a threat)")
    )
    for det_id, c in det.items():
        pos, neg = c["hit"] + c["miss"], c["false_alarm"] + c["correct_rejection"]
        hit = f"{c['hit'] / pos:.3f}" if pos else "n/a"
        fa = f"{c['false_alarm'] / neg:.3f}" if neg else "n/a"
        print(f"  detector {det_id:<10} hit rate {hit}, false-alarm rate {fa}")
    return rates
