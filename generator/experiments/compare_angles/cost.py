"""The cost of each form: derivation (`derive.py`), emitted C size, gcc time, vector-field time.

Input: a `System`, the forms, a derivation budget and a number of timing repeats. Output: a
`Cost` per form (`costs`): the derivation's numbers, the bytes and lines of the emitted C,
one uncached `gcc -O2 -shared` and the time per vector-field evaluation of the emitted C,
the forms timed side by side (best of `repeats`) at the same state away from the poles
(`generic_angles`, `generic_state`).

Example:
    >>> q, w = generic_state(3)
    >>> q.shape, w.shape
    ((3, 3), (3, 3))
"""

from __future__ import annotations

import ctypes
import subprocess
import tempfile
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from s2gen import System
from s2gen.inspect import DEFAULT_FLAGS, compile_shared, compiler, header_macro

from .derive import derive_with_budget
from .model import Cost

_BENCH = """\
/* Timing harness of s2gen compare-angles: evaluates the vector field `reps` times. */
#include "{header}"

int {prefix}_bench(const double *p, const double *a, const double *b, double *c, double *d,
        double *work, long reps)
{{
    long k;
    int status = 0;
    (void)d;
    for (k = 0; k < reps; ++k) {{
        status |= {call};
    }}
    return status;
}}
"""


def gcc_seconds(files: dict[str, str]) -> float:
    """Wall time of one uncached gcc run of the emitted C with build.DEFAULT_FLAGS."""
    cc, _ = compiler()
    with tempfile.TemporaryDirectory(prefix="s2gen-gcc-") as tmp:
        for name, text in files.items():
            (Path(tmp) / name).write_text(text)
        sources = [str(Path(tmp) / n) for n in sorted(files) if n.endswith(".c")]
        start = time.perf_counter()
        subprocess.run(
            [cc, *DEFAULT_FLAGS, "-o", str(Path(tmp) / "lib.so"), *sources, "-lm"], check=True
        )
        return time.perf_counter() - start


def generic_angles(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Angles and rates (x, xd) of a state with every body well away from the poles.

    Example:
        >>> generic_angles(1)
        (array([0.4, 0.3]), array([ 0.5, -0.3]))
    """
    i = np.arange(n)
    x = np.stack([0.4 + 0.1 * (i % 8), 0.3 + 0.7 * i], axis=1).ravel()
    xd = np.stack([0.5 - 0.05 * i, -0.3 + 0.1 * i], axis=1).ravel()
    return x, xd


def generic_state(n: int) -> tuple[np.ndarray, np.ndarray]:
    """`generic_angles` as (q, omega = q x qdot), shape (n, 3) each (timing, chain states).

    Example:
        >>> q, w = generic_state(2)
        >>> bool(np.all(np.abs(q[:, 2]) < 0.95)), float(np.max(np.abs(np.sum(q * w, 1)))) < 1e-15
        (True, True)
    """
    x, xd = generic_angles(n)
    th, ph, thd, phd = x[0::2], x[1::2], xd[0::2], xd[1::2]
    st, ct, sp_, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    q = np.stack([st * cp, st * sp_, ct], axis=1)
    qdot = thd[:, None] * np.stack([ct * cp, ct * sp_, -st], axis=1)
    qdot += (st * phd)[:, None] * np.stack([-sp_, cp, np.zeros(n)], axis=1)
    return q, np.cross(q, qdot)


class RhsTimer:
    """Times the emitted C vector field of one form at `generic_angles` (the same state for
    both forms): each call runs one loop calibrated to about 20 ms (a harness compiled with the
    module) and returns ns per evaluation."""

    def __init__(self, system: System, form: str, files: dict[str, str]) -> None:
        header = next(name for name in files if name.endswith(".h"))
        prefix = header[:-2]
        if form == "s2":
            a, b = (v.ravel() for v in generic_state(system.n))
            call = f"{prefix}_rhs(p, a, b, c, d, work)"
        else:
            a, b = generic_angles(system.n)
            call = f"{prefix}_rhs(p, a, b, c, work)"
        bench = _BENCH.format(header=header, prefix=prefix, call=call)
        self.lib = ctypes.CDLL(str(compile_shared({**files, "bench.c": bench}).path))
        self.fn = getattr(self.lib, f"{prefix}_bench")
        self.fn.restype = ctypes.c_int
        self.arrays = [np.array(system.parameter_values, float), a, b]
        self.arrays += [
            np.zeros(a.size),
            np.zeros(a.size),
            np.zeros(header_macro(files[header], prefix, "WORK_SIZE")),
        ]
        self.args = [ctypes.c_void_p(x.ctypes.data) for x in self.arrays]
        self.name = prefix
        self.reps = max(1, int(0.02 / max(self._loop(1000) / 1000, 1e-9)))

    def _loop(self, reps: int) -> float:
        start = time.perf_counter()
        if self.fn(*self.args, ctypes.c_long(reps)) != 0:
            raise RuntimeError(f"{self.name}_rhs failed at the timing state")
        return time.perf_counter() - start

    def __call__(self) -> float:
        return 1e9 * self._loop(self.reps) / self.reps


def _build(system: System, form: str, budget: float) -> tuple[Cost, RhsTimer | None]:
    """Derive (subprocess, budget) and compile one form: its cost so far and its timer."""
    got = derive_with_budget(system, form, budget)
    if got is None:
        return Cost(form, system.n, f"> {budget:g} s"), None
    if "error" in got:
        return Cost(form, system.n, got["error"]), None
    files: dict[str, str] = got["files"]
    c = Cost(
        form=form,
        n=system.n,
        status="ok",
        seconds=got["seconds"],
        module_seconds=got["module_seconds"],
        ops_before=got["ops_before"],
        ops=got["ops"],
        ops_evaluated=got["ops_evaluated"],
        solve_flops=got["solve_flops"],
        c_bytes=sum(len(t.encode()) for t in files.values()),
        c_lines=sum(t.count("\n") for t in files.values()),
        gcc_seconds=gcc_seconds(files),
    )
    return c, RhsTimer(system, form, files)


def costs(
    system: System,
    forms: Sequence[str],
    budget: float,
    repeats: int,
    skip: dict[str, str] | None = None,
) -> list[Cost]:
    """Derive and compile each form, then time their vector fields side by side (the forms
    interleaved, best of `repeats`). Forms in `skip` are not tried (status given).

    Example:
        >>> import s2gen
        >>> dp = s2gen.load("double_pendulum")
        >>> [c.status for c in costs(dp, FORMS[:2], 60, 3)]  # doctest: +SKIP
        ['ok', 'ok']
    """
    skip = skip or {}
    built = [
        (Cost(f, system.n, skip[f]), None) if f in skip else _build(system, f, budget)
        for f in forms
    ]
    best = {c.form: float("inf") for c, timer in built if timer is not None}
    for _ in range(max(1, repeats)):
        for c, timer in built:
            if timer is not None:
                best[c.form] = min(best[c.form], timer())
    return [replace(c, rhs_ns=best[c.form]) if c.form in best else c for c, _ in built]


def _cost_line(c: Cost) -> str:
    if c.status != "ok":
        return c.status
    return (
        f"derive {c.seconds:7.2f} s, {c.ops:6d} ops, gcc {c.gcc_seconds:5.2f} s, "
        f"rhs {c.rhs_ns:8.0f} ns"
    )
