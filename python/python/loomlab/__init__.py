"""loomlab: Gymnasium environments over a closed-loop looming-escape simulator.

Importing the package registers the Gymnasium ids

- ``loomlab/Escape-v0``: continuous velocity commands (``Box(-1, 1, (3,))``),
- ``loomlab/EscapeDiscrete-v0``: none / dodge left / dodge right / stop (``Discrete(4)``),

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

import operator as _operator
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
    "PythonDetector",
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
    ``limit`` and ``jobs`` are at least 1, and ``resume=True`` needs ``out``, as the CLI requires
    (ValueError otherwise); a NaN or infinite value in a dict entry is a ScenarioError naming it.

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
            _check_entry(len(entries), d)
            entries.append(d)
        else:
            raise TypeError(
                f"run_suite: detectors holds {d!r}; give ids (str), [[detectors]] entries (dict) or "
                "loomlab.PythonDetector objects"
            )
    limit = _at_least_one("limit", limit, "the number of episodes to run; None: all of them", "--limit")
    jobs = _at_least_one("jobs", jobs, "episodes run in parallel; None: one per CPU", "--jobs")
    if resume and out is None:
        raise ValueError(
            "run_suite: resume=True continues the run folder given as out=...; give out= (the folder of the "
            "interrupted run)"
        )
    if out is not None:
        return _run_to_folder(suite, seed, size, limit, ids, entries, python, detectors_file, jobs, out, resume)
    text = _native.run_suite(
        _os.fspath(suite),
        seed,
        size,
        limit,
        ids,
        None if detectors_file is None else _os.fspath(detectors_file),
        jobs,
        json.dumps(entries) if entries else None,
        python,
    )
    result: Dict[str, Any] = json.loads(text)
    return result


def _at_least_one(name: str, value: Any, meaning: str, flag: str) -> Optional[int]:
    """``value`` as an int >= 1 (``None`` stays ``None``), else ValueError (the CLI's ``flag`` refuses it too)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int):
        try:
            value = _operator.index(value)
        except TypeError:
            raise TypeError(f"run_suite: {name}={value!r} must be an int >= 1 ({meaning})") from None
    if value < 1:
        raise ValueError(
            f"run_suite: {name}={value} must be at least 1 ({meaning}; `loomlab run {flag}` refuses it too)"
        )
    return int(value)


def _check_entry(index: int, entry: Dict[str, Any]) -> None:
    """Refuses a ``[[detectors]]`` dict holding a value that neither TOML nor JSON can carry (NaN,
    ±inf): the error names the entry, the key and the value."""
    import math

    def walk(key: str, v: Any) -> None:
        if isinstance(v, float) and not math.isfinite(v):
            name = entry.get("label", entry.get("id", "?"))
            raise ScenarioError(
                f"run_suite: detectors entry {index} (`{name}`): {key} = {v}; numbers must be finite "
                "(give a finite threshold, or leave the key out for the detector's default)"
            )
        if isinstance(v, dict):
            for k, x in v.items():
                walk(f"{key}.{k}", x)
        elif isinstance(v, (list, tuple)):
            for i, x in enumerate(v):
                walk(f"{key}[{i}]", x)

    for k, v in entry.items():
        walk(str(k), v)


def _run_to_folder(suite, seed, size, limit, ids, entries, python, detectors_file, jobs, out, resume) -> Dict[str, Any]:
    import json

    args = [_os.fspath(suite), "--out", _os.fspath(out), "--seed", str(int(seed)), "--quiet"]
    for flag, value in (("--size", size), ("--limit", limit), ("--jobs", jobs)):
        if value is not None:
            args += [flag, str(int(value))]
    if ids:
        args += ["--detectors", ",".join(ids)]
    with _tempfile.TemporaryDirectory() as tmp:
        if entries:
            # the dict entries after those of detectors_file (which holds only [[detectors]] tables)
            listed = ""
            if detectors_file is not None:
                with open(detectors_file) as f:
                    listed = f.read() + "\n"
            detectors_file = _os.path.join(tmp, "detectors.toml")
            with open(detectors_file, "w") as f:
                f.write(listed + _toml_entries(entries))
        if detectors_file is not None:
            args += ["--detectors-file", _os.fspath(detectors_file)]
        if resume:
            args.append("--resume")
        code = _native.run_cli(args, python, None)
    if code == 130:
        raise KeyboardInterrupt(f"run_suite: interrupted; the finished episodes are saved in {out} (resume=True)")
    if code != 0:
        raise LoomlabError(f"run_suite: `loomlab run {' '.join(args)}` exited with {code} (see above)")
    with open(_os.path.join(_os.fspath(out), "report.json")) as f:
        report: Dict[str, Any] = json.load(f)
    return report


def _toml_entries(entries: List[Dict[str, Any]]) -> str:
    """``[[detectors]]`` tables of dict entries (JSON values are valid TOML inline values)."""
    import json

    def value(v: Any) -> str:
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json.dumps(str(k))} = {value(x)}" for k, x in v.items()) + " }"
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, bool):
            return "true" if v else "false"
        return json.dumps(v)

    return "".join(
        "[[detectors]]\n" + "".join(f"{json.dumps(str(k))} = {value(v)}\n" for k, v in e.items()) for e in entries
    )


def detector_ids() -> List[str]:
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
