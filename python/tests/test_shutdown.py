"""Environments end their background work on close() and at exit; bounds on what they accept."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import loomlab

CYCLES = textwrap.dedent(
    """
    import gymnasium as gym
    import numpy as np
    import loomlab

    # the env's own scenario (scenario=None), not the registered ids' default suite: the race is
    # in close(), and loading a suite 200 times only costs time
    for i in range(200):
        env = gym.make("loomlab/Escape-v0", observe_frames=True, frame_size=32, scenario=None)
        env.reset(seed=i)
        env.step(np.zeros(3, dtype=np.float32))
        env.close()
    # several preparations in flight at once, closed right before the interpreter exits
    envs = [gym.make("loomlab/Escape-v0", observe_frames=True, frame_size=32, scenario=None) for _ in range(6)]
    for i, env in enumerate(envs):
        env.reset(seed=1000 + i)
    for env in envs:
        env.close()
    # and some left open: closed at exit (atexit), as is a vector environment
    left = [gym.make("loomlab/Escape-v0", frame_size=32) for _ in range(2)]
    for env in left:
        env.reset(seed=7)
    vec = gym.make_vec("loomlab/Escape-v0", num_envs=3, frame_size=32)
    vec.reset(seed=3)
    print("done")
    """
)


def test_repeated_create_reset_step_close_exits_cleanly():
    """A prefetch thread still rendering (lavapipe/LLVM) after close() crashed the exit (139) in 2
    of 8 runs; close() and exit now join it."""
    p = subprocess.run([sys.executable, "-c", CYCLES], capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, (p.returncode, p.stderr[-2000:])
    assert p.stdout.strip() == "done"


def test_make_vec_refuses_more_envs_than_the_bound(short_kwargs):
    """100 000 environments ran past 300 s; 400 took 2.1 GB."""
    with pytest.raises(loomlab.ScenarioError, match=r"`num_envs` = 100000: must be in 1\.\.=256.*several processes"):
        gym.make_vec("loomlab/Escape-v0", num_envs=100_000, **short_kwargs)


def test_the_action_scale_is_the_robots_and_absurd_scales_are_refused(short_kwargs):
    """Action 1.0 drove at the robot's 2 m/s while the observation said 3."""
    env = loomlab.EscapeEnv(**short_kwargs)
    env.reset(seed=0)
    obs, *_ = env.step(np.array([1.0, 0.0, 0.0], dtype=np.float32))
    assert obs["robot"][3] == pytest.approx(2.0), "forward_mps: the robot's max_speed_mps"
    env.close()
    with pytest.raises(loomlab.ScenarioError, match=r"`action.max_forward_mps` = 1000000000: must be at most 100"):
        loomlab.EscapeEnv(**short_kwargs, action_config={"max_forward_mps": 1e9})
