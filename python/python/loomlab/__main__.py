"""``python -m loomlab run SUITE --detector module:Class [--label L --threshold T --trigger S] ...``

``loomlab run`` (every flag of ``loomlab run --help``: ``--out``, ``--limit``, ``--size``,
``--resume``, ...) in this process, with detectors written in Python added to every scenario's
rows. ``--detector`` may be given several times; each ``--label``/``--threshold``/``--trigger``
belongs to the ``--detector`` before it (defaults: the class's ``label``/``threshold``/``trigger``
attributes, see :class:`loomlab.PythonDetector`). It writes the same run folder as ``loomlab run``
(report.html included); Ctrl-C stops it the same way (finished episodes saved, ``--resume``
continues). Exit codes are ``loomlab run``'s.
"""

from __future__ import annotations

import sys
from typing import List, Optional

USAGE = (
    "usage: python -m loomlab run [SUITE] --detector module:Class [--label L] [--threshold T] [--trigger S] "
    "[loomlab run options]"
)


def _python_detectors(argv: List[str]):
    """Splits ``argv`` into the Python detectors and the arguments left for ``loomlab run``."""
    from .detectors import PythonDetector, load_class

    specs: List[dict] = []
    rest: List[str] = []
    i = 0
    while i < len(argv):
        a = argv[i]
        name, eq, inline = a.partition("=")
        if name in ("--detector", "--label", "--threshold", "--trigger"):
            if eq:
                value = inline
            elif i + 1 < len(argv):
                i += 1
                value = argv[i]
            else:
                raise ValueError(f"{name} needs a value")
            if name == "--detector":
                specs.append({"detector": value})
            elif not specs:
                raise ValueError(f"{name} {value}: give it after the --detector it belongs to")
            elif name[2:] in specs[-1]:
                raise ValueError(f"{name} given twice for --detector {specs[-1]['detector']}")
            else:
                specs[-1][name[2:]] = value
        else:
            rest.append(a)
        i += 1
    detectors = []
    for s in specs:
        threshold: Optional[float] = None
        if "threshold" in s:
            try:
                threshold = float(s["threshold"])
            except ValueError:
                raise ValueError(f"--threshold {s['threshold']!r} is not a number") from None
        detectors.append(
            PythonDetector(
                load_class(s["detector"]), label=s.get("label"), threshold=threshold, trigger=s.get("trigger")
            )
        )
    return detectors, rest


def main(argv: Optional[List[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] != "run":
        print(USAGE, file=sys.stderr)
        return 2
    from . import _native

    try:
        detectors, rest = _python_detectors(argv[1:])
    except (ValueError, TypeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        return _native.run_cli(rest, detectors, [sys.executable, "-m", "loomlab", *argv])
    except _native.LoomlabError as e:
        # refused before the run (a label clashing with a built-in detector or a reference row):
        # bad input, exit 2 as `loomlab run` (1 means regressions)
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
