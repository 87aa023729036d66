"""Runs of driven systems from Python: the start time, the inputs (an array or state feedback)
and the work done, through the emitted C's or NumPy's driven integrate().

Input: a C or NumPy backend of a driven system (forces, inputs or time t), a fixed-step
method of the VI family or an explicit Runge-Kutta method, h, the number of steps, the initial
state at t0, the parameters and the inputs: None (the spec's defaults), an array of shape
(steps, n_inputs) (row k held over step k), or a callable ``u(t, q, w)`` returning the
n_inputs values to hold over the step that starts at t from the state (q, w) (arrays of
shape (n, 3)), called once per step. Output: the arrays of the run, the work done and the
inputs that were held.

A callable that raises, or returns values that are not n_inputs finite numbers, stops the run
at that step: the samples before it are kept and the error names the step and the cause.

Example:
    >>> from s2gen.spec import define_system
    >>> s = define_system(name="spin", bodies=1, parameters={}, inputs={"tau": 1.0},
    ...                   diagonal=["2"], potential=0, forces={"F1": "tau*cross(e3, q1)"})
    >>> rows = input_rows(s, [[1.0], [2.0]], 2)
    >>> rows.shape, input_rows(s, None, 2)
    ((2, 1), None)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from s2gen.methods import driven_methods
from s2gen.system import System

__all__ = ["Feedback", "check_driven_method", "input_rows"]

#: What a caller may give as inputs.
Inputs = Any


def check_driven_method(system: System, method: str, backend: str = "c") -> None:
    """ValueError of one line when `method` does not integrate this driven system (yet) on
    `backend` (the NumPy module has no RATTLE for driven systems).

    Example:
        >>> from s2gen.spec import define_system
        >>> s = define_system(name="p", bodies=1, parameters={}, diagonal=["1"],
        ...                   potential="cos(t)*q1[2]")
        >>> check_driven_method(s, "rk2-proj")
        Traceback (most recent call last):
        ...
        ValueError: <python api>: method 'rk2-proj' does not integrate driven systems (forces, inputs or time t) yet; choose one of vi, rk45, rk2, rk4, vi4, rattle, vi6, vi8, rattle4, rattle6, rattle8, dop853, rk3
    """
    numpy = driven_methods(rattle=False, adaptive=False)
    if backend == "numpy" and method in driven_methods() and method not in numpy:
        raise ValueError(
            f"{system.origin}: method {method!r} integrates driven systems on the c backend "
            f"only yet; on numpy choose one of {', '.join(numpy)}"
        )
    rattle = not system.forces or system.is_diagonal
    if method in driven_methods() and method not in driven_methods(rattle):
        raise ValueError(
            f"{system.origin}: method {method!r} takes forces only with a diagonal inertia "
            f"yet; choose one of {', '.join(driven_methods(rattle))}"
        )
    if method not in driven_methods(rattle):
        raise ValueError(
            f"{system.origin}: method {method!r} does not integrate driven systems (forces, "
            f"inputs or time t) yet; choose one of {', '.join(driven_methods(rattle))}"
        )


def input_rows(system: System, inputs: Inputs, nsteps: int) -> np.ndarray | None:
    """The inputs as a C-contiguous float array of shape (nsteps, n_inputs), or None for the
    defaults (or a callable, handled by `Feedback`); ValueError of one line for anything
    else. Non-finite entries are passed on: the run stops at their step.

    Example:
        >>> from s2gen.spec import define_system
        >>> s = define_system(name="p", bodies=1, parameters={}, inputs={"a": 0.0, "b": 1.0},
        ...                   diagonal=["1"], potential="a*q1[2] + b*q1[0]")
        >>> input_rows(s, np.ones((3, 1)), 3)
        Traceback (most recent call last):
        ...
        ValueError: <python api>: inputs of shape (3, 1): expected (3, 2), one row of the 2 inputs (a, b) per step
    """
    if inputs is None or callable(inputs):
        return None
    names = system.inputs.names
    try:
        rows = np.ascontiguousarray(np.asarray(inputs, dtype=float))
    except (TypeError, ValueError):
        raise ValueError(f"{system.origin}: inputs must be an array of numbers") from None
    if rows.shape != (nsteps, len(names)):
        raise ValueError(
            f"{system.origin}: inputs of shape {rows.shape}: expected {(nsteps, len(names))}, "
            f"one row of the {len(names)} inputs ({', '.join(names)}) per step"
        )
    return rows


class Feedback:
    """A Python state feedback ``u(t, q, w)`` as the emitted integrate()'s callback.

    `function` is the ctypes function to pass to the emitted C, `held` the Python function to
    pass to the emitted NumPy; `rows` collects the inputs returned (one row per step); a call
    that raises or returns something else than n_inputs finite numbers writes NaN (the run
    stops there with a non-finite input) and keeps the reason in `error`.

    Example:
        >>> import ctypes
        >>> fb = Feedback(lambda t, q, w: [2.0 * t], n=1, n_inputs=1)
        >>> u = (ctypes.c_double * 1)()
        >>> z = (ctypes.c_double * 3)()
        >>> fb.function(None, 0.5, z, z, u)
        >>> u[0], fb.rows.tolist()
        (1.0, [[1.0]])
    """

    def __init__(self, function: Callable[..., Any], n: int, n_inputs: int) -> None:
        from s2gen.runtime.c import FEEDBACK

        self.call, self.n, self.n_inputs = function, n, n_inputs
        self.error: str | None = None
        self._rows: list[np.ndarray] = []
        self.function = FEEDBACK(self._called)

    @property
    def rows(self) -> np.ndarray:
        """The inputs returned so far, one row per step."""
        return np.array(self._rows, dtype=float).reshape(len(self._rows), self.n_inputs)

    def held(self, t: float, q: np.ndarray, w: np.ndarray) -> np.ndarray:
        """The inputs to hold over the step that starts at t from (q, w) (copied for the
        call): the function's values, or NaN where it failed (the run stops there).

        Example:
            >>> fb = Feedback(lambda t, q, w: [q[0, 2] + t], n=1, n_inputs=1)
            >>> fb.held(0.5, np.array([[0.0, 0.0, 1.0]]), np.zeros((1, 3))).tolist()
            [1.5]
        """
        qa = np.array(q, dtype=float).reshape(self.n, 3)
        wa = np.array(w, dtype=float).reshape(self.n, 3)
        try:
            out = np.asarray(self.call(t, qa, wa), dtype=float).reshape(-1)
            if out.shape != (self.n_inputs,) or not np.all(np.isfinite(out)):
                raise ValueError(
                    f"returned {out.tolist()!r}: expected {self.n_inputs} finite numbers"
                )
        except Exception as exc:  # noqa: BLE001 - no exception crosses C: the run stops here
            if self.error is None:
                self.error = f"the input function at t = {t:.6g}: {type(exc).__name__}: {exc}"
            out = np.full(self.n_inputs, np.nan)
        self._rows.append(out)
        return out

    def _called(self, _ctx: Any, t: float, q: Any, w: Any, u: Any) -> None:
        n3 = 3 * self.n
        qa = np.ctypeslib.as_array(q, shape=(n3,))
        wa = np.ctypeslib.as_array(w, shape=(n3,))
        out = self.held(t, qa, wa)
        for k in range(self.n_inputs):
            u[k] = float(out[k])
