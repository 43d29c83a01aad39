"""Train PPO (stable-baselines3) on loomlab/EscapeDiscrete-v0 with normalized observations and
score it with ``loomlab.evaluate`` next to the threshold controllers and the reference rows.

A minimal version of ``python -m loomlab.train`` (which adds held-out evaluation during training,
checkpoints, resume and logs). Needs the optional dependencies: ``pip install 'loomlab[rl]'``.

    python examples/ppo_sb3.py [--timesteps 50000] [--n-envs 8] [--eval-seeds 2] [--smoke]

``--smoke`` trains for 64 steps and evaluates one short episode; without stable-baselines3 it says so
and exits 0.
"""

from __future__ import annotations

import argparse

from _evaluate import SMOKE_STEPS, add_smoke_flag, skip_missing

import loomlab
from loomlab.evaluation import markdown_table
from loomlab.train import sb3_vec_env


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--timesteps", type=int, default=50_000)
    p.add_argument("--n-envs", type=int, default=8)
    p.add_argument("--eval-seeds", type=int, default=2, help="held-out seeds 2000, 2001, …")
    p.add_argument("--frame-size", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--save", default=None, help="save the trained model to this path")
    add_smoke_flag(p)
    args = p.parse_args()
    n_steps, limit, eval_limit = 256, None, None
    if args.smoke:
        args.timesteps, args.n_envs, args.eval_seeds, args.frame_size = 64, 2, 1, 32
        n_steps, limit, eval_limit = 32, SMOKE_STEPS, 1
    try:
        from stable_baselines3 import PPO
    except ImportError as e:  # pragma: no cover - optional dependency
        if args.smoke:
            skip_missing("ppo_sb3.py", "stable-baselines3 and torch", "pip install 'loomlab[rl]'", e)
        raise SystemExit("this example needs stable-baselines3: pip install 'loomlab[rl]'") from e

    venv = loomlab.EscapeVectorEnv(
        args.n_envs,
        frame_size=args.frame_size,
        action_type="discrete",
        obs_mode="normalized",
        max_episode_steps=limit,
        reward={"unnecessary_dodge_penalty": 10.0},
    )
    model = PPO("MlpPolicy", sb3_vec_env(venv), n_steps=n_steps, batch_size=min(256, n_steps), seed=args.seed)
    model.learn(total_timesteps=args.timesteps)
    if args.save:
        model.save(args.save)
    report = loomlab.evaluate(
        model,
        seeds=range(2000, 2000 + args.eval_seeds),
        limit=eval_limit,
        label="ppo",
        frame_size=args.frame_size,
        action_type="discrete",
    )
    print(markdown_table(report, "ppo"))


if __name__ == "__main__":
    main()
