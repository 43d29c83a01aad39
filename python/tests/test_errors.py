"""Rust errors map to the loomlab exception tree; bad actions and scenarios raise clearly."""

from __future__ import annotations

import pickle
import re
import warnings
from decimal import Decimal

import numpy as np
import pytest
from gymnasium.error import ClosedEnvironmentError

import loomlab
from loomlab import EscapeEnv, _native


def test_exception_tree():
    for cls in (loomlab.ScenarioError, loomlab.RenderError, loomlab.DetectorError, loomlab.ActionError):
        assert issubclass(cls, loomlab.LoomlabError)
        assert cls.__module__ == "loomlab"
    assert issubclass(loomlab.LoomlabError, Exception)
    for kind, cls in [
        ("scenario", loomlab.ScenarioError),
        ("render", loomlab.RenderError),
        ("detector", loomlab.DetectorError),
        ("action", loomlab.ActionError),
        ("other", loomlab.LoomlabError),
    ]:
        with pytest.raises(cls):
            _native._raise(kind)


@pytest.mark.parametrize(
    "action, match",
    [
        (np.array([1.5, 0.0, 0.0], dtype=np.float32), "outside"),
        (np.array([np.nan, 0.0, 0.0], dtype=np.float32), "NaN"),
        (np.zeros(2, dtype=np.float32), r"shape \(3,\)"),
        (np.zeros((1, 3), dtype=np.float32), r"shape \(3,\)"),
        ("left", "3 numbers"),
    ],
)
def test_bad_continuous_actions_raise_action_error(short_kwargs, action, match):
    env = EscapeEnv(**short_kwargs)
    env.reset(seed=0)
    with pytest.raises(loomlab.ActionError, match=match):
        env.step(action)
    # nothing happened: the next valid step is the first one
    _, _, _, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert info["step"] == 1


@pytest.mark.parametrize("action, match", [(4, "0..4"), (-1, "0..4"), (1.5, "integer"), ([1], "integer")])
def test_bad_discrete_actions_raise_action_error(short_kwargs, action, match):
    env = EscapeEnv(action_type="discrete", **short_kwargs)
    env.reset(seed=0)
    with pytest.raises(loomlab.ActionError, match=match):
        env.step(action)


def test_clip_actions_clamps_instead(short_kwargs):
    env = EscapeEnv(clip_actions=True, **short_kwargs)
    env.reset(seed=0)
    obs, *_ = env.step(np.array([5.0, 0.0, -5.0], dtype=np.float32))
    # forward: 5 clipped to 1, scaled to 3 m/s, clamped to the robot's max_speed_mps (2)
    assert obs["robot"][3] == pytest.approx(2.0) and obs["robot"][5] == pytest.approx(-1.5)
    with pytest.raises(loomlab.ActionError):
        env.step(np.array([np.inf, 0.0, 0.0], dtype=np.float32))


def test_bad_scenarios_raise_scenario_error(tmp_path, short_toml):
    with pytest.raises(loomlab.ScenarioError, match="neither a shipped scenario"):
        EscapeEnv("no/such/scenario.toml")
    # a folder is a suite: an empty one says so
    with pytest.raises(loomlab.ScenarioError, match="no scenario files"):
        EscapeEnv(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text(short_toml.replace("speed_mps", "sped_mps"))
    with pytest.raises(loomlab.ScenarioError, match="sped_mps"):
        EscapeEnv(bad)
    good = tmp_path / "good.toml"
    good.write_text(short_toml)
    assert EscapeEnv(good, frame_size=32).reset(seed=0)[1]["threat"]
    with pytest.raises(loomlab.ScenarioError, match="frame_size"):
        EscapeEnv(scenario_toml=short_toml, frame_size=3)
    with pytest.raises(loomlab.ScenarioError, match="reward.effort_per_s"):
        EscapeEnv(scenario_toml=short_toml, reward={"effort_per_s": -1.0})
    with pytest.raises(loomlab.ScenarioError, match="unknown field"):
        EscapeEnv(scenario_toml=short_toml, reward={"effort": 1.0})


def test_unknown_detector_raises_detector_error(short_toml):
    with pytest.raises(loomlab.DetectorError, match="hopfeld"):
        EscapeEnv(scenario_toml=short_toml, detectors=["hopfeld"])
    env = EscapeEnv(scenario_toml=short_toml, detectors="all", frame_size=32)
    assert env.detector_ids == loomlab.detector_ids()


def test_step_before_reset_raises(short_kwargs):
    env = EscapeEnv(**short_kwargs)
    with pytest.raises(loomlab.LoomlabError, match="reset"):
        env.step(np.zeros(3, dtype=np.float32))


# --- issue 14: nothing lost, nothing unbounded -------------------------------------------------------


@pytest.mark.parametrize("seed", [2**64, 2**64 + 5, -1, True, 1.5, "3"])
def test_seeds_outside_u64_raise_value_error_naming_the_seed(short_kwargs, seed):
    env = EscapeEnv(**short_kwargs)
    with pytest.raises(ValueError, match=rf"2\*\*64.*got {re.escape(repr(seed))}"):
        env.reset(seed=seed)
    # the native class checks too (no wrapping modulo 2**64, no OverflowError)
    with pytest.raises(ValueError, match=re.escape(repr(seed))):
        env._native.reset(seed)
    # the largest seed is fine
    _, info = env.reset(seed=2**64 - 1)
    assert info["step"] == 0


def test_run_suite_seed_outside_u64_raises_value_error():
    for seed in (2**64, -1):
        with pytest.raises(ValueError, match=rf"2\*\*64\), got {seed}"):
            loomlab.run_suite("no/such/suite.toml", seed=seed)


@pytest.mark.parametrize(
    "action, given",
    [
        (np.array([0.5 + 1j, 0.0, 0.0]), "complex128"),
        ([0.5j, 0, 0], "complex128"),
        (["0.5", "0", "0"], "<U3"),
        (np.array([Decimal("0.5"), 0, 0], dtype=object), "object"),
    ],
)
def test_non_real_continuous_actions_raise_action_error(short_kwargs, action, given):
    env = EscapeEnv(**short_kwargs)
    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning: nothing is silently converted
        with pytest.raises(loomlab.ActionError, match=rf"3 numbers .*real numbers.*got {re.escape(given)}"):
            env.step(action)
    _, _, _, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert info["step"] == 1


@pytest.mark.parametrize("action", [1 + 0j, np.complex64(2), "1", Decimal(1)])
def test_non_real_discrete_actions_raise_action_error(short_kwargs, action):
    env = EscapeEnv(action_type="discrete", **short_kwargs)
    env.reset(seed=0)
    with pytest.raises(loomlab.ActionError, match=rf"integer in 0\.\.3 .*got {re.escape(repr(action))}"):
        env.step(action)


@pytest.mark.parametrize("key", ["clip_actions", "observe_frames"])
def test_boolean_options_take_only_bools(short_kwargs, key):
    for value in ["no", "False", 0, 1, None, np.int64(0)]:
        with pytest.raises(loomlab.ScenarioError, match=rf"`{key}` = {re.escape(repr(value))}: must be True or False"):
            EscapeEnv(**short_kwargs, **{key: value})
    env = EscapeEnv(**short_kwargs, **{key: np.bool_(True)})
    assert env._native.observe_frames is (key == "observe_frames")


@pytest.mark.parametrize(
    "kwargs, key, shown",
    [
        ({"thresholds": {"hopfield": float("nan")}}, "thresholds.hopfield", "nan"),
        ({"thresholds": {"soc": np.float32("inf")}}, "thresholds.soc", "inf"),
        ({"reward": {"effort_per_s": float("-inf")}}, "reward.effort_per_s", "-inf"),
        ({"reward": loomlab.RewardConfig(survival_per_s=float("nan"))}, "reward.survival_per_s", "nan"),
        ({"action_config": {"max_forward_mps": float("nan")}}, "action_config.max_forward_mps", "nan"),
        ({"max_episode_steps": float("nan")}, "max_episode_steps", "nan"),
        ({"thresholds": {"hopfield": 1j}}, "thresholds.hopfield", "1j"),
    ],
)
def test_non_finite_options_name_the_option_the_value_and_the_fix(short_kwargs, kwargs, key, shown):
    with pytest.raises(loomlab.ScenarioError) as e:
        EscapeEnv(**short_kwargs, **kwargs)
    msg = str(e.value)
    assert f"`{key}` = " in msg and shown in msg, msg
    assert "finite" in msg or "real number" in msg, msg
    assert "(json)" not in msg and "line 1 column" not in msg, msg


def test_numpy_option_values_are_accepted_and_type_errors_name_the_option(short_kwargs):
    env = EscapeEnv(**dict(short_kwargs, frame_size=np.int64(32)), thresholds={"hopfield": np.float32(12.0)})
    assert env.thresholds["hopfield"] == 12.0
    with pytest.raises(loomlab.ScenarioError, match=r"`reward.effort_per_s` = \"fast\": invalid type: string"):
        EscapeEnv(**short_kwargs, reward={"effort_per_s": "fast"})
    with pytest.raises(loomlab.ScenarioError, match=r"`max_episode_steps` = 2.5: invalid type: floating point"):
        EscapeEnv(**short_kwargs, max_episode_steps=2.5)


def test_closed_env_raises_closed_environment_error(short_kwargs):
    env = EscapeEnv(render_mode="rgb_array", **short_kwargs)
    env.reset(seed=0)
    env.close()
    assert env.closed
    for call in (
        lambda: env.step(np.zeros(3, dtype=np.float32)),
        lambda: env.reset(seed=0),
        lambda: env.reset(),
        env.render,
        lambda: env._native.step_continuous(0.0, 0.0, 0.0),
    ):
        with pytest.raises(ClosedEnvironmentError, match="closed environment"):
            call()
    env.close()  # closing twice is allowed
    assert env.detector_ids == ["hopfield", "soc"]  # metadata stays readable
    clone = pickle.loads(pickle.dumps(env))  # a closed env pickles as closed
    assert clone.closed
