"""Run a system with one backend: compiled models, `simulate`, `Trajectory`.

Input: a `System`, a method (see `s2gen.methods`), a backend ("c": emitted C compiled and
loaded with ctypes; "numpy": the emitted NumPy module; "reference": the independent
`s2gen.reference`), step size, horizon and options. Output: a `Trajectory` (t, q, omega,
energy, statistics, wall time). A failure raises `IntegrationError`, which names the step and
why and keeps the trajectory computed so far (`.partial`). A method a backend does not have is
refused before anything runs.

Example:
    >>> from s2gen.systems import builtin
    >>> tr = simulate(builtin("double_pendulum"), method="vi", backend="c", h=0.01, T=0.1)
    >>> tr.q.shape
    (11, 2, 3)
"""

from __future__ import annotations

import functools
import time
from typing import Any, Protocol

import numpy as np

from s2gen.methods import BACKENDS, CONTROLS, NAMES, Status, check_method
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import IntegrationError, Trajectory
from s2gen.system import System

__all__ = [
    "BACKENDS",
    "CONTROLS",
    "METHODS",
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
    q = system.q0 if q0 is None else np.asarray(q0, dtype=float)
    w = system.omega0 if omega0 is None else np.asarray(omega0, dtype=float)
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
    if not (h > 0 and T > 0):
        raise ValueError(f"h and T must be positive (got h={h}, T={T})")
    nsteps = round(T / h)
    if abs(nsteps * h - T) > 1e-9 * T:
        raise ValueError(f"T={T} is not a whole number of steps h={h}")
    if not (isinstance(every, int) and every >= 1 and nsteps % every == 0):
        raise ValueError(f"every={every!r} must be a positive divisor of the {nsteps} steps")
    opts = options or Options()
    q0, omega0 = _initial_state(system, q0, omega0, opts.unit_tol)
    p = np.array(system.parameter_values if params is None else params, dtype=float)
    if p.shape != (len(system.parameter_names),):
        raise ValueError(
            f"{system.name}: expected {len(system.parameter_names)} parameter values "
            f"({', '.join(system.parameter_names)}), got {p.size}"
        )
    start = time.perf_counter()
    status, q, w, en, stats = be.integrate(method, h, nsteps, q0, omega0, p, opts, every, energy)
    wall = time.perf_counter() - start
    t = h * every * np.arange(nsteps // every + 1)
    if status != 0:
        k = int(stats.get("fail_step", 0))
        kept = None if en is None else en[:k]
        partial = Trajectory(t[:k], q[:k], w[:k], kept, method, backend, h, stats, wall)
        why = Status(status).message if status in Status._value2member_map_ else status
        last = f"after t = {t[k - 1]:.6g}" if k else "at the initial state"
        raise IntegrationError(
            f"{method} ({backend}) failed {last}: {why}; the {k} valid samples are kept",
            status,
            k,
            partial,
        )
    return Trajectory(t, q, w, en, method, backend, h, stats, wall)
