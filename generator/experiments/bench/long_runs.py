"""How a long run is carried out: in windows that double in length, keeping window maxima.

Input: a `LongSetup` (system, state, conserved momentum components), a method with its step
or tolerance, and the window ends. Output: a `LongSeries` per run with the window maxima of
|E − E0|, | |q_i| − 1 |, |q_i · ω_i| and |L − L0| (conserved components), the steps, gradient
evaluations and wall time. Every run is on the emitted C (RK45 under Hairer's control,
DOP853); a run can be continued to a later horizon from where it stopped. Progress lines go
to `log`.

Example:
    >>> _windows(1000)
    [64, 128, 256, 512, 40]
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from s2gen import IntegrationError, Options, System, Trajectory, simulate
from s2gen.inspect import get_backend

from .common import Log, _why
from .model import LongSeries, LongSetup


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

    def run(self, method: str, h: float, T: float, options: Options | None = None) -> Trajectory:
        """One window on the emitted C from the current state (raises `IntegrationError`);
        the state is taken as it is (RK states drift off unit length by design), and a drifting
        energy does not warn (the series measures it)."""
        return simulate(
            self.system,
            method,
            "c",
            h=h,
            T=T,
            options=replace(options or Options(), unit_tol=0.0, energy_warn=0.0),
            params=self.params,
            q0=self.q,
            omega0=self.w,
        )

    def add(self, t_end: float, out: Trajectory) -> None:
        """Count a window run by `run` (wall time, gradient evaluations) and record it."""
        self.series.wall += out.wall_time
        self.series.evals += int(out.stats.get("gradient_evals", 0))
        self.window(t_end, out.q, out.omega, out.energy)


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


def _long_fixed(tr: _Tracker, h: float, more_steps: int, log: Log) -> LongSeries:
    """`more_steps` steps of h from where the run stopped (windows doubling from 64 steps, or
    from half the steps done when continuing)."""
    s = tr.series
    done = s.steps
    prog = _Progress(s.label, (done + more_steps) * h, log)
    first = 64 if done == 0 else min(2**17, max(64, done // 2))
    for n in _windows(more_steps, first):
        if s.status != "ok":
            break
        try:
            out = tr.run(s.method, h, n * h)
        except IntegrationError as exc:
            s.status = f"{_why(exc)} in the window from step {done}"
            break
        done += n
        s.steps = done
        tr.add(done * h, out)
        prog(done * h)
    return s


def _long_adaptive(tr: _Tracker, ends: Sequence[float], log: Log) -> LongSeries:
    """The run's adaptive method (RK45 under Hairer's control, or DOP853) at its tolerance,
    one call per window up to each of `ends` beyond where it stopped, 32 samples a window."""
    s = tr.series
    prog = _Progress(s.label, ends[-1], log)
    opts = Options(rtol=s.rtol, atol=s.rtol, control="hairer")
    for t_end in ends:
        span = t_end - tr.t
        if s.status != "ok" or span <= 0:
            continue
        try:
            out = tr.run(s.method, span / 32, span, opts)
        except IntegrationError as exc:
            s.status = f"{_why(exc)} in the window ending at t = {t_end:g}"
            break
        s.steps += int(out.stats.get("steps", 0))
        tr.add(t_end, out)
        prog(t_end)
    return s


def _long_transformed(tr: _Tracker, ends: Sequence[float], log: Log) -> LongSeries:
    """The run's time-transformed method at its fictitious step eps (the series' h), one call
    per window up to each of `ends` (rounded down to the grid of eps) beyond where it stopped,
    at most about 32 samples a window (every sample spacing that divides the window; each
    sample is reached by one extra step, counted in the evaluations).
    Each call starts the step-size variable xi afresh at the monitor of its first state, so
    the chain is reversible within a window and restarted at its end (a few dozen windows)."""
    s = tr.series
    eps = s.h
    prog = _Progress(s.label, ends[-1], log)
    for t_end in ends:
        n = math.floor(t_end / eps + 1e-9) - round(tr.t / eps)
        if s.status != "ok" or n <= 0:
            continue
        every = max(d for d in range(1, max(1, n // 32) + 1) if n % d == 0)
        try:
            out = simulate(
                tr.system,
                s.method,
                "c",
                h=eps,
                T=n * eps,
                every=every,
                options=Options(unit_tol=0.0, energy_warn=0.0),
                params=tr.params,
                q0=tr.q,
                omega0=tr.w,
            )
        except IntegrationError as exc:
            s.status = f"{_why(exc)} in the window ending at t = {t_end:g}"
            break
        s.steps += int(out.stats.get("steps", 0))
        tr.add(tr.t + n * eps, out)
        prog(tr.t)
    return s


def _tracker(setup: LongSetup, label: str, method: str, h: float, rtol: float) -> _Tracker:
    series = LongSeries(setup.name, label, method, h, rtol)
    p = np.array(setup.system.parameter_values, dtype=float)
    tr = _Tracker(series, setup.system, p, setup.conserved, setup.q0.copy(), setup.w0.copy())
    tr.start()
    return tr
