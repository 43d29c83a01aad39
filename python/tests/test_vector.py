"""Vector environment: native batching equals N single environments (SyncVectorEnv), make_vec."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import loomlab
from loomlab import EscapeEnv, EscapeVectorEnv


@pytest.mark.parametrize("action_type", ["continuous", "discrete"])
def test_vector_env_equals_n_single_envs(short_kwargs, action_type):
    n = 3
    kwargs = dict(short_kwargs, max_episode_steps=25, observe_frames=True, action_type=action_type)
    native = EscapeVectorEnv(n, **kwargs)
    sync = SyncVectorEnv([lambda: EscapeEnv(**kwargs) for _ in range(n)])
    assert native.single_observation_space == sync.single_observation_space
    assert native.single_action_space == sync.single_action_space
    assert native.observation_space == sync.observation_space

    np.testing.assert_equal(native.reset(seed=7), sync.reset(seed=7))
    native.action_space.seed(1)
    ends = np.zeros(n, dtype=int)  # episode ends per environment
    outcomes = np.zeros(n, dtype=int)  # info["outcome"] reported per environment
    for _ in range(60):
        actions = native.action_space.sample()
        got = native.step(actions)
        want = sync.step(actions)
        np.testing.assert_equal(got, want)
        _, _, terminated, truncated, info = got
        done = terminated | truncated
        ends += done
        if "outcome" in info:
            # the outcome is reported exactly for the environments whose episode just ended
            np.testing.assert_array_equal(info["_outcome"], done)
            outcomes += info["_outcome"]
        else:
            assert not done.any()
    # every environment ended (and was auto-reset) at least once, each with its outcome
    assert (ends >= 1).all(), f"episode ends per environment: {ends}"
    np.testing.assert_array_equal(outcomes, ends)


def test_make_vec_uses_the_native_vector_env(short_kwargs):
    envs = gym.make_vec("loomlab/Escape-v0", num_envs=2, **short_kwargs)
    assert isinstance(envs, EscapeVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    obs, info = envs.reset(seed=0)
    assert obs["robot"].shape == (2, 7) and obs["hopfield"].shape == (2, 3)
    obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert reward.shape == (2,) and reward.dtype == np.float64
    assert terminated.dtype == np.bool_ and info["t_s"].shape == (2,)
    assert obs in envs.observation_space
    d = gym.make_vec("loomlab/EscapeDiscrete-v0", num_envs=2, **short_kwargs)
    assert d.single_action_space == gym.spaces.Discrete(4)


def test_vector_render(short_kwargs):
    envs = EscapeVectorEnv(2, render_mode="rgb_array", **short_kwargs)
    envs.reset(seed=0)
    assert envs.render().shape == (2, 32, 32, 3)


def test_vector_bad_actions_raise(short_kwargs):
    envs = EscapeVectorEnv(2, **short_kwargs)
    envs.reset(seed=0)
    with pytest.raises(loomlab.ActionError, match=r"shape \(2, 3\)"):
        envs.step(np.zeros((3, 3), dtype=np.float32))
    with pytest.raises(loomlab.ActionError, match="outside"):
        envs.step(np.array([[0, 0, 0], [0, 2.0, 0]], dtype=np.float32))
    d = EscapeVectorEnv(2, action_type="discrete", **short_kwargs)
    d.reset(seed=0)
    with pytest.raises(loomlab.ActionError):
        d.step(np.array([0.5, 1.0]))
    with pytest.raises(loomlab.ActionError, match="0..4"):
        d.step(np.array([0, 9]))
