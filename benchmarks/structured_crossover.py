"""``python benchmarks/structured_crossover.py``: structured against dense solves, by chain size.

Input: command-line options (``--systems``, ``--n``, ``--flags``, ``--steps``,
``--repeats``). Output: a table on stdout: per chain (``rope``: point masses, max-index M
with a zero diagonal remainder; ``rod``: the paper's elastic rod), number of bodies n and flag
set (``portable``: -O2; ``native``: -O3 -march=native; see `s2gen.build.FLAG_SETS`), the
process's CPU time per VI step with ``[inertia] solver = "structured"`` (the max-index
solves: block elimination body by body, the band as fallback) and with ``"dense"`` (LU of the
3n x 3n Newton matrix), their ratio, and the solver "auto" picks for that n
(`s2gen.equations.structure.choose_solver`). Each run is one ``integrate`` call of `steps`
steps from the system's initial state; structured and dense runs alternate and the table gives
the median of `repeats`. The header names the CPU (from /proc/cpuinfo) and the load average.
Numbers only: no test times them.

Example:
    >>> parse_args(["--n", "6", "7"]).n
    [6, 7]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable

import numpy as np
from python_step import cpu_model

from s2gen.equations.structure import choose_solver
from s2gen.runtime.c import CBackend
from s2gen.runtime.options import Options
from s2gen.system import System
from s2gen.systems.chains import rope
from s2gen.systems.paper import elastic_rod

SYSTEMS: dict[str, Callable[[int, str], System]] = {
    "rope": lambda n, solver: rope(n, solver=solver),
    "rod": lambda n, solver: elastic_rod(n, "paper", solver=solver),
}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--systems", nargs="+", default=sorted(SYSTEMS), choices=sorted(SYSTEMS))
    ap.add_argument("--n", nargs="+", type=int, default=[4, 5, 6, 7, 8, 10])
    ap.add_argument("--flags", nargs="+", default=["portable", "native"])
    ap.add_argument("--steps", type=int, default=0, help="steps per run (0: 40000 / n)")
    ap.add_argument("--repeats", type=int, default=5)
    return ap.parse_args(argv)


def vi_cpu_per_step(be: CBackend, steps: int, h: float | None = None) -> float:
    """CPU time per VI step (µs) of one integrate call from the system's initial state, with
    step `h` (default its [run] h, else 1e-3)."""
    s = be.system
    h = h or s.run.h or 1e-3
    p = np.asarray(s.parameter_values, dtype=float)
    t = time.process_time()
    status, *_ = be.integrate("vi", h, steps, s.q0, s.omega0, p, Options(), steps, False)
    if status != 0:
        raise RuntimeError(f"{s.name}: integrate failed with status {status}")
    return (time.process_time() - t) / steps * 1e6


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    print(f"cpu: {cpu_model()}; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("| system | n | flags | structured µs/step | dense µs/step | structured/dense | auto |")
    print("|---|---:|---|---:|---:|---:|---|")
    for name in args.systems:
        for n in args.n:
            make = SYSTEMS[name]
            auto = choose_solver(make(n, "auto")).value
            steps = args.steps or max(2000, 40000 // n)
            for flags in args.flags:
                backs = [CBackend(make(n, solver), opt=flags) for solver in ("structured", "dense")]
                times: list[list[float]] = [[], []]
                for _ in range(args.repeats):
                    for k, be in enumerate(backs):
                        times[k].append(vi_cpu_per_step(be, steps))
                a, b = (statistics.median(t) for t in times)
                print(f"| {name} | {n} | {flags} | {a:.2f} | {b:.2f} | {a / b:.2f} | {auto} |")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} after")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
