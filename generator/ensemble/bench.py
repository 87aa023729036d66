"""Benchmark of the ensemble machinery: serial against local workers, overhead, client memory.

Input: the ensemble's settings (system, members, perturbation, method, h, T, every, options),
the local worker count (default 2) and the small member count for the memory comparison
(default 16). Output: a `BenchReport` and its printed lines:

- wall time of the members run in this process (``workers=0``, the same store writes; in
  batches of `s2gen.ensemble.dispatch.MAX_BATCH` through integrate_batch() where it applies) and on a `LocalCluster` of K worker processes, and the speedup;
- per-member overhead = (K * wall - sum of the members' own integration times) / members: the
  worker time not spent integrating (scheduling, transfer, the client's store writes,
  idle ends), per member; with K = 1 (serial) the same formula;
- the client's peak resident memory (``ru_maxrss``) for the small and the full ensemble, each
  run in a fresh process of its own (the workers are separate processes, not counted);
- the machine's ceiling: the same integrations split over K plain processes (no Dask, no
  store, no transfer; through integrate_batch() where the system has it, as the ensemble's
  tasks run them; each loads its modules before its clock starts, as the workers do while
  the ensemble sets up), their speedup over the serial run's integration time. On a machine whose
  K cores slow each other down (shared caches, a busy host), this ceiling is below K, and it
  bounds what any scheduler can reach.

The build (the module with integrate_batch() too, where the members use it) is done once up
front (content-hash cache), so no run pays for gcc; each run's
set-up (cluster start, payload broadcast, model loads) is reported apart from its members'
phase.

Example:
    >>> report = benchmark("double_pendulum", members=8, T=0.5)  # doctest: +SKIP
    >>> print("\\n".join(report.lines()))  # doctest: +SKIP
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from s2gen.runtime.options import Options

__all__ = ["BenchReport", "BenchRun", "benchmark"]


@dataclass(frozen=True)
class BenchRun:
    """One timed ensemble: members, workers (0 serial), times in seconds, client peak RSS."""

    members: int
    workers: int
    setup: float
    wall: float
    integration: float
    peak_rss_mb: float

    @property
    def overhead_ms(self) -> float:
        """Worker time not spent integrating, per member (ms)."""
        k = max(self.workers, 1)
        return 1e3 * (k * self.wall - self.integration) / self.members


@dataclass(frozen=True)
class BenchReport:
    """The settings, the three runs (serial, parallel full, parallel small) and the plain
    processes' time (the slowest of K processes integrating a K-th of the members each)."""

    title: str
    build: float
    serial: BenchRun
    parallel: BenchRun
    small: BenchRun
    plain: float
    load: tuple[float, float]

    @property
    def ceiling(self) -> float:
        """Speedup of K plain processes over the serial integrations (the machine's bound)."""
        return self.serial.integration / self.plain

    @property
    def speedup(self) -> float:
        """Serial wall time over parallel wall time, members' phase."""
        return self.serial.wall / self.parallel.wall

    def lines(self) -> list[str]:
        """The report as printed."""
        s, p, m = self.serial, self.parallel, self.small
        k = p.workers
        return [
            self.title,
            (
                f"build (gcc, cached by content) {self.build:.2f} s, before the runs; load average "
                f"(1 min) {self.load[0]:.2f} before, {self.load[1]:.2f} after"
            ),
            (
                f"serial, one process:   members {s.wall:7.2f} s  (integration {s.integration:.2f} s,"
                f" set-up {s.setup:.2f} s)"
            ),
            (
                f"{k} local workers:       members {p.wall:7.2f} s  (integration "
                f"{p.integration:.2f} s, set-up {p.setup:.2f} s: cluster start, payload)"
            ),
            (
                f"speedup: {self.speedup:.2f}x on the members' phase, "
                f"{(s.wall + s.setup) / (p.wall + p.setup):.2f}x including set-up"
            ),
            (
                f"machine ceiling: {k} plain processes (no Dask, no store) integrate the same "
                f"members in {self.plain:.2f} s: {self.ceiling:.2f}x; the ensemble's members' "
                f"phase reaches {self.plain / p.wall:.0%} of their throughput"
            ),
            (
                f"per-member overhead ({k} x wall - integration) / members: {p.overhead_ms:.1f} ms "
                f"on {k} workers, {s.overhead_ms:.1f} ms serial"
            ),
            (
                f"client peak RSS: {m.members} members {m.peak_rss_mb:.0f} MB, {p.members} members "
                f"{p.peak_rss_mb:.0f} MB ({k} workers, each run in a fresh process)"
            ),
        ]


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _settings(
    spec: str,
    members: int,
    perturb: Mapping[str, float],
    method: str | None,
    h: float | None,
    T: float | None,
    every: int,
    options: Options,
    seed: int,
) -> dict[str, Any]:
    return {
        "system": spec,
        "members": members,
        "perturb": dict(perturb),
        "method": method,
        "h": h,
        "T": T,
        "every": every,
        "options": asdict(options),
        "seed": seed,
    }


def _timed(settings: dict[str, Any], workers: int, out: str) -> BenchRun:
    """Run one ensemble in this process and time it."""
    from .dispatch import ensemble

    kw = dict(settings)
    kw["options"] = Options(**kw["options"])
    if workers == 0:  # serially in batches where integrate_batch() applies, as tasks run
        import s2gen

        from .dispatch import MAX_BATCH

        system = s2gen.load(kw["system"])
        if _batched(system, kw["method"] or system.run.method or "vi"):
            kw["batch_size"] = MAX_BATCH
    r = ensemble(**kw, workers=workers, out=out, overwrite=True)
    if r.failed or r.task_errors:
        print(f"note: {len(r.failed)} failed, {len(r.task_errors)} task errors", file=sys.stderr)
    return BenchRun(
        r.members, r.workers, r.setup_time, r.wall_time, r.integration_time, _peak_rss_mb()
    )


def _plain(settings: dict[str, Any], part: int, parts: int) -> float:
    """Seconds to integrate members part, part + parts, ... directly (no Dask, no store)."""
    import s2gen

    from .members import initial_state, member_table

    system = s2gen.load(settings["system"])
    table = member_table(
        system, settings["members"], settings["perturb"], None, settings["seed"],
        settings["h"], settings["T"],
    )  # fmt: skip
    method = settings["method"] or system.run.method or "vi"
    opts = Options(**settings["options"])
    mine = table.members[part::parts]
    if _batched(system, method):
        return _plain_batched(system, table, mine, method, opts)
    model = s2gen.compile(system)
    start = time.perf_counter()
    for m in mine:
        q0, w0 = initial_state(system, table, m)
        try:
            model.integrate(
                method, m.h, table.T, q0=q0, omega0=w0, params=dict(m.params), options=opts
            )
        except RuntimeError:  # IntegrationError: a failed member costs what it cost
            pass
    return time.perf_counter() - start


def _batched(system: Any, method: str) -> bool:
    """Whether the members can run through integrate_batch()."""
    from s2gen.parts.batch import BATCH_METHODS, batch_refusal

    return method in BATCH_METHODS and batch_refusal(system) is None


def _plain_batched(system: Any, table: Any, mine: Any, method: str, opts: Options) -> float:
    """Seconds to integrate `mine` through integrate_batch(), `MAX_BATCH` members per call
    (members of one step size and sweep point together)."""
    import s2gen

    from .dispatch import MAX_BATCH
    from .members import initial_states

    model = s2gen.compile(system)
    groups: dict[tuple[float, tuple[tuple[str, float], ...]], list[Any]] = {}
    for m in mine:
        groups.setdefault((m.h, m.params), []).append(m)
    if mine:  # load the module with integrate_batch() before the clock starts, as the
        # ensemble's workers do while it sets up: one step of one member
        q0, w0 = initial_states(system, table, mine[:1])
        model.integrate_batch(method, mine[0].h, mine[0].h, q0=q0, omega0=w0, options=opts)
    start = time.perf_counter()
    for (h, params), ms in groups.items():
        for lo in range(0, len(ms), MAX_BATCH):
            q0, w0 = initial_states(system, table, ms[lo : lo + MAX_BATCH])
            model.integrate_batch(
                method, h, table.T, q0=q0, omega0=w0, params=dict(params), options=opts
            )
    return time.perf_counter() - start


def _spawn(job: dict[str, Any]) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "s2gen.ensemble.bench", json.dumps(job)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=os.environ.copy(),
    )


def _answer(proc: subprocess.Popen[str]) -> Any:
    out, err = proc.communicate()
    if proc.returncode != 0:
        tail = (err.strip().splitlines() or ["no output"])[-1]
        raise RuntimeError(f"benchmark run failed: {tail}")
    return json.loads(out.strip().splitlines()[-1])


def _in_fresh_process(settings: dict[str, Any], workers: int, out: str) -> BenchRun:
    """`_timed` in a new Python process (so its peak RSS is its own)."""
    return BenchRun(**_answer(_spawn({"settings": settings, "workers": workers, "out": out})))


def _plain_processes(settings: dict[str, Any], k: int) -> float:
    """The slowest of k concurrent processes, each integrating a k-th of the members."""
    procs = [_spawn({"settings": settings, "part": i, "parts": k}) for i in range(k)]
    return max(float(_answer(p)) for p in procs)


def benchmark(
    spec: str = "elastic_rod",
    members: int = 64,
    perturb: Mapping[str, float] | None = None,
    method: str | None = None,
    h: float | None = None,
    T: float | None = None,
    every: int = 1,
    workers: int = 2,
    small: int = 16,
    options: Options | None = None,
    seed: int = 0,
    out: str | Path | None = None,
    log: Callable[[str], None] = print,
) -> BenchReport:
    """Time the members serially and on `workers` local workers; client memory, small vs full."""
    import s2gen

    system = s2gen.load(spec)
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    s2gen.compile(system)
    if _batched(system, method or system.run.method or "vi"):  # the members' module, too
        from s2gen.runtime.c import CBackend

        CBackend(system.with_batch())
    build = time.perf_counter() - start
    perturb = perturb or {"omega": 1e-13}
    opts = options or Options()
    full = _settings(spec, members, perturb, method, h, T, every, opts, seed)
    little = {**full, "members": min(small, members)}
    # the stores only serve the timing: a folder of our own is removed afterwards (at every 1
    # the rod's three stores hold about 1.7 GB)
    scratch = None if out is not None else tempfile.mkdtemp(prefix="s2gen-bench-")
    folder = Path(out) if out is not None else Path(str(scratch))
    try:
        log(f"serial: {members} members in this process ...")
        serial = _timed(full, 0, str(folder / "serial"))
        log(f"{workers} local workers: {members} members (fresh process) ...")
        parallel = _in_fresh_process(full, workers, str(folder / "parallel"))
        log(f"{workers} local workers: {little['members']} members (fresh process) ...")
        few = _in_fresh_process(little, workers, str(folder / "small"))
        log(f"{workers} plain processes: {members} members, no Dask, no store ...")
        plain = _plain_processes(full, workers)
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
    run = system.run
    title = (
        f"{system.name} (n = {system.n}): {members} members, {method or run.method or 'vi'}, "
        f"h = {h or run.h:g}, T = {T or run.T:g}, every {every}, perturb "
        + ", ".join(f"{k}={v:g}" for k, v in perturb.items())
        + f"; {os.cpu_count()} cores"
    )
    load = (load_before, os.getloadavg()[0])
    return BenchReport(title, build, serial, parallel, few, plain, load)


def _main(job_text: str) -> None:
    job = json.loads(job_text)
    if "parts" in job:
        print(json.dumps(_plain(job["settings"], job["part"], job["parts"])))
        return
    run = _timed(job["settings"], job["workers"], job["out"])
    print(json.dumps(asdict(run)))


if __name__ == "__main__":
    _main(sys.argv[1])
