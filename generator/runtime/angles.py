"""The emitted angle-form modules (C and NumPy) and their runner.

Input: a `System`. Output: the lowered and printed angle module, its files
(the shared templates `c/module.c.jinja`, `c/angles.h.jinja`, `numpy/module.py.jinja` with the
`_angles_*` partials, file stem ``<system>_angles``), backends
that integrate it (RK45 and RK4) and `simulate_angles`, which maps the samples back to
(q_i, omega_i = q_i x qdot_i) so that every metric is computed as for the S^2 form.

The emitted code reports the chart's singularity by status code (`ERR_POLE` when an initial q_i
is within `POLE_TOL` of a pole, `ERR_SINGULAR` when the LU pivots of M(x) span more than
1/`MIN_PIVOT_RATIO`); the runner raises `PoleError` / `AngleIntegrationError`, naming the body
and the time.

Example:
    >>> from s2gen.systems import builtin
    >>> simulate_angles(builtin("double_pendulum"), "rk4", h=0.01, T=0.1)
    ... # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    PoleError: body 2 is at a pole at t = 0 (sin theta_2 = 0): phi_2 is arbitrary and ...
"""

from __future__ import annotations

import ctypes
import functools
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from s2gen.emit import emit_angles
from s2gen.equations.angles import ANGLE_METHODS
from s2gen.ir import ModuleKind
from s2gen.methods import CONTROLS, Status
from s2gen.runtime.c import CLibrary, contiguous, pointer
from s2gen.runtime.numpy_module import import_cached
from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = [
    "AngleC",
    "AngleIntegrationError",
    "AngleNumpy",
    "AngleTrajectory",
    "PoleError",
    "angle_backend",
    "emit_angles",
    "simulate_angles",
    "to_angles",
]


def _why(status: int) -> str:
    """The message of an angle-module status (the angle form's singular M is a pole's)."""
    if status == Status.SINGULAR:
        return (
            "the angle-form mass matrix M(x) is singular or ill-conditioned (a body is near a pole)"
        )
    return Status(status).message if status in Status._value2member_map_ else f"status {status}"


# -------------------------------------------------------------------------------------- runtime
class PoleError(ValueError):
    """An angle-form state cannot be formed: a body sits at a pole (phi arbitrary)."""

    def __init__(self, body: int, time: float, sin_theta: float) -> None:
        super().__init__(
            f"body {body} is at a pole at t = {time:.6g} (sin theta_{body} = {sin_theta:.3g}): "
            f"phi_{body} is arbitrary and phi_{body}-dot undefined, so the angle form cannot "
            "represent this state"
        )
        self.body, self.time, self.sin_theta = body, time, sin_theta


@dataclass(frozen=True)
class AngleTrajectory:
    """Angle-form samples on t_k = k h, and the same states as (q, omega) (N+1, n, 3).

    `energy` is the angle module's own T + V; `counts` (N+1, 2) the cumulative accepted and
    rejected RK45 steps at each sample (RK4: steps, 0).
    """

    t: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray
    counts: np.ndarray
    method: str
    backend: str
    h: float
    stats: dict[str, float] = field(default_factory=dict)
    wall_time: float = 0.0


class AngleIntegrationError(RuntimeError):
    """An angle-form integration failed; names the body nearest a pole and the time."""

    def __init__(
        self, message: str, status: int, body: int, time: float, partial: AngleTrajectory
    ) -> None:
        super().__init__(message)
        self.status, self.body, self.time, self.partial = status, body, time, partial


class AngleC:
    """The emitted C angle module, compiled (cached by content) and loaded with ctypes."""

    name = "c"

    def __init__(self, system: System, simplify: bool = False) -> None:
        self.system = system
        self.files = emit_angles(system, "c", simplify)
        self.library = CLibrary(self.files, ModuleKind.ANGLES, f"{system.name}_angles")
        self.build = self.library.build
        self.work = self.library.work
        self._fn = self.library.fn

    def to_angles(self, q: np.ndarray, w: np.ndarray) -> tuple[int, int, np.ndarray, np.ndarray]:
        """(status, body (0-based), x, xd) of one (q, omega) state."""
        nx = 2 * self.system.n
        x, xd, body = np.zeros(nx), np.zeros(nx), ctypes.c_int(-1)
        status = self._fn["to_angles"](contiguous(q), contiguous(w), x, xd, ctypes.byref(body))
        return int(status), int(body.value), x, xd

    def to_sphere(self, x: np.ndarray, xd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q, omega) of angle states of shape (..., 2n), as (..., n, 3)."""
        lead = x.shape[:-1]
        count = int(np.prod(lead, dtype=int))
        q, w = np.zeros(count * 3 * self.system.n), np.zeros(count * 3 * self.system.n)
        self._fn["to_sphere"](count, contiguous(x), contiguous(xd), q, w)
        shape = (*lead, self.system.n, 3)
        return q.reshape(shape), w.reshape(shape)

    def rhs(self, x: np.ndarray, xd: np.ndarray, params: np.ndarray) -> tuple[int, np.ndarray]:
        """(status, xdd) at one state."""
        xdd = np.zeros(x.size)
        status = self._fn["rhs"](contiguous(params), contiguous(x), contiguous(xd), xdd, self.work)
        return int(status), xdd

    def energy(self, x: np.ndarray, xd: np.ndarray, params: np.ndarray) -> float:
        return float(self._fn["energy"](contiguous(params), contiguous(x), contiguous(xd)))

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        x0: np.ndarray,
        xd0: np.ndarray,
        params: np.ndarray,
        options: Options,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
        nx = 2 * self.system.n
        x = np.full((nsteps + 1, nx), np.nan)
        xd = np.full((nsteps + 1, nx), np.nan)
        en = np.full(nsteps + 1, np.nan)
        counts = np.zeros((nsteps + 1, 2), dtype=np.int_)
        lib = self.library
        st = lib.Stats()
        status = self._fn["integrate"](
            contiguous(params),
            ctypes.byref(lib.options(options)),
            ANGLE_METHODS[method],
            h,
            nsteps,
            contiguous(x0),
            contiguous(xd0),
            x,
            xd,
            pointer(en),
            pointer(counts),
            self.work,
            ctypes.byref(st),
        )
        stats = {k: float(v) for k, v in lib.stats(st).items()}
        return int(status), x, xd, en, counts, stats


class AngleNumpy:
    """The emitted NumPy angle module, written to the cache folder by content hash, imported."""

    name = "numpy"

    def __init__(self, system: System, simplify: bool = False) -> None:
        self.system = system
        ((fname, text),) = emit_angles(system, "numpy", simplify).items()
        self.module = import_cached(fname, text)

    def to_angles(self, q: np.ndarray, w: np.ndarray) -> tuple[int, int, np.ndarray, np.ndarray]:
        status, body, x, xd = self.module.to_angles(q, w)
        return int(status), int(body), np.asarray(x), np.asarray(xd)

    def to_sphere(self, x: np.ndarray, xd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q, w = self.module.to_sphere(x, xd)
        return np.asarray(q), np.asarray(w)

    def rhs(self, x: np.ndarray, xd: np.ndarray, params: np.ndarray) -> tuple[int, np.ndarray]:
        status, xdd = self.module.rhs(params, x, xd)
        return int(status), np.asarray(xdd)

    def energy(self, x: np.ndarray, xd: np.ndarray, params: np.ndarray) -> float:
        return float(self.module.energy(params, x, xd))

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        x0: np.ndarray,
        xd0: np.ndarray,
        params: np.ndarray,
        options: Options,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
        status, x, xd, en, counts, stats = self.module.integrate(
            params,
            ANGLE_METHODS[method],
            h,
            nsteps,
            x0,
            xd0,
            rtol=options.rtol,
            atol=options.atol,
            control=CONTROLS.index(options.control),
            hmax=options.hmax,
            max_steps=options.max_steps,
        )
        return int(status), x, xd, en, counts, {k: float(v) for k, v in stats.items()}


@functools.lru_cache(maxsize=16)
def angle_backend(system: System, backend: str = "c", simplify: bool = False) -> Any:
    """The (cached) emitted angle module of a system: "c" (ctypes) or "numpy".

    Example:
        >>> from s2gen.systems import builtin
        >>> angle_backend(builtin("double_pendulum"), "numpy").name
        'numpy'
    """
    if backend == "c":
        return AngleC(system, simplify)
    if backend == "numpy":
        return AngleNumpy(system, simplify)
    raise ValueError(f"unknown angle backend {backend!r}; choose c or numpy")


def to_angles(
    system: System, q: np.ndarray, omega: np.ndarray, backend: str = "c"
) -> tuple[np.ndarray, np.ndarray]:
    """Angles and rates (x, xd) of a (q, omega) state; raises PoleError naming the body.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> to_angles(s, s.q0, s.omega0)  # doctest: +IGNORE_EXCEPTION_DETAIL
        Traceback (most recent call last):
        PoleError: body 2 is at a pole at t = 0 (sin theta_2 = 0): phi_2 is arbitrary and ...
    """
    return _initial_angles(angle_backend(system, backend), q, omega)


def _initial_angles(be: Any, q: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x, xd of a (q, omega) state by the module `be`; PoleError / ValueError if impossible."""
    status, body, x, xd = be.to_angles(np.asarray(q, float), np.asarray(omega, float))
    if status == 7:
        qb = np.asarray(q, float)[body]
        raise PoleError(body + 1, 0.0, float(np.hypot(qb[0], qb[1])))
    if status != 0:
        raise ValueError(f"initial state not convertible to angles: {_why(status)}")
    return x, xd


def simulate_angles(
    system: System,
    method: str = "rk45",
    backend: str = "c",
    h: float | None = None,
    T: float | None = None,
    options: Options | None = None,
    q0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
    simplify: bool = False,
) -> AngleTrajectory:
    """Integrate the angle form from the system's (or the given) (q, omega) state.

    Raises PoleError if a body starts at a pole, AngleIntegrationError if the run fails.
    """
    if method not in ANGLE_METHODS:
        raise ValueError(f"unknown angle method {method!r}; choose one of {sorted(ANGLE_METHODS)}")
    h = h if h is not None else system.run.h
    T = T if T is not None else system.run.T
    if h is None or T is None or not (h > 0 and T > 0):
        raise ValueError(f"{system.origin}: need positive h and T (got h={h}, T={T})")
    nsteps = round(T / h)
    q0 = system.q0 if q0 is None else np.asarray(q0, dtype=float)
    omega0 = system.omega0 if omega0 is None else np.asarray(omega0, dtype=float)
    if q0 is None or omega0 is None:
        raise ValueError(f"{system.origin}: no initial state ([initial] q and omega)")
    be = angle_backend(system, backend, simplify)
    x0, xd0 = _initial_angles(be, q0, omega0)
    p = np.array(system.parameter_values, dtype=float)
    start = time.perf_counter()
    status, x, xd, en, counts, stats = be.integrate(
        method, h, nsteps, x0, xd0, p, options or Options()
    )
    wall = time.perf_counter() - start
    k = int(stats["fail_step"]) if status else nsteps + 1
    q, w = be.to_sphere(x[:k], xd[:k])
    t = h * np.arange(nsteps + 1)
    tr = AngleTrajectory(
        t[:k], x[:k], xd[:k], q, w, en[:k], counts[:k], method, backend, h, stats, wall
    )
    if status:
        body, when = int(stats["fail_body"]) + 1, float(stats["fail_time"])
        raise AngleIntegrationError(
            f"{method} ({backend}) on the angle form failed in the step from t = {when:.6g}: "
            f"{_why(status)}; body {body} is nearest a pole "
            f"(|sin theta_{body}| = {stats['fail_sin']:.3g}); {k} valid samples kept",
            status,
            body,
            when,
            tr,
        )
    return tr
