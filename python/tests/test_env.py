"""Single-environment tests: Gymnasium API conformance, ground truth, determinism, pickling."""

from __future__ import annotations

import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import loomlab
from loomlab import EscapeEnv


def rollout(env: gym.Env, seed: int, steps: int, action_seed: int = 0):
    """Resets with `seed`, then steps with actions sampled from a seeded action space."""
    env.action_space.seed(action_seed)
    out = [env.reset(seed=seed)]
    for _ in range(steps):
        r = env.step(env.action_space.sample())
        out.append(r)
        if r[2] or r[3]:
            break
    return out


def assert_same(a, b) -> None:
    np.testing.assert_equal(a, b)


def test_import_registers_the_ids_and_make_works_without_arguments():
    assert "loomlab/Escape-v0" in gym.registry
    assert "loomlab/EscapeDiscrete-v0" in gym.registry
    env = gym.make("loomlab/Escape-v0")
    obs, info = env.reset(seed=0)
    # the default suite (scenarios/suites/default) at its camera size, with its detector rows
    labels = env.unwrapped.detector_labels
    assert labels[:3] == ["hopfield", "hopfield_adapted", "soc"] and "tracker_tau" in labels
    assert set(obs) == set(labels) | {"theta_hat", "alarm", "robot"}
    assert obs in env.observation_space
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert obs in env.observation_space
    assert isinstance(reward, float) and not terminated and not truncated
    assert env.unwrapped._native.frame_size == 96
    env.close()
    # the old default scenario is one argument away
    env = gym.make("loomlab/Escape-v0", scenario="escape_default", frame_size=64)
    obs, info = env.reset(seed=0)
    assert env.unwrapped.detector_ids == ["hopfield", "soc", "keil2004", "cizek2019", "fu2020"]
    assert info["threat"] is True and info["t_contact_s"] > 0
    env.close()


@pytest.mark.parametrize("observe_frames", [False, True])
def test_check_env_passes(short_kwargs, observe_frames):
    # made through gymnasium.make so that check_env can also try the other render modes via the spec
    env = gym.make(
        "loomlab/Escape-v0", observe_frames=observe_frames, render_mode="rgb_array", **short_kwargs
    ).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # check_env's warnings are failures too
        check_env(env, skip_render_check=False)
    if observe_frames:
        obs, _ = env.reset(seed=1)
        assert obs["frame"].shape == (32, 32) and obs["frame"].dtype == np.uint8
        assert obs["frame"].std() > 0  # ground, wall and ball are visible


def test_check_env_passes_for_the_discrete_variant(short_kwargs):
    env = gym.make("loomlab/EscapeDiscrete-v0", **short_kwargs).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env)
    assert env.action_space == gym.spaces.Discrete(6)  # the manoeuvres


def test_seeded_rollout_repeats_exactly(short_kwargs):
    a = rollout(EscapeEnv(observe_frames=True, **short_kwargs), seed=123, steps=200)
    b = rollout(EscapeEnv(observe_frames=True, **short_kwargs), seed=123, steps=200)
    assert len(a) == len(b) > 10
    assert_same(a, b)
    # the seed stream continues identically without a seed
    env = EscapeEnv(**short_kwargs)
    env.reset(seed=5)
    first = env.reset()
    env.reset(seed=5)
    assert_same(env.reset(), first)


def test_pickle_round_trip_continues_the_episode(short_kwargs):
    env = EscapeEnv(observe_frames=True, **short_kwargs)
    env.reset(seed=9)
    env.action_space.seed(3)
    for _ in range(10):
        env.step(env.action_space.sample())
    clone = pickle.loads(pickle.dumps(env))
    assert clone.detector_ids == env.detector_ids
    assert clone.observation_space == env.observation_space
    for k in range(20):
        action = np.array([0.5, -0.2, np.sin(k)], dtype=np.float32)
        assert_same(clone.step(action), env.step(action))
    # a fresh (never reset) environment pickles too
    fresh = pickle.loads(pickle.dumps(EscapeEnv(**short_kwargs)))
    assert_same(fresh.reset(seed=4), EscapeEnv(**short_kwargs).reset(seed=4))


def test_ground_truth_collision_and_scored_outcome(short_kwargs):
    env = EscapeEnv(action_type="discrete", **short_kwargs)
    obs, info = env.reset(seed=0)
    assert info["threat"] and 0.3 < info["t_contact_s"] < 0.6
    assert info["ttc_s"] > 0 and info["angular_size_deg"] > 0
    total = 0.0
    while True:
        obs, reward, terminated, truncated, info = env.step(0)  # keep cruising
        total += reward
        if terminated or truncated:
            break
    assert terminated and not truncated and info["collision"]
    # reported in the frame of the contact or the next (rapier finds a contact in the narrow
    # phase that opens a step)
    assert 0 <= info["t_s"] - info["t_contact_s"] <= 2 * env.dt + 1e-9
    out = info["outcome"]
    assert out["threat"] and out["collision"] and not out["evaded"]
    assert set(out["detectors"]) == {"hopfield", "soc"}
    # a contact this early can be unavoidable for a dodge that must accelerate (dynamic physics)
    assert {d["outcome"] for d in out["detectors"].values()} <= {"hit", "miss", "unavoidable"}
    assert out["episode_return"] == pytest.approx(total)
    assert info["reward_terms"]["collision"] == -10.0
    with pytest.raises(loomlab.LoomlabError):
        env.step(0)


def test_dodging_evades_and_the_controller_baseline_is_reported(short_kwargs):
    env = EscapeEnv(action_type="discrete", **short_kwargs)
    env.reset(seed=0)
    while True:
        obs, reward, terminated, truncated, info = env.step(1)  # dodge left all the time
        assert info["controller_action"] in range(4)
        if terminated or truncated:
            break
    assert terminated and not info["collision"] and info["outcome"]["evaded"]
    assert obs["robot"][1] > 0.5  # moved to the left


def test_reward_is_configurable(short_kwargs):
    env = EscapeEnv(
        reward=loomlab.RewardConfig(survival_per_s=0.0, effort_per_s=0.0, progress_per_m=1.0),
        action_type="discrete",
        **short_kwargs,
    )
    env.reset(seed=0)
    _, reward, *_ = env.step(0)
    assert reward == pytest.approx(1.0 * env.dt, rel=1e-6)  # 1 m/s along the heading


def test_truncation_on_the_time_limit(short_kwargs):
    env = EscapeEnv(max_episode_steps=5, **short_kwargs)
    env.reset(seed=0)
    for _ in range(4):
        assert env.step(np.zeros(3, dtype=np.float32))[3] is False
    _, _, terminated, truncated, info = env.step(np.zeros(3, dtype=np.float32))
    assert truncated and not terminated and "outcome" in info


def test_render_rgb_array(short_kwargs):
    env = EscapeEnv(render_mode="rgb_array", **short_kwargs)
    env.reset(seed=0)
    img = env.render()
    assert img.shape == (32, 32, 3) and img.dtype == np.uint8
    assert EscapeEnv(**short_kwargs).render() is None


def test_shipped_scenarios_are_listed():
    assert "escape_default" in loomlab.scenario_names()
    assert "[world]" in loomlab.scenario_toml("escape_default")


def test_envs_step_concurrently_from_python_threads(short_kwargs):
    """The GIL is released while Rust steps: two threads stepping two envs give the sequential results."""
    import threading

    def run(seed, out):
        env = EscapeEnv(**short_kwargs)
        out.append(rollout(env, seed=seed, steps=40, action_seed=seed))

    sequential = []
    for seed in (1, 2):
        run(seed, sequential)
    results = {1: [], 2: []}
    threads = [threading.Thread(target=run, args=(seed, results[seed])) for seed in (1, 2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert_same([results[1][0], results[2][0]], sequential)


def test_defaults_and_action_names_are_rusts():
    """RewardConfig/ActionConfig and the action names restate nothing: same fields and values as
    Rust's defaults (exported by the extension)."""
    from dataclasses import asdict

    from loomlab import _native
    from loomlab.env import CONTINUOUS_ACTION_NAMES, DISCRETE_ACTIONS

    assert asdict(loomlab.RewardConfig()) == _native.REWARD_DEFAULTS
    assert asdict(loomlab.ActionConfig()) == _native.ACTION_DEFAULTS
    assert DISCRETE_ACTIONS == ("none", "dodge_left", "dodge_right", "stop") == _native.DISCRETE_ACTIONS
    assert CONTINUOUS_ACTION_NAMES == ("forward", "yaw_rate", "lateral") == _native.CONTINUOUS_ACTION_NAMES
    assert gym.make("loomlab/EscapeDiscrete-v0", frame_size=32).action_space.n == len(_native.MANOEUVRE_ACTIONS)
    assert loomlab.EscapeEnv(frame_size=32, action_type="discrete").action_space.n == len(DISCRETE_ACTIONS)
