"""Steps of a fixed-step method from Python: on the C backend at the cost of one C call each.

Input: a backend ("c" or "numpy"), a fixed-step method (not RK45 or DOP853), a step size,
parameter values, options and an initial state. Output: a `Stepper` whose `advance()` takes
one step of the emitted step function (`NAME_step` in C, `step` in the NumPy module) in place,
with its warm-start carry, so that a run of steps reproduces `integrate` bit for bit, Newton
iterations included; `step_copy` is the same step from a caller's state (`Model.step`, through
`s2gen.runtime.step_cache`).

On the C backend everything that does not change between steps is prepared once: the
function's prototype (from the `s2gen.interface` record of `step`, as every ctypes
declaration), the options and stepper structs, the carry, the workspace, the parameters and
two state buffers the steps alternate between, with the argument tuples of both directions
built in advance. A step passes the prepared tuple to the C function: no conversion, no
allocation, no check (the state is the last step's output, finite; a new one is checked when
set). Time and caller inputs, when the C step takes them, are one more scalar and one more
prepared buffer in the same tuples.

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

import abc
import ctypes
from typing import Any

import numpy as np

from s2gen.interface import Kind
from s2gen.methods import Status, check_method
from s2gen.runtime.diagnostics import energy_scale
from s2gen.runtime.inputs import initial_state
from s2gen.runtime.options import Options
from s2gen.runtime.trajectory import IntegrationError, Trajectory

__all__ = ["CStepper", "NumpyStepper", "Stepper", "make_stepper"]

_CTYPES = {Kind.DOUBLE: ctypes.c_double, Kind.INT: ctypes.c_int, Kind.LONG: ctypes.c_long}


def _readonly(a: np.ndarray) -> np.ndarray:
    view = a.view()
    view.flags.writeable = False
    return view


class Stepper(abc.ABC):
    """A run of one fixed-step method, one step per `advance()`.

    `q` and `omega` are the current state, shape (n, 3), read-only views valid until the next
    step (copy them to keep them); `t` is its time and `iterations` the Newton iterations of
    the last step. `set_state` starts from another state, checked as `integrate` checks an
    initial one. A failed step raises `IntegrationError` with the status `integrate` gives and
    leaves the state before it. Made by `Model.stepper` (C: `CStepper`, NumPy: `NumpyStepper`).
    """

    def __init__(
        self, backend: Any, method: str, h: float, params: np.ndarray, options: Options
    ) -> None:
        self.backend, self.method, self.h, self.options = backend, method, float(h), options
        self.code = check_method(method, backend.name).code
        self._system = backend.system
        self._params = np.array(params, dtype=np.float64)

    @property
    @abc.abstractmethod
    def q(self) -> np.ndarray:
        """The current unit vectors, (n, 3) (a read-only view, valid until the next step)."""
        ...

    @property
    @abc.abstractmethod
    def omega(self) -> np.ndarray:
        """The current angular velocities, (n, 3) (a read-only view, as `q`)."""
        ...

    @property
    @abc.abstractmethod
    def t(self) -> float:
        """The time of the current state: t0 plus the steps taken."""
        ...

    @property
    @abc.abstractmethod
    def iterations(self) -> int:
        """The Newton iterations of the last step (all substeps; 0 for explicit ones)."""
        ...

    def set_state(self, q: np.ndarray | None, omega: np.ndarray | None) -> None:
        """Continue from (q, omega) (None: the spec's), checked as `integrate` checks an
        initial state (shape (n, 3), finite, unit q_i to `Options.unit_tol`, finite gradient
        of V): ValueError otherwise. The next step starts afresh unless this is the state the
        last step returned."""
        q, omega = initial_state(self._system, q, omega, self.options.unit_tol)
        energy_scale(self.backend, q, omega, self._params, energy=False)
        self._load(np.array(q, dtype=np.float64), np.array(omega, dtype=np.float64))

    @abc.abstractmethod
    def _load(self, q: np.ndarray, omega: np.ndarray) -> None: ...

    @abc.abstractmethod
    def advance(self) -> None:
        """One step of size h from the current state; `IntegrationError` with the step's
        status if it fails (the state stays the one before it)."""
        ...

    @abc.abstractmethod
    def step_copy(self, q: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """One step from (q, omega) (float64 arrays of shape (n, 3), unchecked): a copy of the
        state after it, or None if the step failed (the state is then unchanged)."""
        ...

    def retarget(self, h: float, params: np.ndarray) -> None:
        """Take steps of size h with parameter values `params` from now on (both already
        checked), the next one afresh: a step with other values from the last state is the
        first step of a new run, as `integrate` would take it."""
        self.h = float(h)
        self._params[...] = params  # in place: the prepared calls point at this array
        self._restart()

    @abc.abstractmethod
    def _restart(self) -> None: ...

    def _error(self, status: int) -> IntegrationError:
        t, s = self.t, self._system  # a failed step leaves the time of its start
        why = Status(status).message if status in Status._value2member_map_ else str(status)
        partial = Trajectory(
            np.array([t]),
            self.q[None].copy(),
            self.omega[None].copy(),
            None,
            self.method,
            self.backend.name,
            self.h,
            system=s.name,
            spec_hash=s.spec_hash(),
            spec=s.source,
            spec_folder=s.source_folder,
            params=dict(zip(s.parameter_names, self._params.tolist())),
        )
        return IntegrationError(
            f"{self.method} ({self.backend.name}) failed after t = {t:.6g}: {why}; the state "
            "before it is kept",
            status,
            1,
            partial,
        )


class CStepper(Stepper):
    """A `Stepper` on the emitted C: one prepared C call per step (module docstring)."""

    def __init__(
        self,
        backend: Any,
        method: str,
        h: float,
        params: np.ndarray,
        options: Options,
        q0: np.ndarray | None,
        omega0: np.ndarray | None,
        t0: float = 0.0,
    ) -> None:
        super().__init__(backend, method, h, params, options)
        lib, system = backend.library, self._system
        self._opt = lib.options(options)
        self._st = lib.Stepper()
        if lib.fn["step_start"](ctypes.byref(self._st), self.code, t0):
            raise ValueError(f"{method}: the step API takes fixed-step methods only")
        self._carry = np.zeros(max(1, lib.carry_size))
        self._work = np.zeros(backend.work.size)  # its own: a run in a thread uses the backend's
        self._iters = ctypes.c_int(0)
        self._h = ctypes.c_double(self.h)
        self._buffers = np.zeros((2, 2, system.n, 3))  # [side][q, omega]
        self._slots = tuple((side[0], side[1]) for side in self._buffers)
        self._views = tuple((_readonly(side[0]), _readonly(side[1])) for side in self._buffers)
        fn = lib.api.function("step")
        argtypes: list[Any] = [_CTYPES.get(p.kind, ctypes.c_void_p) for p in fn.params]
        proto = ctypes.CFUNCTYPE(ctypes.c_int, *argtypes)
        self._call = proto((f"{system.name}_step", lib.lib))
        self._args = tuple(self._arguments(fn.params, side) for side in (0, 1))
        self._side = 0
        self.set_state(q0, omega0)

    def _arguments(self, params: Any, side: int) -> tuple[Any, ...]:
        """The argument tuple of a step from buffer `side` into the other one."""
        src, dst = self._buffers[side], self._buffers[1 - side]
        values = {
            "p": self._params.ctypes.data,
            "opt": ctypes.addressof(self._opt),
            "st": ctypes.addressof(self._st),
            "h": self._h,
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
        return self._views[self._side][0]

    @property
    def omega(self) -> np.ndarray:
        return self._views[self._side][1]

    @property
    def t(self) -> float:
        return float(self._st.t)

    @property
    def iterations(self) -> int:
        return int(self._iters.value)

    def _restart(self) -> None:
        self._h.value = self.h
        self._st.steps = 0  # the C step then starts afresh: the carry is not read

    def _load(self, q: np.ndarray, omega: np.ndarray) -> None:
        slot_q, slot_w = self._slots[self._side]
        slot_q[...] = q
        slot_w[...] = omega

    def advance(self) -> None:
        status = self._call(*self._args[self._side])
        if status:
            raise self._error(status)
        self._side ^= 1

    def step_copy(self, q: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        side = self._side
        slot_q, slot_w = self._slots[side]
        slot_q[...] = q
        slot_w[...] = omega
        if self._call(*self._args[side]):
            return None
        self._side = 1 - side
        out = self._buffers[1 - side].copy()
        return out[0], out[1]


class NumpyStepper(Stepper):
    """A `Stepper` on the emitted NumPy module's `step` (its own carry in its stepper)."""

    def __init__(
        self,
        backend: Any,
        method: str,
        h: float,
        params: np.ndarray,
        options: Options,
        q0: np.ndarray | None,
        omega0: np.ndarray | None,
        t0: float = 0.0,
    ) -> None:
        super().__init__(backend, method, h, params, options)
        self._module = backend.module
        status, self._st = self._module.step_start(self.code, t0)
        if status:
            raise ValueError(f"{method}: the step API takes fixed-step methods only")
        self._newton = (options.newton_tol, options.newton_maxiter)
        self._iters = 0
        self._state = (np.zeros((self._system.n, 3)), np.zeros((self._system.n, 3)))
        self.set_state(q0, omega0)

    @property
    def q(self) -> np.ndarray:
        return _readonly(self._state[0])

    @property
    def omega(self) -> np.ndarray:
        return _readonly(self._state[1])

    @property
    def t(self) -> float:
        return float(self._st.t)

    @property
    def iterations(self) -> int:
        return int(self._iters)

    def _restart(self) -> None:
        self._st.last, self._st.steps = None, 0  # the module's step then starts afresh

    def _load(self, q: np.ndarray, omega: np.ndarray) -> None:
        self._state = (q, omega)

    def _step(self, q: np.ndarray, omega: np.ndarray) -> int:
        tol, maxiter = self._newton
        with np.errstate(all="ignore"):  # as the module's integrate(): the status says it
            status, qn, wn, iters = self._module.step(
                self._params, self._st, self.h, q, omega, tol, maxiter
            )
        if not status:
            self._state, self._iters = (qn, wn), iters
        return int(status)

    def advance(self) -> None:
        status = self._step(*self._state)
        if status:
            raise self._error(status)

    def step_copy(self, q: np.ndarray, omega: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        if self._step(q, omega):
            return None
        return self._state[0].copy(), self._state[1].copy()  # the module keeps its own


def make_stepper(
    backend: Any,
    method: str,
    h: float,
    params: np.ndarray,
    options: Options,
    q0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
    t0: float = 0.0,
) -> Stepper:
    """The stepper of a backend ("c" or "numpy"; ValueError for another) from arguments
    already checked (see `Model.stepper`).

    Example:
        >>> from s2gen.runtime import get_backend
        >>> from s2gen.systems import builtin
        >>> be = get_backend(builtin("double_pendulum"), "numpy")
        >>> type(make_stepper(be, "rk4", 0.01, be.default_params(), Options())).__name__
        'NumpyStepper'
    """
    kinds: dict[str, type[CStepper | NumpyStepper]] = {"c": CStepper, "numpy": NumpyStepper}
    if backend.name not in kinds:
        raise ValueError(
            f"the {backend.name} backend has no step function; Model.step works on every backend"
        )
    return kinds[backend.name](backend, method, h, params, options, q0, omega0, t0)
