"""Rust errors map to the loomlab exception tree; bad actions and scenarios raise clearly."""

from __future__ import annotations

import numpy as np
import pytest

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
    assert obs["robot"][3] == pytest.approx(3.0) and obs["robot"][5] == pytest.approx(-1.5)
    with pytest.raises(loomlab.ActionError):
        env.step(np.array([np.inf, 0.0, 0.0], dtype=np.float32))


def test_bad_scenarios_raise_scenario_error(tmp_path, short_toml):
    with pytest.raises(loomlab.ScenarioError, match="neither a shipped scenario"):
        EscapeEnv("no/such/scenario.toml")
    with pytest.raises(loomlab.ScenarioError, match="directory"):
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
