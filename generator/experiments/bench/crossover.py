"""The horizon from which the VI family is ahead of a Runge-Kutta method at equal energy error.

Input: a `LongSetup` (system, initial state, the system's step h), targets for the relative
energy error (max |E - E0| over the run divided by the largest kinetic energy along it), the
adaptive method to beat (RK45 or DOP853, emitted C) and the most steps a VI-family run may
take. Output: one `Crossover` per target, and the `LongSeries` of the runs that decided it.

For a target eps, measured, not extrapolated:

1. the cheapest VI-family run that keeps the error below eps: for each method, the largest step
   of a grid (2^(1/8) apart, from the system's h up) at which a probe run (10^4 steps of the
   system's h) stays below eps/4 (its error is bounded, but its largest value still grows
   slowly as the run visits more of the phase space), and its wall time per unit of simulated
   time (best of 3, only the final state kept);
2. the RK's tolerances (10^(1/4) apart, 1e-3 ... 1e-13) whose probe runs cost less per unit
   time than that VI run: the tightest two run on, the horizon doubling, until their error
   exceeds eps; the later of the two times is the horizon T* up to which a Runge-Kutta run no
   more costly than the VI keeps the error, so that from T* on the VI is the cheaper at equal
   error. The chase stops at the VI's horizon after the most steps allowed ("not within");
3. the VI run itself goes on to T* (or that horizon), to check that it stays below eps.

Example:
    >>> crossover_horizon([(1e-6, 2.0, 50.0), (1e-7, 3.0, 400.0), (1e-8, 9.0, 5000.0)], 5.0)
    (1e-07, 400.0)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from s2gen import IntegrationError, Options, simulate

from .common import Log, _why, kinetic_energy
from .long_runs import _long_adaptive, _long_fixed, _Tracker, _tracker
from .model import VI_FAMILY, LongSeries, LongSetup

#: Relative energy errors at which the crossovers are measured.
CROSSOVER_TARGETS = (1e-6, 1e-9)
#: Steps of the system's h in a probe run.
PROBE_STEPS = 10**4


@dataclass
class Crossover:
    """Where the cheapest VI-family run beats `rk` at relative energy error `target`."""

    example: str
    target: float
    rk: str
    vi_method: str = ""
    vi_h: float = math.nan
    vi_cost: float = math.nan  # wall seconds per unit of simulated time
    rk_tol: float = math.nan  # the tightest tolerance cheaper than the VI
    rk_cost: float = math.nan
    horizon: float = math.nan  # T*: when that RK run exceeds the target (nan: not within)
    chased: float = math.nan  # how far the RK runs went
    vi_reached: float = math.nan  # how far the VI ran
    vi_max: float = math.nan  # its largest relative energy error up to there
    status: str = "ok"
    runs: list[LongSeries] = field(default_factory=list)

    def note(self) -> str:
        """One sentence for bench.md and the log."""
        head = f"relative energy error ≤ {self.target:g} against {self.rk}: "
        if self.status != "ok":
            return head + self.status
        vi = (
            f"the cheapest VI-family run is {self.vi_method} (h = {self.vi_h:.3g}, "
            f"{self.vi_cost * 1e6:.3g} µs per unit time); "
        )
        if math.isnan(self.rk_tol):
            return head + vi + f"every {self.rk} tolerance that reaches it costs more: the VI wins"
        rk = (
            f"the tightest {self.rk} tolerance as cheap ({self.rk_tol:.2g}, "
            f"{self.rk_cost * 1e6:.3g} µs per unit time) "
        )
        check = (
            f"; the VI ran to t = {self.vi_reached:.4g} with max error {self.vi_max:.2g}"
            f"{'' if self.vi_max <= self.target else ' (above the target: no claim)'}"
        )
        if math.isnan(self.horizon):
            return head + vi + rk + f"keeps it to t = {self.chased:.4g} (not within)" + check
        return head + vi + rk + f"exceeds it at t = {self.horizon:.4g} (crossover)" + check


def crossover_horizon(
    rk_runs: Sequence[tuple[float, float, float]], vi_cost: float
) -> tuple[float, float]:
    """(tolerance, time) of the RK run no more costly than the VI (cost per unit time) that
    keeps the error longest: rk_runs holds (tolerance, cost, time the error exceeded the
    target, inf if it never did); (nan, nan) when none is as cheap."""
    cheap = [(t, tol) for tol, cost, t in rk_runs if cost < vi_cost and not math.isnan(t)]
    if not cheap:
        return math.nan, math.nan
    t_exceed, tol = max(cheap)
    return tol, t_exceed


def _relative_max(s: LongSeries, scale: float) -> float:
    return float(s.running_max()[-1]) / scale if s.dE else math.inf


def _cost(setup: LongSetup, method: str, h: float, T: float, opts: Options | None) -> float:
    """Best of 3 wall seconds per unit time, only the final state kept."""
    n = max(1, round(T / h))
    runs = [
        simulate(
            setup.system,
            method,
            "c",
            h=h,
            T=n * h,
            options=replace(opts or Options(), unit_tol=0.0),
            q0=setup.q0,
            omega0=setup.w0,
            every=n,
            energy=False,
        )
        for _ in range(3)
    ]
    return min(r.wall_time for r in runs) / (n * h)


def _probe_fixed(setup: LongSetup, method: str, h: float, scale: float, log: Log) -> float:
    """Largest relative energy error of a probe run of `method` at step h (inf on failure)."""
    tr = _tracker(setup, f"{method} h={h:.3g} (probe)", method, h, math.nan)
    s = _long_fixed(tr, h, max(1, round(PROBE_STEPS * setup.h / h)), log)
    return _relative_max(s, scale) if s.status == "ok" else math.inf


def _cheapest_vi(
    setup: LongSetup, target: float, scale: float, log: Log
) -> tuple[str, float, float] | None:
    """(method, h, cost per unit time) of the cheapest VI-family run within target/4."""
    best: tuple[str, float, float] | None = None
    for method in VI_FAMILY:
        h, good = setup.h, math.nan
        while (
            h < PROBE_STEPS * setup.h and _probe_fixed(setup, method, h, scale, log) <= target / 2
        ):
            good, h = h, h * 2**0.25
        if math.isnan(good):
            continue
        cost = _cost(setup, method, good, PROBE_STEPS * setup.h, None)
        log(f"      {method:8s} largest h within {target / 4:g}: {good:.3g}, {cost * 1e6:.3g} µs/t")
        if best is None or cost < best[2]:
            best = (method, good, cost)
    return best


def _chase(tr: _Tracker, target: float, scale: float, start: float, cap: float, log: Log) -> float:
    """Run an adaptive run on from horizon `start`, the horizon doubling, until its relative
    energy error exceeds target (returns the end of that window) or the horizon reaches cap
    (returns inf); nan if the run fails."""
    s = tr.series
    horizon = min(start, cap)
    while s.status == "ok":
        _long_adaptive(tr, [tr.t + (horizon - tr.t) * j / 8 for j in range(1, 9)], log)
        above = [t for t, m in zip(s.t, s.running_max()) if m > target * scale]
        if above:
            return above[0]
        if horizon >= cap:
            return math.inf
        horizon = min(2 * horizon, cap)
    return math.nan


def crossovers(
    setup: LongSetup,
    rk: str,
    targets: Sequence[float] = CROSSOVER_TARGETS,
    max_steps: int = 10**7,
    log: Log = print,
) -> list[Crossover]:
    """The crossover of the VI family with `rk` at each relative energy error target."""
    opts = Options(rtol=1e-12, atol=1e-12, control="hairer")
    T_probe = PROBE_STEPS * setup.h
    ref = simulate(
        setup.system, "dop853", "c", h=T_probe / 200, T=T_probe, options=opts,
        q0=setup.q0, omega0=setup.w0,
    )  # fmt: skip
    scale = float(np.max(kinetic_energy(setup.system, ref.q, ref.omega)))
    out = []
    for target in targets:
        log(f"    crossover at relative energy error {target:g} against {rk}:")
        c = Crossover(setup.name, target, rk)
        out.append(c)
        best = _cheapest_vi(setup, target, scale, log)
        if best is None:
            c.status = "no VI-family run reaches it at the system's step or above"
            continue
        c.vi_method, c.vi_h, c.vi_cost = best
        cap = max_steps * c.vi_h
        probes = []
        for k in range(12, 53):
            tol = 10.0 ** (-k / 4)
            try:
                cost = _cost(setup, rk, T_probe / 32, T_probe, Options(rtol=tol, atol=tol))
            except IntegrationError as exc:
                log(f"      {rk} tol {tol:.2g}: {_why(exc)}")
                continue
            probes.append((tol, cost))
        cheap = sorted((p for p in probes if p[1] < c.vi_cost), key=lambda p: p[0])[:2]
        chased = []
        for tol, cost in cheap:
            tr = _tracker(setup, f"{rk} tol={tol:.2g} (chase)", rk, math.nan, tol)
            when = _chase(tr, target, scale, T_probe, cap, log)
            c.runs.append(tr.series)
            c.chased = max(tr.t, 0.0 if math.isnan(c.chased) else c.chased)
            chased.append((tol, cost, when))
            log(f"      {rk} tol {tol:.2g} ({cost * 1e6:.3g} µs/t): exceeds it at t = {when:.4g}")
        if cheap and all(math.isnan(when) for _, _, when in chased):
            c.status = f"the {rk} runs as cheap as the VI failed: no crossover"
            continue
        c.rk_tol, horizon = crossover_horizon(chased, c.vi_cost)
        if not math.isnan(c.rk_tol):
            c.rk_cost = {t: cost for t, cost, _ in chased}[c.rk_tol]
            c.horizon = horizon if math.isfinite(horizon) else math.nan
        reach = c.horizon if math.isfinite(c.horizon) else (c.chased if cheap else T_probe)
        label = f"{c.vi_method} h={c.vi_h:.3g} (crossover)"
        vi = _tracker(setup, label, c.vi_method, c.vi_h, math.nan)
        _long_fixed(vi, c.vi_h, max(1, min(max_steps, math.ceil(reach / c.vi_h))), log)
        c.runs.append(vi.series)
        c.vi_reached, c.vi_max = vi.t, _relative_max(vi.series, scale)
        log(f"      {c.note()}")
    return out
