"""Train PPO with RLlib on loomlab/EscapeDiscrete-v0 (a short run that shows the wiring).

Needs RLlib and torch: ``pip install 'loomlab[rllib]'``. Starts a local Ray (or joins the cluster
in ``RAY_ADDRESS``), registers the environment with :func:`loomlab.rllib.register` and trains for
a few iterations, printing the mean episode return.

    python examples/rllib_ppo.py [--iterations 5] [--env-runners 1] [--frame-size 64] [--smoke]

``--smoke`` trains one small iteration; without RLlib or torch it says so and exits 0.
"""

from __future__ import annotations

import argparse

from _evaluate import add_smoke_flag, skip_missing

import loomlab  # noqa: F401  (the package itself needs no Ray)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--iterations", type=int, default=5)
    p.add_argument("--env-runners", type=int, default=1, help="RLlib env runner processes")
    p.add_argument("--frame-size", type=int, default=64)
    p.add_argument("--batch", type=int, default=1024, help="train batch size (env steps) per iteration")
    p.add_argument("--seed", type=int, default=0)
    add_smoke_flag(p)
    args = p.parse_args()
    if args.smoke:
        args.iterations, args.env_runners, args.frame_size, args.batch = 1, 0, 32, 64
    try:
        import ray
        import torch  # noqa: F401  (RLlib's learner; imported here so that its absence is named)
        from ray.rllib.algorithms.ppo import PPOConfig
    except ImportError as e:  # pragma: no cover - optional dependency
        if args.smoke:
            skip_missing("rllib_ppo.py", "RLlib and torch", "pip install 'loomlab[rllib]'", e)
        raise SystemExit("this example needs RLlib and torch: pip install 'loomlab[rllib]'") from e

    import loomlab.rllib

    ray.init(include_dashboard=False)
    env = loomlab.rllib.register("loomlab/EscapeDiscrete-v0")
    config = (
        PPOConfig()
        .environment(env, env_config={"frame_size": args.frame_size, "seed": args.seed})
        .env_runners(num_env_runners=args.env_runners, num_envs_per_env_runner=1)
        .training(
            train_batch_size_per_learner=args.batch,
            minibatch_size=min(256, args.batch),
            num_epochs=4,
            lr=3e-4,
        )
        .debugging(seed=args.seed)
    )
    algo = config.build_algo()
    for i in range(args.iterations):
        result = algo.train()
        runners = result.get("env_runners", {})
        print(
            f"iteration {i + 1}: episode_return_mean {runners.get('episode_return_mean', float('nan')):.3f}, "
            f"episodes {runners.get('num_episodes', 0)}, env steps {runners.get('num_env_steps_sampled_lifetime', 0)}"
        )
    algo.stop()
    ray.shutdown()


if __name__ == "__main__":
    main()
