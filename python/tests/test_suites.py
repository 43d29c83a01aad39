"""The environment on suites: suite loading and the tier filter, disjoint seed streams, the decision
features, the manoeuvre actions, seeded determinism and the training step."""

from __future__ import annotations

import os

import gymnasium as gym
import numpy as np
import pytest

import loomlab
from loomlab import EscapeEnv, EscapeVectorEnv, ScenarioError
from loomlab.env import MANOEUVRE_ACTIONS, suite_path

SUITE = suite_path("default")
# a cheap row of every kind the decision features read: the tracker (box, tracks, τ̂ and the gate)
FAST = {"detectors": "tracker", "frame_size": 32, "max_episode_steps": 12}


def tiers_of_suite() -> dict:
    """Each scenario file's tier (the top-level `tier` key), by scenario name."""
    out = {}
    for f in sorted(os.listdir(SUITE)):
        if f.endswith(".toml") and f != "suite.toml":
            with open(os.path.join(SUITE, f)) as fh:
                for line in fh:
                    if line.startswith("tier"):
                        out[f[: -len(".toml")]] = int(line.split("=")[1].split("#")[0])
                        break
    return out


def test_registered_ids_serve_the_default_suite():
    env = gym.make("loomlab/EscapeDiscrete-v0").unwrapped
    try:
        assert env._native.scenario_name == "default"
        assert env._native.frame_size == 96, "the suite's camera size"
        assert env.action_space == gym.spaces.Discrete(len(MANOEUVRE_ACTIONS))
        assert MANOEUVRE_ACTIONS == ("cruise", "sidestep_left", "sidestep_right", "stop", "reverse", "plan")
        # the suite's [[detectors]] rows, with their labels
        assert "tracker_tau_persistent" in env.detector_labels and "hopfield_tau" in env.detector_labels
    finally:
        env.close()


def test_a_suite_with_a_tier_filter_draws_only_those_tiers():
    tiers = tiers_of_suite()
    env = EscapeEnv(SUITE, tiers=[0], **FAST)
    try:
        assert env._native.scenario_name == "default"
        names = {_episode_scenario(env, s) for s in range(6)}
        assert names and all(tiers[n] == 0 for n in names), names
    finally:
        env.close()
    # a list of files is a suite; suite:NAME is the repository's suite folder
    two = EscapeEnv([os.path.join(SUITE, "head_on_ball.toml"), os.path.join(SUITE, "slow_ball.toml")], **FAST)
    two.close()
    with pytest.raises(ScenarioError, match="tiers"):
        EscapeEnv(SUITE, tiers=[9], **FAST)
    with pytest.raises(ScenarioError, match="tiers"):
        EscapeEnv(os.path.join(SUITE, "head_on_ball.toml"), tiers=[0], **FAST)
    with pytest.raises(ScenarioError, match="seed_stream"):
        EscapeEnv(SUITE, seed_stream="test", **FAST)
    with pytest.raises(ScenarioError, match="suite:nope"):
        EscapeEnv("suite:nope", **FAST)


def _episode_scenario(env: EscapeEnv, seed: int) -> str:
    """The scenario of the episode that seed `seed` draws."""
    env.reset(seed=seed)
    return env._native.episode_scenario


def test_train_and_eval_streams_never_share_a_seed():
    seeds = {}
    for stream in ("train", "eval"):
        env = EscapeEnv(SUITE, tiers=[0], seed_stream=stream, **FAST)
        drawn = []
        for seed in (0, 1):
            env.reset(seed=seed)
            drawn.append(env._native.episode_seed)
            for _ in range(2):
                env.reset()
                drawn.append(env._native.episode_seed)
        env.reset(seed=0)
        assert env._native.episode_seed == drawn[0], "a seed restarts the same stream"
        env.close()
        seeds[stream] = drawn
    assert all(s < 2**63 for s in seeds["train"]) and all(s >= 2**63 for s in seeds["eval"])
    assert not set(seeds["train"]) & set(seeds["eval"])


def test_decision_features_follow_the_rows_decisions_and_repeat_under_a_seed(short_toml):
    toml = short_toml.replace(
        '[[detectors]]\nid = "soc"',
        '[[detectors]]\nid = "tracker"\nlabel = "tracker_tau"\ntrigger = "tau"\ncourse = "image"\n'
        "persistence_frames = 2\npersistence_window_frames = 3",
    )
    kwargs = {"scenario_toml": toml, "frame_size": 48, "obs_mode": "decision", "action_type": "manoeuvre"}
    env = EscapeEnv(**kwargs)
    names = list(env._native.feature_names)
    assert env.observation_space.shape == (len(names),)
    for row in ("hopfield", "tracker_tau"):
        keys = ("value", "alarm", "inv_tau_ps", "gate_open", "miss_radii", "pass_side", "arrival_s", "confirmations")
        assert all(f"{row}.{key}" in names for key in keys)
    assert {"track.seen", "objects.0.theta_rad", "looming_side", "robot.time"} <= set(names)

    def episode():
        obs, _ = env.reset(seed=3)
        out = [obs]
        raw = EscapeEnv(**dict(kwargs, obs_mode="raw"))
        raw.reset(seed=3)
        while True:
            obs, _, term, trunc, _ = env.step(0)
            robs, _, _, _, _ = raw.step(0)
            # the features' alarms are the rows' decisions (the raw observation's alarm flags)
            got = [obs[names.index(f"{r}.alarm")] == 1.0 for r in ("hopfield", "tracker_tau")]
            assert got == list(robs["alarm"].astype(bool))
            assert obs in env.observation_space
            out.append(obs)
            if term or trunc:
                raw.close()
                return np.stack(out)

    first = episode()
    assert first[:, names.index("track.seen")].max() == 1.0, "the tracker's box is observed"
    np.testing.assert_array_equal(first, episode())
    env.close()


def test_manoeuvre_actions_move_the_robot_as_named(short_kwargs):
    env = EscapeEnv(**short_kwargs, action_type="manoeuvre")
    moved = {}
    for i, name in enumerate(MANOEUVRE_ACTIONS):
        env.reset(seed=1)
        for _ in range(10):
            obs, *_ = env.step(i)
        moved[name] = obs["robot"][:2]
    assert moved["sidestep_left"][1] > 0.02 and moved["sidestep_right"][1] < -0.02
    assert moved["reverse"][0] < moved["stop"][0] < moved["cruise"][0]
    from loomlab import ActionError

    with pytest.raises(ActionError, match="plan"):
        env.step(6)
    env.close()


def test_step_train_equals_step_with_same_step_resets(short_kwargs):
    kwargs = dict(short_kwargs, obs_mode="decision", action_type="manoeuvre", max_episode_steps=6, action_repeat=2)
    a, b = EscapeVectorEnv(3, **kwargs), EscapeVectorEnv(3, **kwargs)
    oa, _ = a.reset(seed=5)
    ob, _ = b.reset(seed=5)
    np.testing.assert_array_equal(oa, ob)
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(10):
        acts = rng.integers(0, len(MANOEUVRE_ACTIONS), size=3)
        obs, rew, term, trunc, last, outcomes = a.step_train(acts)
        o2, r2, t2, tr2, info = b.step(acts)
        np.testing.assert_array_equal(rew, r2.astype(np.float32))
        np.testing.assert_array_equal(term, t2)
        np.testing.assert_array_equal(last, o2)
        done = np.flatnonzero(np.logical_or(term, trunc))
        assert [i for i, _ in outcomes] == list(done)
        if len(done):
            ended += len(done)
            fresh, _ = b.reset_envs(done)
            o2 = np.array(o2)
            o2[done] = fresh
        np.testing.assert_array_equal(obs, o2)
    assert ended > 0
    a.close()
    b.close()
    assert loomlab.EscapeVectorEnv(1, **dict(short_kwargs)).trains_fast is False
