"""Steps of a fixed-step method from Python at the cost of one C call each.

Input: a C backend, a fixed-step method (not RK45 or DOP853), a step size, parameter values,
options and an initial state. Output: a `Stepper` whose `advance()` takes one step of the
emitted `NAME_step` in place, and the cache behind `Model.step` (`StepCache`), which checks a
caller's state cheaply and steps it through the same call.

Everything that does not change between steps is prepared once: the function's prototype
(from the `s2gen.interface` record of `step`, as every ctypes declaration), the options and
stepper structs, the carry, the workspace, the parameters and two state buffers the steps
alternate between, with the argument tuples of both directions built in advance. A step then
passes the prepared tuple to the C function: no conversion, no allocation, no check. The
carry makes a run of steps reproduce `integrate` bit for bit, Newton iterations included
(see the header's `step`). Time and caller inputs, when the C step takes them, are one more
scalar and one more prepared buffer in the same tuples.

Example:
    >>> import s2gen
    >>> model = s2gen.compile(s2gen.load("double_pendulum"))
    >>> stepper = model.stepper("vi", h=0.01)
    >>> for _ in range(10):
    ...     stepper.advance()
    >>> tr = model.integrate("vi", h=0.01, T=0.1, energy=False)
    >>> bool((stepper.q == tr.q[-1]).all() and (stepper.omega == tr.omega[-1]).all())
    True
"""

from __future__ import annotations

import ctypes
import math
from typing import Any

import numpy as np

from s2gen.build import header_macro
from s2gen.emit import emit
from s2gen.interface import Kind
from s2gen.methods import Status, check_method
from s2gen.runtime.c import CBackend
from s2gen.runtime.diagnostics import energy_scale
from s2gen.runtime.inputs import initial_state
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import IntegrationError, Trajectory

__all__ = ["StepCache", "Stepper"]

_CTYPES = {Kind.DOUBLE: ctypes.c_double, Kind.INT: ctypes.c_int, Kind.LONG: ctypes.c_long}
#: Bodies up to which a caller's state is checked element by element in Python (below the
#: cost of the NumPy calls that check a larger one).
_SCALAR_CHECK_BODIES = 8
#: Most prepared steppers `Model.step` keeps (one per method, step size, options, parameters).
STEP_CACHE_SIZE = 8


class Stepper:
    """A run of one fixed-step method on the emitted C, one C call per `advance()`.

    `q` and `omega` are the current state, shape (n, 3), read-only views valid until the next
    step (copy them to keep them); `t` is its time. `set_state` starts from another state,
    checked as `integrate` checks an initial one. A failed step raises `IntegrationError`
    with the status `integrate` gives and leaves the state before it.
    """

    def __init__(
        self,
        backend: CBackend,
        method: str,
        h: float,
        params: np.ndarray,
        options: Options,
        q0: np.ndarray | None,
        omega0: np.ndarray | None,
        t0: float = 0.0,
    ) -> None:
        """A stepper at (q0, omega0) and time t0; `h`, `params` and `options` as checked by
        `Model.stepper` (which is how to make one)."""
        lib, system = backend.library, backend.system
        self.backend, self.method, self.h = backend, method, float(h)
        self.options = options
        self._system = system
        self._params = np.array(params, dtype=np.float64)
        self._opt = lib.options(options)
        self._st = lib.Stepper()
        status = lib.fn["step_start"](ctypes.byref(self._st), check_method(method, "c").code, t0)
        if status:
            raise ValueError(f"{method}: the step API takes fixed-step methods only")
        carry = header_macro(emit(system, "c")[f"{system.name}.h"], "STEP_CARRY")
        self._carry = np.zeros(max(1, carry))
        self._work = np.zeros(backend.work.size)  # its own: a run in a thread uses the backend's
        self._iters = ctypes.c_int(0)
        self._buffers = np.zeros((2, 2, system.n, 3))  # [side][q, omega]
        self._slots = tuple((side[0], side[1]) for side in self._buffers)
        self._views = tuple(
            tuple(self._readonly(b) for b in side) for side in self._buffers
        )  # fmt: skip
        fn = lib.api.function("step")
        argtypes: list[Any] = [_CTYPES.get(p.kind, ctypes.c_void_p) for p in fn.params]
        proto = ctypes.CFUNCTYPE(ctypes.c_int, *argtypes)
        self._call = proto((f"{system.name}_step", lib.lib))
        self._args = tuple(self._arguments(fn.params, side) for side in (0, 1))
        self._side = 0
        self.set_state(q0, omega0)

    @staticmethod
    def _readonly(a: np.ndarray) -> np.ndarray:
        view = a.view()
        view.flags.writeable = False
        return view

    def _arguments(self, params: Any, side: int) -> tuple[Any, ...]:
        """The argument tuple of a step from buffer `side` into the other one."""
        src, dst = self._buffers[side], self._buffers[1 - side]
        values = {
            "p": self._params.ctypes.data,
            "opt": ctypes.addressof(self._opt),
            "st": ctypes.addressof(self._st),
            "h": self.h,
            "q": src[0].ctypes.data,
            "w": src[1].ctypes.data,
            "qn": dst[0].ctypes.data,
            "wn": dst[1].ctypes.data,
            "carry": self._carry.ctypes.data,
            "work": self._work.ctypes.data,
            "iters": ctypes.addressof(self._iters),
        }
        return tuple(values[p.name] for p in params)

    @property
    def q(self) -> np.ndarray:
        """The current unit vectors, (n, 3) (a read-only view, valid until the next step)."""
        return self._views[self._side][0]

    @property
    def omega(self) -> np.ndarray:
        """The current angular velocities, (n, 3) (a read-only view, as `q`)."""
        return self._views[self._side][1]

    @property
    def t(self) -> float:
        """The time of the current state: t0 plus the steps taken."""
        return float(self._st.t)

    @property
    def iterations(self) -> int:
        """The Newton iterations of the last step (all substeps; 0 for explicit ones)."""
        return int(self._iters.value)

    def set_state(self, q: np.ndarray | None, omega: np.ndarray | None) -> None:
        """Continue from (q, omega) (None: the spec's), checked as `integrate` checks an
        initial state (shape (n, 3), finite, unit q_i to `Options.unit_tol`, finite gradient
        of V): ValueError otherwise. The next step starts afresh unless this is the state the last step
        returned."""
        q, omega = initial_state(self._system, q, omega, self.options.unit_tol)
        energy_scale(self.backend, q, omega, self._params, energy=False)
        self._buffers[self._side, 0] = q
        self._buffers[self._side, 1] = omega

    def advance(self) -> None:
        """One step of size h from the current state (one C call); `IntegrationError` with
        the step's status if it fails (the state stays the one before it)."""
        status = self._call(*self._args[self._side])
        if status:
            raise self._error(status)
        self._side ^= 1

    def _error(self, status: int) -> IntegrationError:
        t = self.t  # the C leaves the time of a failed step's start
        why = Status(status).message if status in Status._value2member_map_ else str(status)
        partial = Trajectory(
            np.array([t]),
            self.q[None].copy(),
            self.omega[None].copy(),
            None,
            self.method,
            "c",
            self.h,
            system=self._system.name,
            spec_hash=self._system.spec_hash(),
            spec=self._system.source,
            params=dict(zip(self._system.parameter_names, self._params.tolist())),
        )
        return IntegrationError(
            f"{self.method} (c) failed after t = {t:.6g}: {why}; the state before it is kept",
            status,
            1,
            partial,
        )

    def step_copy(self, q: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """One step from (q, omega) copied in (arrays of shape (n, 3), unchecked): a copy of
        the state after it, or None if the step failed (the state is then unchanged)."""
        side = self._side
        slot_q, slot_w = self._slots[side]
        slot_q[...] = q
        slot_w[...] = omega
        if self._call(*self._args[side]):
            return None
        self._side = 1 - side
        out = self._buffers[1 - side].copy()
        return out[0], out[1]


def _params_key(params: Any) -> Any:
    """A hashable key equal only for parameter arguments that give the same values the same
    way (types included: True is refused where 1.0 is not); TypeError if there is none."""
    if params is None:
        return None
    if isinstance(params, dict):
        return ("map", *((k, type(v), v) for k, v in params.items()))
    if isinstance(params, (list, tuple)):
        return ("seq", *((type(v), v) for v in params))
    if isinstance(params, np.ndarray) and params.dtype.kind in "fi":
        return ("array", params.dtype.str, params.shape, *params.ravel().tolist())
    raise TypeError(type(params).__name__)


class StepCache:
    """`Model.step` on the C backend: a prepared `Stepper` per (method, h, options,
    parameters), fed the caller's state after a cheap check. `step` returns None whenever the
    checked path (one-step `integrate`) must decide: a state that is not a float64 array of
    shape (n, 3), not finite or near the unit-length limit, arguments seen for the first time
    that fail their checks, an adaptive method, a failed step. That path then gives the same
    result or raises the same error as before, so the cache changes no outcome; a run of
    calls, each from the state the last returned, reproduces `integrate` over those steps
    bit for bit (the carry's warm start, as `integrate` takes its steps).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> cache = StepCache(CBackend(s))
        >>> q, w = cache.step(s.q0, s.omega0, 0.01, "vi", None, None)
        >>> q.shape, cache.step(s.q0, s.omega0, 0.01, "rk45", None, None)
        ((2, 3), None)
    """

    def __init__(self, backend: CBackend) -> None:
        self.backend = backend
        self._shape = (backend.system.n, 3)
        self._entries: dict[Any, tuple[Stepper | None, float, float, Options | None]] = {}

    def step(
        self,
        q: Any,
        omega: Any,
        h: Any,
        method: str,
        options: Options | None,
        params: Any,
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """One step from (q, omega), or None: see the class."""
        if type(q) is not np.ndarray or type(omega) is not np.ndarray:
            return None
        shape = self._shape
        if (
            q.shape != shape
            or omega.shape != shape
            or q.dtype is not _F64
            or omega.dtype is not _F64
        ):
            return None
        try:
            key = (method, h, id(options), _params_key(params))
            entry = self._entries.get(key)
        except TypeError:
            return None
        if entry is None:
            entry = self._prepare(key, q, omega, h, method, options, params)
        stepper, limit, unit_tol, _ = entry
        if stepper is None or not _plausible(q, omega, limit, unit_tol):
            return None
        return stepper.step_copy(q, omega)

    def _prepare(
        self,
        key: Any,
        q: np.ndarray,
        omega: np.ndarray,
        h: Any,
        method: str,
        options: Options | None,
        params: Any,
    ) -> tuple[Stepper | None, float, float, Options | None]:
        """The cache entry of new arguments: a stepper, or None when the checked path must
        take them (invalid, or an adaptive method). The entry keeps `options` alive so that
        its id in the key is not reused."""
        from s2gen.runtime import check_run
        from s2gen.runtime.inputs import parameter_vector

        stepper: Stepper | None = None
        opts = options or Options()
        try:
            if not check_method(method, "c").adaptive:
                check_run(self.backend.system, method, h, h, opts)
                p = parameter_vector(self.backend.system, params)
                stepper = Stepper(self.backend, method, h, p, opts, q, omega)
        except ValueError:
            return None, 0.0, 0.0, options  # not kept: the checked path raises
        # |(computed length) - 1| stays within 1e-15 of NumPy's; nearer the limit, NumPy decides
        limit = opts.unit_tol - 1e-15 if opts.unit_tol > 0 else math.inf
        if len(self._entries) >= STEP_CACHE_SIZE:
            del self._entries[next(iter(self._entries))]
        self._entries[key] = (stepper, limit, opts.unit_tol, options)
        return self._entries[key]


_F64 = np.dtype(np.float64)


def _plausible(q: np.ndarray, omega: np.ndarray, limit: float, unit_tol: float) -> bool:
    """True when q_i are unit vectors to within `limit` and omega is finite (a sum that
    overflows says False: the checked path then decides)."""
    if q.shape[0] <= _SCALAR_CHECK_BODIES:
        for x, y, z in q.tolist():
            if not abs(math.sqrt(x * x + y * y + z * z) - 1.0) <= limit:
                return False
        return math.isfinite(sum(omega.ravel().tolist()))
    off = np.abs(np.linalg.norm(q, axis=1) - 1.0)
    return bool(np.all(off <= unit_tol) if unit_tol > 0 else np.all(np.isfinite(q))) and bool(
        np.all(np.isfinite(omega))
    )
