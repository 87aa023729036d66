"""The Jacobian of one reference step by the complex-step derivative.

Input: a `System` (closed or driven), a fixed-step method (the VI and RATTLE families with
their compositions, the fixed-step Runge-Kutta methods: `STEP_METHODS`), a state (q, w) at
time t, a step h, the inputs u held over the step and the parameter values.
Output: from `step_jacobian`, the state after the step and A = dx+/dx (6n x 6n, the
embedding coordinates x = (q, w), the 3n components of q body-major, then the 3n of w),
B = dx+/du (6n x inputs) and P = dx+/dp (6n x parameters, in `System.parameter_names`
order); from `step_jvp`, the state after the step and A d for one state direction d (one
complex step); from `state_jacobian`, A alone through a step built once by
`reference_stepper` (for runs of many steps). The field's Jacobian is
`s2gen.reference.field_jacobian`'s.

The derivative is taken through the reference's own step (`forced_integrate`'s VI, RATTLE and
Runge-Kutta steps on the `DrivenProblem` of the system; a closed system is the problem
without drive, whose steps are the conservative ones operation for operation), not from any
derived equation: for a real-analytic step f and a real direction d,
f(x + i eps d) = f(x) + i eps f'(x) d + O(eps^2), so f'(x) d = Im f(x + i eps d) / eps with
no subtraction, exact to round-off for any small eps (here 1e-30: the O(eps^2) terms are below
the smallest double relative to the value). The step carries complex states, inputs and
parameters (`problem.numbers`); its implicit solves stop on the real parts, so the iteration
counts are the real step's, and Newton's converged iterate carries the derivative of the
solution in its imaginary part (the implicit function theorem, applied by the iteration
itself). A parameter direction rebuilds the problem at complex parameter values (the mass
matrix, the potential's and the forces' coefficients).

Example:
    >>> from s2gen.systems import builtin
    >>> s = builtin("double_pendulum")
    >>> qn, wn, A, B, P = step_jacobian(s, "vi", 0.0, 0.01, s.q0, s.omega0, None,
    ...                                 s.parameter_values)
    >>> A.shape, B.shape, P.shape
    ((12, 12), (12, 0), (12, 5))
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from s2gen.methods import method as method_row
from s2gen.reference.driven_system import driven_problem_from_system
from s2gen.reference.forced import DrivenProblem
from s2gen.reference.forced_integrate import DRIVEN_METHODS, _geometric, _runge_kutta
from s2gen.reference.problem import Array, problem_from_system
from s2gen.reference.recorder import _new_stats
from s2gen.system import System

__all__ = [
    "EPS",
    "STEP_METHODS",
    "complex_step",
    "reference_step",
    "reference_stepper",
    "state_jacobian",
    "step_jacobian",
    "step_jvp",
]

#: The imaginary step of the complex-step derivative
EPS = 1e-30
#: The methods whose step `step_jacobian` differentiates (the fixed-step ones)
STEP_METHODS = DRIVEN_METHODS


def _problem(system: System, params: Sequence[Any] | Array) -> DrivenProblem:
    """The system's problem at the parameter values (real or complex)."""
    if system.driven:
        return driven_problem_from_system(system, list(params))
    return DrivenProblem(problem_from_system(system, list(params)))


def reference_stepper(
    system: System,
    method: str,
    params: Sequence[Any] | Array,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> Callable[[Array, Array, float, float, Array], tuple[Array, Array]]:
    """The reference's step of `method` as a function (q, w, t, h, u) -> (q+, w+) at the
    parameter values `params` (the problem built once, for many steps); q, w and u may be
    complex. ValueError (one line) for a method without a fixed step.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> f = reference_stepper(s, "vi", s.parameter_values)
        >>> q1, w1 = f(s.q0, s.omega0, 0.0, 0.01, np.zeros(0))
        >>> bool(abs(np.linalg.norm(q1, axis=1) - 1).max() < 1e-14)
        True
    """
    if method not in STEP_METHODS:
        raise ValueError(
            f"{system.name}: the reference's step Jacobian is for the fixed-step methods "
            f"{', '.join(STEP_METHODS)}, not {method!r}"
        )
    problem = _problem(system, params)
    stats = _new_stats()
    if method_row(method).geometric:
        advance = _geometric(problem, method, newton_tol, newton_maxiter, stats)
    else:
        advance = _runge_kutta(problem, method, stats)

    def step(q: Array, w: Array, t: float, h: float, u: Array) -> tuple[Array, Array]:
        q1, w1, _ = advance(q, w, t, h, 0, u)
        return q1, w1

    return step


def reference_step(
    system: System,
    method: str,
    params: Sequence[Any] | Array,
    t: float,
    h: float,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> Callable[[Array, Array, Array], tuple[Array, Array]]:
    """The reference's step of `method` from time t as a function (q, w, u) -> (q+, w+) at
    the parameter values `params`; q, w and u may be complex. ValueError (one line) for a
    method without a fixed step.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> f = reference_step(s, "rk4", s.parameter_values, 0.0, 0.01)
        >>> q1, w1 = f(s.q0 + 0j, s.omega0, np.zeros(0))
        >>> q1.dtype, q1.shape
        (dtype('complex128'), (2, 3))
    """
    advance = reference_stepper(system, method, params, newton_tol, newton_maxiter)

    def step(q: Array, w: Array, u: Array) -> tuple[Array, Array]:
        return advance(q, w, t, h, u)

    return step


def complex_step(fun: Callable[[Array], Array], x: Array, directions: Array) -> Array:
    """The derivative of `fun` (real-analytic, R^m -> R^k, written for complex arrays) at x
    along each column of `directions` (m x c): shape (k, c), Im fun(x + i EPS d) / EPS.

    Example:
        >>> d = complex_step(lambda x: np.exp(x) * np.sin(x), np.array([0.7]), np.eye(1))
        >>> bool(abs(d[0, 0] - np.exp(0.7) * (np.sin(0.7) + np.cos(0.7))) < 1e-15)
        True
    """
    x = np.asarray(x, dtype=float)
    cols = [np.imag(fun(x + 1j * EPS * d)) / EPS for d in np.asarray(directions, dtype=float).T]
    if not cols:
        return np.zeros((np.size(fun(x)), 0))
    return np.stack(cols, axis=1)


def _flat(qw: tuple[Array, Array]) -> Array:
    """(q, w) as one vector x in the embedding order."""
    return np.concatenate([np.ravel(qw[0]), np.ravel(qw[1])])


def _split(y: Array, n: int) -> tuple[Array, Array]:
    """x in the embedding order as (q, w), shape (n, 3) each."""
    return y[: 3 * n].reshape(n, 3), y[3 * n :].reshape(n, 3)


def _inputs(system: System, u: Array | Sequence[float] | None) -> Array:
    """The inputs as a real vector (None: the spec's)."""
    ni = len(system.inputs.names)
    return np.asarray(system.inputs.values if u is None else u, dtype=float).reshape(ni)


def step_jacobian(
    system: System,
    method: str,
    t: float,
    h: float,
    q: Array,
    w: Array,
    u: Array | Sequence[float] | None,
    params: Sequence[float] | Array,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> tuple[Array, Array, Array, Array, Array]:
    """One reference step of `method` from (q, w) (shape (n, 3)) at time t with the inputs u
    (None: the spec's) and its derivatives by the complex step: (q+, w+, A, B, P) in the
    embedding coordinates (module docstring). Each column costs one complex step.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> qn, wn, A, B, P = step_jacobian(s, "rk4", 0.0, 0.01, s.q0, s.omega0, None,
        ...                                 s.parameter_values)
        >>> bool(np.allclose(A, np.eye(12), atol=0.2)), P.shape
        (True, (12, 5))
    """
    n, ni = system.n, len(system.inputs.names)
    p = np.asarray(params, dtype=float)
    uu = _inputs(system, u)
    x = np.concatenate([np.ravel(q), np.ravel(w)]).astype(float)
    step = reference_step(system, method, p, t, h, newton_tol, newton_maxiter)
    qn, wn, A = state_jacobian(step, x, uu, n)
    B = complex_step(lambda v: _flat(step(*_split(x, n), v)), uu, np.eye(ni))

    def in_params(pp: Array) -> Array:
        return _flat(
            reference_step(system, method, pp, t, h, newton_tol, newton_maxiter)(*_split(x, n), uu)
        )

    P = complex_step(in_params, p, np.eye(len(p)))
    return qn, wn, A, B, P


def state_jacobian(
    step: Callable[[Array, Array, Array], tuple[Array, Array]], x: Array, u: Array, n: int
) -> tuple[Array, Array, Array]:
    """The step (q, w, u) -> (q+, w+) of n bodies from x = (q, w) (embedding order, real)
    with the inputs u, and its state derivative: (q+, w+, A), A by 6n complex steps; q+ and w+
    are the real step's.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> f = reference_step(s, "vi", s.parameter_values, 0.0, 0.01)
        >>> x = np.concatenate([s.q0.ravel(), s.omega0.ravel()])
        >>> qn, wn, A = state_jacobian(f, x, np.zeros(0), 2)
        >>> A.shape, bool((qn == f(s.q0, s.omega0, np.zeros(0))[0]).all())
        ((12, 12), True)
    """
    x1 = _flat(step(*_split(x, n), u))
    A = complex_step(lambda y: _flat(step(*_split(y, n), u)), x, np.eye(6 * n))
    qn, wn = _split(x1, n)
    return qn.copy(), wn.copy(), A


def step_jvp(
    system: System,
    method: str,
    t: float,
    h: float,
    q: Array,
    w: Array,
    dq: Array,
    dw: Array,
    u: Array | Sequence[float] | None,
    params: Sequence[float] | Array,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> tuple[Array, Array, Array, Array]:
    """One reference step of `method` from (q, w) at time t with the inputs u (None: the
    spec's) and its derivative along the state direction (dq, dw) (all of shape (n, 3),
    embedding coordinates): (q+, w+, dq+, dw+), (dq+, dw+) = A (dq, dw) by one complex step
    (two steps in all: q+ and w+ are the real step's).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> qn, wn, dqn, dwn = step_jvp(s, "vi", 0.0, 0.01, s.q0, s.omega0, 0 * s.q0,
        ...                             s.omega0, None, s.parameter_values)
        >>> dqn.shape, bool(np.abs(dwn - s.omega0).max() < 0.1)
        ((2, 3), True)
    """
    n = system.n
    p = np.asarray(params, dtype=float)
    uu = _inputs(system, u)
    x = np.concatenate([np.ravel(q), np.ravel(w)]).astype(float)
    d = np.concatenate([np.ravel(dq), np.ravel(dw)]).astype(float)
    step = reference_step(system, method, p, t, h, newton_tol, newton_maxiter)
    qn, wn = (a.copy() for a in _split(_flat(step(*_split(x, n), uu)), n))
    dx = complex_step(lambda y: _flat(step(*_split(y, n), uu)), x, d[:, None])[:, 0]
    dqn, dwn = _split(dx, n)
    return qn, wn, dqn.copy(), dwn.copy()
