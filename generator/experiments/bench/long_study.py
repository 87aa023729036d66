"""Long-time behaviour of one example: drift of the invariants and the crossover with RK.

Input: an example name, a number of steps and the tolerance of the tight adaptive runs.
Output: the `LongSeries` of vi, vi4, RATTLE and RK4 at the system's h, of RK45 and DOP853 at
the tolerance, and of vi/vi4 at equal cost with each tight RK, plus notes: the setup (a
replacement initial state when the example's own collides) and where the VI's energy error
becomes the smaller (`crossover`).

Example:
    >>> series, notes = long_time("double_pendulum", 2000, log=lambda s: None)  # doctest: +SKIP
    >>> len(series)  # doctest: +SKIP
    10
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from s2gen.runtime import IntegrationError, Options, get_backend, simulate
from s2gen.system import System

from .common import Log, _fmt, _print, _why, example_system
from .long_runs import _long_dop853, _long_fixed, _long_rk45, _tracker, _windows
from .model import LongSeries, LongSetup


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
