"""`Model.step`'s fast path: a prepared stepper per set of arguments, fed the caller's state.

Input: a backend ("c" or "numpy") and the arguments of `Model.step`. Output: the state after
one step, or None when the checked path (a one-step `integrate`) must decide: a state that is
not a float64 array of shape (n, 3), not finite or near the unit-length limit, arguments seen
for the first time that fail their checks, an adaptive method, a failed step. That path then
gives the same result or raises the same error as before, so the cache changes no outcome; a
run of calls, each from the state the last returned with the same arguments, reproduces
`integrate` over those steps bit for bit (the step's warm start, as `integrate` takes its
steps).

The method and the options (by value) select a `s2gen.runtime.stepper.Stepper`; a new step
size or new parameter values (compared with their types: True is refused where 1.0 is not)
retarget it, checked, and its next step starts afresh, so that a caller varying h or a
parameter does not build a stepper per call; another options object of equal values is
checked (equal is not enough: True equals 1) and steps on. At most `STEP_CACHE_SIZE` are
kept, the oldest dropped first.

Example:
    >>> from s2gen.runtime import get_backend
    >>> from s2gen.systems import builtin
    >>> s = builtin("double_pendulum")
    >>> cache = StepCache(get_backend(s, "c"))
    >>> q, w = cache.step(s.q0, s.omega0, 0.01, "vi", None, None)
    >>> q.shape, cache.step(s.q0, s.omega0, 0.01, "rk45", None, None)
    ((2, 3), None)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from s2gen.methods import check_method
from s2gen.runtime.options import Options
from s2gen.runtime.stepper import Stepper, make_stepper

__all__ = ["STEP_CACHE_SIZE", "StepCache"]

#: Most prepared steppers one model keeps (one per method and options).
STEP_CACHE_SIZE = 8
#: Bodies up to which a caller's state is checked element by element in Python (below the
#: cost of the NumPy calls that check a larger one).
_SCALAR_CHECK_BODIES = 8
_F64 = np.dtype(np.float64)


def _params_key(params: Any) -> Any:
    """A hashable key equal only for parameter arguments that give the same values the same
    way (types included); TypeError if there is none."""
    if params is None:
        return None
    if isinstance(params, dict):
        return ("map", *((k, type(v), v) for k, v in params.items()))
    if isinstance(params, (list, tuple)):
        return ("seq", *((type(v), v) for v in params))
    if isinstance(params, np.ndarray) and params.dtype.kind in "fi":
        return ("array", params.dtype.str, params.shape, *params.ravel().tolist())
    raise TypeError(type(params).__name__)


@dataclass
class _Entry:
    """A prepared step: its stepper (None: the checked path takes these arguments), the
    unit-length limits of the fast check, the options object last checked and the key of the
    parameters the stepper holds."""

    stepper: Stepper | None
    limit: float
    unit_tol: float
    options: Options | None
    params: Any


class StepCache:
    """The prepared steps of one model (module docstring)."""

    def __init__(self, backend: Any) -> None:
        self.backend = backend
        self._shape = (backend.system.n, 3)
        self._entries: dict[Any, _Entry] = {}

    def step(
        self, q: Any, omega: Any, h: Any, method: str, options: Options | None, params: Any
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """One step from (q, omega), or None: see the module docstring."""
        if type(q) is not np.ndarray or type(omega) is not np.ndarray:
            return None
        shape = self._shape
        if q.shape != shape or omega.shape != shape or q.dtype is not _F64:
            return None
        if omega.dtype is not _F64:
            return None
        try:
            key, pkey = (method, options), _params_key(params)
            entry = self._entries.get(key)
        except TypeError:
            return None
        if entry is None:
            entry = self._prepare(key, pkey, q, omega, h, method, options, params)
        stepper = entry.stepper
        if stepper is None or not _plausible(q, omega, entry.limit, entry.unit_tol):
            return None
        changed = h != stepper.h or pkey != entry.params or options is not entry.options
        if changed and not self._retarget(entry, h, params, pkey, options):
            return None
        return stepper.step_copy(q, omega)

    def _retarget(
        self, entry: _Entry, h: Any, params: Any, pkey: Any, options: Options | None
    ) -> bool:
        """Point the entry's stepper at a new step size or new parameters (its next step then
        starts afresh), or take another options object of the same values; False if they fail
        `integrate`'s checks (the stepper is then unchanged)."""
        from s2gen.runtime import check_run
        from s2gen.runtime.inputs import parameter_vector

        stepper, system = entry.stepper, self.backend.system
        assert stepper is not None
        try:
            check_run(system, stepper.method, h, h, options or Options())
            p = parameter_vector(system, params)
        except ValueError:
            return False
        if h != stepper.h or pkey != entry.params:
            stepper.retarget(h, p)
        entry.params, entry.options = pkey, options
        return True

    def _prepare(
        self,
        key: Any,
        pkey: Any,
        q: np.ndarray,
        omega: np.ndarray,
        h: Any,
        method: str,
        options: Options | None,
        params: Any,
    ) -> _Entry:
        """The entry of new arguments: a stepper, or None when the checked path must take
        them (invalid: not kept, or an adaptive method)."""
        from s2gen.runtime import check_run
        from s2gen.runtime.inputs import parameter_vector

        system, stepper = self.backend.system, None
        opts = options or Options()
        try:
            if not check_method(method, self.backend.name).adaptive:
                check_run(system, method, h, h, opts)
                p = parameter_vector(system, params)
                stepper = make_stepper(self.backend, method, h, p, opts, q, omega)
        except ValueError:
            return _Entry(None, 0.0, 0.0, options, pkey)
        # |(computed length) - 1| is within 1e-15 of NumPy's; nearer the limit, NumPy decides
        limit = opts.unit_tol - 1e-15 if opts.unit_tol > 0 else math.inf
        if len(self._entries) >= STEP_CACHE_SIZE:
            del self._entries[next(iter(self._entries))]
        self._entries[key] = _Entry(stepper, limit, opts.unit_tol, options, pkey)
        return self._entries[key]


def _plausible(q: np.ndarray, omega: np.ndarray, limit: float, unit_tol: float) -> bool:
    """True when the q_i are unit vectors to within `limit` and omega is finite (a sum that
    overflows says False: the checked path then decides).

    Example:
        >>> _plausible(np.eye(3), np.zeros((3, 3)), 1e-12, 1e-12)
        True
        >>> _plausible(np.eye(3), np.full((3, 3), np.nan), 1e-12, 1e-12)
        False
    """
    if q.shape[0] <= _SCALAR_CHECK_BODIES:
        for x, y, z in q.tolist():
            if not abs(math.sqrt(x * x + y * y + z * z) - 1.0) <= limit:
                return False
        return math.isfinite(sum(omega.ravel().tolist()))
    finite = bool(np.all(np.isfinite(q)) and np.all(np.isfinite(omega)))
    off = np.abs(np.linalg.norm(q, axis=1) - 1.0)
    return finite and (unit_tol <= 0 or bool(np.all(off <= unit_tol)))
