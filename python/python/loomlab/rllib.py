"""RLlib support: the loomlab environments as registered RLlib environments.

::

    import loomlab.rllib
    from ray.rllib.algorithms.ppo import PPOConfig

    env = loomlab.rllib.register()              # "loomlab/Escape-v0" in Ray Tune's registry
    config = PPOConfig().environment(env, env_config={"frame_size": 64})

``env_config`` holds the keyword arguments of :class:`loomlab.EscapeEnv` (``scenario``,
``detectors``, ``action_type``, ``reward``, ...) plus ``flatten`` (default ``True``): RLlib's
default models take a flat ``Box`` observation, so the ``Dict`` observation is flattened with
Gymnasium's ``FlattenObservation``. Each env runner gets its own seed stream: the environment is
seeded with ``seed`` (default 0) + 1000 × ``worker_index`` + ``vector_index`` at its first reset.

Needs Ray with RLlib: ``pip install 'loomlab[rllib]'``. Importing this module does not import Ray;
:func:`register` does.
"""

from __future__ import annotations

from typing import Any, Mapping, Optional

import gymnasium as gym

__all__ = ["ENV_IDS", "env_creator", "register"]

#: The Gymnasium ids this module registers with RLlib.
ENV_IDS = ("loomlab/Escape-v0", "loomlab/EscapeDiscrete-v0")


class _SeedOnFirstReset(gym.Wrapper):
    """Seeds the first ``reset`` (RLlib may reset without a seed)."""

    def __init__(self, env: gym.Env, seed: int):
        super().__init__(env)
        self._first_seed: Optional[int] = seed

    def reset(self, *, seed=None, options=None):
        if seed is None and self._first_seed is not None:
            seed = self._first_seed
        self._first_seed = None
        return self.env.reset(seed=seed, options=options)


def env_creator(env_config: Optional[Mapping[str, Any]] = None, env_id: str = "loomlab/Escape-v0") -> gym.Env:
    """Builds one environment from an RLlib ``env_config`` (an ``EnvContext`` or a plain dict)."""
    import loomlab  # noqa: F401  (registers the Gymnasium ids in this worker process)

    config = dict(env_config or {})
    flatten = bool(config.pop("flatten", True))
    seed = int(config.pop("seed", 0))
    seed += 1000 * int(getattr(env_config, "worker_index", 0)) + int(getattr(env_config, "vector_index", 0))
    env = gym.make(env_id, **config)
    if flatten:
        env = gym.wrappers.FlattenObservation(env)
    return _SeedOnFirstReset(env, seed)


def register(env_id: str = "loomlab/Escape-v0", name: Optional[str] = None) -> str:
    """Registers ``env_id`` (one of :data:`ENV_IDS`) with Ray Tune's registry under ``name``
    (default: the same id) and returns the name to pass to ``AlgorithmConfig.environment``."""
    if env_id not in ENV_IDS:
        raise ValueError(f"env_id must be one of {ENV_IDS}, got {env_id!r}")
    try:
        from ray.tune.registry import register_env
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("RLlib support needs Ray: pip install 'loomlab[rllib]'") from e
    name = name or env_id
    register_env(name, lambda cfg: env_creator(cfg, env_id))
    return name
