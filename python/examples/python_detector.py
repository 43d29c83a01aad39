"""A looming detector written in Python, scored by loomlab's runner next to the built-in ones.

``NumpySoc`` re-implements the built-in ``soc`` detector (the sum of absolute temporal contrast,
Keil 2025) in numpy. Wrapped in :class:`loomlab.PythonDetector` at the built-in row's threshold it
gives the same alarms, hits, false alarms and collisions: the runner hands it exactly the frames the
Rust detectors see and feeds its output to the same escape controller and scoring.

python examples/python_detector.py [--limit 16] [--size 64] [--out DIR] [--smoke]

The same from the command line (the module importable from the working directory):

    cd python/examples && python -m loomlab run ../../scenarios/suites/default \\
        --detector python_detector:NumpySoc --threshold 270 --detectors soc --limit 16 --out out/numpy-soc

(``--detectors soc`` keeps the suite's own ``soc`` row, at its default threshold 270, next to it.)
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Optional

import numpy as np

import loomlab

SUITE = Path(__file__).resolve().parents[2] / "scenarios" / "suites" / "default"


class NumpySoc:
    """SOC(t) = Σ_ij |F_ij(t) − F_ij(t−1)|; 0 on the first frame (no previous frame)."""

    label = "numpy_soc"
    trigger = "output"

    def __init__(self) -> None:
        self.previous: Optional[np.ndarray] = None

    def reset(self) -> None:
        self.previous = None

    def step(self, frame: np.ndarray) -> float:
        f = frame.astype(np.float64)  # float32 (n, n), luminance in [0, 1]; the Rust model sums in f64
        previous, self.previous = self.previous, f
        if previous is None:
            return 0.0
        return float(np.abs(f - previous).sum())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--limit", type=int, default=16, help="episodes of the default suite")
    p.add_argument("--size", type=int, default=64, help="frame size n")
    p.add_argument("--threshold", type=float, default=60.0, help="alarm threshold of both rows (SOC units)")
    p.add_argument("--out", default=None, help="also write the run folder (report.html) here")
    p.add_argument("--smoke", action="store_true", help="a quick check: 4 episodes at n = 32")
    args = p.parse_args()
    if args.smoke:
        args.limit, args.size, args.threshold = 4, 32, 5.0
    mine = loomlab.PythonDetector(NumpySoc, threshold=args.threshold)
    report = loomlab.run_suite(
        SUITE,
        detectors=[{"id": "soc", "threshold": args.threshold}, mine],
        limit=args.limit,
        size=args.size,
        out=args.out,
    )
    keys = ("hits", "misses", "false_alarms", "correct_rejections", "collisions")
    for label in ("soc", mine.label):
        row = report["detectors"][label]
        print(f"{label:>10}: " + ", ".join(f"{k} {row[k]}" for k in keys))
    same = all(report["detectors"]["soc"][k] == report["detectors"][mine.label][k] for k in keys)
    print("same as the built-in soc:", same)
    if not same:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
