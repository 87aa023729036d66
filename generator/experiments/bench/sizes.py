"""Scaling with n: generation time (derive + emit + gcc) and time per step against size.

Times are CPU seconds (this process for the derivation and the runs, its children for gcc),
so that other load on a shared machine does not inflate them.

Input: `quick`. Output: one `ScaleRow` per system size: elastic rods (coupled M) with the
dense solvers (n = 5 … 80) and with the structured O(n) ones (max-index inertia, n = 10 …
1000), both at h = 2e-5 (the largest step at which the paper's rod, whose joint stiffness
does not shrink with the elements, stays stable up to n = 1000), and Lennard-Jones particles
on a Fibonacci sphere (`md_system`: all pairs, and with a cutoff, up to n = 10⁵), generated in
a fresh build cache with SymPy's caches cleared.

Example:
    >>> md_system(50, cutoff=2.5).n
    50
"""

from __future__ import annotations

import contextlib
import math
import os
import resource
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from s2gen import System, simulate

from .common import Log, _print
from .model import ScaleRow


@contextlib.contextmanager
def _fresh_cache() -> Iterator[Path]:
    """A private, empty build cache ($S2GEN_CACHE) so gcc really runs; removed afterwards."""
    old = os.environ.get("S2GEN_CACHE")
    tmp = tempfile.mkdtemp(prefix="s2gen-bench-cache-")
    os.environ["S2GEN_CACHE"] = tmp
    try:
        yield Path(tmp)
    finally:
        if old is None:
            os.environ.pop("S2GEN_CACHE", None)
        else:
            os.environ["S2GEN_CACHE"] = old
        shutil.rmtree(tmp, ignore_errors=True)


def md_system(n: int, cutoff: float | None = None) -> System:
    """n Lennard-Jones particles on a Fibonacci lattice of the unit sphere (diagonal M).

    sigma puts the force zero at the mean nearest-neighbour distance; `cutoff` (in units of
    sigma) restricts the all-pairs term to |q_i - q_j| < cutoff sigma (neighbour lists);
    velocities are the paper's two vortices.

    Example:
        >>> md_system(100).n
        100
    """
    from s2gen import paper
    from s2gen.inspect import RunSettings

    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = math.pi * (1 + math.sqrt(5)) * k
    r = np.sqrt(1 - z**2)
    pts = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    sig = paper.lennard_jones_sigma(paper.nearest_neighbour_distance(pts))
    w = paper.vortex_velocities(pts, paper.vortex_axes(30.0), (1.0, 1.0), math.radians(15.0))
    return paper.lennard_jones_system(
        "md_fibonacci",
        pts,
        w,
        sig,
        RunSettings(h=0.005, T=1.0, method="vi"),
        f"s2gen.bench.md_system(n={n}, cutoff={cutoff})",
        cutoff=None if cutoff is None else cutoff * sig,
    )


#: Step size of the rods' per-step timings (stable for the paper's rod up to n = 1000).
ROD_H = 2e-5
#: The rod families: the same system with the dense and with the structured solvers.
DENSE_ROD, STRUCTURED_ROD = "rod dense", "rod structured"


def _children_cpu() -> float:
    """CPU seconds used so far by this process's finished children (gcc)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _per_step(
    system: System, method: str, budget: float = 0.3, h: float | None = None
) -> tuple[float, float]:
    """Best-of-3 CPU microseconds per step (the process's CPU time, so that other load on a
    shared machine does not inflate it), with a step count aimed at `budget` seconds, and the
    Newton iterations per step of that run."""
    h = h or system.run.h or 1e-3
    probe = simulate(system, method, "c", h=h, T=2 * h, energy=False)
    per = max(probe.wall_time / 2, 1e-8)
    n = int(min(max(budget / per, 2), 200000))
    best, newton = math.inf, math.nan
    for _ in range(3):
        start = time.process_time()
        tr = simulate(system, method, "c", h=h, T=n * h, energy=False)
        cpu = time.process_time() - start
        if cpu < best:
            best, newton = cpu, tr.stats["newton_iters"] / n
    return best / n * 1e6, newton


def _scale_one(
    family: str, n: int, make: Callable[[], System], log: Log, h: float | None = None
) -> ScaleRow:
    from s2gen.inspect import clear_caches, compile_shared, emit, solver

    t0 = time.process_time()
    system = make()
    t1 = time.process_time()
    clear_caches()
    try:
        files = emit(system, "c", cache=False)
        t2 = time.process_time()
        gcc = _children_cpu()
        compile_shared(files)
        t3 = t2 + _children_cpu() - gcc
        vi, newton = _per_step(system, "vi", h=h)
        rk4, _ = _per_step(system, "rk4", h=h)
        status = "ok"
    except Exception as exc:  # noqa: BLE001 - report the size that broke, keep going
        log(f"    {family} n = {n}: {type(exc).__name__}: {str(exc)[:200]}")
        nan = math.nan
        return ScaleRow(family, n, t1 - t0, nan, nan, 0, nan, nan, f"failed: {type(exc).__name__}")
    size = sum(len(v) for k, v in files.items() if k.endswith(".c"))
    solved_by = solver(system)
    step = h or system.run.h or 1e-3
    row = ScaleRow(
        family, n, t1 - t0, t2 - t1, t3 - t2, size, vi, rk4, status, solved_by, step, newton
    )
    log(
        f"    {family:14s} n = {n:>6d}: create {row.create_s:6.2f} s, derive+emit "
        f"{row.emit_s:6.2f} s, gcc {row.gcc_s:6.2f} s; per step vi {vi:.3g} us "
        f"({newton:.2f} Newton), rk4 {rk4:.3g} us ({solved_by} solves)"
    )
    return row


def rod_sizes(quick: bool) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(dense, structured) sizes of the rod families.

    Example:
        >>> rod_sizes(True)
        ((10, 20), (10, 20, 40))
    """
    if quick:
        return (10, 20), (10, 20, 40)
    return (5, 10, 20, 40, 80), (10, 20, 40, 80, 160, 320, 1000)


def scaling(quick: bool = False, log: Log = _print) -> list[ScaleRow]:
    """Generation (derive + emit + gcc, fresh caches) and per-step time against n.

    Rod: coupled M with the dense solvers, n = 5 ... 80, and with the structured ones,
    n = 10 ... 1000 (both at h = `ROD_H`). Molecular dynamics: diagonal M, one all-pairs
    Lennard-Jones term, and its cutoff (neighbour-list) variant up to
    n = 10^5. All-pairs sizes stop once a VI step takes longer than 0.5 s.

    Example:
        >>> rows = scaling(quick=True)  # doctest: +SKIP
        >>> rows[0].family, rows[0].n  # doctest: +SKIP
        ('rod dense', 10)
    """
    from s2gen import paper

    rows: list[ScaleRow] = []
    log("scaling: generation and per-step time against n (fresh build cache)")
    dense, structured = rod_sizes(quick)
    with _fresh_cache():
        for n in dense:
            make = lambda n=n: paper.elastic_rod(n, solver="dense")  # type: ignore[misc]
            rows.append(_scale_one(DENSE_ROD, n, make, log, ROD_H))
        for n in structured:
            make = lambda n=n: paper.elastic_rod(n, solver="structured")  # type: ignore[misc]
            rows.append(_scale_one(STRUCTURED_ROD, n, make, log, ROD_H))
        for n in (100, 300) if quick else (100, 300, 1000, 3000, 10000):
            row = _scale_one("md all-pairs", n, lambda n=n: md_system(n), log)  # type: ignore[misc]
            rows.append(row)
            if not row.vi_us < 5e5:
                break
        sizes = (100, 1000) if quick else (100, 1000, 10000, 100000)
        for n in sizes:
            make = lambda n=n: md_system(n, cutoff=2.5)  # type: ignore[misc]
            rows.append(_scale_one("md cutoff 2.5σ", n, make, log))
    return rows
