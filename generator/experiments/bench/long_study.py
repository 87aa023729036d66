"""Long-time behaviour of one example: drift of the invariants and the crossover with RK.

Input: an example name, a number of steps, the tolerance of the tight adaptive runs and the
most steps a crossover run may take. Output: the `LongSeries` of the VI family (the VI, RATTLE
and their compositions) and RK4 at the system's h, of RK45 and DOP853 (emitted C) at the
tolerance, and, where the emitted C has them, of the time-transformed `LONG_TRANSFORMED` at
`LONG_EPS`; the crossovers with RK45 and DOP853 at equal energy error (`crossover.py`), with the
runs that decided them; notes: the setup (a replacement initial state when the example's own
collides) and one per crossover.

Example:
    >>> series, notes, found = long_time("double_pendulum", 2000, log=lambda s: None)  # doctest: +SKIP
    >>> [c.rk for c in found]  # doctest: +SKIP
    ['rk45', 'rk45', 'dop853', 'dop853']
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from s2gen import IntegrationError, Options, System, simulate
from s2gen.inspect import get_backend

from .common import Log, _fmt, _print, _why, example_system
from .crossover import CROSSOVER_TARGETS, Crossover, crossovers
from .long_runs import _long_adaptive, _long_fixed, _long_transformed, _tracker, _windows
from .model import VI_FAMILY, LongSeries, LongSetup
from .sweeps import has_transformed

#: Methods of the long runs at the system's step.
LONG_FIXED = (*VI_FAMILY, "rk4")
#: The tight adaptive runs the VI family is measured against.
LONG_ADAPTIVE = ("rk45", "dop853")
#: The time-transformed methods of the long runs, where the emitted C has them, and their
#: fictitious step: eps is in units of the fastest pair's phase (s2gen.monitor), so 0.1 takes
#: at least 2 pi / 0.1 = 63 steps per period of the fastest pair whatever the system's h.
#: rattle4-adaptive runs beside vi4-adaptive: the same discrete flow by RATTLE's operations,
#: so its energy error is the VI's and the two rows compare their cost over the long run.
LONG_TRANSFORMED = ("vi4-adaptive", "rattle4-adaptive", "vi8-adaptive")
LONG_EPS = 0.1


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
    name: str,
    steps: int,
    tight: float = 1e-10,
    log: Log = _print,
    crossover_steps: int = 10**7,
    targets: tuple[float, ...] = CROSSOVER_TARGETS,
) -> tuple[list[LongSeries], list[str], list[Crossover]]:
    """Long runs (the VI family and RK4 at the system's h; RK45 and DOP853 at tolerance
    `tight`), then the crossovers with RK45 and DOP853 at each relative energy error of
    `targets` (VI-family runs of at most `crossover_steps` steps); returns the series (the
    crossovers' deciding runs included), notes and crossovers.

    Example:
        >>> series, notes, found = long_time("double_pendulum", 2000, log=lambda s: None,
        ...                                  targets=())
        >>> [s.method for s in series][:5]
        ['vi', 'vi4', 'vi6', 'vi8', 'rattle']
    """
    setup = long_setup(name, steps, log)
    h = setup.h
    log(
        f"{name}: long time, {steps} steps of h = {h:g} (T = {setup.T:g}); conserved L "
        f"components {[c + 1 for c in setup.conserved]}"
    )
    out: list[LongSeries] = []
    for method in LONG_FIXED:
        out.append(
            _long_fixed(_tracker(setup, f"{method} h={h:g}", method, h, math.nan), h, steps, log)
        )
        log(_long_line(out[-1]))
    ends = list(np.cumsum(_windows(steps)) * h)
    for method in LONG_ADAPTIVE:
        tr = _tracker(setup, f"{method} tol={tight:g}", method, math.nan, tight)
        out.append(_long_adaptive(tr, ends, log))
        log(_long_line(out[-1]))
    if has_transformed(setup.system):
        for method in LONG_TRANSFORMED:
            tr = _tracker(setup, f"{method} eps={LONG_EPS:g}", method, LONG_EPS, math.nan)
            out.append(_long_transformed(tr, ends, log))
            log(_long_line(out[-1]))
    notes = [setup.note] if setup.note else []
    found: list[Crossover] = []
    if targets:
        for rk in LONG_ADAPTIVE:
            found += crossovers(setup, rk, targets, crossover_steps, log)
    out += [run for c in found for run in c.runs]
    notes += [c.note() for c in found]
    return out, notes, found


def _long_line(s: LongSeries) -> str:
    final = s.running_max()[-1] if s.dE else math.nan
    return (
        f"    {s.label:30s} {s.steps:>9d} steps {s.evals:>10d} evals {s.wall:8.2f} s  "
        f"max|dE| {final:.2e}  slope {_fmt(s.slope(), '.2f')}  {s.status}"
    )
