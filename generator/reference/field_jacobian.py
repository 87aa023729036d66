"""The Jacobian of the reference's continuous field by the complex-step derivative.

Input: a `System` (closed or driven), a state (q, w) at time t, the inputs u and the
parameter values. Output: from `field_jacobian`, the field (qdot, wdot) and its derivatives
J = df/dx (6n x 6n, the embedding coordinates x = (q, w) of `s2gen.reference.step_jacobian`),
Ju = df/du (6n x inputs) and Jp = df/dp (6n x parameters, in `System.parameter_names` order).

The field is the one the reference's Runge-Kutta steps evaluate: `driven_rhs` of the system's
`DrivenProblem` (for a closed system the conservative field, operation for operation:
qdot_i = w_i x q_i and A(q) wdot = b), differentiated as `step_jacobian` differentiates a step:
f'(x) d = Im f(x + i EPS d) / EPS, one complex evaluation per column, exact to round-off, with
no derived equation. A parameter column evaluates the field of the problem built at complex
parameter values.

Example:
    >>> from s2gen.systems import builtin
    >>> s = builtin("double_pendulum")
    >>> qd, wd, J, Ju, Jp = field_jacobian(s, 0.0, s.q0, s.omega0, None, s.parameter_values)
    >>> J.shape, Ju.shape, Jp.shape
    ((12, 12), (12, 0), (12, 5))
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from s2gen.reference.forced import driven_rhs
from s2gen.reference.problem import Array
from s2gen.reference.step_jacobian import _flat, _inputs, _problem, _split, complex_step
from s2gen.system import System

__all__ = ["field_jacobian"]


def field_jacobian(
    system: System,
    t: float,
    q: Array,
    w: Array,
    u: Array | Sequence[float] | None,
    params: Sequence[float] | Array,
) -> tuple[Array, Array, Array, Array, Array]:
    """The reference field at (q, w) (shape (n, 3)) at time t with the inputs u (None: the
    spec's) and its derivatives by the complex step: (qdot, wdot, J, Ju, Jp) in the embedding
    coordinates (module docstring); qdot and wdot are the real evaluation's. A singular A(q)
    raises `numpy.linalg.LinAlgError`.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> qd, wd, J, Ju, Jp = field_jacobian(s, 0.0, s.q0, s.omega0, None,
        ...                                    s.parameter_values)
        >>> bool(np.allclose(J[:6, 6:] @ s.omega0.ravel(), qd.ravel()))  # qdot is linear in w
        True
    """
    n, ni = system.n, len(system.inputs.names)
    p = np.asarray(params, dtype=float)
    uu = _inputs(system, u)
    x = np.concatenate([np.ravel(q), np.ravel(w)]).astype(float)
    problem = _problem(system, p)

    def field(y: Array, v: Array) -> Array:
        return _flat(driven_rhs(problem, t, *_split(y, n), v))

    qd, wd = (a.copy() for a in _split(field(x, uu), n))
    J = complex_step(lambda y: field(y, uu), x, np.eye(6 * n))
    Ju = complex_step(lambda v: field(x, v), uu, np.eye(ni))

    def in_params(pp: Array) -> Array:
        return _flat(driven_rhs(_problem(system, pp), t, *_split(x, n), uu))

    Jp = complex_step(in_params, p, np.eye(len(p)))
    return qd, wd, J, Ju, Jp
