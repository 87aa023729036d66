"""Run a system with one backend: compiled models, `simulate`, `Trajectory`.

Input: a `System`, a method (see `s2gen.methods`), a backend ("c": emitted C compiled and
loaded with ctypes; "numpy": the emitted NumPy module; "reference": the independent
`s2gen.reference`), step size, horizon and options. Output: a `Trajectory` (t, q, omega,
energy, statistics, wall time). A failure raises `IntegrationError`, which names the step and
why and keeps the trajectory computed so far (`.partial`); a stored sample whose energy is not
finite while its state is counts as such a failure (status NONFINITE). Bad arguments raise
ValueError before anything runs: a method a backend does not have, h or T not positive and
finite, more than `MAX_STEPS` steps, samples that would take more than half of the machine's
memory, parameters of the wrong count or not finite, an initial state of the wrong shape or not
unit, and options out of range (RK45 tolerances below `RTOL_FLOOR` = 100 eps and `ATOL_FLOOR`).

Example:
    >>> from s2gen.systems import builtin
    >>> tr = simulate(builtin("double_pendulum"), method="vi", backend="c", h=0.01, T=0.1)
    >>> tr.q.shape
    (11, 2, 3)
"""

from __future__ import annotations

import functools
import math
import numbers
import os
import time
from typing import Any, Protocol

import numpy as np

from s2gen.methods import BACKENDS, CONTROLS, NAMES, Status, check_method
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import IntegrationError, Trajectory
from s2gen.system import System

__all__ = [
    "ATOL_FLOOR",
    "BACKENDS",
    "CONTROLS",
    "MAX_STEPS",
    "METHODS",
    "RTOL_FLOOR",
    "Backend",
    "IntegrationError",
    "Options",
    "Trajectory",
    "get_backend",
    "run",
    "simulate",
]

#: Method names (the table is `s2gen.methods.METHODS`).
METHODS = NAMES
#: The smallest RK45 relative tolerance (100 eps, as MATLAB's ode45): below it the error
#: estimate is round-off and the step size shrinks without end.
RTOL_FLOOR = 100 * float(np.finfo(float).eps)
#: The smallest RK45 absolute tolerance: below it, round-off in components that should stay 0
#: drives the step size toward 0 (four pendula at rtol = RTOL_FLOOR over T = 1: 4,600 steps
#: at atol = 1e-20, 2.3 million at 1e-40; at 1e-300 it never finished).
ATOL_FLOOR = 1e-20
#: The most steps one run may take (the emitted C counts them in a long).
MAX_STEPS = 2**62


class Backend(Protocol):
    """What every backend offers (C, NumPy, reference)."""

    name: str
    system: System

    def integrate(
        self,
        method_name: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
        every: int = 1,
        with_energy: bool = True,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray | None, dict[str, int]]: ...

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float: ...

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray: ...

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray: ...


@functools.lru_cache(maxsize=16)
def _backend_cached(system: System, name: str) -> Backend:
    if name == "c":
        from s2gen.runtime.c import CBackend

        return CBackend(system)
    if name == "numpy":
        from s2gen.runtime.numpy_module import NumpyBackend

        return NumpyBackend(system)
    from s2gen.runtime.reference_backend import ReferenceBackend

    return ReferenceBackend(system)


def get_backend(system: System, name: str) -> Any:
    """The (cached) backend object of a system: "c", "numpy" or "reference"."""
    if name not in BACKENDS:
        raise ValueError(f"unknown backend {name!r}; choose one of {', '.join(BACKENDS)}")
    return _backend_cached(system, name)


def simulate(
    system: System,
    method: str = "vi",
    backend: str = "c",
    h: float | None = None,
    T: float | None = None,
    options: Options | None = None,
    params: np.ndarray | None = None,
    q0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
    every: int = 1,
    energy: bool = True,
) -> Trajectory:
    """Integrate a system from its (or the given) initial state to T with step h, keeping
    every `every`-th sample (T/h must be a multiple of it) and, with `energy`, its energy."""
    check_method(method, backend)
    return run(
        get_backend(system, backend), method, h, T, options, params, q0, omega0, every, energy
    )


def _initial_state(
    system: System, q0: np.ndarray | None, omega0: np.ndarray | None, unit_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """The initial state (given or the spec's), checked: shapes, finite values, unit q_i."""
    q, w = system.q0, system.omega0
    try:
        q = q if q0 is None else np.asarray(q0, dtype=float)
        w = w if omega0 is None else np.asarray(omega0, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"q0 and omega0 must be arrays of shape ({system.n}, 3) of numbers"
        ) from None
    if q is None or w is None:
        raise ValueError(f"{system.origin}: no initial state ([initial] q and omega)")
    for name, a in (("q0", q), ("omega0", w)):
        if a.shape != (system.n, 3):
            raise ValueError(f"{name} must have shape ({system.n}, 3), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains a non-finite value")
    if unit_tol > 0.0:
        off = np.abs(np.linalg.norm(q, axis=1) - 1.0)
        bad = np.flatnonzero(~(off <= unit_tol))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"q0 of body {i + 1} has length {np.linalg.norm(q[i]):.17g}, not 1 to within "
                f"{unit_tol:g} (normalize it, or set Options.unit_tol)"
            )
    return q, w


def _positive_number(value: Any, what: str) -> float:
    """`value` as a finite positive float (ValueError naming `what` otherwise)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{what} must be a positive number, got {value!r}")  # noqa: TRY004
    number = float(value)
    if not (math.isfinite(number) and number > 0.0):
        raise ValueError(f"{what} must be a positive finite number, got {value!r}")
    return number


def _check_options(opts: Options) -> None:
    """Integrator options within their documented ranges (ValueError naming the field)."""
    if not isinstance(opts, Options):
        raise ValueError(  # noqa: TRY004 (bad input is a ValueError: the CLI reports those)
            f"options must be an s2gen.Options, got {type(opts).__name__}"
        )
    rtol = _positive_number(opts.rtol, "Options.rtol")
    atol = _positive_number(opts.atol, "Options.atol")
    if rtol < RTOL_FLOOR:
        raise ValueError(
            f"Options.rtol = {rtol:g} is below the floor {RTOL_FLOOR:.3g} (100 eps): RK45 "
            "cannot meet it in double precision"
        )
    if atol < ATOL_FLOOR:
        raise ValueError(
            f"Options.atol = {atol:g} is below the floor {ATOL_FLOOR:g}: round-off would drive "
            "the RK45 step size toward 0"
        )
    if opts.control not in CONTROLS:
        raise ValueError(f"Options.control = {opts.control!r} is not one of {', '.join(CONTROLS)}")
    hmax = opts.hmax
    if not (isinstance(hmax, numbers.Real) and math.isfinite(float(hmax)) and float(hmax) >= 0):
        raise ValueError(f"Options.hmax must be a finite number >= 0 (0: T/10), got {opts.hmax!r}")
    _positive_number(opts.newton_tol, "Options.newton_tol")
    maxiter = opts.newton_maxiter
    if isinstance(maxiter, bool) or not isinstance(maxiter, numbers.Integral) or maxiter < 1:
        raise ValueError(f"Options.newton_maxiter must be a positive integer, got {maxiter!r}")
    if not (isinstance(opts.unit_tol, numbers.Real) and not math.isnan(opts.unit_tol)):
        raise ValueError(
            f"Options.unit_tol must be a number (<= 0: no check), got {opts.unit_tol!r}"
        )


def _parameter_values(system: System, params: Any) -> np.ndarray:
    """The parameter vector (given or the spec's), checked: its length and finite values."""
    names = system.parameter_names
    try:
        p = np.array(system.parameter_values if params is None else params, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"{system.name}: parameter values must be {len(names)} numbers "
            f"({', '.join(names) or 'none'}), got {params!r}"
        ) from None
    if p.shape != (len(names),):
        raise ValueError(
            f"{system.name}: expected {len(names)} parameter values "
            f"({', '.join(names) or 'none'}), got {p.size}"
        )
    bad = np.flatnonzero(~np.isfinite(p))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{system.name}: parameter {names[k]} = {p[k]} is not finite")
    return p


def _memory_limit() -> int:
    """Bytes a trajectory may take: half of the machine's physical memory."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (ValueError, OSError, AttributeError):
        return 8 * 2**30


def _check_size(system: System, nsteps: int, every: int, energy: bool) -> None:
    """Refuse a run whose stored samples would not fit in memory (before allocating them)."""
    samples = nsteps // every + 1
    size = samples * (6 * system.n + (1 if energy else 0)) * 8
    limit = _memory_limit()
    if size > limit:
        raise ValueError(
            f"{system.name}: {samples} samples of {system.n} bodies take {size / 2**30:.3g} GiB, "
            f"more than the limit of {limit / 2**30:.3g} GiB (half of this machine's memory); "
            "store fewer samples with every=..."
        )


def _first_nonfinite_energy(en: np.ndarray | None, valid: int) -> int | None:
    """The first of the `valid` samples whose energy is not finite (None: all finite)."""
    if en is None:
        return None
    bad = np.flatnonzero(~np.isfinite(en[:valid]))
    return int(bad[0]) if bad.size else None


def run(
    be: Backend,
    method: str = "vi",
    h: float | None = None,
    T: float | None = None,
    options: Options | None = None,
    params: np.ndarray | None = None,
    q0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
    every: int = 1,
    energy: bool = True,
) -> Trajectory:
    """`simulate` on a given backend object (a `Model` brings its own)."""
    system, backend = be.system, be.name
    check_method(method, backend)
    h = h if h is not None else system.run.h
    T = T if T is not None else system.run.T
    if h is None or T is None:
        raise ValueError(f"{system.origin}: no step size h or final time T given (spec [run])")
    h, T = _positive_number(h, "the step size h"), _positive_number(T, "the final time T")
    if T / h > MAX_STEPS:
        raise ValueError(f"T/h = {T / h:.3g} steps is more than the limit of {MAX_STEPS:.3g}")
    nsteps = round(T / h)
    if nsteps < 1 or abs(nsteps * h - T) > 1e-9 * T:
        raise ValueError(f"T={T} is not a whole number of steps h={h}")
    if (
        isinstance(every, bool)
        or not isinstance(every, numbers.Integral)
        or every < 1
        or nsteps % every != 0
    ):
        raise ValueError(f"every={every!r} must be a positive divisor of the {nsteps} steps")
    every = int(every)
    opts = Options() if options is None else options
    _check_options(opts)
    q0, omega0 = _initial_state(system, q0, omega0, opts.unit_tol)
    p = _parameter_values(system, params)
    _check_size(system, nsteps, every, energy)
    start = time.perf_counter()
    status, q, w, en, stats = be.integrate(method, h, nsteps, q0, omega0, p, opts, every, energy)
    wall = time.perf_counter() - start
    t = h * every * np.arange(nsteps // every + 1)
    k = int(stats.get("fail_step", 0)) if status != 0 else len(t)
    why = Status(status).message if status in Status._value2member_map_ else str(status)
    bad_energy = _first_nonfinite_energy(en, k)
    if bad_energy is not None:  # the state is finite there (else the backend had stopped)
        k, status = bad_energy, int(Status.NONFINITE)
        why = (
            f"the energy is not finite at t = {t[k]:.6g} while the state is (the potential or "
            "the kinetic energy is undefined there or beyond the range of a double: check V "
            "and the parameters)"
        )
        stats = {**stats, "fail_step": k}
    if status != 0:
        kept = None if en is None else en[:k]
        partial = Trajectory(t[:k], q[:k], w[:k], kept, method, backend, h, stats, wall)
        last = f"after t = {t[k - 1]:.6g}" if k else "at the initial state"
        raise IntegrationError(
            f"{method} ({backend}) failed {last}: {why}; the {k} valid samples are kept",
            status,
            k,
            partial,
        )
    return Trajectory(t, q, w, en, method, backend, h, stats, wall)
