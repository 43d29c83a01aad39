"""Detector-parameter sweeps over scenario suites, distributed on Ray.

Run one from the command line::

    python -m loomlab.sweep sweeps/hopfield_quick.toml            # local Ray, every CPU
    python -m loomlab.sweep SWEEP.toml --address auto             # an existing Ray cluster
    python -m loomlab.sweep SWEEP.toml --local                    # no Ray: shards in this process

or from Python with :func:`run_sweep`. The sweep file format is documented in
``scenarios/README.md`` (section "Sweep files"). A sweep expands a suite × a grid (or seeded random
search) of detector settings into shards (a block of episodes × a block of parameter points), runs
every shard as a Ray task, writes each finished shard to ``OUT/shards/`` and merges them into one
report per parameter point (``OUT/points/<label>/report.json``, identical to what ``loomlab run``
writes for that point but for ``wall_time_s``), ``OUT/ranking.csv`` and ``OUT/summary.json``, and
the page ``OUT/report.html`` (ranking table, hit-rate-vs-false-alarm-rate scatter of every point,
each point linking to its own page ``OUT/points/<label>/report.html``).

Finished shards are never rerun: run the same command again after an interruption and it goes on
where it stopped. Ray is an optional extra (``pip install 'loomlab[ray]'``); ``import loomlab``
never imports it, and ``--local`` runs without it.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

from . import _native
from ._native import LoomlabError, ScenarioError, SweepError

__all__ = ["SweepResult", "main", "run_sweep"]

#: Exit status of the command line when it stopped early (``--max-shards``, interrupt): rerun it
#: to resume.
EXIT_INCOMPLETE = 3

# Plans cached per worker process (Ray reuses workers), keyed by (sweep file, limit).
_PLANS: Dict[Tuple[str, Optional[int]], "_native.SweepPlan"] = {}


def _plan(path: str, limit: Optional[int], fingerprint: str) -> "_native.SweepPlan":
    key = (path, limit)
    plan = _PLANS.get(key)
    if plan is None or plan.fingerprint != fingerprint:
        plan = _native.SweepPlan(path, limit)
        _PLANS[key] = plan
    if plan.fingerprint != fingerprint:
        raise SweepError(
            f"{path}: on host {socket.gethostname()} this sweep has fingerprint {plan.fingerprint}, "
            f"the driver's has {fingerprint}: the sweep file or its suite differ between machines. "
            "Every node needs the same files at the same path (a shared filesystem, or the same checkout)."
        )
    return plan


def _shard_task(path: str, limit: Optional[int], fingerprint: str, index: int, jobs: int) -> Tuple[int, str, float]:
    """Runs one shard (in a Ray worker): returns ``(index, rows as CSV text, seconds)``."""
    started = time.perf_counter()
    csv = _plan(path, limit, fingerprint).run_shard(index, jobs)
    return index, csv, time.perf_counter() - started


@dataclass
class SweepResult:
    """What :func:`run_sweep` did."""

    #: The output folder.
    out: Path
    #: Shards in the sweep.
    shards_total: int
    #: Shards run by this call.
    shards_run: int
    #: Shards found finished and skipped.
    shards_skipped: int
    #: Episodes in the sweep and parameter points.
    episodes: int
    points: int
    #: Episode runs by this call (an episode once per shard it is in; each run scores the points of
    #: its shard), the (episode, point) scores they gave, and this call's wall time.
    episodes_run: int
    scores_run: int
    wall_time_s: float
    #: Whether every shard is finished and the reports are merged.
    complete: bool
    #: The ranking (best first, first ``top`` rows) as a text table; empty when incomplete.
    ranking_table: str = ""
    #: ``summary.json`` (objective, ranking with every point's summary and its objective per
    #: difficulty tier, ``tier_scores``); empty when incomplete.
    summary: dict = field(default_factory=dict)

    @property
    def episodes_per_s(self) -> float:
        """Episode runs (each scoring every point of its shard) finished per second by this call."""
        return self.episodes_run / self.wall_time_s if self.wall_time_s > 0 else 0.0

    @property
    def scores_per_s(self) -> float:
        """(Episode, point) scores per second by this call."""
        return self.scores_run / self.wall_time_s if self.wall_time_s > 0 else 0.0

    def report(self, label: str) -> dict:
        """The merged report of parameter point ``label``."""
        return json.loads((self.out / "points" / label / "report.json").read_text())

    @property
    def report_html(self) -> Path:
        """The sweep's page (written when the sweep is complete)."""
        return self.out / "report.html"


class _Progress:
    """A one-line progress display on stderr (a line per ~10 % when stderr is not a terminal)."""

    def __init__(self, total: int, episodes: Sequence[int], enabled: bool):
        self.total, self.sizes, self.enabled = total, episodes, enabled
        self.done = self.episodes = 0
        self.started = time.perf_counter()
        self.tty = sys.stderr.isatty()
        self.last_decile = -1

    def update(self, shard: int) -> None:
        self.done += 1
        self.episodes += self.sizes[shard]
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.started
        rate = self.episodes / elapsed if elapsed > 0 else 0.0
        eta = (elapsed / self.done) * (self.total - self.done)
        line = (
            f"sweep: {self.done}/{self.total} shards, {self.episodes} episodes, "
            f"{rate:.2f} episodes/s, {elapsed:.0f} s elapsed, ETA {eta:.0f} s"
        )
        if self.tty:
            sys.stderr.write("\r" + line.ljust(90))
            sys.stderr.flush()
        elif self.done * 10 // self.total > self.last_decile:
            self.last_decile = self.done * 10 // self.total
            print(line, file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.enabled and self.tty and self.done:
            sys.stderr.write("\n")


def _import_ray():
    try:
        import ray
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise LoomlabError(
            "Ray is not installed: pip install 'loomlab[ray]' (or run the sweep without Ray: --local)"
        ) from e
    return ray


def run_sweep(
    sweep: os.PathLike | str,
    *,
    out: Optional[os.PathLike | str] = None,
    workers: Optional[int] = None,
    threads_per_worker: Optional[int] = None,
    limit: Optional[int] = None,
    restart: bool = False,
    max_shards: Optional[int] = None,
    address: Optional[str] = None,
    local: bool = False,
    progress: bool = True,
    top: int = 10,
    on_shard: Optional[Callable[[int], None]] = None,
) -> SweepResult:
    """Runs (or resumes) the sweep described by the file ``sweep``.

    Args:
        sweep: the sweep file (TOML; format in ``scenarios/README.md``).
        out: output folder (default ``out/sweep/<name>``).
        workers: shards run at once (default: the cluster's CPUs / ``threads_per_worker``).
        threads_per_worker: episode threads inside each shard task (each task asks Ray for this
            many CPUs); default 1 on Ray, every CPU with ``local``.
        limit: run only the first ``limit`` episodes of the suite (overrides the file's).
        restart: discard the output folder's shards and results and start over.
        max_shards: run at most this many new shards, then stop (resume later).
        address: the Ray cluster (``ray.init(address=...)``); default: the running one if
            ``ray.init`` was called, else a new local one.
        local: no Ray: run the shards one after another in this process.
        progress: show progress on stderr.
        top: rows of the ranking table returned.
        on_shard: called with the shard index after each shard is written.

    Raises:
        ScenarioError: the sweep file or its suite is invalid (names the file and key).
        SweepError: the output folder holds another sweep (use ``restart`` or another ``out``).
        LoomlabError: Ray is missing, or a shard failed (finished shards are kept).
    """
    started = time.perf_counter()
    path = str(Path(sweep).resolve())
    if threads_per_worker is not None and threads_per_worker < 1:
        raise SweepError("threads_per_worker must be at least 1")
    if workers is not None and workers < 1:
        raise SweepError("workers must be at least 1")
    if max_shards is not None and max_shards < 0:
        raise SweepError("max_shards must be >= 0")
    plan = _native.SweepPlan(path, limit)
    out_dir = Path(out) if out is not None else Path("out") / "sweep" / plan.name
    done = plan.open_out(str(out_dir), restart)
    todo = [i for i, d in enumerate(done) if not d]
    skipped = len(done) - len(todo)
    if max_shards is not None:
        todo = todo[:max_shards]
    cuts = [plan.shard(i) for i in range(plan.shard_count)]
    sizes = [e1 - e0 for e0, e1, _, _ in cuts]
    bar = _Progress(len(todo), sizes, progress)

    def finished(i: int, csv: str) -> None:
        plan.write_shard(str(out_dir), i, csv)
        bar.update(i)
        if on_shard is not None:
            on_shard(i)

    try:
        if local or not todo:
            for i in todo:
                finished(i, plan.run_shard(i, threads_per_worker))
        else:
            _run_on_ray(plan, path, limit, todo, workers, threads_per_worker or 1, address, finished)
    finally:
        bar.close()
    wall = time.perf_counter() - started
    remaining = plan.shard_count - skipped - len(todo)
    result = SweepResult(
        out=out_dir,
        shards_total=plan.shard_count,
        shards_run=len(todo),
        shards_skipped=skipped,
        episodes=plan.episode_count,
        points=len(plan.points()),
        episodes_run=sum(sizes[i] for i in todo),
        scores_run=sum(sizes[i] * (cuts[i][3] - cuts[i][2]) for i in todo),
        wall_time_s=wall,
        complete=remaining == 0,
    )
    if result.complete:
        result.ranking_table = plan.finish(str(out_dir), wall, top)
        result.summary = json.loads((out_dir / "summary.json").read_text())
    return result


def _run_on_ray(plan, path, limit, todo, workers, threads, address, finished) -> None:
    ray = _import_ray()
    started_here = False
    if not ray.is_initialized():
        ray.init(address=address, include_dashboard=False, logging_level=logging.WARNING)
        started_here = True
    try:
        if workers is None:
            workers = max(1, int(ray.cluster_resources().get("CPU", 1)) // threads)
        task = ray.remote(num_cpus=threads, max_retries=1)(_shard_task)
        queue = list(todo)
        pending = []
        try:
            while queue or pending:
                while queue and len(pending) < workers:
                    pending.append(task.remote(path, limit, plan.fingerprint, queue.pop(0), threads))
                ready, pending = ray.wait(pending, num_returns=1)
                index, csv, _seconds = ray.get(ready[0])
                finished(index, csv)
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
    finally:
        if started_here:
            ray.shutdown()


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m loomlab.sweep",
        description=(
            "Run a detector-parameter sweep (a scenario suite x a grid or random search of detector "
            "settings) as Ray tasks, merge the shards into one report per parameter point and rank "
            "the points. Finished shards are kept: rerun the same command to resume."
        ),
        epilog=(
            "Outputs in OUT: report.html (ranking and scatter, linking every point's own page), "
            "points/<label>/{report.json,report.html,episodes.csv,detectors.toml}, ranking.csv, "
            "summary.json, shards/. Rerun one point with: loomlab run SUITE --detectors-file "
            "OUT/points/<label>/detectors.toml (plus the sweep's --seed/--size/--limit). "
            f"Exit status: 0 done, 2 bad input, {EXIT_INCOMPLETE} stopped early (resumable), 130 interrupted."
        ),
    )
    p.add_argument("sweep", type=Path, help="sweep file (TOML; format in scenarios/README.md)")
    p.add_argument("--out", "-o", type=Path, help="output folder (default: out/sweep/<name>)")
    p.add_argument("--workers", "-w", type=int, help="shards run at once (default: the cluster's CPUs)")
    p.add_argument(
        "--threads-per-worker",
        type=int,
        help="episode threads per shard task (default: 1 on Ray, every CPU with --local)",
    )
    p.add_argument("--limit", type=int, help="run only the first N episodes of the suite")
    p.add_argument("--max-shards", type=int, help="run at most N new shards, then stop (resume later)")
    p.add_argument("--restart", action="store_true", help="discard the output folder's shards and start over")
    p.add_argument("--address", help="Ray cluster address (default: a new local cluster); 'auto' for a running one")
    p.add_argument("--local", action="store_true", help="no Ray: run the shards one after another in this process")
    p.add_argument("--top", type=int, default=10, help="rows of the ranking to print (default 10)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress, print only the ranking")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    """The command line (``python -m loomlab.sweep --help``)."""
    args = _parser().parse_args(argv)
    try:
        r = run_sweep(
            args.sweep,
            out=args.out,
            workers=args.workers,
            threads_per_worker=args.threads_per_worker,
            limit=args.limit,
            restart=args.restart,
            max_shards=args.max_shards,
            address=args.address,
            local=args.local,
            progress=not args.quiet,
            top=args.top,
        )
    except KeyboardInterrupt:
        print("\ninterrupted: finished shards are kept; rerun the same command to resume", file=sys.stderr)
        return 130
    except (LoomlabError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        if not isinstance(e, (ScenarioError, SweepError)):
            print("(finished shards are kept: fix the cause and rerun the same command to resume)", file=sys.stderr)
        return 2
    if not args.quiet:
        print(
            f"{r.shards_run} shards run in {r.wall_time_s:.1f} s: {r.episodes_run} episode runs "
            f"({r.episodes_per_s:.2f}/s), {r.scores_run} episode x point scores ({r.scores_per_s:.1f}/s); "
            f"{r.shards_skipped} shards already done; {r.points} points over {r.episodes} episodes"
        )
    if not r.complete:
        left = r.shards_total - r.shards_skipped - r.shards_run
        print(f"{left} of {r.shards_total} shards left: rerun the same command to go on ({r.out})")
        return EXIT_INCOMPLETE
    print(r.ranking_table.rstrip())
    print(f"reports in {r.out}/points, ranking in {r.out}/ranking.csv, page {r.report_html}")
    return 0


if __name__ == "__main__":
    from loomlab.sweep import main as _main  # the package's module, so Ray pickles tasks by reference

    sys.exit(_main())
