"""Vector environment: native batching equals N single environments (SyncVectorEnv), make_vec."""

from __future__ import annotations

import os
import pickle
import re
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError
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
    assert d.single_action_space == gym.spaces.Discrete(6)  # the manoeuvres


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


def test_vector_seeds_never_wrap_around(short_kwargs):
    envs = EscapeVectorEnv(2, **short_kwargs)
    for seed in (2**64 - 1, 2**64, -1):  # 2**64 - 1: env 1 would get 2**64
        with pytest.raises(ValueError, match=rf"got {seed}"):
            envs.reset(seed=seed)
    with pytest.raises(ValueError, match=r"environment 1 gets|2 environments"):
        envs._native.reset(2**64 - 1)  # the native class checks too
    obs, info = envs.reset(seed=2**64 - 2)
    np.testing.assert_array_equal(info["step"], [0, 0])


def test_vector_non_real_actions_raise_action_error(short_kwargs):
    envs = EscapeVectorEnv(2, **short_kwargs)
    envs.reset(seed=0)
    for bad, given in [(np.zeros((2, 3), dtype=np.complex64), "complex64"), ([["0"] * 3] * 2, "<U1")]:
        with pytest.raises(loomlab.ActionError, match=rf"\(2, 3\) float array .*got {re.escape(given)}"):
            envs.step(bad)


def test_vector_errors_name_the_environment(short_kwargs):
    envs = EscapeVectorEnv(3, **short_kwargs)
    with pytest.raises(loomlab.LoomlabError, match=r"^environment \d of the vector environment: .*reset"):
        envs.step(np.zeros((3, 3), dtype=np.float32))  # before reset
    envs.reset(seed=0)
    bad = np.zeros((3, 3), dtype=np.float32)
    bad[2, 1] = 2.0
    with pytest.raises(loomlab.ActionError, match=r"^environment 2 of the vector environment: .*outside"):
        envs.step(bad)
    bad[2, 1] = np.nan
    with pytest.raises(loomlab.ActionError, match=r"^environment 2 of the vector environment: .*NaN"):
        envs.step(bad)


def test_closed_vector_env_raises_closed_environment_error(short_kwargs):
    envs = EscapeVectorEnv(2, render_mode="rgb_array", **short_kwargs)
    envs.reset(seed=0)
    envs.close()
    assert envs.closed and envs._native.closed
    for call in (
        lambda: envs.step(np.zeros((2, 3), dtype=np.float32)),
        lambda: envs.reset(seed=0),
        envs.render,
        lambda: envs._native.step_continuous(np.zeros((2, 3), dtype=np.float32)),
    ):
        with pytest.raises(ClosedEnvironmentError, match="closed environment"):
            call()
    envs.close()  # closing twice is allowed
    assert pickle.loads(pickle.dumps(envs)).closed


@pytest.mark.parametrize("action_type", ["continuous", "discrete"])
def test_vector_pickle_round_trip_continues_every_environment(short_kwargs, action_type):
    kwargs = dict(short_kwargs, max_episode_steps=15, observe_frames=True, action_type=action_type)
    envs = EscapeVectorEnv(3, **kwargs)
    envs.reset(seed=11)
    envs.action_space.seed(2)
    for _ in range(15):  # every episode is truncated in the last step: the next step auto-resets
        envs.step(envs.action_space.sample())
    clone = pickle.loads(pickle.dumps(envs))
    assert clone.num_envs == 3 and clone.observation_space == envs.observation_space
    for _ in range(25):
        actions = envs.action_space.sample()
        np.testing.assert_equal(clone.step(actions), envs.step(actions))
    # a fresh (never reset) vector environment pickles too: same observations for the same seed
    fresh = pickle.loads(pickle.dumps(EscapeVectorEnv(3, **kwargs)))
    np.testing.assert_equal(fresh.reset(seed=4), EscapeVectorEnv(3, **kwargs).reset(seed=4))


def _lp_num_threads_after_import(env: dict[str, str]) -> str | None:
    code = "import os, loomlab; print(os.environ.get('LP_NUM_THREADS', 'unset'))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    value = out.stdout.strip()
    return None if value == "unset" else value


def test_import_has_llvmpipe_rasterise_on_its_queue_thread_on_a_few_cpus_only():
    # The rule of `loomlab run` (loomlab_sim::render::llvmpipe_threads): on at most 4 CPUs the
    # vector env's members keep every CPU busy, and llvmpipe's own rasterizer threads cost more
    # than they save. A value the user set is kept.
    env = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    few_cpus = len(os.sched_getaffinity(0)) <= 4
    assert _lp_num_threads_after_import(env) == ("0" if few_cpus else None)
    assert _lp_num_threads_after_import(dict(env, LP_NUM_THREADS="3")) == "3"
