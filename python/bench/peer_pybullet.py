"""Peer benchmark: loomlab's render step against pybullet's TinyRenderer, in one run.

`make bench-peer` (or `python python/bench/peer_pybullet.py`) times, at 64x64 and 128x128:

- loomlab: physics + ground truth + render + readback of a plane-and-sphere scene (the
  `render_bench` example of loomlab-sim: a checkered ground, the sky, one ball thrown at the
  camera while the robot drives), one view per submission (`batch 1`) and B views per submission
  (`Sim::step_batch`, `batch B`, the batch's physics in groups overlapping the previous group's
  rendering); device and pipeline creation are not timed. A batched run on Mesa's lavapipe with at
  most 4 CPUs sets `LP_NUM_THREADS=0` as `loomlab run` does (llvmpipe rasterises on its queue
  thread, beside the stepping thread); the batched run is timed again with llvmpipe's own default,
  one rasterizer thread per CPU (`LPn`; a Mesa setting, same pixels);
- pybullet: `stepSimulation()` + `getCameraImage(n, n, renderer=ER_TINY_RENDERER)` of a plane and
  a sphere (pybullet's CPU software rasterizer; the connection and the scene set-up not timed).

The two alternate for `--rounds` rounds (so both see the same machine load: ratios, not absolute
numbers, are what compare across machines) and the median steps/s of each is printed with the
ratio loomlab / pybullet. pybullet is optional (`pip install pybullet`): without it only loomlab is
timed and the ratio column says so.

A benchmark, not a test: nothing here asserts a speed.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def default_bench_binary() -> Path:
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "examples" / "render_bench"


def loomlab_steps_per_s(
    binary: Path, n: int, batch: int, seconds: float, extra_env: dict[str, str] | None = None
) -> tuple[float, str]:
    """Steps/s of the render_bench example (one process: start-up excluded by the example)."""
    cmd = [str(binary), "--n", str(n), "--batch", str(batch), "--seconds", str(seconds)]
    env = {**os.environ, **(extra_env or {})}
    res = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    if res.returncode != 0:
        raise SystemExit(f"bench-peer: {' '.join(cmd)} failed:\n{res.stderr.strip()}")
    line = json.loads(res.stdout.strip().splitlines()[-1])
    return float(line["steps_per_s"]), str(line["adapter"])


class PybulletPeer:
    """A plane and a sphere; one step = stepSimulation + getCameraImage(ER_TINY_RENDERER)."""

    def __init__(self) -> None:
        import pybullet as p  # noqa: PLC0415 (optional dependency)
        import pybullet_data  # noqa: PLC0415

        self.p = p
        self.client = p.connect(p.DIRECT)
        p.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=self.client)
        p.setGravity(0, 0, -9.8, physicsClientId=self.client)
        p.loadURDF("plane.urdf", physicsClientId=self.client)
        col = p.createCollisionShape(p.GEOM_SPHERE, radius=0.2, physicsClientId=self.client)
        vis = p.createVisualShape(p.GEOM_SPHERE, radius=0.2, physicsClientId=self.client)
        self.sphere = p.createMultiBody(1.0, col, vis, basePosition=[4, 0, 1], physicsClientId=self.client)
        self.view = p.computeViewMatrix([0, 0, 0.3], [1, 0, 0.3], [0, 0, 1])
        self.proj = p.computeProjectionMatrixFOV(60, 1, 0.05, 100)
        self.steps = 0

    def step(self, n: int) -> None:
        p = self.p
        if self.steps % 300 == 0:  # throw the ball again (the scene stays in view)
            p.resetBasePositionAndOrientation(self.sphere, [4, 0, 1], [0, 0, 0, 1], physicsClientId=self.client)
            p.resetBaseVelocity(self.sphere, [-3, 0, 2], physicsClientId=self.client)
        p.stepSimulation(physicsClientId=self.client)
        p.getCameraImage(n, n, self.view, self.proj, renderer=p.ER_TINY_RENDERER, physicsClientId=self.client)
        self.steps += 1

    def steps_per_s(self, n: int, seconds: float) -> float:
        for _ in range(20):  # warm-up
            self.step(n)
        t0 = time.perf_counter()
        k = 0
        while time.perf_counter() - t0 < seconds:
            self.step(n)
            k += 1
        return k / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="64,128", help="frame sizes n (comma-separated; default 64,128)")
    ap.add_argument("--batch", type=int, default=64, help="views per submission of the batched run (default 64)")
    ap.add_argument("--seconds", type=float, default=2.0, help="timed seconds per measurement (default 2)")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds; medians are reported (default 3)")
    ap.add_argument("--bench-binary", type=Path, default=default_bench_binary(), help="the render_bench example")
    ap.add_argument(
        "--baseline-binary",
        type=Path,
        help="render_bench built from another commit, timed at batch 1 in the same rounds (before/after)",
    )
    args = ap.parse_args(argv)
    if args.batch < 1 or args.rounds < 1 or args.seconds <= 0:
        ap.error("--batch and --rounds must be >= 1 and --seconds > 0")
    sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    if not args.bench_binary.exists():
        print(
            f"bench-peer: {args.bench_binary} is missing: cargo build --release -p loomlab-sim --example render_bench",
            file=sys.stderr,
        )
        return 2
    try:
        peer: PybulletPeer | None = PybulletPeer()
    except ImportError as e:
        print(f"bench-peer: pybullet is not installed ({e}); timing loomlab alone (pip install pybullet)")
        peer = None
    batches = sorted({1, args.batch})
    results: dict[tuple[str, int], list[float]] = {}
    adapter = ""
    for _ in range(args.rounds):
        for n in sizes:
            for b in batches:
                sps, adapter = loomlab_steps_per_s(args.bench_binary, n, b, args.seconds)
                results.setdefault((f"loomlab batch {b}", n), []).append(sps)
            if args.baseline_binary is not None:
                sps, _ = loomlab_steps_per_s(args.baseline_binary, n, 1, args.seconds)
                results.setdefault(("baseline batch 1", n), []).append(sps)
            if "llvmpipe" in adapter and "LP_NUM_THREADS" not in os.environ:
                threads = {"LP_NUM_THREADS": str(os.cpu_count() or 1)}
                sps, _ = loomlab_steps_per_s(args.bench_binary, n, args.batch, args.seconds, threads)
                results.setdefault((f"loomlab batch {args.batch} LPn", n), []).append(sps)
            if peer is not None:
                results.setdefault(("pybullet TinyRenderer", n), []).append(peer.steps_per_s(n, args.seconds))
    print(f"loomlab adapter: {adapter}")
    print(f"machine: {os.cpu_count()} CPUs; {args.rounds} alternating rounds of {args.seconds:g} s, medians")
    print(f"{'':24}" + "".join(f"{f'{n}x{n} steps/s':>18}{'ratio':>8}" for n in sizes))
    rows = ["baseline batch 1"] if args.baseline_binary is not None else []
    rows += [f"loomlab batch {b}" for b in batches]
    rows += [r for r in (f"loomlab batch {args.batch} LPn",) if (r, sizes[0]) in results]
    rows += ["pybullet TinyRenderer"] if peer is not None else []
    for row in rows:
        line = f"{row:24}"
        for n in sizes:
            med = statistics.median(results[(row, n)])
            peer_med = statistics.median(results[("pybullet TinyRenderer", n)]) if peer is not None else None
            ratio = f"{med / peer_med:7.2f}x" if peer_med else "     n/a"
            line += f"{med:18.0f}{ratio:>8}"
        print(line)
    if any(r.endswith("LPn") for r in rows):
        print(f"LPn: the same with LP_NUM_THREADS={os.cpu_count()} (llvmpipe's default: a rasterizer thread per CPU)")
    if peer is None:
        print("(ratio: pybullet not installed)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
