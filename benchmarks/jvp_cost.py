"""``python benchmarks/jvp_cost.py``: what a step's Jacobian-vector product costs against the step.

Input: command-line options (``--n``, ``--methods``, ``--flags``, ``--calls``,
``--repeats``). Output: a table on stdout: per chain ``rope:n=N`` (max-index M, structured
solves), flag set (``portable``: -O2; ``native``: -O3 -march=native; see
`s2gen.build.FLAG_SETS`, what S2GEN_OPT selects) and method, the time per call of the emitted
step (``NAME_rk_step``; for ``vi`` ``NAME_vi_step``, Newton from its cold start as
step_jvp() takes it) and of ``NAME_step_jvp`` (the same step and its tangent along one
direction; the module built with ``System.with_jacobians``), both called through ctypes from
the rope's initial state (h = 1e-5) and a fixed random tangent, and their ratio. The two are timed in
alternating batches (the best of `repeats` batches of `calls` calls each), so that the load
of a shared machine falls on both alike. The header names the CPU (from /proc/cpuinfo) and
the load average. Numbers only: no test times them.

Example:
    >>> parse_args(["--n", "100", "--calls", "10"]).n
    [100]
"""

from __future__ import annotations

import argparse
import ctypes
import os
import time
from collections.abc import Callable

import numpy as np
from python_step import cpu_model

from s2gen.methods import method
from s2gen.runtime.c import CBackend, contiguous
from s2gen.runtime.options import Options
from s2gen.systems import builtin


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", nargs="+", type=int, default=[100, 1000, 10000])
    ap.add_argument("--methods", nargs="+", default=["rk4", "vi"])
    ap.add_argument("--flags", nargs="+", default=["portable", "native"])
    ap.add_argument("--calls", type=int, default=0, help="calls per batch (0: about 0.1 s)")
    ap.add_argument("--repeats", type=int, default=7)
    return ap.parse_args(argv)


def _calls(be: CBackend, name: str, h: float) -> tuple[Callable[[], int], Callable[[], int]]:
    """(one step, one step with its tangent) as ctypes calls from the initial state."""
    s, lib = be.system, be.library
    n = s.n
    p = contiguous(np.asarray(s.parameter_values, dtype=float))
    q, w = contiguous(np.asarray(s.q0, float)), contiguous(np.asarray(s.omega0, float))
    rng = np.random.default_rng(0)
    dq, dw = contiguous(rng.standard_normal((n, 3))), contiguous(rng.standard_normal((n, 3)))
    qn, wn, dqn, dwn = (np.empty((n, 3)) for _ in range(4))
    work, jwork = lib.work, np.zeros(lib.jvp_work)
    code, fn = method(name).code, lib.fn
    opt = ctypes.byref(lib.options(Options()))

    def step() -> int:
        if name == "vi":
            return int(fn["vi_step"](p, opt, h, q, w, qn, wn, work, None))
        return int(fn["rk_step"](p, code, h, q, w, qn, wn, work))

    def jvp() -> int:
        return int(fn["step_jvp"](p, opt, code, h, q, w, dq, dw, qn, wn, dqn, dwn, jwork))

    assert step() == 0 and jvp() == 0, (s.name, name)
    return step, jvp


def _batch(call: Callable[[], int], calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        call()
    return (time.perf_counter() - start) / calls


def _alternating(a: Callable[[], int], b: Callable[[], int], calls: int, repeats: int):
    """The best seconds per call of a and of b, their batches alternating."""
    ta = tb = float("inf")
    for _ in range(repeats):
        ta = min(ta, _batch(a, calls))
        tb = min(tb, _batch(b, calls))
    return ta, tb


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    args = parse_args(argv)
    print(f"# step_jvp against the step; CPU: {cpu_model()}; load {os.getloadavg()[0]:.2f}")
    print(f"{'system':14} {'flags':9} {'method':7} {'step µs':>10} {'jvp µs':>10} {'ratio':>6}")
    for n in args.n:
        system = builtin("rope", n=n, solver="structured").with_jacobians()
        h = 1e-5
        for flags in args.flags:
            be = CBackend(system, opt=flags)
            for name in args.methods:
                step, jvp = _calls(be, name, h)
                calls = args.calls or max(1, int(0.1 / max(_batch(step, 1), 1e-7)))
                ts, tj = _alternating(step, jvp, calls, args.repeats)
                print(
                    f"{'rope:n=' + str(n):14} {flags:9} {name:7} {ts * 1e6:10.1f} "
                    f"{tj * 1e6:10.1f} {tj / ts:6.2f}"
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
