"""Detectors written in Python, scored by the same Rust runner as the built-in ones.

:class:`PythonDetector` wraps any object with ``reset()`` and ``step(frame)``; pass it to
:func:`loomlab.run_suite` (``detectors=[...]``) or name its class on the command line
(``python -m loomlab run SUITE --detector module:Class``). The closed loop is Rust's: every frame the
runner renders is handed to ``step`` as a float32 numpy array of shape (n, n), luminance in [0, 1]
(exactly what the Rust detectors receive), and what ``step`` returns feeds the same alarm threshold,
escape controller and scoring as a Rust detector's signals. See docs/adding-a-detector.md.
"""

from __future__ import annotations

import importlib
import inspect
import re
from typing import Any, Dict, List, Optional, Union

try:  # Python >= 3.8
    from typing import Protocol
except ImportError:  # pragma: no cover
    Protocol = object  # type: ignore[assignment,misc]

import numpy as np

#: The trigger signals a Python detector can be alarmed on.
TRIGGERS = ("output", "angular_size")

#: One object of a step's ``objects`` list: ``id`` (an int ≥ 0, the detector's own number for it,
#: stable while it follows the object), ``box`` (``[x0, x1, y0, y1]``: its image box in normalised
#: image coordinates, x to the right and y up, each in [-1, 1]), ``theta_deg`` (its θ̂ in degrees)
#: and optionally ``tau_s`` (its time to contact in seconds, > 0, when the detector estimates one;
#: None or absent: the escape agent estimates it from θ̂).
PerceivedObject = Dict[str, Union[int, float, None, List[float]]]

#: What ``step`` may return: the output, or a dict with ``output`` and optionally
#: ``angular_size_deg`` (θ̂ in degrees, or None), ``image_x``, ``image_y`` and ``objects`` (every
#: object the detector perceives, a list of :data:`PerceivedObject`; the first is its primary
#: object, whose θ̂ and box stand for ``output``, ``angular_size_deg`` and the object's region when
#: the dict leaves them out). Values are checked every frame (finite, boxes inside the image, ids
#: ints and distinct); an error names the detector's label, the frame and the key.
StepResult = Union[float, Dict[str, Union[None, float, List[PerceivedObject]]]]


class Detector(Protocol):
    """What :class:`PythonDetector` wraps."""

    def reset(self) -> None:
        """Forget all history (called before every episode's first frame)."""

    def step(self, frame: np.ndarray) -> StepResult:
        """Process the next frame: float32 (n, n), luminance in [0, 1]. A ``step(frame, ego)`` also
        gets the efference copy of the camera period that ended with this frame: the command the
        robot applied (``forward_mps``, ``yaw_rate_rps``, ``lateral_mps``) and the camera's own
        motion and pose (``dt_s``, ``rotation_rad``, ``translation_m``, ``height_m``, ``pitch_rad``,
        ``roll_rad``; docs/adding-a-detector.md). A ``step`` with the keyword argument ``events``
        also gets an event camera's events of the period (a dict of ``t_s``, ``x``, ``y``,
        ``polarity`` arrays in time order, ``on`` and ``off`` (n, n) count images, ``t_start_s``,
        ``t_end_s``; None without an event camera: docs/events.md)."""
        ...


_LABEL = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")


def _snake(name: str) -> str:
    """``NumpySoc`` → ``numpy_soc``, ``NotANumber`` → ``not_a_number``, ``LGMDModel`` → ``lgmd_model``."""
    name = re.sub(r"(.)([A-Z][a-z]+)", r"\1_\2", name)
    return re.sub(r"([a-z0-9])([A-Z])", r"\1_\2", name).lower()


class PythonDetector:
    """A Python detector for :func:`loomlab.run_suite` and ``python -m loomlab run``.

    ``detector`` is an object with ``reset()`` and ``step(frame) -> float | dict``, or a class whose
    no-argument constructor makes one. A ``step(frame, ego)`` also gets the efference copy, the
    command applied during the frame's camera period (``forward_mps``, ``yaw_rate_rps``,
    ``lateral_mps``). The runner needs a fresh detector for every episode (and for
    the closed loop after an alarm), possibly on several threads: it calls the class, or
    ``copy.deepcopy`` of the object, then ``reset()``. The Python calls hold the GIL, so they run
    one at a time while rendering and the Rust detectors run in parallel.

    ``label`` names the report row and CSV columns (default: the object's ``label`` attribute, else
    its class name in snake_case); ``threshold`` is the alarm threshold (default: the object's
    ``threshold`` attribute), compared with the ``trigger`` signal (default: its ``trigger``
    attribute, else ``"output"``): ``"output"`` or ``"angular_size"`` (θ̂ in degrees, returned as
    ``angular_size_deg``; then the detector also serves the θ̂ accuracy scores).
    """

    def __init__(
        self,
        detector: Any,
        *,
        label: Optional[str] = None,
        threshold: Optional[float] = None,
        trigger: Optional[str] = None,
    ) -> None:
        for method in ("reset", "step"):
            if not callable(getattr(detector, method, None)):
                raise TypeError(
                    f"PythonDetector: {detector!r} has no method {method}(); it needs reset() and step(frame)"
                )
        cls = detector if isinstance(detector, type) else type(detector)
        label = label if label is not None else getattr(detector, "label", None) or _snake(cls.__name__)
        if not isinstance(label, str) or not _LABEL.fullmatch(label):
            raise ValueError(
                f"PythonDetector: label {label!r} must be 1 to 64 ASCII letters, digits and `_`, starting with a "
                "letter (it names the report row and CSV columns)"
            )
        threshold = threshold if threshold is not None else getattr(detector, "threshold", None)
        if threshold is None:
            raise ValueError(
                f"PythonDetector `{label}`: give threshold=... (the alarm threshold in the trigger signal's units)"
            )
        try:
            threshold = float(threshold)
        except (TypeError, ValueError):
            raise ValueError(f"PythonDetector `{label}`: threshold {threshold!r} is not a number") from None
        if not np.isfinite(threshold):
            raise ValueError(f"PythonDetector `{label}`: threshold {threshold} must be finite")
        trigger = trigger if trigger is not None else getattr(detector, "trigger", None) or "output"
        if trigger == "angular_size_deg":
            trigger = "angular_size"
        if trigger not in TRIGGERS:
            raise ValueError(f"PythonDetector `{label}`: trigger {trigger!r}; use one of {', '.join(TRIGGERS)}")
        self.detector = detector
        self.label: str = label
        self.threshold: float = threshold
        self.trigger: str = trigger

    def __repr__(self) -> str:
        return (
            f"PythonDetector({self.detector!r}, label={self.label!r}, threshold={self.threshold!r}, "
            f"trigger={self.trigger!r})"
        )


def _accepts_ego(detector: Any) -> bool:
    """Whether ``detector.step`` takes a second positional argument (the efference copy)."""
    try:
        params = inspect.signature(detector.step).parameters.values()
    except (TypeError, ValueError):
        return False
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.name != "events"]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


def _accepts_events(detector: Any) -> bool:
    """Whether ``detector.step`` takes the keyword argument ``events`` (an event camera's events of
    the period: a dict of ``t_s``, ``x``, ``y``, ``polarity`` arrays, ``on`` and ``off`` count
    images, ``t_start_s`` and ``t_end_s``; None without an event camera; docs/events.md)."""
    try:
        params = inspect.signature(detector.step).parameters
    except (TypeError, ValueError):
        return False
    p = params.get("events")
    return p is not None and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)


def load_class(spec: str) -> Any:
    """The object named by ``"module:Name"`` (``module`` importable, e.g. from the working directory)."""
    module, sep, name = spec.partition(":")
    if not sep or not module or not name:
        raise ValueError(f"--detector {spec!r}: write it as module:Class (e.g. my_detectors:Soc)")
    try:
        mod = importlib.import_module(module)
    except ImportError as e:
        raise ValueError(f"--detector {spec!r}: cannot import {module!r}: {e}") from None
    obj: Any = mod
    for part in name.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise ValueError(f"--detector {spec!r}: module {module!r} has no {name!r}") from None
    return obj
