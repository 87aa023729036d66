"""Derivation cost of one form: derive, lower and emit it, timed, in a fresh subprocess.

Input: a `System` and a form of `FORMS` (and a time budget). Output: a dict with the
derivation + cse time of the vector field ("seconds") and of the whole emitted module
("module_seconds"), its operation counts before and after cse, the flops of its linear solve
and the emitted C files; None when the budget runs out (a blow-up is reported, not waited
for), {"error": ...} when the derivation fails.

Example:
    >>> import s2gen
    >>> _derive(s2gen.load("double_pendulum"), "s2")["ops"] > 0  # doctest: +SKIP
    True
"""

from __future__ import annotations

import multiprocessing
import time
from typing import Any

from s2gen import System
from s2gen.inspect import (
    Kernel,
    Module,
    c_sources,
    field_kernels,
    lower_kernel,
    lowered,
    lowered_angles,
)


def _field_ops(module: Module) -> tuple[int, int, int]:
    """(ops before cse, after cse, after cse as evaluated per call) of a module's vector field
    (the kernels and call counts the module records in `field_calls`)."""
    uses = [(module.kernel(name), count) for name, count in module.field_calls]
    kernels = [(k, c) for k, c in uses if isinstance(k, Kernel)]
    before = sum(k.ops_before for k, _ in kernels)
    return before, sum(k.ops_after for k, _ in kernels), sum(k.ops_after * c for k, c in kernels)


def _s2_field_seconds(system: System) -> float:
    """Derivation + cse time of the S^2 vector field alone (continuous and system kernels)."""
    start = time.perf_counter()
    for k in field_kernels(system):
        lower_kernel(k)
    return time.perf_counter() - start


def _derive(system: System, form: str) -> dict[str, Any]:
    """Derive, lower and emit one form in this process; timings, op counts and C files.

    "seconds" is the vector field's derivation + cse; "module_seconds" that of every kernel
    of the emitted module (for S^2 also the variational integrators' generic kernels).
    """
    if form == "s2":
        field = _s2_field_seconds(system)
        start = time.perf_counter()
        module = lowered(system)
        whole = time.perf_counter() - start
        files = c_sources(module)
        before, after, evaluated = _field_ops(module)
        dim = 3 * system.n if module.coupling is not None else 0
        solve = 2 * dim**3 // 3  # LU with partial pivoting, as the angle form
    else:
        start = time.perf_counter()
        angles = lowered_angles(system, simplify=form == "angles-simplified")
        field = whole = time.perf_counter() - start
        files = c_sources(angles)
        before, after, evaluated = _field_ops(angles)
        solve = 2 * (2 * system.n) ** 3 // 3
    return {
        "seconds": field,
        "module_seconds": whole,
        "ops_before": before,
        "ops": after,
        "ops_evaluated": evaluated,
        "solve_flops": solve,
        "files": files,
    }


def _derive_job(system: System, form: str, conn: Any) -> None:
    """Subprocess entry: derive one form and send the result (or the error) back."""
    try:
        conn.send(_derive(system, form))
    except Exception as exc:  # noqa: BLE001 - any failure is reported to the parent
        conn.send({"error": f"{type(exc).__name__}: {exc}"})
    conn.close()


def derive_with_budget(system: System, form: str, budget: float) -> dict[str, Any] | None:
    """`_derive` in a fresh subprocess (cold caches); None if it takes longer than `budget` s.

    Example:
        >>> import s2gen
        >>> derive_with_budget(s2gen.load("double_pendulum"), "angles", 60)["ops"]  # doctest: +SKIP
        386
    """
    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_derive_job, args=(system, form, child), daemon=True)
    proc.start()
    child.close()
    result: dict[str, Any] | None = None
    if parent.poll(budget):
        result = parent.recv()
    proc.join(timeout=None if result is not None else 0)
    if proc.is_alive():
        proc.terminate()
        proc.join()
    return result
