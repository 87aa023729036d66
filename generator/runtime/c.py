"""The C backend: emitted C compiled (cached by content) and called through ctypes.

Input: a `System`. Output: a backend object whose `integrate` returns
(status, q, omega, energy, stats) and whose `energy`, `gradient`, `rhs` and
`angular_momentum` evaluate single states with given parameters.

Example:
    >>> from s2gen.systems import builtin
    >>> be = CBackend(builtin("double_pendulum"))
    >>> be.gradient(builtin("double_pendulum").q0, be.default_params()).shape
    (2, 3)
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np

from s2gen.build import compile_shared, header_macro
from s2gen.emit import emit
from s2gen.methods import CONTROLS, Status, method
from s2gen.runtime.options import Options
from s2gen.system import System

__all__ = ["CBackend"]


class _Opt(ctypes.Structure):
    _fields_ = [
        ("rtol", ctypes.c_double),
        ("atol", ctypes.c_double),
        ("hmax", ctypes.c_double),
        ("control", ctypes.c_int),
        ("newton_tol", ctypes.c_double),
        ("newton_maxiter", ctypes.c_int),
    ]


_STAT_FIELDS = ("steps", "rejected", "gradient_evals", "newton_iters", "newton_max", "fail_step")


class _Stats(ctypes.Structure):
    _fields_ = [*((k, ctypes.c_long) for k in _STAT_FIELDS), ("fail_time", ctypes.c_double)]


_DP = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")


def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


class CBackend:
    """The emitted C, compiled (cached) and loaded with declared argument types."""

    name = "c"

    def __init__(self, system: System, files: dict[str, str] | None = None) -> None:
        """Compile `files` (default: the system's emitted C) and load the library; `files`
        lets a process that never derived the system (a cluster worker) build it."""
        self.system = system
        files = emit(system, "c") if files is None else files
        self.build = compile_shared(files)
        self.lib = ctypes.CDLL(str(self.build.path))
        pre = system.name
        self.work = np.zeros(header_macro(files[f"{pre}.h"], "WORK_SIZE"))
        self._integrate = self._fn(f"{pre}_integrate", ctypes.c_int)
        self._integrate.argtypes = [
            _DP,
            ctypes.POINTER(_Opt),
            ctypes.c_int,
            ctypes.c_double,
            ctypes.c_long,
            *[_DP] * 6,
            ctypes.POINTER(_Stats),
        ]
        self._energy = self._fn(f"{pre}_energy", ctypes.c_double, [_DP] * 3)
        self._gradient = self._fn(f"{pre}_gradient", None, [_DP] * 3)
        self._rhs = self._fn(f"{pre}_rhs", ctypes.c_int, [_DP] * 6)
        self._mom = self._fn(f"{pre}_angular_momentum", None, [_DP] * 4)

    def _fn(self, name: str, res: object, args: list[object] | None = None) -> Any:
        f = getattr(self.lib, name)
        f.restype = res
        if args is not None:
            f.argtypes = args
        return f

    def default_params(self) -> np.ndarray:
        return np.array(self.system.parameter_values, dtype=float)

    def energy(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> float:
        return float(self._energy(_c(params), _c(q), _c(w)))

    def gradient(self, q: np.ndarray, params: np.ndarray) -> np.ndarray:
        g = np.zeros(np.size(q))
        self._gradient(_c(params), _c(q), g)
        return g.reshape(np.shape(q))

    def rhs(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, ...]:
        dq, dw = np.zeros(np.size(q)), np.zeros(np.size(q))
        status = self._rhs(_c(params), _c(q), _c(w), dq, dw, self.work)
        if status:
            raise RuntimeError(Status(status).message)
        return dq.reshape(np.shape(q)), dw.reshape(np.shape(q))

    def angular_momentum(self, q: np.ndarray, w: np.ndarray, params: np.ndarray) -> np.ndarray:
        out = np.zeros(3)
        self._mom(_c(params), _c(q), _c(w), out)
        return out

    def integrate(
        self,
        method_name: str,
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
            method(method_name).code,
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
        return status, q, w, en, {k: int(getattr(stats, k)) for k in _STAT_FIELDS}
