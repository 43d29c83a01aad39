"""loomlab: Gymnasium environments over a closed-loop looming-escape simulator.

Importing the package registers the Gymnasium ids

- ``loomlab/Escape-v0``: continuous velocity commands (``Box(-1, 1, (3,))``),
- ``loomlab/EscapeDiscrete-v0``: the escape controller's manoeuvres: cruise / sidestep left /
  sidestep right / stop / reverse / plan (``Discrete(6)``),

both on the default suite (``scenarios/suites/default``, its camera size and detector rows) and
both with a native vector entry point, so ``gymnasium.make_vec(id, num_envs=N)`` steps N
environments on Rust threads.

:func:`run_suite` runs a scenario suite in-process, with detectors written in Python
(:class:`PythonDetector`) next to the built-in ones (``python -m loomlab run`` is ``loomlab run``
with ``--detector module:Class``); :func:`evaluate` scores a policy on a suite next to
its detectors and reference rows, as ``loomlab run`` scores them; ``python -m loomlab.train`` trains
one (PPO with the optional extra ``loomlab[rl]``, or a pure-numpy CEM); ``python -m loomlab.sweep`` runs detector
parameter sweeps on Ray and :mod:`loomlab.rllib` registers the environments with RLlib. Ray is an
optional extra (``pip install 'loomlab[ray]'``) that importing this package never loads.
"""

from __future__ import annotations

import os as _os
import tempfile as _tempfile
from typing import Any, Dict, List, Optional, Sequence, Union

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
from .detectors import PythonDetector
from .env import DEFAULT_SUITE_ARG, SENSOR_PROFILES, ActionConfig, EscapeEnv, RewardConfig, SensorProfileError
from .vector import EscapeVectorEnv

__version__ = _native.__version__

__all__ = [
    "ActionConfig",
    "ActionError",
    "DetectorError",
    "EscapeEnv",
    "EscapeVectorEnv",
    "LoomlabError",
    "PythonDetector",
    "RenderError",
    "RewardConfig",
    "SENSOR_PROFILES",
    "ScenarioError",
    "SensorProfileError",
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
    suite: Union[str, "_os.PathLike[str]"],
    *,
    seed: int = 0,
    size: Optional[int] = None,
    limit: Optional[int] = None,
    detectors: Union[str, Sequence[Union[str, Dict[str, Any], PythonDetector]], None] = None,
    detectors_file: Union[str, "_os.PathLike[str]", None] = None,
    jobs: Optional[int] = None,
    out: Union[str, "_os.PathLike[str]", None] = None,
    resume: bool = False,
) -> Dict[str, Any]:
    """Runs a scenario suite in this process and returns its report (the ``report.json`` dict).

    The same as ``loomlab run SUITE --seed SEED --size SIZE --limit LIMIT --detectors IDS
    --detectors-file FILE --jobs JOBS``. ``detectors`` mixes

    - ids (``"soc"``): run these of the suite's detectors (``--detectors``),
    - dicts (``{"id": "soc", "label": "soc_low", "threshold": 100}``): ``[[detectors]]`` entries,
      run instead of each scenario's own list, next to those of ``detectors_file``,
    - :class:`PythonDetector` objects: run in every scenario next to the other rows.

    ``detectors`` may also be one str: an id or a comma list (``"soc,hopfield"``), as ``--detectors``.
    The arguments travel as one typed request (``loomlab._native.RunRequest``) to the session
    ``loomlab run`` runs, which refuses what the CLI refuses: ``limit`` and ``jobs`` below 1 and
    ``resume=True`` without ``out`` (ValueError), a NaN or infinite value in a dict entry
    (ScenarioError naming it).

    Without ``out`` nothing is written (Ctrl-C: the episodes in flight finish, then
    KeyboardInterrupt; a second Ctrl-C stops the process at once with exit code 130, as the CLI's).
    With ``out`` it writes the run folder ``loomlab run --out OUT`` writes (episodes.csv as
    episodes finish, report.json, plots, report.html); Ctrl-C stops it as the CLI's does (every
    finished episode is saved, KeyboardInterrupt is raised) and ``resume=True`` continues it.
    For many parameter settings use :mod:`loomlab.sweep`.
    """
    import json

    ids: Optional[List[str]] = None
    entries: List[Dict[str, Any]] = []
    python: List[PythonDetector] = []
    if isinstance(detectors, (str, PythonDetector, dict)):
        # one id, a comma list as the CLI's --detectors, or one entry: not a sequence to iterate
        if isinstance(detectors, str):
            detectors = [d.strip() for d in detectors.split(",") if d.strip()]
        else:
            detectors = [detectors]
    for d in detectors if detectors is not None else []:
        if isinstance(d, PythonDetector):
            python.append(d)
        elif isinstance(d, str):
            ids = (ids or []) + [d]
        elif isinstance(d, dict):
            entries.append(d)
        else:
            raise TypeError(
                f"run_suite: detectors holds {d!r}; give ids (str), [[detectors]] entries (dict) or "
                "loomlab.PythonDetector objects"
            )
    request = _native.RunRequest(
        _os.fspath(suite),
        out=None if out is None else _os.fspath(out),
        seed=seed,
        size=size,
        limit=limit,
        detectors=ids,
        detectors_file=None if detectors_file is None else _os.fspath(detectors_file),
        entries=entries,
        jobs=jobs,
        resume=resume,
    )
    result: Dict[str, Any] = json.loads(_native.run_suite(request, python))
    return result


def detector_ids() -> List[str]:
    """Every built-in detector id, in display order (the Rust registry's: hopfield, soc, ...)."""
    return list(_native.detector_ids())


def _register() -> None:
    for env_id, kwargs in (
        ("loomlab/Escape-v0", {"scenario": DEFAULT_SUITE_ARG, "frame_size": None}),
        ("loomlab/EscapeDiscrete-v0", {"scenario": DEFAULT_SUITE_ARG, "frame_size": None, "action_type": "manoeuvre"}),
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
