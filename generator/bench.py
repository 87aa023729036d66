"""`s2gen bench`: work-precision, long-time, stability and scaling measurements, with reports.

Input: example names (built-in systems; default ``double_pendulum three_bodies``), an output
folder and switches (`--quick`, `--long`, `--stability`, `--scaling`). Output, in the folder:
``bench.csv`` (one row per run of the work-precision sweeps), ``per_step.csv``, ``bench.md``
(tables and generated findings; every number comes from this run), ``wp_<example>.png``
(work-precision, log-log) and, with the switches, ``long.csv``/``long_<example>.png``,
``stability.csv``/``stability.png``, ``scaling.csv``/``scaling.png``. Progress lines go to
stdout as the work goes on.

Our methods all run on the same emitted C (`runtime.simulate`, backend "c"): the VI ("vi"), its
4th-order Yoshida composition ("vi4"), RATTLE, RK2, RK2 with renormalization, RK4 and RK45
under both error controls. Outside peers (`peers.py`) run in the same process: scipy's
`solve_ivp` (RK45, DOP853) on the emitted NumPy right-hand side, and PyDy (double pendulum).

Definitions (repeated in bench.md):
- state error: the 2-norm of (q, omega)(T) - (q, omega)_ref(T) over all 6n components, the
  reference being our C RK45 (Hairer control, rtol = atol = 1e-13), cross-checked against vi4
  at two small steps (the smaller discrepancy is the reference's stated accuracy);
- energy error: max |E - E0| over every step (fixed-step methods) or over T/200-spaced
  samples (adaptive methods and peers), also divided by the largest kinetic energy along the
  reference ("relative");
- cost: best-of-k wall time of the integration call only, and gradient evaluations (for the
  peers: right-hand-side evaluations, each one gradient).

Example:
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:  # doctest: +SKIP
    ...     report = bench(["double_pendulum"], d, quick=True)
    ...     sorted(p.name for p in report.files)[:2]
    ['bench.csv', 'bench.md']
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import math
import os
import platform
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from . import peers
from .runtime import IntegrationError, Options, Trajectory, get_backend, simulate
from .system import SpecError, System

__all__ = [
    "DEFAULT_EXAMPLES",
    "FIXED",
    "BenchReport",
    "LongSeries",
    "WPRow",
    "add_parser",
    "bench",
    "cheapest",
    "crossover",
    "example_system",
    "findings",
    "fitted_orders",
    "largest_stable",
    "long_time",
    "md_system",
    "per_step_times",
    "run",
    "scaling",
    "stability",
    "stability_cases",
    "work_precision",
]

DEFAULT_EXAMPLES = ("double_pendulum", "three_bodies")
FIXED = ("vi", "vi4", "rattle", "rk4", "rk2", "rk2-proj")
VI_FAMILY = ("vi", "vi4")
#: Published figures for n = 20 (quoted, not measured here).
PUBLISHED_N20 = (
    ("PyDy", "about 33 s to generate and compile"),
    ("CasADi", "about 28 s of gcc"),
)
#: Horizons (full, quick) of the work-precision sweeps, chosen so the reference is trustworthy.
HORIZONS = {"double_pendulum": (10.0, 2.0), "three_bodies": (2.0, 1.0)}
ORDERS = {"vi": 2.0, "vi4": 4.0, "rattle": 2.0, "rk4": 4.0, "rk2": 2.0, "rk2-proj": 2.0}
#: Gradient evaluations per step of the fixed-step methods.
EVALS_PER_STEP = {"vi": 1, "vi4": 3, "rattle": 1, "rk4": 4, "rk2": 2, "rk2-proj": 2}
REF_RTOL = 1e-13
SAMPLES = 200

Log = Callable[[str], None]


def _print(line: str) -> None:
    print(line, flush=True)


# ------------------------------------------------------------------------------------ helpers
def example_system(name: str) -> System:
    """A built-in system by name, else a factory of `s2gen.paper_systems` of that name.

    Example:
        >>> example_system("double_pendulum").n
        2
    """
    from .systems import builtin, builtin_names

    if name in builtin_names():
        return builtin(name)
    from . import paper_systems

    factory = getattr(paper_systems, name, None)
    if name in getattr(paper_systems, "__all__", ()) and callable(factory):
        system = factory()
        if isinstance(system, System):
            return system
    raise SpecError(f"unknown example {name!r}; built-ins are: {', '.join(builtin_names())}")


def _best_wall(run: Callable[[], Trajectory], k: int) -> Trajectory:
    """Run up to k times (fewer when a run is slow); the result carries the best wall time."""
    best = run()
    total = best.wall_time
    for _ in range(k - 1):
        if total > 2.0:
            break
        tr = run()
        total += tr.wall_time
        if tr.wall_time < best.wall_time:
            best = tr
    return best


def _state(tr: Trajectory) -> np.ndarray:
    return np.concatenate([tr.q[-1].ravel(), tr.omega[-1].ravel()])


def _err(q: np.ndarray, w: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(np.concatenate([q.ravel(), w.ravel()]) - ref))


def kinetic_energy(system: System, q: np.ndarray, w: np.ndarray, params: Any = None) -> np.ndarray:
    """1/2 sum_ij M_ij qdot_i . qdot_j with qdot_i = omega_i x q_i, for (..., n, 3) arrays.

    Example:
        >>> s = example_system("double_pendulum")
        >>> float(kinetic_energy(s, s.q0, s.omega0)) > 0
        True
    """
    M = system.inertia_numeric(params)
    qdot = np.cross(w, q)
    return 0.5 * np.einsum("ij,...ic,...jc->...", M, qdot, qdot)


def _fmt(x: float | None, spec: str = ".3g") -> str:
    if x is None or not np.isfinite(x):
        return "—"
    return format(x, spec)


def _times(ratio: float | None) -> str:
    return _fmt(ratio, ".0f") + "×" if ratio is not None and np.isfinite(ratio) else "—"


def _ms(seconds: float) -> str:
    return _fmt(seconds * 1e3, ".3g") + " ms"


# ---------------------------------------------------------------------------- work-precision
@dataclass
class WPRow:
    """One run of a work-precision sweep."""

    example: str
    method: str
    family: str
    h: float
    rtol: float
    T: float
    steps: int
    evals: int
    newton_per_step: float
    wall: float
    state_err: float
    max_dE: float
    rel_dE: float
    status: str = "ok"

    @property
    def setting(self) -> str:
        """The swept setting as text: h for fixed-step methods, else the tolerance."""
        return f"h={self.h:.4g}" if self.method in FIXED else f"tol={self.rtol:.0e}"

    @property
    def ok(self) -> bool:
        """Finished, with a finite error below 1."""
        return self.status == "ok" and np.isfinite(self.state_err) and self.state_err < 1.0


@dataclass
class Reference:
    """The converged solution of one example and how well it is known."""

    system: System
    T: float
    state: np.ndarray
    accuracy: float
    kinetic_scale: float
    energy0: float
    wall: float


@dataclass
class ExampleBench:
    """Everything measured on one example."""

    name: str
    system: System
    reference: Reference
    rows: list[WPRow] = field(default_factory=list)
    per_step: list[dict[str, Any]] = field(default_factory=list)
    pydy: dict[str, Any] = field(default_factory=dict)
    long: list[LongSeries] = field(default_factory=list)
    long_notes: list[str] = field(default_factory=list)
    call_overhead: float = math.nan


def reference(system: System, T: float, log: Log = _print) -> Reference:
    """C RK45 (Hairer, rtol = atol = 1e-13) cross-checked against vi4 at two small steps.

    Example:
        >>> ref = reference(example_system("double_pendulum"), 1.0, log=lambda s: None)
        >>> ref.accuracy < 1e-9
        True
    """
    opts = Options(rtol=REF_RTOL, atol=REF_RTOL, control="hairer")
    tr = simulate(system, "rk45", "c", h=T / SAMPLES, T=T, options=opts)
    state = _state(tr)
    h0 = system.run.h or T / 1000
    n_check = max(64, 2 ** math.ceil(math.log2(T / h0)) * 8)
    gaps = []
    for n in (n_check, 2 * n_check):
        chk = simulate(system, "vi4", "c", h=T / n, T=T)
        gaps.append(float(np.linalg.norm(_state(chk) - state)))
    acc = min(gaps)
    kin = float(np.max(kinetic_energy(system, tr.q, tr.omega)))
    log(
        f"  reference: rk45 (hairer, tol {REF_RTOL:g}) over T = {T:g}: {tr.stats['steps']} steps; "
        f"vi4 at h = T/{n_check}, T/{2 * n_check} agrees to {acc:.2e}"
    )
    return Reference(system, T, state, acc, kin, float(tr.energy[0]), tr.wall_time)


def _sweep_steps(system: System, T: float, quick: bool) -> list[int]:
    """Step counts (h = T/N) from coarse to fine, doubling."""
    h0 = system.run.h or T / 1000
    n0 = max(8, 2 ** round(math.log2(T / (16 * h0))))
    return [n0 * 2**k for k in range(7 if quick else 12)]


def _our_row(
    name: str, method: str, tr: Trajectory, ref: Reference, rtol: float = float("nan")
) -> WPRow:
    steps = int(tr.stats.get("steps", len(tr.t) - 1))
    newton = tr.stats.get("newton_iters", 0) / max(steps, 1)
    dE = float(np.max(np.abs(tr.energy - tr.energy[0])))
    return WPRow(
        name,
        method,
        "s2gen",
        tr.h if method in FIXED else float("nan"),
        rtol,
        ref.T,
        steps,
        int(tr.stats.get("gradient_evals", 0)),
        newton,
        tr.wall_time,
        _err(tr.q[-1], tr.omega[-1], ref.state),
        dE,
        dE / ref.kinetic_scale,
    )


def _failed_row(name: str, method: str, family: str, h: float, rtol: float, T: float, why: str):
    nan = float("nan")
    return WPRow(name, method, family, h, rtol, T, 0, 0, nan, nan, nan, nan, nan, why)


def _fixed_sweep(
    name: str, method: str, ref: Reference, steps: Sequence[int], budget: float, k: int, log: Log
) -> list[WPRow]:
    rows: list[WPRow] = []
    for n in steps:
        h = ref.T / n
        try:
            tr = _best_wall(partial(simulate, ref.system, method, "c", h=h, T=ref.T), k)
        except IntegrationError as exc:
            rows.append(_failed_row(name, method, "s2gen", h, math.nan, ref.T, _why(exc)))
            continue
        row = _our_row(name, method, tr, ref)
        rows.append(row)
        if row.state_err < 30 * ref.accuracy or tr.wall_time > budget:
            break
    log(f"    {method:9s} {_sweep_line(rows)}")
    return rows


def _why(exc: IntegrationError) -> str:
    reasons = {1: "infeasible", 2: "newton", 3: "non-finite", 5: "step-underflow", 6: "singular"}
    return f"failed ({reasons.get(exc.status, exc.status)} at step {exc.step})"


def _sweep_line(rows: Sequence[WPRow]) -> str:
    ok = [r for r in rows if r.status == "ok"]
    if not ok:
        return "all runs failed"
    a, b = ok[0], ok[-1]
    return (
        f"{len(rows)} runs, {a.setting}: err {a.state_err:.1e} ({_ms(a.wall)}) ... "
        f"{b.setting}: err {b.state_err:.1e} ({_ms(b.wall)})"
    )


def _tolerances(quick: bool) -> list[float]:
    return [10.0**-k for k in (range(3, 11, 2) if quick else range(3, 13))]


def _rk45_sweep(name: str, control: str, ref: Reference, quick: bool, k: int, log: Log):
    rows = []
    for tol in _tolerances(quick):
        opts = Options(rtol=tol, atol=tol, control=control)
        run = partial(simulate, ref.system, "rk45", "c", h=ref.T / SAMPLES, T=ref.T, options=opts)
        try:
            rows.append(_our_row(name, f"rk45-{control}", _best_wall(run, k), ref, tol))
        except IntegrationError as exc:
            rows.append(
                _failed_row(name, f"rk45-{control}", "s2gen", math.nan, tol, ref.T, _why(exc))
            )
    log(f"    rk45-{control:6s} {_sweep_line(rows)}")
    return rows


def _peer_row(name: str, family: str, r: peers.PeerRun, ref: Reference) -> WPRow:
    return WPRow(
        name,
        r.name,
        family,
        math.nan,
        r.rtol,
        r.T,
        r.steps,
        r.evals,
        math.nan,
        r.wall,
        _err(r.q, r.omega, ref.state) if r.status == "ok" else math.nan,
        r.max_dE,
        r.max_dE / ref.kinetic_scale,
        r.status,
    )


def _scipy_sweep(name: str, ref: Reference, quick: bool, k: int, log: Log) -> list[WPRow]:
    rows = []
    for method in ("RK45", "DOP853"):
        part = []
        for tol in _tolerances(quick):
            r = peers.scipy_run(ref.system, method, tol, ref.T, samples=SAMPLES, repeats=k)
            part.append(_peer_row(name, "scipy", r, ref))
        log(f"    {'scipy-' + method:12s} {_sweep_line(part)}")
        rows += part
    return rows


def _pydy_sweep(ex: ExampleBench, quick: bool, k: int, generator: str, log: Log) -> list[WPRow]:
    missing = peers.pydy_available()
    if missing:
        ex.pydy = {"status": f"PyDy could not be imported ({missing}); skipped"}
        log(f"    pydy: {ex.pydy['status']}")
        return []
    try:
        model = peers.pydy_model(ex.system, generator)
        ex.pydy = {
            "status": "ok",
            "generator": model.generator,
            "derive_s": model.derive_seconds,
            "generate_s": model.generate_seconds,
            "note": model.note,
        }
        log(
            f"    pydy ({model.generator}): derivation {model.derive_seconds:.2f} s, code "
            f"generation + compilation {model.generate_seconds:.2f} s {model.note}"
        )
        if generator == "auto" and model.generator == "cython":
            lam = peers.pydy_model(ex.system, "lambdify")
            ex.pydy["lambdify_generate_s"] = lam.generate_seconds
        rows = []
        for integrator in ("lsoda", "DOP853"):
            part = []
            for tol in _tolerances(quick):
                r = peers.pydy_run(
                    ex.system, model, integrator, tol, ex.reference.T, samples=SAMPLES, repeats=k
                )
                ex.pydy["pole_distance"] = r.extra.get("pole_distance", math.nan)
                part.append(_peer_row(ex.name, "pydy", r, ex.reference))
            log(f"    {part[0].method:12s} {_sweep_line(part)}")
            rows += part
        return rows
    except Exception as exc:  # noqa: BLE001 - a broken peer is reported, the bench goes on
        ex.pydy = {"status": f"PyDy failed: {type(exc).__name__}: {exc}"}
        log(f"    pydy: {ex.pydy['status']}")
        return []


def work_precision(
    name: str,
    quick: bool = False,
    T: float | None = None,
    pydy_generator: str = "auto",
    log: Log = _print,
) -> ExampleBench:
    """All methods and peers on one example over sweeps of h or tolerance.

    Example:
        >>> ex = work_precision("double_pendulum", quick=True, log=lambda s: None)  # doctest: +SKIP
        >>> {r.method for r in ex.rows} >= {"vi", "vi4", "rk45-hairer"}  # doctest: +SKIP
        True
    """
    system = example_system(name)
    full_T, quick_T = HORIZONS.get(name, (min(system.run.T or 10.0, 10.0),) * 2)
    T = T or (quick_T if quick else full_T)
    log(f"{name}: work-precision over T = {T:g} (n = {system.n})")
    get_backend(system, "c")
    ref = reference(system, T, log)
    ex = ExampleBench(name, system, ref)
    k = 3 if quick else 5
    budget = 0.5 if quick else 5.0
    steps = _sweep_steps(system, T, quick)
    for method in FIXED:
        ex.rows += _fixed_sweep(name, method, ref, steps, budget, k, log)
    for control in ("hairer", "matlab"):
        ex.rows += _rk45_sweep(name, control, ref, quick, k, log)
    ex.rows += _scipy_sweep(name, ref, quick, 2 if quick else 3, log)
    if system.parameter_names == ("m1", "m2", "l1", "l2", "g") and system.n == 2:
        gen = "lambdify" if quick and pydy_generator == "auto" else pydy_generator
        ex.rows += _pydy_sweep(ex, quick, 2 if quick else 3, gen, log)
    else:
        ex.pydy = {"status": f"the PyDy peer models the double pendulum only; not run on {name}"}
    ex.call_overhead = _call_overhead(system, T)
    ex.per_step = per_step_times(system, T, quick, log)
    return ex


def _call_overhead(system: System, T: float) -> float:
    """Best-of-20 wall time of a one-step call (output arrays, ctypes): in every timing above."""
    one = _best_wall(partial(simulate, system, "rk4", "c", h=T / SAMPLES, T=T / SAMPLES), 20)
    return one.wall_time


def fitted_orders(rows: Sequence[WPRow], floor: float) -> dict[str, float]:
    """Least-squares slope of log(state error) against log(h) per fixed-step method.

    Uses the runs whose error lies between 100 x the reference accuracy and 1e-2 (the
    asymptotic range), when there are at least three.

    Example:
        >>> rows = [WPRow("x", "vi", "s2gen", h, 0, 1, 0, 0, 0, 0, 3 * h**2, 0, 0)
        ...         for h in (0.01, 0.005, 0.0025)]
        >>> round(fitted_orders(rows, 1e-12)["vi"], 6)
        2.0
    """
    out = {}
    for method in FIXED:
        pts = [
            (r.h, r.state_err)
            for r in rows
            if r.method == method and r.ok and 100 * floor < r.state_err < 1e-2
        ]
        if len(pts) >= 3:
            hs, es = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            out[method] = float(np.polyfit(hs, es, 1)[0])
    return out


# ---------------------------------------------------------------------------- per-step timing
PER_STEP_METHODS = ("vi", "vi4", "rattle", "rk4", "rk45")


def per_step_times(
    system: System, T: float, quick: bool, log: Log = _print
) -> list[dict[str, Any]]:
    """Time per step of emitted C, emitted NumPy and the NumPy reference, side by side: the
    same N steps of h = T/N on each backend. Fixed-step methods: (best wall of N steps - best
    wall of 1 step) / (N - 1), which removes the per-call overhead; rk45 (tol 1e-8, output
    every T/N): best wall / accepted steps.

    Example:
        >>> rows = per_step_times(example_system("double_pendulum"), 1.0, True, lambda s: None)
        >>> rows[0]["method"], rows[0]["c_us"] > 0
        ('vi', True)
    """
    n = 100 if quick else 400
    h = T / n
    out = []
    for method in PER_STEP_METHODS:
        row: dict[str, Any] = {"system": system.name, "method": method, "h": h, "steps": n}
        for backend in ("c", "numpy", "reference"):
            if backend == "reference" and method in ("vi4", "rattle"):
                continue
            k = 20 if backend == "c" else 2 if quick else 3
            try:
                row[f"{backend}_us"] = _seconds_per_step(system, method, backend, h, n, k) * 1e6
            except IntegrationError as exc:
                log(f"    per step {method} on {backend}: {_why(exc)}")
        for backend in ("numpy", "reference"):
            if f"{backend}_us" in row and "c_us" in row:
                row[f"{backend}_over_c"] = row[f"{backend}_us"] / row["c_us"]
        out.append(row)
        log(
            f"    per step {method:7s} C {_fmt(row.get('c_us'))} us, NumPy "
            f"{_fmt(row.get('numpy_us'))} us ({_fmt(row.get('numpy_over_c'))}x), reference "
            f"{_fmt(row.get('reference_us'))} us ({_fmt(row.get('reference_over_c'))}x)"
        )
    return out


def _seconds_per_step(system: System, method: str, backend: str, h: float, n: int, k: int) -> float:
    opts = Options(rtol=1e-8, atol=1e-8, control="hairer")
    full = _best_wall(partial(simulate, system, method, backend, h=h, T=n * h, options=opts), k)
    if method == "rk45":
        return full.wall_time / max(int(full.stats.get("steps", n)), 1)
    one = _best_wall(partial(simulate, system, method, backend, h=h, T=h, options=opts), k)
    return max(full.wall_time - one.wall_time, 0.0) / (n - 1)


# ---------------------------------------------------------------------------------- long time
@dataclass
class LongSeries:
    """A long run, kept as per-window maxima (windows double in length, so they are evenly
    spread on a log time axis) instead of every sample."""

    example: str
    label: str
    method: str
    h: float
    rtol: float
    t: list[float] = field(default_factory=list)
    dE: list[float] = field(default_factory=list)
    unit: list[float] = field(default_factory=list)
    qw: list[float] = field(default_factory=list)
    dL: list[float] = field(default_factory=list)
    steps: int = 0
    evals: int = 0
    wall: float = 0.0
    status: str = "ok"

    def running_max(self) -> np.ndarray:
        """max |E - E0| over [0, t_k] at each window end t_k."""
        return np.maximum.accumulate(np.asarray(self.dE)) if self.dE else np.zeros(0)

    def slope(self, decades: float = 2.0) -> float:
        """Fitted drift slope d log(max |E - E0|) / d log t over the last `decades` of time."""
        t, e = np.asarray(self.t), self.running_max()
        keep = (t >= t[-1] / 10**decades) & (e > 0) if len(t) else np.zeros(0, bool)
        if keep.sum() < 3:
            return math.nan
        return float(np.polyfit(np.log(t[keep]), np.log(e[keep]), 1)[0])


@dataclass
class _Tracker:
    """Accumulates one long run's windows; q, w is the state to continue from."""

    series: LongSeries
    system: System
    params: np.ndarray
    conserved: tuple[int, ...]
    q: np.ndarray
    w: np.ndarray
    e0: float = math.nan
    l0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    t: float = 0.0

    def start(self) -> None:
        be = get_backend(self.system, "c")
        self.e0 = be.energy(self.q, self.w, self.params)
        self.l0 = be.angular_momentum(self.q, self.w, self.params)

    def window(self, t_end: float, q: np.ndarray, w: np.ndarray, energy: np.ndarray) -> None:
        """Record the maxima over one window's samples (q, w: (k, n, 3)); continue from the last."""
        be = get_backend(self.system, "c")
        s = self.series
        s.t.append(t_end)
        s.dE.append(float(np.max(np.abs(energy - self.e0))))
        s.unit.append(float(np.max(np.abs(np.linalg.norm(q, axis=-1) - 1.0))))
        s.qw.append(float(np.max(np.abs(np.einsum("...c,...c->...", q, w)))))
        picks = np.unique(np.linspace(0, len(q) - 1, min(len(q), 9)).astype(int))
        dl = [be.angular_momentum(q[i], w[i], self.params) - self.l0 for i in picks]
        comps = list(self.conserved)
        s.dL.append(float(np.max(np.abs(np.asarray(dl)[:, comps]))) if comps else math.nan)
        self.q, self.w, self.t = q[-1].copy(), w[-1].copy(), t_end


def _windows(total_steps: int, first: int = 64, largest: int = 2**17) -> list[int]:
    """Chunk lengths doubling from `first` up to `largest`, summing to total_steps."""
    out, size, done = [], first, 0
    while done < total_steps:
        n = min(size, total_steps - done)
        out.append(n)
        done += n
        size = min(2 * size, largest)
    return out


class _Progress:
    def __init__(self, label: str, total: float, log: Log, every: float = 3.0) -> None:
        self.label, self.total, self.log, self.every = label, total, log, every
        self.start = self.last = time.perf_counter()

    def __call__(self, t: float) -> None:
        now = time.perf_counter()
        if now - self.last >= self.every:
            self.last = now
            frac = 100 * t / self.total
            self.log(
                f"      ... {self.label}: t = {t:.6g} / {self.total:.6g} ({frac:.0f} %), "
                f"{now - self.start:.0f} s"
            )


def _long_fixed(tr: _Tracker, h: float, total_steps: int, log: Log) -> LongSeries:
    s = tr.series
    prog = _Progress(s.label, total_steps * h, log)
    done = 0
    for n in _windows(total_steps):
        try:
            out = simulate(
                tr.system, s.method, "c", h=h, T=n * h, params=tr.params, q0=tr.q, omega0=tr.w
            )
        except IntegrationError as exc:
            s.status = f"{_why(exc)} in the window from step {done}"
            break
        s.wall += out.wall_time
        s.evals += int(out.stats.get("gradient_evals", 0))
        done += n
        s.steps = done
        tr.window(done * h, out.q, out.omega, out.energy)
        prog(done * h)
    return s


def _long_rk45(tr: _Tracker, ends: Sequence[float], log: Log) -> LongSeries:
    s = tr.series
    prog = _Progress(s.label, ends[-1], log)
    opts = Options(rtol=s.rtol, atol=s.rtol, control="hairer")
    for t_end in ends:
        span = t_end - tr.t
        try:
            out = simulate(
                tr.system,
                "rk45",
                "c",
                h=span / 32,
                T=span,
                options=opts,
                params=tr.params,
                q0=tr.q,
                omega0=tr.w,
            )
        except IntegrationError as exc:
            s.status = f"{_why(exc)} in the window ending at t = {t_end:g}"
            break
        s.wall += out.wall_time
        s.evals += int(out.stats.get("gradient_evals", 0))
        s.steps += int(out.stats.get("steps", 0))
        tr.window(t_end, out.q, out.omega, out.energy)
        prog(t_end)
    return s


def _long_dop853(tr: _Tracker, ends: Sequence[float], log: Log) -> LongSeries:
    from scipy.integrate import solve_ivp

    s = tr.series
    n = tr.system.n
    f = peers.c_field(tr.system, tr.params)
    be = get_backend(tr.system, "c")
    prog = _Progress(s.label, ends[-1], log)
    for t_end in ends:
        y0 = np.concatenate([tr.q.ravel(), tr.w.ravel()])
        t_eval = np.linspace(tr.t, t_end, 33)
        start = time.perf_counter()
        sol = solve_ivp(f, (tr.t, t_end), y0, "DOP853", t_eval, rtol=s.rtol, atol=s.rtol)
        s.wall += time.perf_counter() - start
        if not sol.success or not np.all(np.isfinite(sol.y)):
            s.status = f"failed ({sol.message}) in the window ending at t = {t_end:g}"
            break
        s.evals += int(sol.nfev)
        y = sol.y.T
        q, w = y[:, : 3 * n].reshape(-1, n, 3), y[:, 3 * n :].reshape(-1, n, 3)
        energy = np.array([be.energy(q[i], w[i], tr.params) for i in range(len(q))])
        tr.window(t_end, q, w, energy)
        prog(t_end)
    return s


@dataclass
class LongSetup:
    """What every long run of one example shares: system, step, horizon, initial state."""

    name: str
    system: System
    h: float
    steps: int
    q0: np.ndarray
    w0: np.ndarray
    conserved: tuple[int, ...] = ()
    note: str = ""

    @property
    def T(self) -> float:
        return self.steps * self.h


def conserved_components(
    system: System, q0: np.ndarray | None = None, w0: np.ndarray | None = None, T: float = 10.0
) -> tuple[int, ...]:
    """Components of the angular momentum that a tight RK45 run keeps to 1e-8 (relative).

    Example:
        >>> conserved_components(example_system("double_pendulum"))
        (2,)
    """
    opts = Options(rtol=1e-12, atol=1e-12, control="hairer")
    tr = simulate(system, "rk45", "c", h=T / 50, T=T, options=opts, q0=q0, omega0=w0)
    be = get_backend(system, "c")
    p = np.array(system.parameter_values)
    L = np.array([be.angular_momentum(tr.q[k], tr.omega[k], p) for k in range(len(tr.t))])
    scale = 1.0 + float(np.linalg.norm(L[0]))
    return tuple(c for c in range(3) if np.max(np.abs(L[:, c] - L[0, c])) <= 1e-8 * scale)


def rotating_triangle(eps: float = 0.03, rate: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """A collision-free state of the three bodies: an equilateral triangle on the equator
    turning about e3 at `rate`, perturbed by `eps` (positions and one velocity).

    Example:
        >>> q, w = rotating_triangle()
        >>> bool(np.allclose(np.linalg.norm(q, axis=1), 1) and np.allclose((q * w).sum(1), 0))
        True
    """
    phi = np.array([0.0, 2 * np.pi / 3 + eps, 4 * np.pi / 3])
    lat = np.array([eps, 0.0, -eps / 2])
    q = np.stack([np.cos(lat) * np.cos(phi), np.cos(lat) * np.sin(phi), np.sin(lat)], axis=1)
    w = np.tile([0.0, 0.0, rate], (3, 1))
    w[1, 0] += eps
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    return q, w


#: Collision-free replacement states for long runs of examples whose own state collides.
LONG_STATES: dict[str, Callable[[], tuple[np.ndarray, np.ndarray]]] = {
    "three_bodies": rotating_triangle,
}


def long_setup(name: str, steps: int, log: Log = _print) -> LongSetup:
    """The example's state, unless a tight RK45 run from it breaks down within the horizon
    (a collision) and `LONG_STATES` has a replacement; the reason is kept in `.note`.

    Example:
        >>> long_setup("double_pendulum", 1000, log=lambda s: None).T
        10.0
    """
    system = example_system(name)
    h = system.run.h or 0.01
    assert system.q0 is not None and system.omega0 is not None
    setup = LongSetup(name, system, h, steps, system.q0.copy(), system.omega0.copy())
    if name in LONG_STATES:
        opts = Options(rtol=1e-12, atol=1e-12, control="hairer")
        span = min(setup.T, 100.0)
        try:
            simulate(system, "rk45", "c", h=span / 1000, T=span, options=opts)
        except IntegrationError as exc:
            setup.q0, setup.w0 = LONG_STATES[name]()
            setup.note = (
                f"{name}'s own initial state breaks down at t = {exc.step * span / 1000:.4g} "
                f"(our RK45 at tol 1e-12: {_why(exc)}: a collision); the long runs start "
                f"instead from `{LONG_STATES[name].__name__}()` in `s2gen.bench`"
            )
            log(f"  {setup.note}")
    setup.conserved = conserved_components(system, setup.q0, setup.w0)
    return setup


def _tracker(setup: LongSetup, label: str, method: str, h: float, rtol: float) -> _Tracker:
    series = LongSeries(setup.name, label, method, h, rtol)
    p = np.array(setup.system.parameter_values, dtype=float)
    tr = _Tracker(series, setup.system, p, setup.conserved, setup.q0.copy(), setup.w0.copy())
    tr.start()
    return tr


def long_time(
    name: str, steps: int, tight: float = 1e-10, log: Log = _print
) -> tuple[list[LongSeries], list[str]]:
    """Long runs (VI, vi4, RATTLE, RK4 at the system's h; RK45 and DOP853 at tolerance `tight`),
    then vi and vi4 at equal cost with each tight RK; returns the series and notes (setup,
    crossovers).

    Example:
        >>> series, notes = long_time("double_pendulum", 2000, log=lambda s: None)
        >>> [s.method for s in series][:4]
        ['vi', 'vi4', 'rattle', 'rk4']
    """
    setup = long_setup(name, steps, log)
    h = setup.h
    log(
        f"{name}: long time, {steps} steps of h = {h:g} (T = {setup.T:g}); conserved L "
        f"components {[c + 1 for c in setup.conserved]}"
    )
    out: list[LongSeries] = []
    for method in ("vi", "vi4", "rattle", "rk4"):
        out.append(
            _long_fixed(_tracker(setup, f"{method} h={h:g}", method, h, math.nan), h, steps, log)
        )
        log(_long_line(out[-1]))
    ends = list(np.cumsum(_windows(steps)) * h)
    out.append(
        _long_rk45(_tracker(setup, f"rk45 tol={tight:g}", "rk45", math.nan, tight), ends, log)
    )
    log(_long_line(out[-1]))
    out.append(
        _long_dop853(_tracker(setup, f"DOP853 tol={tight:g}", "DOP853", math.nan, tight), ends, log)
    )
    log(_long_line(out[-1]))
    notes = [setup.note] if setup.note else []
    notes += _equal_cost_runs(setup, out, log)
    return out, notes


def _long_line(s: LongSeries) -> str:
    final = s.running_max()[-1] if s.dE else math.nan
    return (
        f"    {s.label:22s} {s.steps:>9d} steps {s.evals:>10d} evals {s.wall:8.2f} s  "
        f"max|dE| {final:.2e}  slope {_fmt(s.slope(), '.2f')}  {s.status}"
    )


def _equal_cost_runs(setup: LongSetup, out: list[LongSeries], log: Log) -> list[str]:
    """vi and vi4 runs whose cost per unit time equals the tight RK45's (wall time, both emitted
    C) and DOP853's (gradient evaluations: scipy drives it from Python), and the crossover time
    after which the VI's energy error is the smaller."""
    base = {s.method: s for s in out[:2]}
    rks = [(s, "wall" if s.method == "rk45" else "evals") for s in out[4:6]]
    notes = []
    for rk, basis in rks:
        if rk.status != "ok" or not rk.t:
            notes.append(f"{rk.label} did not finish ({rk.status}): no crossover")
            continue
        for method, vi in base.items():
            per_step = vi.wall / max(vi.steps, 1) if basis == "wall" else vi.evals / vi.steps
            cost = (rk.wall if basis == "wall" else rk.evals) / rk.t[-1]
            h_eq = per_step / cost
            label = f"{method} h={h_eq:.3g} (= {rk.method} {basis})"
            eq = _long_fixed(
                _tracker(setup, label, method, h_eq, math.nan),
                h_eq,
                max(1, int(setup.T / h_eq)),
                log,
            )
            out.append(eq)
            log(_long_line(eq))
            notes.append(_crossover_note(rk, eq, basis))
            log(f"    {notes[-1]}")
    return notes


def crossover(rk: LongSeries, vi: LongSeries) -> tuple[float, str]:
    """First window end after which the RK's running max |E - E0| stays above the VI's.

    Returns (time, kind): kind "measured", "before the first window", or "extrapolated" (from
    the RK's fitted drift slope, when it is still below the VI's at the end), or "none".

    Example:
        >>> rk = LongSeries("x", "rk", "rk45", 0, 0, [1.0, 10.0, 100.0], [1e-8, 1e-7, 1e-6])
        >>> vi = LongSeries("x", "vi", "vi", 0, 0, [1.0, 10.0, 100.0], [3e-7, 3e-7, 3e-7])
        >>> crossover(rk, vi)
        (100.0, 'measured')
    """
    t = np.asarray(rk.t)
    rk_max = rk.running_max()
    vi_t, vi_max = np.asarray(vi.t), vi.running_max()
    if not len(t) or not len(vi_t):
        return math.nan, "none"
    idx = np.clip(np.searchsorted(vi_t, t, side="right") - 1, 0, len(vi_t) - 1)
    above = rk_max > vi_max[idx]
    if above.all():
        return float(t[0]), "before the first window"
    if above[-1]:
        last_below = int(np.nonzero(~above)[0][-1])
        return float(t[last_below + 1]), "measured"
    slope = rk.slope()
    if not slope > 0:
        return math.nan, "none"
    return float(t[-1] * (vi_max[-1] / rk_max[-1]) ** (1.0 / slope)), "extrapolated"


def _crossover_note(rk: LongSeries, vi: LongSeries, basis: str) -> str:
    t, kind = crossover(rk, vi)
    cost = "wall time" if basis == "wall" else "gradient evaluations"
    vi_err = vi.running_max()[-1] if vi.dE else math.nan
    horizon = vi.t[-1] if vi.t else math.nan
    head = (
        f"at equal {cost} per unit time, {vi.method} (h = {vi.h:.3g}) keeps max |E − E0| at "
        f"{vi_err:.2e} over T = {horizon:.4g}; {rk.label} "
    )
    if kind == "measured":
        return head + f"exceeds it from t = {t:.4g} on (measured crossover)"
    if kind == "before the first window":
        return (
            head + f"already exceeds it by the first window (t = {t:.4g}): the VI wins throughout"
        )
    if kind == "extrapolated" and t <= 1000 * horizon:
        return head + (
            f"stays below it over the run; its fitted drift slope {rk.slope():.2f} puts the "
            f"crossover at t ≈ {t:.3g} (extrapolated)"
        )
    if kind == "extrapolated":
        return head + (
            f"stays below it over the run, and its fitted drift slope {rk.slope():.2f} puts the "
            f"crossover beyond 1000× this horizon (t ≈ {t:.2g}, extrapolated): the RK wins here"
        )
    return head + "stays below it with no growth to extrapolate: no crossover, the RK wins here"


# ------------------------------------------------------------------------ stability envelope
@dataclass
class StabilityCase:
    """A hard case: a system with parameter values, a horizon and what makes it hard."""

    label: str
    system: System
    params: np.ndarray
    T: float
    note: str
    skipped: str = ""


def _lj_encounter() -> System:
    """Three Lennard-Jones particles; bodies 1 and 2 meet head-on (closest approach ~0.8 sigma)."""
    from .spec import define_system

    a = 0.3
    q = [[math.cos(a), -math.sin(a), 0.0], [math.cos(a), math.sin(a), 0.0], [0.0, 0.0, 1.0]]
    w = [[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.2, 0.0, 0.0]]
    r2 = "dot(qi-qj, qi-qj)"
    return define_system(
        name="lj_encounter",
        bodies=3,
        parameters={"m": 1.0, "eps": 1.0, "sigma": 0.1},
        diagonal=["m"] * 3,
        pair_terms=[{"V": f"4*eps*((sigma**2/{r2})**6 - (sigma**2/{r2})**3)", "pairs": "all"}],
        initial_q=q,
        initial_omega=w,
        run={"h": 1e-4, "T": 0.6},
        origin="s2gen.bench._lj_encounter",
    )


def _with(system: System, **values: float) -> np.ndarray:
    p = dict(system.parameters)
    p.update(values)
    return np.array([p[k] for k in system.parameter_names], dtype=float)


def stability_cases(quick: bool = False) -> list[StabilityCase]:
    """The hard cases: poles, a stiff rod, a close encounter, near-singular M, large n.

    Example:
        >>> [c.label for c in stability_cases(quick=True)][:2]
        ['poles: double pendulum', 'stiff rod kappa=1e+03']
    """
    from .paper_systems import elastic_rod, molecular

    dp = example_system("double_pendulum")
    rod = elastic_rod(5 if quick else 10)
    cases = [
        StabilityCase(
            "poles: double pendulum",
            dp,
            _with(dp),
            5.0,
            "body 2 starts at e3, the pole of the polar-angle chart",
        ),
    ]
    for kappa in (1e3, 1e5) if quick else (1e3, 1e4, 1e5):
        cases.append(
            StabilityCase(
                f"stiff rod kappa={kappa:.0e}",
                rod,
                _with(rod, kappa=kappa),
                0.1,
                f"elastic_rod(n={rod.n}) with bending stiffness {kappa:g} N m",
            )
        )
    lj = _lj_encounter()
    cases.append(
        StabilityCase(
            "LJ close encounter",
            lj,
            _with(lj),
            0.6,
            "two particles meet head-on at 2 rad/s, sigma = 0.1",
        )
    )
    for ratio in (1e2, 1e4) if quick else (1e2, 1e4, 1e6):
        cases.append(
            StabilityCase(
                f"near-singular M m2/m1={ratio:.0e}",
                dp,
                _with(dp, m1=1.0 / ratio),
                2.0,
                f"double pendulum with m1 = m2/{ratio:g}: cond(M) grows with m2/m1",
            )
        )
    if not quick:
        big = elastic_rod(40)
        cases.append(
            StabilityCase(
                "large n: rod n=40",
                big,
                _with(big),
                0.1,
                "elastic_rod(n=40): coupled 40 x 40 inertia",
            )
        )
        md = molecular(1)
        cases.append(
            StabilityCase(
                "large n: LJ n=42",
                md,
                _with(md),
                2.0,
                "molecular(subdivisions=1): 42 particles, all pairs",
            )
        )
    return cases


@dataclass
class StabRow:
    """One run of a stability sweep."""

    case: str
    method: str
    h: float
    steps: int
    h_wmax: float
    err: float
    newton_per_step: float
    newton_max: int
    status: str


def _stab_run(case: StabilityCase, method: str, n: int, ref: dict[str, Any]) -> StabRow:
    h = case.T / n
    hw = h * ref["wmax"]
    try:
        tr = simulate(case.system, method, "c", h=h, T=case.T, params=case.params)
    except IntegrationError as exc:
        return StabRow(case.label, method, h, n, hw, math.nan, math.nan, 0, _why(exc))
    if not (np.all(np.isfinite(tr.q)) and np.all(np.isfinite(tr.omega))):
        return StabRow(case.label, method, h, n, hw, math.nan, math.nan, 0, "failed (non-finite)")
    err = max(
        float(np.max(np.abs(tr.q[-1] - ref["q"]))),
        float(np.max(np.abs(tr.omega[-1] - ref["w"]))) / ref["wmax"],
        float(np.max(np.abs(tr.energy - tr.energy[0]))) / ref["kin"],
    )
    newton = tr.stats.get("newton_iters", 0) / n
    status = "ok" if err <= 1.0 else "failed (error > 1)"
    return StabRow(case.label, method, h, n, hw, err, newton, tr.stats.get("newton_max", 0), status)


def _stab_reference(case: StabilityCase) -> dict[str, Any]:
    opts = Options(rtol=1e-11, atol=1e-11, control="hairer")
    tr = simulate(
        case.system, "rk45", "c", h=case.T / SAMPLES, T=case.T, options=opts, params=case.params
    )
    wmax = float(np.max(np.linalg.norm(tr.omega, axis=-1)))
    kin = float(np.max(kinetic_energy(case.system, tr.q, tr.omega, case.params)))
    return {"q": tr.q[-1], "w": tr.omega[-1], "wmax": wmax, "kin": kin, "steps": tr.stats["steps"]}


def stability_sweep(case: StabilityCase, method: str, ref: dict[str, Any]) -> list[StabRow]:
    """Runs of one method with h growing by 2^(1/4) from a stable start until the first failure.

    Example:
        >>> c = stability_cases(quick=True)[0]
        >>> rows = stability_sweep(c, "rk4", _stab_reference(c))  # doctest: +SKIP
        >>> rows[-1].status.startswith("failed")  # doctest: +SKIP
        True
    """
    rows: list[StabRow] = []
    n = 64
    while True:  # find a stable start, refining if needed
        row = _stab_run(case, method, n, ref)
        rows.append(row)
        if row.status == "ok" or n >= 2**20:
            break
        n *= 4
    k = 0
    while row.status == "ok":
        k += 1
        m = round(n * 2 ** (-k / 4))
        if m < 1 or m == rows[-1].steps:
            break
        row = _stab_run(case, method, m, ref)
        rows.append(row)
    return rows


def largest_stable(rows: Sequence[StabRow]) -> StabRow | None:
    """The largest h that ran ok in a sweep (None if none did).

    Example:
        >>> rows = [StabRow("c", "vi", h, 1, h, 0.1, 0, 0, s)
        ...         for h, s in ((0.1, "ok"), (0.2, "ok"), (0.3, "failed (newton at step 2)"))]
        >>> largest_stable(rows).h
        0.2
    """
    ok = [r for r in rows if r.status == "ok"]
    return max(ok, key=lambda r: r.h) if ok else None


def stability(quick: bool = False, log: Log = _print) -> tuple[list[StabRow], list[StabilityCase]]:
    """Every hard case and fixed-step method: the runs of the upward h sweeps."""
    log("stability envelope: h grows by 2^(1/4) until each method fails")
    rows: list[StabRow] = []
    cases = stability_cases(quick)
    for case in cases:
        get_backend(case.system, "c")
        try:
            ref = _stab_reference(case)
        except IntegrationError as exc:
            case.skipped = f"the RK45 reference (tol 1e-11) itself failed: {exc}"
            log(f"  {case.label}: skipped; {case.skipped}")
            continue
        log(f"  {case.label}: T = {case.T:g}, max |omega| = {ref['wmax']:.3g} ({case.note})")
        for method in FIXED:
            part = stability_sweep(case, method, ref)
            rows += part
            best = largest_stable(part)
            first_fail = next((r for r in part if r.status != "ok" and best and r.h > best.h), None)
            log(
                f"    {method:9s} largest stable h {_fmt(best.h if best else None)} "
                f"(h max|w| {_fmt(best.h_wmax if best else None)}); then "
                f"{first_fail.status if first_fail else 'no failure'}"
            )
    return rows, cases


# ----------------------------------------------------------------------------------- scaling
@contextlib.contextmanager
def _fresh_cache() -> Iterator[Path]:
    """A private, empty build cache ($S2GEN_CACHE) so gcc really runs; removed afterwards."""
    old = os.environ.get("S2GEN_CACHE")
    tmp = tempfile.mkdtemp(prefix="s2gen-bench-cache-")
    os.environ["S2GEN_CACHE"] = tmp
    try:
        yield Path(tmp)
    finally:
        if old is None:
            os.environ.pop("S2GEN_CACHE", None)
        else:
            os.environ["S2GEN_CACHE"] = old
        shutil.rmtree(tmp, ignore_errors=True)


def md_system(n: int, cutoff: float | None = None) -> System:
    """n Lennard-Jones particles on a Fibonacci lattice of the unit sphere (diagonal M).

    sigma puts the force zero at the mean nearest-neighbour distance; `cutoff` (in units of
    sigma) restricts the all-pairs term to |q_i - q_j| < cutoff sigma (neighbour lists);
    velocities are the paper's two vortices.

    Example:
        >>> md_system(100).n
        100
    """
    import sympy as sp
    from scipy.spatial import cKDTree

    from .paper_systems import lennard_jones_sigma, vortex_axes, vortex_velocities
    from .system import RunSettings, Term, local_vector

    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = math.pi * (1 + math.sqrt(5)) * k
    r = np.sqrt(1 - z**2)
    pts = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    dist, _ = cKDTree(pts).query(pts, k=2)
    sig = lennard_jones_sigma(float(np.mean(dist[:, 1])))
    w = vortex_velocities(pts, vortex_axes(30.0), (1.0, 1.0), math.radians(15.0))
    m, eps, sg = (sp.Symbol(s, real=True) for s in ("m", "eps", "sigma"))
    d = sp.Matrix(local_vector("qi")) - sp.Matrix(local_vector("qj"))
    s6 = (sg**2 / d.dot(d)) ** 3
    term = Term("pair", 4 * eps * (s6**2 - s6), label="Lennard-Jones")
    if cutoff is not None:
        term = dataclasses.replace(term, cutoff=cutoff * sig)
    return System.create(
        name="md_fibonacci",
        n=n,
        parameters={"m": 1.0, "eps": 0.01, "sigma": sig},
        inertia=m * sp.eye(n),
        potential=sp.Integer(0),
        q0=pts,
        omega0=w,
        run=RunSettings(h=0.005, T=1.0, method="vi"),
        origin=f"s2gen.bench.md_system(n={n}, cutoff={cutoff})",
        terms=[term],
    )


@dataclass
class ScaleRow:
    """Generation and run cost of one system size."""

    family: str
    n: int
    create_s: float
    emit_s: float
    gcc_s: float
    c_bytes: int
    vi_us: float
    rk4_us: float
    status: str = "ok"


def _per_step(system: System, method: str, budget: float = 0.3) -> float:
    """Best-of-3 microseconds per step, with a step count aimed at `budget` seconds."""
    h = system.run.h or 1e-3
    probe = simulate(system, method, "c", h=h, T=2 * h)
    per = max(probe.wall_time / 2, 1e-8)
    n = int(min(max(budget / per, 2), 200000))
    tr = _best_wall(lambda: simulate(system, method, "c", h=h, T=n * h), 3)
    return tr.wall_time / n * 1e6


def _clear_sympy_caches() -> None:
    """Forget every derivation s2gen caches (printed modules, generic kernels), so a
    generation time includes the whole SymPy derivation."""
    from sympy.core.cache import clear_cache

    from . import emit, lowering

    clear_cache()
    emit._printed_cached.cache_clear()
    generic = getattr(lowering, "generic_kernels", None)
    if generic is not None and hasattr(generic, "cache_clear"):
        generic.cache_clear()


def _scale_one(family: str, n: int, make: Callable[[], System], log: Log) -> ScaleRow:
    from .build import compile_shared
    from .emit import emit

    t0 = time.perf_counter()
    system = make()
    t1 = time.perf_counter()
    _clear_sympy_caches()
    try:
        files = emit(system, "c")
        t2 = time.perf_counter()
        compile_shared(files)
        t3 = time.perf_counter()
        vi = _per_step(system, "vi")
        rk4 = _per_step(system, "rk4")
        status = "ok"
    except Exception as exc:  # noqa: BLE001 - report the size that broke, keep going
        log(f"    {family} n = {n}: {type(exc).__name__}: {str(exc)[:200]}")
        nan = math.nan
        return ScaleRow(family, n, t1 - t0, nan, nan, 0, nan, nan, f"failed: {type(exc).__name__}")
    size = sum(len(v) for k, v in files.items() if k.endswith(".c"))
    row = ScaleRow(family, n, t1 - t0, t2 - t1, t3 - t2, size, vi, rk4, status)
    log(
        f"    {family:14s} n = {n:>6d}: create {row.create_s:6.2f} s, derive+emit "
        f"{row.emit_s:6.2f} s, gcc {row.gcc_s:6.2f} s; per step vi {vi:.3g} us, rk4 {rk4:.3g} us"
    )
    return row


def scaling(quick: bool = False, log: Log = _print) -> list[ScaleRow]:
    """Generation (derive + emit + gcc, fresh caches) and per-step time against n.

    Rod: coupled M, n = 5 ... 80. Molecular dynamics: diagonal M, one all-pairs
    Lennard-Jones term, and its cutoff (neighbour-list) variant up to
    n = 10^5. All-pairs sizes stop once a VI step takes longer than 0.5 s.

    Example:
        >>> rows = scaling(quick=True)  # doctest: +SKIP
        >>> rows[0].family, rows[0].n  # doctest: +SKIP
        ('rod', 5)
    """
    from .paper_systems import elastic_rod

    rows: list[ScaleRow] = []
    log("scaling: generation and per-step time against n (fresh build cache)")
    with _fresh_cache():
        for n in (5, 10, 20) if quick else (5, 10, 20, 40, 80):
            rows.append(_scale_one("rod", n, lambda n=n: elastic_rod(n), log))  # type: ignore[misc]
        for n in (100, 300) if quick else (100, 300, 1000, 3000, 10000):
            row = _scale_one("md all-pairs", n, lambda n=n: md_system(n), log)  # type: ignore[misc]
            rows.append(row)
            if not row.vi_us < 5e5:
                break
        sizes = (100, 1000) if quick else (100, 1000, 10000, 100000)
        for n in sizes:
            make = lambda n=n: md_system(n, cutoff=2.5)  # type: ignore[misc]
            rows.append(_scale_one("md cutoff 2.5σ", n, make, log))
    return rows


# ----------------------------------------------------------------------------- CSV writers
WP_COLUMNS = (
    "example",
    "method",
    "family",
    "h",
    "rtol",
    "T",
    "steps",
    "evals",
    "newton_per_step",
    "wall_s",
    "state_err",
    "max_dE",
    "rel_dE",
    "status",
)


def _cell(x: Any) -> str:
    if isinstance(x, float):
        return "" if not np.isfinite(x) else f"{x:.6g}"
    return str(x)


def _write_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> Path:
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow([_cell(x) for x in r])
    return path


def _wp_values(r: WPRow) -> list[Any]:
    return [
        r.example,
        r.method,
        r.family,
        r.h,
        r.rtol,
        r.T,
        r.steps,
        r.evals,
        r.newton_per_step,
        r.wall,
        r.state_err,
        r.max_dE,
        r.rel_dE,
        r.status,
    ]


def write_tables(report: BenchReport) -> list[Path]:
    """bench.csv, per_step.csv and, when run, long.csv, stability.csv, scaling.csv."""
    out = report.out
    files = []
    if any(ex.rows for ex in report.examples):
        rows = [_wp_values(r) for ex in report.examples for r in ex.rows]
        files.append(_write_csv(out / "bench.csv", WP_COLUMNS, rows))
        keys = (
            "system",
            "method",
            "h",
            "steps",
            "c_us",
            "numpy_us",
            "reference_us",
            "numpy_over_c",
            "reference_over_c",
        )
        per = [
            [row.get(k, math.nan) for k in keys] for ex in report.examples for row in ex.per_step
        ]
        files.append(_write_csv(out / "per_step.csv", keys, per))
    long_rows = [
        [s.example, s.label, s.method, s.h, s.rtol, t, e, u, qw, dl, s.status]
        for ex in report.examples
        for s in ex.long
        for t, e, u, qw, dl in zip(s.t, s.dE, s.unit, s.qw, s.dL)
    ]
    if long_rows:
        head = (
            "example",
            "label",
            "method",
            "h",
            "rtol",
            "t_end",
            "window_max_dE",
            "window_max_unit",
            "window_max_q_dot_w",
            "window_max_dL",
            "status",
        )
        files.append(_write_csv(out / "long.csv", head, long_rows))
    for name, records, kind in (
        ("stability.csv", report.stability, StabRow),
        ("scaling.csv", report.scaling, ScaleRow),
    ):
        if records:
            names = [f.name for f in dataclasses.fields(kind)]
            values = [dataclasses.astuple(r) for r in records]
            files.append(_write_csv(out / name, names, values))
    return files


# ------------------------------------------------------------------------------------ plots
_COLORS = {
    "vi": "C0",
    "vi4": "C1",
    "rattle": "C2",
    "rk4": "C3",
    "rk2": "C4",
    "rk2-proj": "C5",
    "rk45-hairer": "C6",
    "rk45-matlab": "C7",
    "scipy-RK45": "C8",
    "scipy-DOP853": "C9",
}


def _style(method: str) -> dict[str, Any]:
    color = _COLORS.get(method, "k" if "lsoda" in method else "0.5")
    ls = "-" if method in FIXED or method.startswith("rk45") else "--"
    lw = 2.2 if method in VI_FAMILY else 1.2
    marker = "o" if method in FIXED else "s" if method.startswith("rk45") else "^"
    return {"color": color, "ls": ls, "lw": lw, "marker": marker, "ms": 4}


def _plot_wp(ex: ExampleBench, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    panels = (
        ("wall", "state_err"),
        ("evals", "state_err"),
        ("wall", "rel_dE"),
        ("evals", "rel_dE"),
    )
    labels = {
        "wall": "wall time [s] (best of k)",
        "evals": "gradient evaluations",
        "state_err": "state error at T",
        "rel_dE": "max |E - E0| / max kinetic energy",
    }
    methods = list(dict.fromkeys(r.method for r in ex.rows))
    for ax, (x, y) in zip(axes.flat, panels):
        for m in methods:
            pts = [(getattr(r, x), getattr(r, y)) for r in ex.rows if r.method == m and r.ok]
            pts = [(a, b) for a, b in pts if a > 0 and b > 0]
            if pts:
                ax.loglog(*zip(*sorted(pts)), label=m, **_style(m))
        if y == "state_err":
            ax.axhline(ex.reference.accuracy, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel(labels[x])
        ax.set_ylabel(labels[y])
        ax.grid(True, which="both", alpha=0.3)
    handles, names = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=6, fontsize=8)
    fig.suptitle(
        f"{ex.name}: work-precision over T = {ex.reference.T:g} (dotted: reference accuracy)"
    )
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return _save(fig, path)


def _save(fig: Any, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _plot_long(ex: ExampleBench, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    what = (
        ("dE", "max |E - E0| (running max)"),
        ("unit", "| |q_i| - 1 | (window max)"),
        ("qw", "|q_i . omega_i| (window max)"),
        ("dL", "|L - L0|, conserved components"),
    )
    for ax, (key, label) in zip(axes.flat, what):
        for s in ex.long:
            y = s.running_max() if key == "dE" else np.asarray(getattr(s, key))
            t = np.asarray(s.t)
            good = np.isfinite(y) & (y > 0)
            if good.any():
                ax.loglog(t[good], y[good], label=s.label, lw=2 if s.method == "vi" else 1.2)
        ax.set_xlabel("t")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{ex.name}: long-time behaviour")
    fig.tight_layout()
    return _save(fig, path)


def _plot_stability(rows: Sequence[StabRow], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    cases = list(dict.fromkeys(r.case for r in rows))
    cols = 3
    nrows = math.ceil(len(cases) / cols)
    fig, axes = plt.subplots(nrows, cols, figsize=(5 * cols, 3.6 * nrows), squeeze=False)
    for ax, case in zip(axes.flat, cases):
        for m in ("vi", "vi4", "rattle"):
            pts = sorted(
                (r.h, r.newton_per_step)
                for r in rows
                if r.case == case and r.method == m and r.status == "ok"
            )
            if pts and max(p[1] for p in pts) > 0:
                ax.semilogx(*zip(*pts), label=m, **_style(m))
            best = largest_stable([r for r in rows if r.case == case and r.method == m])
            if best:
                ax.axvline(best.h, color=_style(m)["color"], lw=0.8, ls=":")
        ax.set_title(case, fontsize=9)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("h (dotted: largest stable h)")
        ax.set_ylabel("Newton iterations per step")
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
        else:
            ax.text(
                0.5,
                0.5,
                "explicit methods only\n(diagonal M: no Newton)",
                ha="center",
                transform=ax.transAxes,
            )
    for ax in list(axes.flat)[len(cases) :]:
        ax.axis("off")
    fig.tight_layout()
    return _save(fig, path)


def _plot_scaling(rows: Sequence[ScaleRow], path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.5))
    for fam in dict.fromkeys(r.family for r in rows):
        pts = [r for r in rows if r.family == fam and r.status == "ok"]
        if not pts:
            continue
        ns = [r.n for r in pts]
        a.loglog(ns, [r.emit_s + r.gcc_s for r in pts], "o-", label=f"{fam}: derive+emit+gcc")
        a.loglog(ns, [r.gcc_s for r in pts], "x:", label=f"{fam}: gcc only")
        b.loglog(ns, [r.vi_us for r in pts], "o-", label=f"{fam}: vi")
        b.loglog(ns, [r.rk4_us for r in pts], "s--", label=f"{fam}: rk4")
    a.set_ylabel("generation time [s]")
    b.set_ylabel("time per step [us]")
    for ax in (a, b):
        ax.set_xlabel("n (bodies)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


def write_plots(report: BenchReport) -> list[Path]:
    """The PNG figures of every section that ran."""
    files = []
    for ex in report.examples:
        if ex.rows:
            files.append(_plot_wp(ex, report.out / f"wp_{ex.name}.png"))
        if ex.long:
            files.append(_plot_long(ex, report.out / f"long_{ex.name}.png"))
    if report.stability:
        files.append(_plot_stability(report.stability, report.out / "stability.png"))
    if report.scaling:
        files.append(_plot_scaling(report.scaling, report.out / "scaling.png"))
    return files


# ---------------------------------------------------------------------------------- Markdown
def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return out + ["| " + " | ".join(r) + " |" for r in rows]


def cheapest(rows: Sequence[WPRow], metric: str, target: float, cost: str = "wall") -> WPRow | None:
    """The measured run with the smallest `cost` whose `metric` is at most `target`.

    Example:
        >>> a = WPRow("x", "vi", "s2gen", 0.1, 0, 1, 10, 10, 0, 0.5, 1e-3, 0, 0)
        >>> b = WPRow("x", "rk4", "s2gen", 0.1, 0, 1, 10, 40, 0, 0.2, 1e-5, 0, 0)
        >>> cheapest([a, b], "state_err", 1e-2).method
        'rk4'
    """
    ok = [r for r in rows if r.ok and getattr(r, metric) <= target]
    return min(ok, key=lambda r: getattr(r, cost)) if ok else None


def _targets(ex: ExampleBench, metric: str) -> list[float]:
    if metric == "state_err":
        floor = 30 * ex.reference.accuracy
        return [10.0**-k for k in range(2, 13, 2) if 10.0**-k >= floor]
    return [10.0**-k for k in range(3, 12, 2)]


def _winner_rows(ex: ExampleBench, metric: str) -> list[list[str]]:
    out = []
    for target in _targets(ex, metric):
        win = cheapest(ex.rows, metric, target)
        ev = cheapest(ex.rows, metric, target, "evals")
        vi = cheapest([r for r in ex.rows if r.method in VI_FAMILY], metric, target)
        if win is None:
            continue
        ratio = _fmt(vi.wall / win.wall, ".2f") + "×" if vi else "not reached"
        out.append(
            [
                f"≤ {target:.0e}",
                f"{win.method} ({win.setting})",
                _ms(win.wall),
                f"{ev.method} ({ev.evals})" if ev else "—",
                f"{vi.method} ({vi.setting}): {_ms(vi.wall)}" if vi else "not reached",
                ratio,
            ]
        )
    return out


#: Wall-time ratios within this factor of 1 are reported as ties (timing noise).
TIE = 1.15


def findings(ex: ExampleBench, metric: str) -> list[str]:
    """Generated sentences: at each accuracy target, whether a VI (vi, vi4) is the cheapest in
    wall time, and by how much it wins or loses against the cheapest other method (a ratio
    within `TIE` of 1 is a tie)."""
    what = "state error" if metric == "state_err" else "relative energy error"
    lines = []
    for target in _targets(ex, metric):
        vi = cheapest([r for r in ex.rows if r.method in VI_FAMILY], metric, target)
        other = cheapest([r for r in ex.rows if r.method not in VI_FAMILY], metric, target)
        where = f"{what} ≤ {target:.0e} over T = {ex.reference.T:g}"
        if vi and other:
            lines.append(_verdict(where, vi, other))
        elif other:
            lines.append(
                f"- **VI loses** at {where}: no VI run in the sweep reached it; "
                f"{other.method} ({other.setting}) did in {_ms(other.wall)}."
            )
        elif vi:
            lines.append(
                f"- **VI wins** at {where}: only {vi.method} ({vi.setting}) reached it "
                f"({_ms(vi.wall)})."
            )
    return lines


def _verdict(where: str, vi: WPRow, other: WPRow) -> str:
    ratio = vi.wall / other.wall
    pair = (
        f"{vi.method} ({vi.setting}) {_ms(vi.wall)}, fastest other {other.method} "
        f"({other.setting}) {_ms(other.wall)}"
    )
    if 1 / TIE <= ratio <= TIE:
        return f"- **tie** at {where}: {pair} (within {TIE:g}×, timing noise)."
    if ratio < 1:
        return f"- **VI wins** at {where}: {pair}; the other takes {1 / ratio:.2f}× longer."
    return f"- **VI loses** at {where}: {pair}; the VI takes {ratio:.2f}× longer."


def _vi_vs_rattle(ex: ExampleBench) -> str:
    floor = 1e4 * ex.reference.accuracy
    vi = {round(r.h, 12): r for r in ex.rows if r.method == "vi" and r.ok}
    ra = {round(r.h, 12): r for r in ex.rows if r.method == "rattle" and r.ok}
    common = sorted(h for h in set(vi) & set(ra) if ra[h].state_err > floor)
    if not common:
        return ""
    diff = max(abs(vi[h].state_err - ra[h].state_err) / ra[h].state_err for h in common)
    cost = [vi[h].wall / ra[h].wall for h in common if ra[h].wall > 0]
    return (
        f"- vi and RATTLE are variational integrators of the same discrete Lagrangian: at the "
        f"{len(common)} common step sizes whose error is above 10⁴× the reference accuracy "
        f"their state errors differ by at most {diff:.1e} (relative), and the VI's wall time is "
        f"{min(cost):.2f}–{max(cost):.2f}× RATTLE's."
    )


def _md_orders(ex: ExampleBench) -> list[str]:
    orders = fitted_orders(ex.rows, ex.reference.accuracy)
    rows = [[m, _fmt(orders.get(m), ".3f"), f"{ORDERS[m]:g}"] for m in FIXED]
    title = "Fitted order (slope of log state error against log h, errors in 100× reference "
    title += "accuracy … 1e-2):"
    return [title, "", *_table(("method", "fitted", "expected"), rows)]


def _md_energy_vs_scipy(ex: ExampleBench) -> list[str]:
    peer = "scipy-DOP853"
    methods = list(dict.fromkeys(r.method for r in ex.rows))
    head = ["method", *[f"≤ {t:.0e}" for t in _targets(ex, "rel_dE")]]
    rows = []
    base = {
        t: cheapest([r for r in ex.rows if r.method == peer], "rel_dE", t)
        for t in _targets(ex, "rel_dE")
    }
    for m in methods:
        cells = [m]
        for t in _targets(ex, "rel_dE"):
            r = cheapest([x for x in ex.rows if x.method == m], "rel_dE", t)
            b = base[t]
            ratio = f" ({_speedup(b.wall / r.wall)})" if r and b and m != peer else ""
            cells.append(_ms(r.wall) + ratio if r else "—")
        rows.append(cells)
    title = (
        f"Time to reach a relative energy error (cheapest measured run; in brackets: how many "
        f"times faster than {peer} on the emitted NumPy right-hand side, measured in this run):"
    )
    return [title, "", *_table(head, rows)]


def _speedup(ratio: float) -> str:
    return f"{ratio:.3g}× faster" if ratio >= 1 else f"{1 / ratio:.3g}× slower"


def _md_per_step(ex: ExampleBench) -> list[str]:
    rows = [
        [
            r["method"],
            _fmt(r.get("c_us")),
            _fmt(r.get("numpy_us")),
            _times(r.get("numpy_over_c")),
            _fmt(r.get("reference_us")),
            _times(r.get("reference_over_c")),
        ]
        for r in ex.per_step
    ]
    head = (
        "method",
        "C µs/step",
        "NumPy µs/step",
        "NumPy / C",
        "reference µs/step",
        "reference / C",
    )
    first = ex.per_step[0] if ex.per_step else {"h": math.nan, "steps": 0}
    title = (
        f"Time per step: the same {first['steps']} steps of h = {first['h']:.4g} on each backend, "
        "side by side in this run; (best of N steps − best of 1 step)/(N − 1), so the per-call "
        "overhead is excluded (rk45: tol 1e-8, best wall / accepted steps):"
    )
    return [title, "", *_table(head, rows)]


def _md_pydy(ex: ExampleBench) -> list[str]:
    p = ex.pydy
    if p.get("status") != "ok":
        return [f"PyDy: {p.get('status', 'not run')}."]
    line = (
        f"PyDy ({p['generator']} generator): derivation with Kane's method "
        f"{p['derive_s']:.2f} s, code generation + compilation {p['generate_s']:.2f} s"
    )
    if "lambdify_generate_s" in p:
        line += f" (lambdify generator: {p['lambdify_generate_s']:.2f} s)"
    line += f". {p['note']}" if p.get("note") else "."
    line += (
        f" Angles: q = Ry(b) Rx(a) e3, poles at ±e2; the trajectory stays "
        f"{p.get('pole_distance', math.nan):.3f} rad from them."
    )
    return [line]


def _md_example(ex: ExampleBench, out: Path) -> list[str]:
    ref = ex.reference
    intro = (
        f"Reference: our C RK45 (Hairer control, tol {REF_RTOL:g}); vi4 at small steps agrees "
        f"to {ref.accuracy:.2e} (state norm). Largest kinetic energy along it "
        f"{ref.kinetic_scale:.4g} (divides energy errors). ![work-precision](wp_{ex.name}.png)"
    )
    if np.isfinite(ex.call_overhead):
        intro += (
            f" Each of our timings includes a fixed per-call cost (output arrays, ctypes) of "
            f"{ex.call_overhead * 1e6:.0f} µs, measured as the best one-step call; it dominates "
            "the runs below about ten times that."
        )
    lines = [f"## {ex.name} (n = {ex.system.n}, T = {ref.T:g})", "", intro, ""] if ex.rows else []
    if ex.rows:
        head = (
            "state error",
            "fastest (wall)",
            "its time",
            "fewest gradient evals",
            "best VI",
            "best VI / fastest",
        )
        lines += ["### Winners per accuracy", "", *_table(head, _winner_rows(ex, "state_err")), ""]
        head2 = ("rel. energy error", *head[1:])
        lines += [*_table(head2, _winner_rows(ex, "rel_dE")), ""]
        lines += ["### Where the VI loses and where it wins (generated from the rows above)", ""]
        lines += findings(ex, "state_err") + findings(ex, "rel_dE")
        lines += [_vi_vs_rattle(ex), ""]
        lines += _md_orders(ex) + [""] + _md_energy_vs_scipy(ex) + [""]
        lines += _md_per_step(ex) + [""] + _md_pydy(ex) + [""]
        lines += _md_all_runs(ex)
    if ex.long:
        lines += _md_long(ex)
    return lines


def _md_all_runs(ex: ExampleBench) -> list[str]:
    rows = [
        [
            r.method,
            r.setting,
            str(r.steps),
            str(r.evals),
            _fmt(r.newton_per_step, ".2f"),
            _ms(r.wall),
            _fmt(r.state_err, ".2e"),
            _fmt(r.max_dE, ".2e"),
            _fmt(r.rel_dE, ".2e"),
            r.status,
        ]
        for r in ex.rows
    ]
    head = (
        "method",
        "setting",
        "steps",
        "grad evals",
        "Newton/step",
        "wall",
        "state error",
        "max abs dE",
        "rel dE",
        "status",
    )
    return ["<details><summary>All runs</summary>", "", *_table(head, rows), "", "</details>", ""]


def _md_long(ex: ExampleBench) -> list[str]:
    rows = []
    for s in ex.long:
        final = s.running_max()[-1] if s.dE else math.nan
        rows.append(
            [
                s.label,
                str(s.steps or "—"),
                str(s.evals),
                f"{s.wall:.2f} s",
                _fmt(final, ".2e"),
                _fmt(s.slope(), ".2f"),
                _fmt(max(s.unit, default=math.nan), ".1e"),
                _fmt(max(s.qw, default=math.nan), ".1e"),
                _fmt(np.nanmax(s.dL) if s.dL else math.nan, ".1e"),
                s.status,
            ]
        )
    head = (
        "run",
        "steps",
        "grad evals",
        "wall",
        "max abs dE",
        "drift slope",
        "max unit err",
        "max q.w",
        "max dL",
        "status",
    )
    return [
        f"### Long time ({ex.name}) ![long](long_{ex.name}.png)",
        "",
        (
            "Drift slope: least-squares slope of log(running max |E − E0|) against log t over the "
            "last two decades of time (0: bounded; 1: linear drift). dL: conserved components only. "
            "Runs go in windows that double in length (each continues from the last state); the "
            "table keeps window maxima. rk45: our C, Hairer control. DOP853: scipy's `solve_ivp` "
            "on the emitted C right-hand side through ctypes, so its wall time is mostly Python's "
            "and its equal-cost comparison counts gradient evaluations (the VI's Newton iterations "
            "are not counted there; the wall-time comparison with rk45 includes them)."
        ),
        "",
        *_table(head, rows),
        "",
        "Crossover:",
        "",
        *[f"- {n}" for n in ex.long_notes],
        "",
    ]


def _envelope_summary(rows: Sequence[StabRow], case: StabilityCase) -> str:
    """'; widest envelope: M (h = ...); the VI's: ... (x of it)' from the measured sweeps."""
    best = {
        m: largest_stable([r for r in rows if r.case == case.label and r.method == m])
        for m in FIXED
    }
    found = {m: b for m, b in best.items() if b is not None}
    if case.skipped or not found:
        return ""
    top = max(found, key=lambda m: found[m].h)
    vi = found.get("vi")
    text = f"; widest envelope: {top} (h = {found[top].h:.3g})"
    if vi is not None and top != "vi":
        text += f", the VI's h = {vi.h:.3g} is {vi.h / found[top].h:.2f} of it"
    per_eval = max(found, key=lambda m: found[m].h / EVALS_PER_STEP[m])
    text += f"; per gradient evaluation: {per_eval} (h/evals = "
    return text + f"{found[per_eval].h / EVALS_PER_STEP[per_eval]:.3g})"


def _md_stability(rows: Sequence[StabRow], cases: Sequence[StabilityCase]) -> list[str]:
    table = []
    for case in (c for c in cases if not c.skipped):
        for m in FIXED:
            part = [r for r in rows if r.case == case.label and r.method == m]
            best = largest_stable(part)
            fail = next((r for r in part if r.status != "ok" and (not best or r.h > best.h)), None)
            table.append(
                [
                    case.label,
                    m,
                    _fmt(best.h if best else None, ".3g"),
                    _fmt(best.h_wmax if best else None, ".3g"),
                    _fmt(best.h / EVALS_PER_STEP[m] if best else None, ".3g"),
                    _fmt(best.newton_per_step if best else None, ".2f"),
                    fail.status if fail else "none up to the sweep's end",
                ]
            )
    head = (
        "case",
        "method",
        "largest stable h",
        "h·max‖ω‖",
        "h per gradient eval",
        "Newton/step there",
        "what broke first",
    )
    notes = [
        f"- {c.label}: {c.note}, T = {c.T:g}"
        + (f"; not swept: {c.skipped}" if c.skipped else "")
        + _envelope_summary(rows, c)
        for c in cases
    ]
    return [
        "## Stability envelope",
        "",
        (
            "h grows by 2^(1/4) from a stable start until the run fails: explicit update infeasible, "
            "Newton not converged, non-finite state, or error > 1 (error: the largest of |q − q_ref|∞ "
            "at T, |ω − ω_ref|∞/max‖ω‖ and max|E − E0|/max kinetic energy; reference: C RK45, tol "
            "1e-11). max‖ω‖ is taken along the reference. ![stability](stability.png)"
        ),
        "",
        *notes,
        "",
        *_table(head, table),
        "",
    ]


def _md_scaling(rows: Sequence[ScaleRow]) -> list[str]:
    table = [
        [
            r.family,
            str(r.n),
            f"{r.create_s:.2f}",
            _fmt(r.emit_s, ".2f"),
            _fmt(r.gcc_s, ".2f"),
            str(r.c_bytes),
            _fmt(r.vi_us),
            _fmt(r.rk4_us),
            r.status,
        ]
        for r in rows
    ]
    head = (
        "system",
        "n",
        "build System [s]",
        "derive+emit [s]",
        "gcc [s]",
        "C bytes",
        "vi µs/step",
        "rk4 µs/step",
        "status",
    )
    rod20 = next((r for r in rows if r.family == "rod" and r.n == 20 and r.status == "ok"), None)
    ours = (
        f"Ours for the rod at n = 20, measured in this run: derive + emit {rod20.emit_s:.2f} s, "
        f"gcc {rod20.gcc_s:.2f} s."
        if rod20
        else "The rod at n = 20 was not measured in this run."
    )
    quoted = "; ".join(f"{name}: {what}" for name, what in PUBLISHED_N20)
    return [
        "## Scaling with n",
        "",
        (
            "Generation in a fresh build cache (SymPy caches cleared between sizes); per step: best "
            "of 3 on the emitted C. ![scaling](scaling.png)"
        ),
        "",
        *_table(head, table),
        "",
        f"{ours} Published figures for n = 20, quoted and not measured here: {quoted}.",
        "",
    ]


def _machine() -> str:
    from .build import compiler

    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    import scipy
    import sympy

    vers = (
        f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}, "
    )
    vers += f"SymPy {sympy.__version__}"
    with contextlib.suppress(Exception):
        import pydy

        vers += f", PyDy {pydy.__version__}"
    return f"{cpu}, {os.cpu_count()} cores; {compiler()[1]}; {vers}"


def write_markdown(report: BenchReport) -> Path:
    """bench.md: the command, the machine, and every section that ran."""
    lines = [
        "# s2gen bench",
        "",
        f"Command: `{report.command}`",
        "",
        f"Machine: {_machine()}.",
        "",
        (
            "Every number below was measured by this command in this run; ratios compare runs made "
            "side by side. Timings are best-of-k wall times of the integration call on a noisy "
            "2-core machine."
        ),
        "",
        (
            "Definitions: state error = ‖(q, ω)(T) − reference‖₂ over all 6n components; energy "
            "error = max |E − E0| over every step (fixed-step methods) or over T/200-spaced samples "
            "(RK45, scipy, PyDy), and relative: divided by the largest kinetic energy along the "
            "reference; gradient evaluations: ours from the integrator's counters, peers' = "
            "right-hand-side evaluations. vi4 = 4th-order Yoshida composition of the VI; "
            "rk45-hairer/-matlab = our Dormand–Prince with scipy/Hairer's or MATLAB's error control; "
            "scipy-* = `solve_ivp` on the emitted NumPy `rhs`; pydy-* = PyDy's generated "
            "right-hand side in angles, integrated with odeint (LSODA) or DOP853."
        ),
        "",
    ]
    for ex in report.examples:
        lines += _md_example(ex, report.out)
    if report.stability:
        lines += _md_stability(report.stability, report.stability_cases)
    if report.scaling:
        lines += _md_scaling(report.scaling)
    path = report.out / "bench.md"
    path.write_text("\n".join(lines).rstrip() + "\n")
    return path


# ---------------------------------------------------------------------------------- driver
@dataclass
class BenchReport:
    """What one `s2gen bench` run measured and wrote."""

    out: Path
    command: str
    examples: list[ExampleBench] = field(default_factory=list)
    stability: list[StabRow] = field(default_factory=list)
    stability_cases: list[StabilityCase] = field(default_factory=list)
    scaling: list[ScaleRow] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


def bench(
    examples: Sequence[str] = (),
    out: str | Path = "out/bench",
    quick: bool = False,
    *,
    sweeps: bool = True,
    long: bool = False,
    steps: int | None = None,
    tight: float = 1e-10,
    stability_envelope: bool = False,
    scale: bool = False,
    T: float | None = None,
    pydy_generator: str = "auto",
    command: str | None = None,
    log: Log = _print,
) -> BenchReport:
    """Run the requested measurements and write CSV, Markdown and PNG files into `out`.

    Example:
        >>> report = bench(["double_pendulum"], "out/b", quick=True)  # doctest: +SKIP
        >>> [p.name for p in report.files]  # doctest: +SKIP
        ['bench.csv', 'per_step.csv', 'wp_double_pendulum.png', 'bench.md']
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    names = list(examples) or list(DEFAULT_EXAMPLES)
    cmd = command or "s2gen bench " + " ".join(names) + (" --quick" if quick else "")
    report = BenchReport(folder, cmd)
    for name in names if sweeps or long else ():
        if sweeps:
            ex = work_precision(name, quick, T, pydy_generator, log)
        else:
            system = example_system(name)
            ex = ExampleBench(name, system, Reference(system, 0.0, np.zeros(0), 0, 1, 0, 0))
        if long:
            n = steps or (10**5 if quick else 10**6)
            ex.long, ex.long_notes = long_time(name, n, tight, log)
        report.examples.append(ex)
    if stability_envelope:
        report.stability, report.stability_cases = stability(quick, log)
    if scale:
        report.scaling = scaling(quick, log)
    report.files = write_tables(report) + write_plots(report)
    report.files.append(write_markdown(report))
    return report


def add_parser(subparsers: Any) -> None:
    """Register `s2gen bench` on an argparse subparsers object (the CLI calls `run`).

    Example:
        >>> p = argparse.ArgumentParser()
        >>> add_parser(p.add_subparsers(dest="command"))
        >>> p.parse_args(["bench", "--quick"]).quick
        True
    """
    b = subparsers.add_parser(
        "bench",
        help="work-precision, long-time, stability and scaling benchmarks against peers",
        description="Measure every integrator (emitted C) and the outside peers (scipy, PyDy) "
        "over sweeps of h or tolerance; write bench.csv, bench.md and PNG plots to --out.",
    )
    b.add_argument(
        "examples",
        nargs="*",
        metavar="EXAMPLE",
        help=f"built-in systems (default: {' '.join(DEFAULT_EXAMPLES)})",
    )
    b.add_argument("--out", default="out/bench", help="output folder (default out/bench)")
    b.add_argument("--quick", action="store_true", help="short horizons and sweeps (~a minute)")
    b.add_argument("--T", type=float, help="horizon of the work-precision sweeps")
    b.add_argument("--no-sweeps", action="store_true", help="skip the work-precision sweeps")
    b.add_argument("--long", action="store_true", help="long-time runs (energy drift, crossover)")
    b.add_argument("--steps", type=int, help="steps of the long runs (default 1e6; quick 1e5)")
    b.add_argument(
        "--tight",
        type=float,
        default=1e-10,
        help="tolerance of the long RK45 and DOP853 runs (default 1e-10)",
    )
    b.add_argument("--stability", action="store_true", help="stability envelope on hard cases")
    b.add_argument("--scaling", action="store_true", help="generation and step time against n")
    b.add_argument(
        "--pydy-generator",
        choices=("auto", "cython", "lambdify"),
        default="auto",
        help="PyDy code generator (auto: cython if it builds; quick: lambdify)",
    )


def _command(args: argparse.Namespace) -> str:
    """The `s2gen bench` command line equivalent to parsed arguments."""
    parts = ["s2gen", "bench", *args.examples, "--out", str(args.out)]
    flags = ("quick", "no_sweeps", "long", "stability", "scaling")
    parts += [f"--{f.replace('_', '-')}" for f in flags if getattr(args, f)]
    for key in ("T", "steps"):
        if getattr(args, key) is not None:
            parts += [f"--{key}", str(getattr(args, key))]
    if args.tight != 1e-10:
        parts += ["--tight", str(args.tight)]
    if args.pydy_generator != "auto":
        parts += ["--pydy-generator", args.pydy_generator]
    return " ".join(parts)


def run(args: argparse.Namespace) -> int:
    """Carry out `s2gen bench` from parsed arguments; 0 on success, 2 on a bad example name."""
    start = time.perf_counter()
    command = "s2gen " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["bench"] else _command(args)
    try:
        report = bench(
            args.examples,
            args.out,
            args.quick,
            sweeps=not args.no_sweeps,
            long=args.long,
            steps=args.steps,
            tight=args.tight,
            stability_envelope=args.stability,
            scale=args.scaling,
            T=args.T,
            pydy_generator=args.pydy_generator,
            command=command,
        )
    except SpecError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"done in {time.perf_counter() - start:.1f} s; outputs in {report.out}/:")
    for path in report.files:
        print(f"  {path}")
    return 0
