"""``python benchmarks/adaptive_vi.py``: the time-transformed VI methods against the fixed-step
VI compositions, DOP853 and RK45 on close encounters (issue 26).

Input: command-line options (``--quick``, ``--cluster-T``). Output: tables on stdout, headed by
the CPU (from /proc/cpuinfo), the load average and the library versions:

1. three_bodies over T = 10: per run the gradient evaluations, the state error at T (max over
   q and omega against the C DOP853 at rtol = atol = 3e-14), the wall time and the time per
   gradient evaluation (us/grad); then, for the errors 1e-6 and 1e-8, the cheapest run of each
   method that reaches it.
2. encounter_cluster over `--cluster-T` (default 110, about 10^4 encounter times sqrt(a^3/k)):
   per run the gradient evaluations, the largest relative energy error and the fitted slope of
   the windowed maxima of |dE| against time in log-log (0: bounded, 1: linear drift).

Every method runs in the emitted C, each time the best of 5 calls. For each target the
cheapest (in time) run of ``vi8-adaptive`` and of DOP853 reaching it are then timed again
side by side, alternating call by call (the machine is shared: the ratio of the two is what
to quote, with the load printed at the start and the end).

Example:
    >>> parse_args(["--quick"]).quick
    True
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from python_step import cpu_model

import s2gen
from s2gen.runtime.options import Options
from s2gen.systems import builtin

__all__ = ["cpu_model", "main", "parse_args", "slope"]

#: Alternating calls per method when two runs are timed side by side.
ROUNDS = 15


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The options: ``--quick`` (fewer runs, a shorter cluster run), ``--cluster-T``."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="fewer runs, cluster T = 11")
    p.add_argument("--cluster-T", type=float, default=None, help="cluster run length (110)")
    return p.parse_args(argv)


def slope(times: np.ndarray, de: np.ndarray, windows: int = 10) -> float:
    """Fitted slope of log(max |dE| per window) against log(window end time).

    Example:
        >>> t = np.linspace(0.0, 10.0, 1001)
        >>> round(slope(t, 1e-6 * t), 2), abs(round(slope(t, 1e-6 * (1 + 0 * t)), 2))
        (1.0, 0.0)
    """
    parts = np.array_split(np.arange(1, len(times)), windows)
    ends = np.array([times[p[-1]] for p in parts])
    peaks = np.array([np.abs(de[p]).max() for p in parts])
    return float(np.polyfit(np.log(ends), np.log(np.maximum(peaks, 1e-300)), 1)[0])


def _best(run: Callable[..., Any], *args: Any, **kwargs: Any) -> tuple[Any, float]:
    """run(*args, **kwargs) and its best wall time of 5 calls (C runs take milliseconds)."""
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        out = run(*args, **kwargs)
        times.append(time.perf_counter() - t0)
    return out, min(times)


def _row(name: str, setting: str, evals: int, value: float, seconds: float, extra: str) -> None:
    per = seconds / evals * 1e6
    print(
        f"  {name:14s} {setting:>12s} {evals:>10,d} {value:10.2e} {seconds * 1e3:10.3f} "
        f"{per:8.4f} {extra}"
    )


def three_bodies(quick: bool) -> None:
    """Part 1 (see the module docstring)."""
    s = builtin("three_bodies")
    model, T = s2gen.Model(s), 10.0
    truth = model.integrate("dop853", h=T, T=T, options=Options(rtol=3e-14, atol=3e-14))

    def err(q: np.ndarray, w: np.ndarray) -> float:
        return float(max(np.abs(q - truth.q[-1]).max(), np.abs(w - truth.omega[-1]).max()))

    print(f"three_bodies, T = {T:g}: state error at T against DOP853 at 3e-14")
    print(
        f"  {'method':14s} {'setting':>12s} {'gradients':>10s} {'error':>10s} {'time ms':>10s} "
        f"{'us/grad':>8s}"
    )
    rows: list[tuple[str, int, float, float]] = []
    for name in ("vi4", "vi6", "vi8"):
        for h in (2e-3, 1e-3) if quick else (4e-3, 2e-3, 1e-3, 5e-4):
            tr, sec = _best(model.integrate, name, h=h, T=T, every=round(T / h), energy=False)
            evals = int(tr.stats["gradient_evals"])
            rows.append((name, evals, err(tr.q[-1], tr.omega[-1]), sec))
            _row(name, f"h={h:g}", evals, rows[-1][2], sec, "")
    for name in ("dop853", "rk45"):
        for tol in (1e-7, 1e-9, 1e-11) if quick else (1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
            opts = Options(rtol=tol, atol=tol)
            tr, sec = _best(model.integrate, name, h=T, T=T, options=opts, energy=False)
            evals = int(tr.stats["gradient_evals"])
            rows.append((name, evals, err(tr.q[-1], tr.omega[-1]), sec))
            _row(name, f"tol={tol:g}", evals, rows[-1][2], sec, "")
    settings: dict[tuple[str, str], dict[str, Any]] = {}
    for base in ("vi4", "vi6", "vi8"):
        name = f"{base}-adaptive"
        for eps in (0.1, 0.05) if quick else (0.25, 0.2, 0.125, 0.1, 0.05):
            n = round(T / eps)  # each eps divides T: the last sample is at T
            kw = {"h": eps, "T": T, "every": n, "energy": False}
            tr, sec = _best(model.integrate, name, **kw)
            evals = int(tr.stats["gradient_evals"])
            rows.append((name, evals, err(tr.q[-1], tr.omega[-1]), sec))
            settings[(name, f"{evals}")] = kw
            _row(name, f"eps={eps:g}", evals, rows[-1][2], sec, f"steps {tr.stats['steps']:,d}")
    for target in (1e-6, 1e-8):
        print(f"  cheapest run reaching {target:g} (gradients; best time):")
        fastest: dict[str, tuple[str, int, float, float]] = {}
        for name in dict.fromkeys(r[0] for r in rows):
            ok = [r for r in rows if r[0] == name and r[2] <= target]
            if ok:
                best = min(ok, key=lambda r: r[1])
                fastest[name] = min(ok, key=lambda r: r[3])
                print(f"    {name:14s} {best[1]:>10,d} {best[3] * 1e3:10.3f} ms")
            else:
                print(f"    {name:14s}    (none)")
        if "dop853" in fastest and "vi8-adaptive" in fastest:
            _side_by_side(model, T, fastest["dop853"], fastest["vi8-adaptive"], settings)


def _side_by_side(
    model: s2gen.Model,
    T: float,
    dop: tuple[str, int, float, float],
    tt: tuple[str, int, float, float],
    settings: dict[tuple[str, str], dict[str, Any]],
) -> None:
    """The two runs timed alternately, `ROUNDS` calls each; the ratio of their best times."""
    tol = next(t for t in (1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12) if _evals(model, T, t) == dop[1])
    dop_kw = {"h": T, "T": T, "options": Options(rtol=tol, atol=tol), "energy": False}
    tt_kw = settings[(tt[0], f"{tt[1]}")]
    best = {"dop853": np.inf, tt[0]: np.inf}
    for _ in range(ROUNDS):
        for name, kw in (("dop853", dop_kw), (tt[0], tt_kw)):
            t0 = time.perf_counter()
            model.integrate(name, **kw)
            best[name] = min(best[name], time.perf_counter() - t0)
    print(
        f"    side by side ({ROUNDS} alternating calls each, best): dop853 tol={tol:g} "
        f"{best['dop853'] * 1e3:.3f} ms, {tt[0]} {best[tt[0]] * 1e3:.3f} ms: "
        f"ratio {best[tt[0]] / best['dop853']:.2f}"
    )


def _evals(model: s2gen.Model, T: float, tol: float) -> int:
    """DOP853's gradient evaluations at rtol = atol = tol."""
    opts = Options(rtol=tol, atol=tol)
    return int(
        model.integrate("dop853", h=T, T=T, options=opts, energy=False).stats["gradient_evals"]
    )


def cluster(T: float, quick: bool) -> None:
    """Part 2 (see the module docstring)."""
    s = builtin("encounter_cluster")
    model = s2gen.Model(s)
    a, k = s.parameters["a"], s.parameters["k"]
    print(f"encounter_cluster, T = {T:g} ({T / np.sqrt(a**3 / k):,.0f} encounter times):")
    print(
        f"  {'method':14s} {'setting':>12s} {'gradients':>10s} {'max dE/E':>10s} {'time ms':>10s} "
        f"{'us/grad':>8s}"
    )
    every = 0.01
    for tol in (1e-8, 1e-10) if quick else (1e-8, 1e-10, 1e-12):
        t0 = time.perf_counter()
        tr = model.integrate("dop853", h=every, T=T, options=Options(rtol=tol, atol=tol))
        sec = time.perf_counter() - t0
        assert tr.energy is not None
        de = (tr.energy - tr.energy[0]) / abs(tr.energy[0])
        extra = f"slope {slope(tr.t, de):.2f}"
        _row(
            "dop853", f"tol={tol:g}", int(tr.stats["gradient_evals"]), np.abs(de).max(), sec, extra
        )
    model.integrate("vi-adaptive", h=0.1, T=0.1)  # the backend checks the monitor once: not timed
    for name, eps in (("vi4-adaptive", 0.2), ("vi4-adaptive", 0.1), ("vi8-adaptive", 0.2)):
        if quick and eps < 0.2:
            continue
        spacing = round(every / eps * 100) or 1
        n = round(T / eps / spacing) * spacing
        t0 = time.perf_counter()
        tr = model.integrate(name, h=eps, T=n * eps, every=spacing)
        sec = time.perf_counter() - t0
        assert tr.energy is not None
        de = (tr.energy - tr.energy[0]) / abs(tr.energy[0])
        extra = f"slope {slope(tr.t, de):.2f}, steps {tr.stats['steps']:,d}"
        _row(name, f"eps={eps:g}", int(tr.stats["gradient_evals"]), np.abs(de).max(), sec, extra)


def main(argv: Sequence[str] | None = None) -> int:
    """Run both parts and print their tables."""
    args = parse_args(argv)
    print(
        f"CPU: {cpu_model()}; load {os.getloadavg()[0]:.2f}; s2gen {s2gen.__version__}, "
        f"NumPy {np.__version__}, Python {platform.python_version()}"
    )
    three_bodies(args.quick)
    T = args.cluster_T if args.cluster_T is not None else (11.0 if args.quick else 110.0)
    cluster(T, args.quick)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
