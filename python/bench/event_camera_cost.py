"""What the event camera costs: the default suite on frames and on events, side by side.

Runs ``loomlab run --detectors all`` alternately under the sensor profiles ``ideal`` (frames) and
``events`` (the event camera: adaptive sub-frames, ``docs/events.md``), the same suite, seed and
rows: the suite's own and the event rows ``event_soc`` and ``event_lgmd``, which read the event
camera's events under ``events`` and the same model's events made from consecutive frames under
``ideal``. The frame rows read the same frames either way, so the difference is the event camera's
cost: the extra sub-frame renders and the conversion to events, for the open loop and the event
rows' closed-loop tails (a frame row's tail renders no sub-frames). Each round runs both; the wall
time of each run is the ``wall_time_s`` its report.json records and the CPU time its process used.

Run from the repository root, after ``make cli`` (stdlib only: any Python 3.8+)::

    python3 python/bench/event_camera_cost.py                    # the whole suite, 1 round: ~12 min on 2 cores
    python3 python/bench/event_camera_cost.py --limit 40 --rounds 3

It prints one Markdown table (docs/events.md quotes it): each run's wall and CPU time and the
ratio events / frames of the medians. Other load on the machine distorts the ratio; the rounds
alternate so that a change in load hits both.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Dict, List, Tuple


def run_once(binary: str, profile: str, out: Path, limit: int | None, suite: str | None) -> Tuple[float, float]:
    """One ``loomlab run`` under ``profile``: its report's wall time (s) and the CPU time (s) it used."""
    cmd = [binary, "run", "--sensor", profile, "--detectors", "all", "--out", str(out), "--overwrite", "-q"]
    cmd += ["--no-plots", "--no-html"]
    if suite:
        cmd.insert(2, suite)
    if limit:
        cmd += ["--limit", str(limit)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"event_camera_cost: `{' '.join(cmd)}` failed (exit {done.returncode}):\n{done.stdout}")
    wall = json.loads((out / "report.json").read_text())["wall_time_s"]
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return float(wall), cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default="target/release/loomlab", help="the loomlab binary (default: %(default)s)")
    ap.add_argument("--suite", default=None, help="the suite (default: the default suite)")
    ap.add_argument("--limit", type=int, default=None, help="only the first N episodes (default: all)")
    ap.add_argument("--rounds", type=int, default=1, help="rounds of (frames, events) (default: %(default)s)")
    args = ap.parse_args()
    if not os.access(args.bin, os.X_OK):
        sys.exit(f"event_camera_cost: --bin {args.bin} is not an executable (build it: make cli)")
    if args.rounds < 1:
        sys.exit(f"event_camera_cost: --rounds {args.rounds}: give at least 1")
    times: Dict[str, List[Tuple[float, float]]] = {"ideal": [], "events": []}
    with tempfile.TemporaryDirectory(prefix="loomlab-event-cost-") as tmp:
        for r in range(args.rounds):
            for profile in ("ideal", "events"):
                wall, cpu = run_once(args.bin, profile, Path(tmp) / profile, args.limit, args.suite)
                times[profile].append((wall, cpu))
                print(f"round {r + 1}/{args.rounds} {profile}: {wall:.1f} s wall, {cpu:.1f} s CPU", file=sys.stderr)
    episodes = f"first {args.limit} episodes" if args.limit else "every episode"
    suite = args.suite or "the default suite"
    print(f"{suite}, {episodes}, its own rows and the event rows, {args.rounds} round(s), {os.cpu_count()} CPUs\n")
    print("| camera | wall (s), per round | CPU (s), per round |")
    print("|---|---|---|")
    for profile, label in (("ideal", "frames (`ideal`)"), ("events", "events (`events`)")):
        walls = ", ".join(f"{w:.1f}" for w, _ in times[profile])
        cpus = ", ".join(f"{c:.1f}" for _, c in times[profile])
        print(f"| {label} | {walls} | {cpus} |")
    med = {p: (statistics.median(w for w, _ in t), statistics.median(c for _, c in t)) for p, t in times.items()}
    print(
        f"| **events / frames** (medians) | **{med['events'][0] / med['ideal'][0]:.2f}×** "
        f"| **{med['events'][1] / med['ideal'][1]:.2f}×** |"
    )


if __name__ == "__main__":
    main()
