"""The continuous equations of motion (paper eqs. ELq and ELwm) as a vector field.

Input: a `ReferenceProblem` and a state q, w ((n, 3) arrays).
Output: (qdot, wdot), each (n, 3); wdot solves A(q) wdot = b (a division when M is diagonal).
A singular A raises `numpy.linalg.LinAlgError`.
"""

from __future__ import annotations

import numpy as np

from s2gen.reference.geometry import _cross, _off_diagonal, inertia_operator
from s2gen.reference.problem import Array, ReferenceProblem, numbers

__all__ = ["continuous_rhs"]


def continuous_rhs(problem: ReferenceProblem, q: Array, w: Array) -> tuple[Array, Array]:
    """The vector field (qdot, wdot) of paper eqs. ELq and ELwm, implemented literally.

    qdot_i = w_i x q_i and A(q) wdot = b with b_i = sum_{j!=i} M_ij (w_j.w_j) q_i x q_j
    - q_i x g_i. Nothing is renormalized.

    Example:
        >>> e3 = np.array([[0.0, 0.0, 1.0]])
        >>> p = ReferenceProblem(np.array([[2.0]]), lambda q: -e3, lambda q: -q[0, 2])
        >>> dq, dw = continuous_rhs(p, np.array([[1.0, 0, 0]]), np.zeros((1, 3)))
        >>> dw.tolist()
        [[0.0, -0.5, 0.0]]
    """
    q = numbers(q)
    w = numbers(w)
    M = problem.M
    g = numbers(problem.grad(q))
    ww = np.sum(w * w, axis=1)
    b = _cross(q, (_off_diagonal(M) * ww[None, :]) @ q) - _cross(q, g)
    if problem.is_diagonal:  # A = diag(M_ii) I: the solve is a division
        return _cross(w, q), b / np.diag(M)[:, None]
    wdot = np.linalg.solve(inertia_operator(M, q), b.ravel()).reshape(q.shape)
    return _cross(w, q), wdot
