"""A long fixed-step run in chunks, each continuing from the last state, with progress reports.

Input: a backend object (see `s2gen.runtime.get_backend`), a method, h, T, options and a
callback `progress(done, total)` called after each chunk. Output: the same `Trajectory` as one
call of `s2gen.runtime.run` — bit for bit, for the methods in `CHUNKED`, whose step maps
(q, omega) alone — with summed step statistics. The arrays are allocated once for the whole
run and filled chunk by chunk, so chunking costs no extra memory.

Chunks aim at `CHUNK_SECONDS` of work each (the first one is `FIRST_CHUNK` steps, to measure
the cost of a step), so a progress bar moves several times a second on long runs. RK45 (its
step-size history) and RATTLE (its multipliers) carry more than (q, omega) and are not chunked:
`run_chunked` runs them in one call and reports once, at the end.

Example:
    >>> from s2gen.runtime import get_backend
    >>> from s2gen.systems import builtin
    >>> be = get_backend(builtin("double_pendulum"), "c")
    >>> tr = run_chunked(be, "vi", 0.01, 1.0, progress=lambda done, total: None)
    >>> tr.q.shape
    (101, 2, 3)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from s2gen.methods import Status
from s2gen.runtime import Backend, check_run, run
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import IntegrationError, Trajectory

__all__ = ["CHUNKED", "CHUNK_SECONDS", "FIRST_CHUNK", "run_chunked"]

#: Methods whose step is a map of (q, omega) alone: a run split into chunks that continue
#: from the last state is bit for bit the one-call run.
CHUNKED = ("vi", "vi4", "rk2", "rk2-proj", "rk4")
#: Wall time each chunk aims at (after the first).
CHUNK_SECONDS = 0.25
#: Steps of the first chunk, which measures the cost of a step.
FIRST_CHUNK = 50

Progress = Callable[[int, int], None]


def _add_stats(total: dict[str, int], part: dict[str, int]) -> None:
    for key, value in part.items():
        if key == "newton_max":
            total[key] = max(total.get(key, 0), int(value))
        elif key != "fail_step":
            total[key] = total.get(key, 0) + int(value)


def run_chunked(
    be: Backend,
    method: str,
    h: float,
    T: float,
    options: Options | None = None,
    progress: Progress | None = None,
) -> Trajectory:
    """`run(be, method, h, T, options)` in chunks, calling `progress(done, total)` after each.

    Example:
        >>> from s2gen.runtime import get_backend
        >>> from s2gen.systems import builtin
        >>> be = get_backend(builtin("three_bodies"), "c")
        >>> seen = []
        >>> tr = run_chunked(be, "rk4", 0.01, 2.0, progress=lambda d, t: seen.append((d, t)))
        >>> seen[0], seen[-1]
        ((50, 200), (200, 200))
    """
    report = progress or (lambda done, total: None)
    opts = options or Options()
    total = check_run(be.system, method, h, T, opts)
    if method not in CHUNKED:
        tr = run(be, method, h, T, opts)
        report(total, total)
        return tr
    n = be.system.n
    q = np.empty((total + 1, n, 3))
    w = np.empty((total + 1, n, 3))
    en = np.empty(total + 1)
    stats: dict[str, int] = {}
    done, chunk, wall = 0, min(total, FIRST_CHUNK), 0.0
    first: Trajectory | None = None
    while done < total:
        q0 = q[done] if first is not None else None
        w0 = w[done] if first is not None else None
        try:
            tr = run(be, method, h, chunk * h, opts, q0=q0, omega0=w0)
        except IntegrationError as exc:
            raise _failure(exc, done, q, w, en, stats, wall + exc.partial.wall_time) from None
        first = first or tr
        q[done : done + chunk + 1], w[done : done + chunk + 1] = tr.q, tr.omega
        en[done : done + chunk + 1] = tr.energy
        _add_stats(stats, tr.stats)
        wall += tr.wall_time
        done += chunk
        report(done, total)
        per_step = max(tr.wall_time, 1e-9) / chunk
        chunk = min(total - done, max(1, int(CHUNK_SECONDS / per_step)))
    assert first is not None
    t = h * np.arange(total + 1)
    return dataclasses.replace(
        first, t=t, q=q, omega=w, energy=en, stats=stats, wall_time=wall, momentum=None
    )


def _failure(
    exc: IntegrationError,
    done: int,
    q: np.ndarray,
    w: np.ndarray,
    en: np.ndarray,
    stats: dict[str, int],
    wall: float,
) -> IntegrationError:
    """The error of the whole run from the error of the chunk starting at step `done`."""
    part = exc.partial
    k = done + exc.step  # first sample not computed, counted from the run's start
    if exc.step > 0:
        q[done:k], w[done:k], en[done:k] = part.q, part.omega, part.energy
    _add_stats(stats, part.stats)
    stats["fail_step"] = k
    h = part.h
    partial = dataclasses.replace(
        part,
        t=h * np.arange(k),
        q=q[:k].copy(),
        omega=w[:k].copy(),
        energy=en[:k].copy(),
        stats=stats,
        wall_time=wall,
    )
    status = exc.status
    why = Status(status).message if status in Status._value2member_map_ else status
    return IntegrationError(
        f"{part.method} ({part.backend}) failed at step {k} (t = {k * h:.6g}): {why}; "
        f"{k} valid samples kept",
        status,
        k,
        partial,
    )
