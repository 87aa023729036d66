"""NumPy's integrate_batch() against NumPy's integrate() in a loop and against the C batch.

For each system, method and K: K members (each with its own parameters and initial state)
through `Model(system, "numpy").integrate_batch` in one call, the same members through
`Model(system, "numpy").integrate` one call each (the first `--loop` of them: a loop's rate
per member does not depend on K), and through the C backend's `integrate_batch`, alternating
the three paths `--repeats` times in one run. Before timing, the loop's members' final
states are compared with the NumPy batch's bit for bit (exit status 1 if any differs). Prints
member-steps per second of each path (best round on the wall clock, and the median round's
in process CPU time, steadier on a shared machine), the batch's ratio to the loop and the C
batch's ratio to NumPy's, with the CPU model and the load average before and after.

    python benchmarks/batch_numpy.py [--systems four_pendula double_pendulum]
        [--methods vi rk4] [--members 64 512] [--steps 50] [--loop 16] [--repeats 3]

Example:
    >>> parse_args(["--members", "8"]).members
    [8]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from s2gen.runtime.model import Model
from s2gen.systems import builtin

H = 0.01


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line's options."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--systems", nargs="+", default=["four_pendula", "double_pendulum"])
    ap.add_argument("--methods", nargs="+", default=["vi", "rk4"])
    ap.add_argument("--members", nargs="+", type=int, default=[64, 512])
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--loop", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=3)
    return ap.parse_args(argv)


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo (or the platform's processor)."""
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or "unknown"


def members(name: str, K: int) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """K perturbed copies of the spec's state and parameters."""
    s = builtin(name)
    rng = np.random.default_rng(5)
    q0 = s.q0[None] + 1e-2 * rng.standard_normal((K, s.n, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = s.omega0[None] + 0.1 * rng.standard_normal((K, s.n, 3))
    w0 -= np.sum(w0 * q0, axis=2, keepdims=True) * q0
    factor = 1 + 0.1 * rng.random((K, len(s.parameter_names)))
    params = {n: v * factor[:, j] for j, (n, v) in enumerate(s.parameters.items())}
    return q0, w0, params


def timed(run: Callable[[], object]) -> tuple[float, float]:
    """(wall, process CPU) seconds of one call of run."""
    w, c = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - w, time.process_time() - c


def measure(name: str, meth: str, K: int, a: argparse.Namespace) -> int:
    """Time the three paths for one system, method and K; print a row. 1 if the loop's and
    the batch's final states differ, else 0."""
    T = a.steps * H
    q0, w0, params = members(name, K)
    np_model, c_model = Model(builtin(name), "numpy"), Model(builtin(name))
    L = min(a.loop, K)

    def batch() -> object:
        return np_model.integrate_batch(
            meth, h=H, T=T, q0=q0, omega0=w0, params=params, every=a.steps, energy=False
        )

    def loop() -> object:
        return [
            np_model.integrate(
                meth,
                h=H,
                T=T,
                q0=q0[k],
                omega0=w0[k],
                params={n: float(v[k]) for n, v in params.items()},
                every=a.steps,
                energy=False,
            ).q[-1]
            for k in range(L)
        ]

    def c_batch() -> object:
        return c_model.integrate_batch(
            meth, h=H, T=T, q0=q0, omega0=w0, params=params, every=a.steps, energy=False
        )

    b, ends = batch(), loop()
    c_batch()
    if not all(np.array_equal(b.q[k, -1], e) for k, e in enumerate(ends)):  # type: ignore[attr-defined]
        print(f"{name} {meth}: the batch's final states differ from integrate()'s")
        return 1
    rounds: dict[str, list[tuple[float, float]]] = {"batch": [], "loop": [], "c": []}
    for _ in range(a.repeats):
        rounds["batch"].append(timed(batch))
        rounds["loop"].append(timed(loop))
        rounds["c"].append(timed(c_batch))
    work = {"batch": K * a.steps, "loop": L * a.steps, "c": K * a.steps}
    best = {p: work[p] / min(r[0] for r in rs) for p, rs in rounds.items()}
    cpu = {p: work[p] / statistics.median(r[1] for r in rs) for p, rs in rounds.items()}
    print(
        f"{name:16s} {meth:5s} {K:5d}  {best['loop']:10.3g} {best['batch']:10.3g} "
        f"{best['c']:10.3g}  {best['batch'] / best['loop']:7.1f}x ({cpu['batch'] / cpu['loop']:.1f}x cpu)"
        f"  {best['c'] / best['batch']:7.1f}x ({cpu['c'] / cpu['batch']:.1f}x cpu)"
    )
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    a = parse_args(argv)
    print(
        f"CPU: {cpu_model()}, {os.cpu_count()} cores; Python {platform.python_version()}, NumPy {np.__version__}"
    )
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(
        f"{a.steps} steps of h = {H}; loop: the first {a.loop} members; best of {a.repeats} rounds"
    )
    print(
        f"{'system':16s} {'meth':5s} {'K':>5s}  {'loop':>10s} {'np batch':>10s} {'C batch':>10s}"
        f"  {'batch/loop':>18s}  {'C/np batch':>18s}   (member-steps/s)"
    )
    bad = 0
    for name in a.systems:
        for meth in a.methods:
            for K in a.members:
                try:
                    bad |= measure(name, meth, K, a)
                except ValueError as e:
                    print(f"{name:16s} {meth:5s} {K:5d}  refused: {e}")
                    break
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return bad


if __name__ == "__main__":
    sys.exit(main())
