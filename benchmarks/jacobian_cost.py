"""``python benchmarks/jacobian_cost.py``: what a step's exact Jacobian costs against the step.

Input: command-line options (``--systems``, ``--methods``, ``--h``, ``--calls``,
``--repeats``, ``--generation``). Output: with ``--generation``, per system the seconds to
emit its C with and without the step Jacobians (derived afresh, `s2gen.emit.emit` without
the cache; the first in a process also derives the generic kernels); then a table on stdout:
per system and method, the time per call of the
emitted step (``NAME_vi_step`` / ``NAME_rk_step``, or a driven module's ``NAME_step``) and of
``NAME_step_jacobian`` (the same step and A, B in the embedding coordinates; the module built
with ``System.with_jacobians``), both called
through ctypes from the system's initial state (so both include the ctypes call, about a
microsecond), and their ratio; the best of `repeats` batches of `calls` calls. The header
names the CPU (from /proc/cpuinfo). Numbers only: no test times them.

Example:
    >>> parse_args(["--systems", "double_pendulum", "--calls", "10"]).calls
    10
"""

from __future__ import annotations

import argparse
import ctypes
import time
from collections.abc import Callable

import numpy as np
from python_step import cpu_model

import s2gen
from s2gen.methods import Family, method
from s2gen.runtime.c import contiguous, pointer
from s2gen.runtime.model import Model
from s2gen.runtime.options import Options


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--systems",
        nargs="+",
        default=["double_pendulum", "four_pendula", "tests/specs/driven_double.toml"],
    )
    ap.add_argument("--methods", nargs="+", default=["vi", "vi4", "rk4"])
    ap.add_argument("--h", type=float, default=0.001)
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument(
        "--generation", action="store_true", help="also time the emitted C's derivation"
    )
    return ap.parse_args(argv)


def _generation(spec: str) -> tuple[float, float]:
    """Seconds to emit a system's C without and with the step Jacobians (no cache)."""
    from s2gen.emit import emit

    system = s2gen.load(spec)
    times = []
    for s in (system, system.with_jacobians()):
        start = time.perf_counter()
        emit(s, "c", cache=False)
        times.append(time.perf_counter() - start)
    return times[0], times[1]


def _best(call: Callable[[], int], calls: int, repeats: int) -> float:
    """The best batch's seconds per call."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(calls):
            call()
        best = min(best, (time.perf_counter() - start) / calls)
    return best


def _calls(model: Model, name: str, h: float) -> tuple[Callable[[], int], Callable[[], int]]:
    """(one step, one step with its Jacobian) as ctypes calls from the initial state."""
    s = model.system
    lib = model._backend.library  # the emitted functions themselves
    n, ni = s.n, len(s.inputs.names)
    p = contiguous(np.asarray(s.parameter_values, dtype=float))
    q, w = contiguous(np.asarray(s.q0, float)), contiguous(np.asarray(s.omega0, float))
    qn, wn = np.empty((n, 3)), np.empty((n, 3))
    A, B = np.empty((6 * n, 6 * n)), np.empty((6 * n, max(ni, 1)))
    jwork, work = np.zeros(lib.jacobian_work), lib.work
    opt = ctypes.byref(lib.options(Options()))
    code = method(name).code
    fn = lib.fn
    if s.driven:

        def step() -> int:
            return int(fn["step"](p, opt, code, 0.0, h, None, q, w, qn, wn, None, work, None))
    elif method(name).tableau is not None:

        def step() -> int:
            return int(fn["rk_step"](p, code, h, q, w, qn, wn, work))
    else:
        if name != "vi":
            raise SystemExit(f"{name}: a closed module's single step is vi or a Runge-Kutta")

        def step() -> int:
            return int(fn["vi_step"](p, opt, h, q, w, qn, wn, work, None))

    def jacobian() -> int:
        b = pointer(B) if ni else None
        return int(fn["step_jacobian"](p, opt, code, 0.0, h, None, q, w, qn, wn, A, b, None, jwork))

    assert step() == 0 and jacobian() == 0, (s.name, name)
    return step, jacobian


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    args = parse_args(argv)
    print(f"# step_jacobian against the step; CPU: {cpu_model()}; h = {args.h}")
    if args.generation:
        print(f"{'system':32} {'emit s':>8} {'with Jacobians s':>17}")
        for spec in args.systems:
            plain, full = _generation(spec)
            print(f"{spec:32} {plain:8.1f} {full:17.1f}")
    print(f"{'system':32} {'n':>3} {'method':7} {'step µs':>9} {'jacobian µs':>12} {'ratio':>7}")
    for spec in args.systems:
        model = Model(s2gen.load(spec).with_jacobians())
        jacobian_vi = model._backend.library.jacobian_vi
        for name in args.methods:
            if method(name).family is Family.VI and not jacobian_vi:
                continue  # M banded or max-index: the Runge-Kutta methods only
            if name != "vi" and method(name).composition is not None and not model.system.driven:
                continue  # a closed module steps a composition only through step()
            step, jacobian = _calls(model, name, args.h)
            ts = _best(step, args.calls, args.repeats)
            tj = _best(jacobian, args.calls, args.repeats)
            print(
                f"{spec:32} {model.system.n:3} {name:7} {ts * 1e6:9.2f} "
                f"{tj * 1e6:12.2f} {tj / ts:7.1f}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
