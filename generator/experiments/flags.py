"""Which gcc flags the cached library should use: time per step of the emitted C per flag set.

Run: ``python -m s2gen.experiments.flags [--launches N] [--systems a,b,...]``. For each system
(default: the four built-ins with hand-written equivalents: double_pendulum, elastic_rod,
dipoles, molecular) the emitted C is built with each candidate flag set and integrated with the
VI (no energy), the sets alternating within each round so that machine noise hits them alike;
prints the median time per step per set and its ratio to plain -O2.

Example:
    >>> sorted(CANDIDATES)[:2]
    ['O2', 'O2 simd']
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Sequence
from typing import Any

import s2gen
from s2gen import Options
from s2gen.inspect import c_backend

__all__ = ["CANDIDATES", "main", "measure"]

_BASE = ("-std=c99", "-fPIC", "-shared")
_SIMD = ("-fno-math-errno", "-fopenmp-simd")
#: The flag sets compared (the first is the baseline of the ratios).
CANDIDATES: dict[str, tuple[str, ...]] = {
    "O2": (*_BASE, "-O2"),
    "O2 simd": (*_BASE, "-O2", *_SIMD),
    "O3 simd": (*_BASE, "-O3", *_SIMD),
    "O3 native simd": (*_BASE, "-O3", "-march=native", *_SIMD),
    # s2gen's "native" set: gcc's SLP vectoriser off, as it fuses multiply-adds (build.py)
    "O3 native simd no-SLP": (*_BASE, "-O3", "-march=native", "-fno-tree-slp-vectorize", *_SIMD),
}
#: (system, h, steps per launch) as the hand-written yardsticks run them.
RUNS = {
    "double_pendulum": (0.01, 10000),
    "elastic_rod": (1e-4, 3000),
    "dipoles": (1e-3, 10000),
    "molecular": (0.005, 100),
}


def _seconds_per_step(backend: Any, h: float, steps: int) -> float:
    system = backend.system
    start = time.perf_counter()
    status, *_ = backend.integrate(
        "vi",
        h,
        steps,
        system.q0,
        system.omega0,
        backend.default_params(),
        Options(),
        with_energy=False,
    )
    if status:
        raise RuntimeError(f"{system.name}: status {status}")
    return (time.perf_counter() - start) / steps


def measure(name: str, launches: int) -> dict[str, float]:
    """Median seconds per step of `name`'s VI for each candidate flag set."""
    system = s2gen.load(name)
    h, steps = RUNS[name]
    backends = {label: c_backend(system, flags) for label, flags in CANDIDATES.items()}
    times: dict[str, list[float]] = {label: [] for label in CANDIDATES}
    for _ in range(launches):
        for label, backend in backends.items():
            times[label].append(_seconds_per_step(backend, h, steps))
    return {label: statistics.median(t) for label, t in times.items()}


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m s2gen.experiments.flags", description=__doc__)
    ap.add_argument("--launches", type=int, default=5)
    ap.add_argument("--systems", default=",".join(RUNS))
    args = ap.parse_args(argv)
    labels = list(CANDIDATES)
    print("| system | " + " | ".join(f"{lab} (µs/step)" for lab in labels) + " |")
    print("|---|" + "---:|" * len(labels))
    for name in args.systems.split(","):
        t = measure(name, args.launches)
        base = t[labels[0]]
        cells = [f"{t[lab] * 1e6:.3g} ({t[lab] / base:.2f})" for lab in labels]
        print(f"| {name} | " + " | ".join(cells) + " |")
    print(f"\nmedians of {args.launches} alternating launches; in brackets: ratio to {labels[0]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
