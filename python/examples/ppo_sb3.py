"""Train PPO (stable-baselines3) on loomlab/EscapeDiscrete-v0 and compare it with the baselines.

Needs the optional dependencies: ``pip install stable-baselines3 torch`` (the package and its tests
do not). The policy sees the detector signals, θ̂, the alarm flags and the robot state (no frames:
a MultiInputPolicy over the Dict observation).

    python examples/ppo_sb3.py [--timesteps 50000] [--n-envs 4] [--eval-episodes 20] [--smoke]

``--smoke`` trains for 64 steps and evaluates one short episode; without stable-baselines3 it says so
and exits 0.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
from _evaluate import SMOKE_STEPS, add_smoke_flag, evaluate, skip_missing

import loomlab  # noqa: F401  (registers the environments)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--timesteps", type=int, default=50_000)
    p.add_argument("--n-envs", type=int, default=4)
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--scenario", default=None)
    p.add_argument("--frame-size", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--save", default=None, help="save the trained model to this path")
    add_smoke_flag(p)
    args = p.parse_args()
    n_steps, limit = 512, None
    if args.smoke:
        args.timesteps, args.n_envs, args.eval_episodes, args.frame_size = 64, 1, 1, 32
        n_steps, limit = 64, SMOKE_STEPS
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import VecNormalize
    except ImportError as e:  # pragma: no cover - optional dependency
        if args.smoke:
            skip_missing("ppo_sb3.py", "stable-baselines3 and torch", "pip install stable-baselines3 torch", e)
        raise SystemExit("this example needs stable-baselines3: pip install stable-baselines3 torch") from e

    kwargs = dict(scenario=args.scenario, frame_size=args.frame_size, max_episode_steps=limit)
    venv = make_vec_env("loomlab/EscapeDiscrete-v0", n_envs=args.n_envs, seed=args.seed, env_kwargs=kwargs)
    # detector outputs span orders of magnitude (Hopfield z up to (N+1)²): normalise observations
    # (VecNormalize handles Box entries only: the MultiBinary alarm flags stay as they are)
    box_keys = [k for k, s in venv.observation_space.spaces.items() if isinstance(s, gym.spaces.Box)]
    venv = VecNormalize(venv, norm_obs=True, norm_reward=False, norm_obs_keys=box_keys)
    model = PPO("MultiInputPolicy", venv, n_steps=n_steps, batch_size=min(256, n_steps), seed=args.seed, verbose=1)
    model.learn(total_timesteps=args.timesteps)
    if args.save:
        model.save(args.save)
    venv.training = False

    env = gym.make("loomlab/EscapeDiscrete-v0", **kwargs)

    def policy(obs, info):
        action, _ = model.predict(venv.normalize_obs({k: v[None] for k, v in obs.items()}), deterministic=True)
        return int(action[0])

    print("PPO:")
    evaluate(env, policy, args.eval_episodes, seed=10_000)
    print("threshold controller (shadow baseline):")
    evaluate(env, lambda obs, info: info["controller_action"], args.eval_episodes, seed=10_000)


if __name__ == "__main__":
    main()
