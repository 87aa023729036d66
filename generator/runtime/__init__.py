"""Run a system with one backend and return a `Trajectory`.

Input: a `System`, a method ("vi", "rk45", "rk2", "rk2-proj", "rk4"), a backend ("c": emitted C
compiled and loaded with ctypes; "numpy": the emitted NumPy module; "reference": the independent
`reference.py`), step size, horizon and tolerances. Output: a `Trajectory` (t, q, omega, energy,
statistics, wall time). A failure raises `IntegrationError`, which names the step and why and
keeps the trajectory computed so far (`.partial`).

Example:
    >>> from s2gen.systems import builtin
    >>> tr = simulate(builtin("double_pendulum"), method="vi", backend="c", h=0.01, T=0.1)
    >>> tr.q.shape
    (11, 2, 3)
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import importlib.util
import time
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any, Protocol

import numpy as np

from s2gen.build import cache_dir, compile_shared, header_macro
from s2gen.emit import emit
from s2gen.system import System

__all__ = [
    "BACKENDS",
    "CONTROLS",
    "METHODS",
    "IntegrationError",
    "Options",
    "Trajectory",
    "get_backend",
    "simulate",
]

METHODS = ("vi", "vi4", "rattle", "rk45", "rk2", "rk2-proj", "rk4")
BACKENDS = ("c", "numpy", "reference")
CONTROLS = ("matlab", "hairer")
_METHOD_CODE = {"vi": 0, "rk45": 1, "rk2": 2, "rk2-proj": 3, "rk4": 4, "vi4": 5, "rattle": 6}
_STATUS = {
    1: "explicit VI step infeasible (|a_i| > 1 for some body): reduce the step size",
    2: "Newton's method did not converge in the VI step: reduce the step size or raise the limit",
    3: "the state or its gradient became non-finite",
    4: "invalid argument",
    5: "RK45 step size fell below its minimum",
    6: "a linear system was singular (inertia not positive definite along the trajectory?)",
}


@dataclass(frozen=True)
class Options:
    """Integrator options (defaults as MATLAB's ode45 for RK45, tight Newton)."""

    rtol: float = 1e-3
    atol: float = 1e-6
    control: str = "matlab"
    hmax: float = 0.0
    newton_tol: float = 1e-14
    newton_maxiter: int = 50


@dataclass(frozen=True)
class Trajectory:
    """Samples on the grid t_k = k h: q and omega (N+1, n, 3), energy (N+1,)."""

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray
    method: str
    backend: str
    h: float
    stats: dict[str, int] = field(default_factory=dict)
    wall_time: float = 0.0


class IntegrationError(RuntimeError):
    """An integration failed; `.partial` holds the valid samples computed before the failure."""

    def __init__(self, message: str, status: int, step: int, partial: Trajectory) -> None:
        super().__init__(message)
        self.status = status
        self.step = step
        self.partial = partial


class Backend(Protocol):
    name: str

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, dict[str, int]]: ...


# ----------------------------------------------------------------------------------- C backend
class _Opt(ctypes.Structure):
    _fields_ = [
        ("rtol", ctypes.c_double),
        ("atol", ctypes.c_double),
        ("hmax", ctypes.c_double),
        ("control", ctypes.c_int),
        ("newton_tol", ctypes.c_double),
        ("newton_maxiter", ctypes.c_int),
    ]


class _Stats(ctypes.Structure):
    _fields_ = [
        *(
            (k, ctypes.c_long)
            for k in (
                "steps",
                "rejected",
                "gradient_evals",
                "newton_iters",
                "newton_max",
                "fail_step",
            )
        ),
        ("fail_time", ctypes.c_double),
    ]


_DP = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")


class CBackend:
    """The emitted C, compiled (cached) and loaded with declared argument types."""

    name = "c"

    def __init__(self, system: System) -> None:
        self.system = system
        files = emit(system, "c")
        self.build = compile_shared(files)
        self.lib = ctypes.CDLL(str(self.build.path))
        pre = system.name
        self.work = np.zeros(header_macro(files[f"{pre}.h"], "WORK_SIZE"))
        f = self.lib
        self._integrate = getattr(f, f"{pre}_integrate")
        self._integrate.restype = ctypes.c_int
        self._integrate.argtypes = [
            _DP,
            ctypes.POINTER(_Opt),
            ctypes.c_int,
            ctypes.c_double,
            ctypes.c_long,
            _DP,
            _DP,
            _DP,
            _DP,
            _DP,
            _DP,
            ctypes.POINTER(_Stats),
        ]
        self._energy = getattr(f, f"{pre}_energy")
        self._energy.restype = ctypes.c_double
        self._energy.argtypes = [_DP, _DP, _DP]
        self._gradient = getattr(f, f"{pre}_gradient")
        self._gradient.restype = None
        self._gradient.argtypes = [_DP, _DP, _DP]
        self._rhs = getattr(f, f"{pre}_rhs")
        self._rhs.restype = ctypes.c_int
        self._rhs.argtypes = [_DP, _DP, _DP, _DP, _DP, _DP]
        self._mom = getattr(f, f"{pre}_angular_momentum")
        self._mom.restype = None
        self._mom.argtypes = [_DP, _DP, _DP, _DP]

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        return float(self._energy(_c(params), _c(q), _c(w)))

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray:
        g = np.zeros(q.size)
        self._gradient(_c(params), _c(q), g)
        return g.reshape(q.shape)

    def rhs(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        dq, dw = np.zeros(q.size), np.zeros(q.size)
        status = self._rhs(_c(params), _c(q), _c(w), dq, dw, self.work)
        if status:
            raise RuntimeError(_STATUS.get(status, f"status {status}"))
        return dq.reshape(q.shape), dw.reshape(q.shape)

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        out = np.zeros(3)
        self._mom(_c(params), _c(q), _c(w), out)
        return out

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, dict[str, int]]:
        n = self.system.n
        q = np.full((nsteps + 1, n, 3), np.nan)
        w = np.full((nsteps + 1, n, 3), np.nan)
        en = np.full(nsteps + 1, np.nan)
        opt = _Opt(
            options.rtol,
            options.atol,
            options.hmax,
            CONTROLS.index(options.control),
            options.newton_tol,
            options.newton_maxiter,
        )
        stats = _Stats()
        status = self._integrate(
            _c(params),
            ctypes.byref(opt),
            _METHOD_CODE[method],
            h,
            nsteps,
            _c(q0),
            _c(w0),
            q,
            w,
            en,
            self.work,
            ctypes.byref(stats),
        )
        names = ("steps", "rejected", "gradient_evals", "newton_iters", "newton_max", "fail_step")
        return status, q, w, en, {k: int(getattr(stats, k)) for k in names}


def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


# ------------------------------------------------------------------------------- NumPy backend
class NumpyBackend:
    """The emitted NumPy module, written to the cache folder by content hash and imported."""

    name = "numpy"

    def __init__(self, system: System) -> None:
        self.system = system
        ((fname, text),) = emit(system, "numpy").items()
        digest = hashlib.sha256(text.encode()).hexdigest()[:24]
        path = cache_dir() / f"{Path(fname).stem}_{digest}.py"
        if not path.exists():
            tmp = path.with_suffix(f".{digest}.tmp")
            tmp.write_text(text)
            tmp.replace(path)
        self.module = _import_file(path)

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        return float(self.module.energy(params, q, w))

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.gradient(params, q))

    def rhs(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        return tuple(np.asarray(a) for a in self.module.rhs(params, q, w))

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        return np.asarray(self.module.angular_momentum(params, q, w))

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, dict[str, int]]:
        return self.module.integrate(  # type: ignore[no-any-return]
            params,
            _METHOD_CODE[method],
            h,
            nsteps,
            q0,
            w0,
            rtol=options.rtol,
            atol=options.atol,
            control=CONTROLS.index(options.control),
            hmax=options.hmax,
            newton_tol=options.newton_tol,
            newton_maxiter=options.newton_maxiter,
        )


def _import_file(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# --------------------------------------------------------------------------- reference backend
class ReferenceBackend:
    """The independent NumPy reference integrator (`reference.py`)."""

    name = "reference"

    def __init__(self, system: System) -> None:
        self.system = system
        self._problems: dict[tuple[float, ...], Any] = {}

    def _problem(self, params: np.ndarray) -> Any:
        from s2gen import reference

        key = tuple(float(v) for v in params)
        if key not in self._problems:
            self._problems[key] = reference.problem_from_system(self.system, key)
        return self._problems[key]

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        from s2gen import reference

        return float(reference.energy(self._problem(params), q, w))

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        from s2gen import reference

        return np.asarray(reference.angular_momentum(self._problem(params), q, w))

    def integrate(
        self,
        method: str,
        h: float,
        nsteps: int,
        q0: np.ndarray,
        w0: np.ndarray,
        params: np.ndarray,
        options: Options,
    ) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, dict[str, int]]:
        from s2gen import reference

        try:
            tr = reference.integrate(
                self._problem(params),
                method,
                q0,
                w0,
                h,
                nsteps,
                rtol=options.rtol,
                atol=options.atol,
                control=options.control,
                newton_tol=options.newton_tol,
                newton_maxiter=options.newton_maxiter,
            )
            return 0, tr.q, tr.omega, tr.energy, dict(tr.stats)
        except reference.ReferenceIntegrationError as exc:
            n = self.system.n
            q = np.full((nsteps + 1, n, 3), np.nan)
            w = np.full((nsteps + 1, n, 3), np.nan)
            en = np.full(nsteps + 1, np.nan)
            k = 0
            if exc.partial is not None:
                k = len(exc.partial.t)
                q[:k], w[:k], en[:k] = exc.partial.q, exc.partial.omega, exc.partial.energy
            status = int(exc.status)
            return status, q, w, en, {"fail_step": k}


@functools.lru_cache(maxsize=16)
def _backend_cached(system: System, name: str) -> Backend:
    if name == "c":
        return CBackend(system)
    if name == "numpy":
        return NumpyBackend(system)
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
) -> Trajectory:
    """Integrate a system from its (or the given) initial state to T with step h."""
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    h = h if h is not None else system.run.h
    T = T if T is not None else system.run.T
    if h is None or T is None:
        raise ValueError(f"{system.origin}: no step size h or final time T given (spec [run])")
    if not (h > 0 and T > 0):
        raise ValueError(f"h and T must be positive (got h={h}, T={T})")
    nsteps = round(T / h)
    if abs(nsteps * h - T) > 1e-9 * T:
        raise ValueError(f"T={T} is not a whole number of steps h={h}")
    q0 = system.q0 if q0 is None else np.asarray(q0, dtype=float)
    omega0 = system.omega0 if omega0 is None else np.asarray(omega0, dtype=float)
    if q0 is None or omega0 is None:
        raise ValueError(f"{system.origin}: no initial state ([initial] q and omega)")
    p = np.array(system.parameter_values if params is None else params, dtype=float)
    opts = options or Options()
    be = get_backend(system, backend)
    start = time.perf_counter()
    status, q, w, en, stats = be.integrate(method, h, nsteps, q0, omega0, p, opts)
    wall = time.perf_counter() - start
    t = h * np.arange(nsteps + 1)
    if status != 0:
        k = int(stats.get("fail_step", 0))
        partial = Trajectory(t[:k], q[:k], w[:k], en[:k], method, backend, h, stats, wall)
        why = _STATUS.get(status, f"status {status}")
        raise IntegrationError(
            f"{method} ({backend}) failed at step {k} (t = {k * h:.6g}): {why}; "
            f"{k} valid samples kept",
            status,
            k,
            partial,
        )
    return Trajectory(t, q, w, en, method, backend, h, stats, wall)
