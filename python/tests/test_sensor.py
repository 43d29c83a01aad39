"""``sensor=``: the camera profile the environment's episodes run under (issue 55)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import loomlab
from loomlab import EscapeEnv, EscapeVectorEnv, ScenarioError, SensorProfileError


def _frames(short_kwargs: dict, sensor, seed: int, steps: int = 4) -> np.ndarray:
    """The observed frames of the first `steps` periods, standing still."""
    env = EscapeEnv(observe_frames=True, sensor=sensor, **short_kwargs)
    try:
        obs, _ = env.reset(seed=seed)
        frames = [obs["frame"].copy()]
        for _ in range(steps):
            obs, *_ = env.step(np.zeros(3, dtype=np.float32))
            frames.append(obs["frame"].copy())
    finally:
        env.close()
    return np.stack(frames)


def test_profiles_are_listed():
    assert loomlab.SENSOR_PROFILES == ("ideal", "robot", "robot-noise", "robot-blur", "robot-latency", "events")


def test_robot_frames_are_noisy_quantised_and_seeded(short_kwargs):
    ideal_a = _frames(short_kwargs, "ideal", seed=1)
    ideal_b = _frames(short_kwargs, "ideal", seed=2)
    robot_a = _frames(short_kwargs, "robot", seed=1)
    robot_a2 = _frames(short_kwargs, "robot", seed=1)
    robot_b = _frames(short_kwargs, "robot", seed=2)
    # the short scenario has no random keys: the ideal camera sees the same frames under any seed
    np.testing.assert_array_equal(ideal_a, ideal_b)
    # the robot camera's noise is drawn from the seed: the same seed, the same frames; another, others
    np.testing.assert_array_equal(robot_a, robot_a2)
    assert np.mean(robot_a != robot_b) > 0.3
    # noise touches most pixels, not only the projectile's edges
    assert np.mean(robot_a != ideal_a) > 0.3
    # 8-bit: integer codes in [0, 255]; a uniform patch of the ideal frame spreads over many codes
    assert robot_a.dtype == np.uint8
    background = ideal_a[0] == np.bincount(ideal_a[0].ravel()).argmax()
    assert len(np.unique(robot_a[0][background])) > 4
    assert len(np.unique(ideal_a[0][background])) == 1


def test_gym_make_and_vector_take_the_profile(short_kwargs):
    env = gym.make("loomlab/Escape-v0", sensor="robot", observe_frames=True, **short_kwargs)
    try:
        obs, _ = env.reset(seed=3)
        assert obs["frame"].shape == (32, 32)
    finally:
        env.close()
    venv = EscapeVectorEnv(2, sensor="robot", observe_frames=True, **short_kwargs)
    try:
        obs, _ = venv.reset(seed=3)
        # environment i is seeded with 3 + i: their noise differs
        assert np.any(obs["frame"][0] != obs["frame"][1])
    finally:
        venv.close()


@pytest.mark.parametrize("name", ["camera", "Robot", "", 3])
def test_unknown_profile_is_a_clear_value_error(short_kwargs, name):
    with pytest.raises(ValueError, match=r"`sensor` = .*must be one of 'ideal', 'robot'"):
        EscapeEnv(sensor=name, **short_kwargs)
    with pytest.raises(SensorProfileError):
        EscapeVectorEnv(2, sensor=name, **short_kwargs)
    assert issubclass(SensorProfileError, ScenarioError)


def test_observed_frames_come_with_the_event_cameras_counts(short_kwargs):
    """With an event camera (``sensor="events"``) ``observe_frames`` adds ``events``: the period's ON
    and OFF counts per pixel, in the observation space, zero on the reset frame, seeded; on frames
    alone there is no ``events`` key."""

    def run(seed: int) -> np.ndarray:
        env = EscapeEnv(observe_frames=True, sensor="events", **short_kwargs)
        try:
            assert env._native.event_camera
            assert env.observation_space["events"].shape == (2, 32, 32)
            obs, _ = env.reset(seed=seed)
            assert env.observation_space.contains(obs)
            counts = [obs["events"].copy()]
            for _ in range(30):
                obs, *_ = env.step(np.zeros(3, dtype=np.float32))
                assert env.observation_space.contains(obs)
                counts.append(obs["events"].copy())
        finally:
            env.close()
        return np.stack(counts)

    a, a2 = run(1), run(1)
    assert a.dtype == np.uint16 and a.shape == (31, 2, 32, 32)
    assert not a[0].any(), "no events before the first period"
    assert a[1:].sum() > 0, "the approaching ball makes events"
    np.testing.assert_array_equal(a, a2)
    env = EscapeEnv(observe_frames=True, **short_kwargs)
    try:
        obs, _ = env.reset(seed=1)
        assert "events" not in obs and "events" not in env.observation_space.spaces
    finally:
        env.close()


def test_an_environment_observes_one_kind_of_camera(short_toml):
    """A scenario that sweeps the camera kind is refused: the observation space depends on it."""
    toml = short_toml + '\n[sweep]\n"world.camera.kind" = ["frames", "events"]\n'
    with pytest.raises(ScenarioError, match=r"camera kind `events` but episode 0 has `frames`"):
        EscapeEnv(scenario_toml=toml, frame_size=32)
