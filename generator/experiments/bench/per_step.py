"""Time per step of the emitted C, the emitted NumPy and the NumPy reference, side by side;
Newton's iterations per substep of the VI family.

Input: a system, a horizon T and `quick`. Output: one dict per method of `PER_STEP_METHODS`
with microseconds per step on each backend (``c_us``, ``numpy_us``, ``reference_us``) and
the ratios to C (``numpy_over_c``, ``reference_over_c``), written to ``per_step.csv``; and
(`newton_per_substep`) the Newton iterations per substep of every VI-family method at the
system's own step.

Example:
    >>> PER_STEP_METHODS
    ('vi', 'vi4', 'rattle', 'rk4', 'rk45', 'dop853')
"""

from __future__ import annotations

from functools import partial
from typing import Any

from s2gen import IntegrationError, Options, System, simulate
from s2gen.inspect import method as method_record

from .common import Log, _best_wall, _fmt, _print, _why
from .model import VI_FAMILY

PER_STEP_METHODS = ("vi", "vi4", "rattle", "rk4", "rk45", "dop853")
#: Steps of the system's own h over which Newton's iterations are counted.
NEWTON_STEPS = 2000


def per_step_times(
    system: System, T: float, quick: bool, log: Log = _print
) -> list[dict[str, Any]]:
    """Time per step of emitted C, emitted NumPy and the NumPy reference, side by side: the
    same N steps of h = T/N on each backend. Fixed-step methods: (best wall of N steps - best
    wall of 1 step) / (N - 1), which removes the per-call overhead; rk45 and dop853 (tol 1e-8,
    output every T/N): best wall / accepted steps.

    Example:
        >>> from s2gen.experiments.bench import example_system
        >>> rows = per_step_times(example_system("double_pendulum"), 1.0, True, lambda s: None)
        >>> rows[0]["method"], rows[0]["c_us"] > 0
        ('vi', True)
    """
    n = 100 if quick else 400
    h = T / n
    out = []
    for method in PER_STEP_METHODS:
        row: dict[str, Any] = {"system": system.name, "method": method, "h": h, "steps": n}
        for backend in ("c", "numpy", "reference"):
            if backend not in method_record(method).backends:
                continue
            k = 20 if backend == "c" else 2 if quick else 3
            try:
                row[f"{backend}_us"] = _seconds_per_step(system, method, backend, h, n, k) * 1e6
            except IntegrationError as exc:
                log(f"    per step {method} on {backend}: {_why(exc)}")
        for backend in ("numpy", "reference"):
            if f"{backend}_us" in row and "c_us" in row:
                row[f"{backend}_over_c"] = row[f"{backend}_us"] / row["c_us"]
        out.append(row)
        log(
            f"    per step {method:7s} C {_fmt(row.get('c_us'))} us, NumPy "
            f"{_fmt(row.get('numpy_us'))} us ({_fmt(row.get('numpy_over_c'))}x), reference "
            f"{_fmt(row.get('reference_us'))} us ({_fmt(row.get('reference_over_c'))}x)"
        )
    return out


def _seconds_per_step(system: System, method: str, backend: str, h: float, n: int, k: int) -> float:
    opts = Options(rtol=1e-8, atol=1e-8, control="hairer")
    full = _best_wall(partial(simulate, system, method, backend, h=h, T=n * h, options=opts), k)
    if method_record(method).adaptive:
        return full.wall_time / max(int(full.stats.get("steps", n)), 1)
    one = _best_wall(partial(simulate, system, method, backend, h=h, T=h, options=opts), k)
    return max(full.wall_time - one.wall_time, 0.0) / (n - 1)


def newton_per_substep(system: System, log: Log = _print) -> dict[str, float]:
    """Newton iterations per substep of every VI-family method over `NEWTON_STEPS` steps of the
    system's own h on the emitted C (0 when M is diagonal: explicit steps, closed forms).

    Example:
        >>> from s2gen.experiments.bench import example_system
        >>> its = newton_per_substep(example_system("double_pendulum"), lambda s: None)
        >>> 1.5 < its["vi"] < 3 and 1.5 < its["rattle8"] < 3
        True
    """
    h = system.run.h or 0.01
    out = {}
    for method in VI_FAMILY:
        try:
            tr = simulate(system, method, "c", h=h, T=NEWTON_STEPS * h, every=NEWTON_STEPS)
        except IntegrationError as exc:
            log(f"    Newton {method}: {_why(exc)}")
            continue
        subs = method_record(method).evals
        out[method] = tr.stats["newton_iters"] / tr.stats["steps"] / subs
    log(
        f"    Newton iterations per substep (h = {h:g}): "
        + ", ".join(f"{m} {v:.2f}" for m, v in out.items())
    )
    return out
