"""``python benchmarks/python_step.py``: what a step called from Python costs beyond the C step.

Input: command-line options (``--systems``, ``--method``, ``--h``, ``--steps``, ``--calls``,
``--repeats``). Output: a table on stdout per system: the C step's own time (one
``NAME_integrate`` call of `steps` steps, per step), and the time per call of each Python
path with its overhead over that C step: `Model.stepper(...).advance()` (one C call),
`Model.step` on the C backend (each call from the state the last one returned), the same two
on the NumPy backend, and a one-step `Model.integrate` on C (energy kept, as by default), and
without energy on C and NumPy (what `Model.step` cost before it went through the step
function). The
header names the CPU (from /proc/cpuinfo), Python and NumPy, and the load average before and
after.

Each path runs `repeats` batches; the table gives the best batch's time per call on the wall
clock (the least disturbed by other jobs, as `timeit` reports), the median batch's, and the
median batch's in the process's CPU time (which leaves out the time other jobs hold the core:
on a busy machine the steadier figure), and the overhead of the best and of the CPU figure
over the C step's figure of the same kind. Before timing, the stepper's and
`Model.step`'s states after `calls` steps are compared with `integrate`'s: exit status 1 if
they differ in any bit (then the paths do not take the same steps and their times are not
comparable).

Example:
    >>> parse_args(["--systems", "double_pendulum", "--calls", "100"]).calls
    100
"""

from __future__ import annotations

import argparse
import ctypes
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

import s2gen
from s2gen.methods import method as method_record

__all__ = ["Row", "cpu_model", "main", "measure", "parse_args"]


@dataclass(frozen=True)
class Row:
    """One path of one system: seconds per call, of the best and of the median batch on the
    wall clock, and of the median batch in the process's CPU time."""

    system: str
    path: str
    best: float
    median: float
    cpu: float


def cpu_model() -> str:
    """The processor's name from /proc/cpuinfo, else what the platform says.

    Example:
        >>> isinstance(cpu_model(), str)
        True
    """
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _per_call(batch: Callable[[], None], calls: int, repeats: int) -> tuple[float, float, float]:
    """Seconds per call of `repeats` batches of `calls`: the best and the median batch on the
    wall clock, the median batch in CPU time."""
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        batch()
        cpu.append((time.process_time() - start_cpu) / calls)
        wall.append((time.perf_counter() - start) / calls)
    return min(wall), statistics.median(wall), statistics.median(cpu)


def _c_step_seconds(
    model: s2gen.Model, name: str, h: float, steps: int, repeats: int
) -> tuple[float, float, float]:
    """One emitted integrate() call of `steps` steps (no energy), per step."""
    be = model._backend  # the emitted C behind the model, called as a C program would
    lib, system = be.library, model.system
    q = np.zeros((steps + 1) * 3 * system.n)
    w = np.zeros_like(q)
    opt = lib.options(s2gen.Options())
    p, q0, w0 = model.params(), system.q0.ravel().copy(), system.omega0.ravel().copy()
    code = method_record(name).code

    def batch() -> None:
        status = lib.fn["integrate"](
            p, ctypes.byref(opt), code, h, steps, q0, w0, q, w, None, be.work, None
        )
        assert status == 0

    return _per_call(batch, steps, repeats)


def _same_steps(model: s2gen.Model, name: str, h: float, calls: int) -> bool:
    """The stepper and Model.step end where integrate() ends, bit for bit."""
    system = model.system
    tr = model.integrate(name, h, calls * h, energy=False)
    stepper = model.stepper(name, h)
    q, w = system.q0, system.omega0
    for _ in range(calls):
        stepper.advance()
        q, w = model.step(q, w, h, name)
    ends = ((stepper.q, stepper.omega), (q, w))
    return all(np.array_equal(a, tr.q[-1]) and np.array_equal(b, tr.omega[-1]) for a, b in ends)


def measure(
    system_name: str, name: str, h: float, steps: int, calls: int, repeats: int
) -> list[Row]:
    """The rows of one system (see the module docstring); SystemExit(1) if the paths do not
    take integrate()'s steps.

    Example:
        >>> rows = measure("double_pendulum", "vi", 0.01, 200, 20, 1)
        >>> [r.path for r in rows][:2]
        ['C step (integrate loop)', 'Model.stepper advance()']
    """
    system = s2gen.load(system_name)
    model = s2gen.compile(system)
    numpy_model = s2gen.compile(system, "numpy")
    if not _same_steps(model, name, h, calls):
        print(f"{system_name}: the Python paths do not reproduce integrate()", file=sys.stderr)
        raise SystemExit(1)
    stepper, numpy_stepper = model.stepper(name, h), numpy_model.stepper(name, h)

    def advance() -> None:
        for _ in range(calls):
            stepper.advance()

    def numpy_advance() -> None:
        for _ in range(few):
            numpy_stepper.advance()

    def model_step(m: s2gen.Model, n: int) -> Callable[[], None]:
        state = [system.q0, system.omega0]  # each call from the state the last returned

        def batch() -> None:
            q, w = state
            for _ in range(n):
                q, w = m.step(q, w, h, name)
            state[:] = [q, w]

        return batch

    def integrate_one() -> None:
        for _ in range(few):
            model.integrate(name, h, h)

    def integrate_one_bare(m: s2gen.Model) -> Callable[[], None]:
        def batch() -> None:
            for _ in range(few):
                m.integrate(name, h, h, energy=False)

        return batch

    few = max(1, calls // 50)  # the slow paths: fewer calls per batch
    return [
        Row(system_name, "C step (integrate loop)", *_c_step_seconds(model, name, h, steps, repeats)),
        Row(system_name, "Model.stepper advance()", *_per_call(advance, calls, repeats)),
        Row(system_name, "Model.step (C)", *_per_call(model_step(model, calls), calls, repeats)),
        Row(system_name, "Model.stepper advance() (NumPy)", *_per_call(numpy_advance, few, repeats)),
        Row(system_name, "Model.step (NumPy)", *_per_call(model_step(numpy_model, few), few, repeats)),
        Row(system_name, "one-step integrate (C)", *_per_call(integrate_one, few, repeats)),
        Row(system_name, "  no energy: the former Model.step", *_per_call(integrate_one_bare(model), few, repeats)),
        Row(system_name, "  the same on NumPy", *_per_call(integrate_one_bare(numpy_model), few, repeats)),
    ]  # fmt: skip


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--systems", nargs="+", default=["double_pendulum", "four_pendula"])
    ap.add_argument("--method", default="vi", help="a fixed-step method (default vi)")
    ap.add_argument("--h", type=float, default=0.01, help="step size (default 0.01)")
    ap.add_argument("--steps", type=int, default=200_000, help="steps of the C loop")
    ap.add_argument("--calls", type=int, default=20_000, help="calls per batch of a fast path")
    ap.add_argument("--repeats", type=int, default=7, help="batches per figure")
    return ap.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table; 0, or 1 when a path does not take integrate()'s steps."""
    args = parse_args(argv)
    print(f"CPU: {cpu_model()}; Python {platform.python_version()}, NumPy {np.__version__}")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"method {args.method}, h = {args.h:g}; {args.repeats} batches per figure")
    for system_name in args.systems:
        rows = measure(system_name, args.method, args.h, args.steps, args.calls, args.repeats)
        c = rows[0]
        print(f"\n{system_name}: microseconds per call, and beyond the C step (+)")
        heads = ("best", "median", "cpu", "+best", "+cpu")
        print(f"  {'path':34s}" + "".join(f" {x:>9s}" for x in heads))
        for r in rows:
            extra = (r.best - c.best, r.cpu - c.cpu) if r is not c else ()
            cells = "".join(f" {x * 1e6:9.2f}" for x in (r.best, r.median, r.cpu, *extra))
            print(f"  {r.path:34s}{cells}")
    print(f"\nload average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
