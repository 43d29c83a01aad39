"""loomlab: Gymnasium environments over a closed-loop looming-escape simulator.

Importing the package registers the Gymnasium ids

- ``loomlab/Escape-v0``: continuous velocity commands (``Box(-1, 1, (3,))``),
- ``loomlab/EscapeDiscrete-v0``: none / dodge left / dodge right / stop (``Discrete(4)``),

both with a native vector entry point, so ``gymnasium.make_vec(id, num_envs=N)`` steps N
environments on Rust threads.

:func:`run_suite` runs a scenario suite in-process; :func:`evaluate` scores a policy on a suite next to
its detectors and reference rows, as ``loomlab run`` scores them; ``python -m loomlab.train`` trains
one (PPO with the optional extra ``loomlab[rl]``, or a pure-numpy CEM); ``python -m loomlab.sweep`` runs detector
parameter sweeps on Ray and :mod:`loomlab.rllib` registers the environments with RLlib. Ray is an
optional extra (``pip install 'loomlab[ray]'``) that importing this package never loads.
"""

from __future__ import annotations

import os as _os
import tempfile as _tempfile

import gymnasium as gym

# Mesa's Vulkan drivers complain on stderr when XDG_RUNTIME_DIR is unset (headless machines,
# containers, Ray workers); give them a private folder.
if not _os.environ.get("XDG_RUNTIME_DIR"):
    _runtime = _os.path.join(_tempfile.gettempdir(), f"loomlab-runtime-{_os.getuid() if hasattr(_os, 'getuid') else 0}")
    _os.makedirs(_runtime, mode=0o700, exist_ok=True)
    _os.environ["XDG_RUNTIME_DIR"] = _runtime

from . import _native
from ._native import (
    ActionError,
    DetectorError,
    LoomlabError,
    RenderError,
    ScenarioError,
    SweepError,
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
    "SweepError",
    "detector_ids",
    "evaluate",
    "run_suite",
    "scenario_names",
    "scenario_toml",
]


def scenario_names() -> list:
    """Names of the scenarios shipped with the package (usable as ``scenario=``)."""
    return list(_native.scenario_names())


def scenario_toml(name: str) -> str:
    """The TOML text of a shipped scenario (a starting point for your own)."""
    return _native.scenario_toml(name)


def run_suite(
    suite,
    *,
    seed: int = 0,
    size=None,
    limit=None,
    detectors=None,
    detectors_file=None,
    jobs=None,
) -> dict:
    """Runs a scenario suite in this process and returns its report (the ``report.json`` dict).

    The same as ``loomlab run SUITE --seed SEED --size SIZE --limit LIMIT --detectors IDS
    --detectors-file FILE --jobs JOBS`` (without the CSV and plots). For many parameter settings
    use :mod:`loomlab.sweep`.
    """
    import json
    import os

    text = _native.run_suite(
        os.fspath(suite),
        seed,
        size,
        limit,
        None if detectors is None else list(detectors),
        None if detectors_file is None else os.fspath(detectors_file),
        jobs,
    )
    return json.loads(text)


def detector_ids() -> list:
    """Every built-in detector id, in display order (the Rust registry's: hopfield, soc, ...)."""
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


def __getattr__(name: str):
    # `loomlab.evaluate` is loaded on first use, so that `python -m loomlab.evaluation` (its CLI)
    # does not find its module imported already
    if name == "evaluate":
        from .evaluation import evaluate

        return evaluate
    raise AttributeError(f"module 'loomlab' has no attribute {name!r}")
