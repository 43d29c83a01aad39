"""RLlib support (`loomlab.rllib`): the env creator, its registration with Ray Tune, and (where
RLlib and torch are installed) one PPO training iteration on it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from conftest import SHORT_SCENARIO
from gymnasium.utils.env_checker import check_env

import loomlab.rllib
from loomlab.rllib import env_creator


class _Context(dict):
    """Stands in for RLlib's EnvContext (a dict with worker and vector indices)."""

    def __init__(self, config, worker_index=0, vector_index=0):
        super().__init__(config)
        self.worker_index, self.vector_index = worker_index, vector_index


def test_env_creator_gives_a_flat_checked_env():
    env = env_creator({"scenario_toml": SHORT_SCENARIO, "frame_size": 32}, "loomlab/EscapeDiscrete-v0")
    assert isinstance(env.observation_space, gym.spaces.Box) and env.observation_space.shape[0] > 0
    assert isinstance(env.action_space, gym.spaces.Discrete)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset()
    assert env.observation_space.contains(obs)
    env.close()


def test_env_creator_keeps_the_dict_observation_on_request():
    env = env_creator({"scenario_toml": SHORT_SCENARIO, "frame_size": 32, "flatten": False})
    assert isinstance(env.observation_space, gym.spaces.Dict)
    env.close()


def test_env_runners_get_distinct_reproducible_seeds():
    def first_obs(worker, vector=0):
        env = env_creator(_Context({"scenario_toml": SHORT_SCENARIO, "seed": 5}, worker, vector))
        obs, _ = env.reset()
        env.close()
        return obs

    # runner 2, sub-env 1 of seed 5 resets first with 5 + 1000·2 + 1, reproducibly
    env = env_creator(_Context({"scenario_toml": SHORT_SCENARIO, "seed": 5}, 2, 1))
    assert env._first_seed == 5 + 2000 + 1
    env.close()
    np.testing.assert_array_equal(first_obs(1), first_obs(1))


def test_unknown_env_id_is_refused():
    with pytest.raises(ValueError, match="env_id must be one of"):
        loomlab.rllib.register("loomlab/Nope-v0")


def test_register_with_ray_tune():
    registry = pytest.importorskip("ray.tune.registry", exc_type=ImportError)
    name = loomlab.rllib.register("loomlab/EscapeDiscrete-v0", name="loomlab-test-env")
    creator = registry._global_registry.get(registry.ENV_CREATOR, name)
    env = creator(_Context({"scenario_toml": SHORT_SCENARIO}))
    obs, _ = env.reset()
    _, reward, *_ = env.step(env.action_space.sample())
    assert env.observation_space.contains(obs) and np.isfinite(reward)
    env.close()


def test_rllib_ppo_trains_one_iteration():
    pytest.importorskip("torch")
    ray = pytest.importorskip("ray")
    ppo = pytest.importorskip("ray.rllib.algorithms.ppo", exc_type=ImportError)
    started = not ray.is_initialized()
    if started:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        name = loomlab.rllib.register("loomlab/EscapeDiscrete-v0")
        config = (
            ppo.PPOConfig()
            .environment(name, env_config={"scenario_toml": SHORT_SCENARIO, "frame_size": 32})
            .env_runners(num_env_runners=0)
            .training(train_batch_size_per_learner=128, minibatch_size=64, num_epochs=1)
        )
        algo = config.build_algo()
        result = algo.train()
        assert result["env_runners"]["num_env_steps_sampled_lifetime"] >= 128
        algo.stop()
    finally:
        if started:
            ray.shutdown()
