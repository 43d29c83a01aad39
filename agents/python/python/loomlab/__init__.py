"""loomlab: Gymnasium environments over a closed-loop looming-escape simulator.

Importing the package registers the Gymnasium ids

- ``loomlab/Escape-v0``: continuous velocity commands (``Box(-1, 1, (3,))``),
- ``loomlab/EscapeDiscrete-v0``: none / dodge left / dodge right / stop (``Discrete(4)``),

both with a native vector entry point, so ``gymnasium.make_vec(id, num_envs=N)`` steps N
environments on Rust threads.
"""

from __future__ import annotations

import gymnasium as gym

from . import _native
from ._native import (
    ActionError,
    DetectorError,
    LoomlabError,
    RenderError,
    ScenarioError,
)
from .env import ActionConfig, EscapeEnv, RewardConfig
from .vector import EscapeVectorEnv

__version__ = _native.__version__

__all__ = [
    "ActionConfig",
    "ActionError",
    "DetectorError",
    "EscapeEnv",
    "EscapeVectorEnv",
    "LoomlabError",
    "RenderError",
    "RewardConfig",
    "ScenarioError",
    "detector_ids",
    "scenario_names",
    "scenario_toml",
]


def scenario_names() -> list:
    """Names of the scenarios shipped with the package (usable as ``scenario=``)."""
    return list(_native.scenario_names())


def scenario_toml(name: str) -> str:
    """The TOML text of a shipped scenario (a starting point for your own)."""
    return _native.scenario_toml(name)


def detector_ids() -> list:
    """Every detector id: hopfield, soc, keil2004, cizek2019, fu2020."""
    return list(_native.detector_ids())


def _register() -> None:
    for env_id, kwargs in (
        ("loomlab/Escape-v0", {}),
        ("loomlab/EscapeDiscrete-v0", {"action_type": "discrete"}),
    ):
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="loomlab.env:EscapeEnv",
            vector_entry_point="loomlab.vector:EscapeVectorEnv",
            kwargs=kwargs,
        )


_register()
