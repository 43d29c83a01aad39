"""Threshold escape controller baseline.

The scenario's escape controller runs inside the environment in shadow mode on the first chosen
detector: it dodges sideways (away from the looming side) when that detector's trigger signal (θ̂ for
hopfield, the output for the baselines) crosses its threshold. ``info["controller_action"]`` is what it
would do now; feeding it back as the action makes it drive.

    python examples/threshold_controller.py [--detector hopfield] [--threshold 10] [--episodes 20] [--smoke]
"""

from __future__ import annotations

import argparse

import gymnasium as gym
from _evaluate import SMOKE_STEPS, add_smoke_flag, evaluate

import loomlab  # noqa: F401  (registers the environments)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--detector", default="hopfield", help="detector that triggers the escape")
    p.add_argument("--threshold", type=float, default=None, help="alarm threshold (default: the scenario's)")
    p.add_argument("--scenario", default=None, help="shipped scenario name or TOML path (default scenario)")
    p.add_argument("--frame-size", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    add_smoke_flag(p)
    args = p.parse_args()
    limit = None
    if args.smoke:
        args.episodes, args.frame_size, limit = 1, 32, SMOKE_STEPS
    thresholds = {args.detector: args.threshold} if args.threshold is not None else None
    env = gym.make(
        "loomlab/EscapeDiscrete-v0",
        scenario=args.scenario,
        detectors=[args.detector],
        thresholds=thresholds,
        frame_size=args.frame_size,
        max_episode_steps=limit,
    )
    print(f"threshold controller on {args.detector} (threshold {env.unwrapped.thresholds[args.detector]})")

    def policy(obs, info):
        # the action the controller chose on the frame just observed
        return info["controller_action"]

    evaluate(env, policy, args.episodes, args.seed)


if __name__ == "__main__":
    main()
