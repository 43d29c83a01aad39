"""What a Python detector costs per frame over its own work (``make bench-python``).

For each detector: its ``step`` called in a plain Python loop on a (96, 96) float32 frame (its own
time, numpy included), and the same detector stepped through the runner's glue
(``loomlab._native._time_python_detector``: a fresh instance built as for an episode, then
``step`` from a worker thread with the GIL acquired per call, the frame copied into a new numpy
array, the answer parsed into the runner's signals). The difference per frame is the overhead of a
Python detector. The median of ``--repeats`` rounds of ``--frames`` frames each is reported.

python python/bench/python_detector_overhead.py [--n 96] [--frames 20000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Optional

import numpy as np

import loomlab
from loomlab import _native


class Trivial:
    """Returns a constant: nothing but the call itself."""

    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray) -> float:
        return 0.0


class NumpySoc:
    """The built-in ``soc`` in numpy (examples/python_detector.py)."""

    def reset(self) -> None:
        self.previous: Optional[np.ndarray] = None

    def step(self, frame: np.ndarray) -> float:
        f = frame.astype(np.float64)
        previous, self.previous = self.previous, f
        return 0.0 if previous is None else float(np.abs(f - previous).sum())


class DictTheta:
    """Returns a dict with θ̂ and an image position (the dict path)."""

    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray) -> dict:
        return {"output": 0.0, "angular_size_deg": 1.0, "image_x": 0.0}


def own_time(detector, n: int, frames: int) -> float:
    """Seconds of ``frames`` calls of ``step`` in a Python loop (alternating two frames)."""
    rng = np.random.default_rng(0)
    inputs = [rng.random((n, n), dtype=np.float32) for _ in range(2)]
    detector.reset()
    started = time.perf_counter()
    for k in range(frames):
        detector.step(inputs[k % 2])
    return time.perf_counter() - started


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--n", type=int, default=96)
    p.add_argument("--frames", type=int, default=20000)
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args()
    print(f"Python detector overhead at {args.n}x{args.n}, median of {args.repeats} x {args.frames} frames")
    print(f"{'detector':<10} {'own µs/frame':>13} {'via runner µs/frame':>20} {'overhead µs/frame':>18}")
    for cls in (Trivial, DictTheta, NumpySoc):
        own, glued = [], []
        for _ in range(args.repeats):
            own.append(own_time(cls(), args.n, args.frames) / args.frames)
            wrapped = loomlab.PythonDetector(cls, threshold=1.0)
            glued.append(_native._time_python_detector(wrapped, args.n, args.frames) / args.frames)
        o, g = statistics.median(own) * 1e6, statistics.median(glued) * 1e6
        print(f"{cls.__name__:<10} {o:>13.2f} {g:>20.2f} {g - o:>18.2f}")


if __name__ == "__main__":
    main()
