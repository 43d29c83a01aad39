"""Environment steps per second from Python: single env and native vector env (N = 8), n = 64 and 128.

    python examples/bench_env.py [--steps 600] [--sizes 64 128] [--num-envs 8] [--smoke]

Steps use the default scenario, continuous zero actions (cruise stops) and no frames in the
observation; each measurement starts after a warm-up reset. Vector steps/s counts env steps
(num_envs per call).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import loomlab


def bench_single(n: int, steps: int, observe_frames: bool, obs_mode: str = "raw") -> float:
    env = loomlab.EscapeEnv(frame_size=n, observe_frames=observe_frames, obs_mode=obs_mode)
    env.reset(seed=0)
    action = np.array([0.3, 0.0, 0.0], dtype=np.float32)
    done_steps = 0
    t0 = time.perf_counter()
    while done_steps < steps:
        _, _, terminated, truncated, _ = env.step(action)
        done_steps += 1
        if terminated or truncated:
            env.reset()
    return done_steps / (time.perf_counter() - t0)


def bench_vector(n: int, steps: int, num_envs: int, observe_frames: bool, obs_mode: str = "raw") -> float:
    envs = loomlab.EscapeVectorEnv(num_envs, frame_size=n, observe_frames=observe_frames, obs_mode=obs_mode)
    envs.reset(seed=0)
    actions = np.tile(np.array([0.3, 0.0, 0.0], dtype=np.float32), (num_envs, 1))
    calls = max(1, steps // num_envs)
    t0 = time.perf_counter()
    for _ in range(calls):
        envs.step(actions)
    return calls * num_envs / (time.perf_counter() - t0)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=600)
    p.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    p.add_argument("--num-envs", type=int, default=8)
    p.add_argument("--frames", action="store_true", help="observe frames too")
    p.add_argument("--obs-mode", choices=["raw", "normalized"], default="raw", help="observation mode")
    p.add_argument("--smoke", action="store_true", help="a quick check: 20 steps at n = 32, 2 envs")
    args = p.parse_args()
    if args.smoke:
        args.steps, args.sizes, args.num_envs = 20, [32], 2
    env = loomlab.EscapeEnv(frame_size=32)
    print(f"adapter: {env.adapter}")
    print(f"{'n':>5} {'single steps/s':>15} {'vector N=' + str(args.num_envs) + ' steps/s':>22}")
    for n in args.sizes:
        s = bench_single(n, args.steps, args.frames, args.obs_mode)
        v = bench_vector(n, args.steps, args.num_envs, args.frames, args.obs_mode)
        print(f"{n:>5} {s:>15.0f} {v:>22.0f}")


if __name__ == "__main__":
    main()
