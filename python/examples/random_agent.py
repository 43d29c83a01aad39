"""Random agent baseline: uniformly random actions on loomlab/Escape-v0 (or the discrete variant).

python examples/random_agent.py [--episodes 20] [--discrete] [--scenario NAME_OR_PATH] [--smoke]
"""

from __future__ import annotations

import argparse

import gymnasium as gym
from _evaluate import SMOKE_STEPS, add_smoke_flag, evaluate

import loomlab  # noqa: F401  (registers the environments)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--discrete", action="store_true", help="use loomlab/EscapeDiscrete-v0")
    p.add_argument("--scenario", default=None, help="shipped scenario name or TOML path (default scenario)")
    p.add_argument("--frame-size", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    add_smoke_flag(p)
    args = p.parse_args()
    limit = None
    if args.smoke:
        args.episodes, args.frame_size, limit = 1, 32, SMOKE_STEPS
    env_id = "loomlab/EscapeDiscrete-v0" if args.discrete else "loomlab/Escape-v0"
    env = gym.make(env_id, scenario=args.scenario, frame_size=args.frame_size, max_episode_steps=limit)
    env.action_space.seed(args.seed)
    print(f"random agent on {env_id} ({env.unwrapped.adapter})")
    evaluate(env, lambda obs, info: env.action_space.sample(), args.episodes, args.seed)


if __name__ == "__main__":
    main()
