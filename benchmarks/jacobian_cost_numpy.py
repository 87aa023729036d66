"""``python benchmarks/jacobian_cost_numpy.py``: the NumPy module's step Jacobian against the C's.

Input: command-line options (``--systems``, ``--methods``, ``--h``, ``--calls``,
``--repeats``). Output: a table on stdout: per system and method, the time per call of the
emitted NumPy ``step_jacobian`` and of the C's ``NAME_step_jacobian`` (both through
`s2gen.runtime.linearize.step_jacobian`, so both carry the same Python wrapper: the
embedding A, B and P from the system's initial state), measured side by side (a batch of one,
then a batch of the other, `repeats` times, the best batch of each), and their ratio. The
header names the CPU (from /proc/cpuinfo), the load average and the BLAS threads the
environment asks for (OPENBLAS_NUM_THREADS: a threaded BLAS on a loaded machine makes NumPy's
solves of n = 16 ten times slower). Numbers only: no test times them.

Example:
    >>> parse_args(["--systems", "double_pendulum", "--calls", "3"]).calls
    3
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numpy as np
from python_step import cpu_model

import s2gen
from s2gen.runtime.c import CBackend
from s2gen.runtime.linearize import step_jacobian
from s2gen.runtime.numpy_module import NumpyBackend
from s2gen.runtime.options import Options


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--systems",
        nargs="+",
        default=["double_pendulum", "four_pendula", "tests/specs/driven_double.toml", "dipoles"],
    )
    ap.add_argument("--methods", nargs="+", default=["vi", "rk4"])
    ap.add_argument("--h", type=float, default=0.001)
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    return ap.parse_args(argv)


def _call(backend: object, name: str, h: float) -> Callable[[], object]:
    s = backend.system  # type: ignore[attr-defined]
    p = np.asarray(s.parameter_values, dtype=float)
    q, w, opts = np.asarray(s.q0, float), np.asarray(s.omega0, float), Options()

    def call() -> object:
        return step_jacobian(backend, name, 0.0, h, q, w, None, p, opts)

    return call


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    args = parse_args(argv)
    load = os.getloadavg()[0]
    blas = os.environ.get("OPENBLAS_NUM_THREADS", "unset")
    print(f"# NumPy step_jacobian against C; CPU: {cpu_model()}; load {load:.1f}; h = {args.h}")
    print(f"# OPENBLAS_NUM_THREADS={blas}")
    print(f"{'system':32} {'n':>3} {'method':7} {'C ms':>9} {'NumPy ms':>9} {'ratio':>7}")
    for spec in args.systems:
        system = s2gen.load(spec).with_jacobians()
        c_be, py_be = CBackend(system), NumpyBackend(system)
        for name in args.methods:
            calls = (_call(c_be, name, args.h), _call(py_be, name, args.h))
            best = [float("inf"), float("inf")]
            for _ in range(args.repeats):
                for k, call in enumerate(calls):
                    start = time.perf_counter()
                    for _ in range(args.calls):
                        call()
                    best[k] = min(best[k], (time.perf_counter() - start) / args.calls)
            print(
                f"{spec:32} {system.n:3} {name:7} {best[0] * 1e3:9.3f} {best[1] * 1e3:9.3f} "
                f"{best[1] / best[0]:7.1f}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
