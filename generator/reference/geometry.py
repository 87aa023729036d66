"""Geometry of (S^2)^n in NumPy: cross products, hat maps, the inertia operator, invariants.

Input: positions q and angular velocities w, (n, 3) arrays, and a `ReferenceProblem` or its M.
Output: row-wise cross products, hat matrices, the 3n x 3n operator A(q) (A_ii = M_ii I,
A_ij = -M_ij hat(q_i) hat(q_j)), the energy E (float) and the total angular momentum J (3,).
"""

from __future__ import annotations

import numpy as np

from s2gen.reference.problem import Array, ReferenceProblem, numbers

__all__ = ["angular_momentum", "energy", "hat", "inertia_operator"]


def _cross(a: Array, b: Array) -> Array:
    """Row-wise cross product a x b of (..., 3) arrays (np.cross without its overhead);
    complex when either is."""
    a = numbers(a)
    b = numbers(b)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def hat(v: Array) -> Array:
    """The 3x3 matrix with hat(v) @ x == v x x.

    Example:
        >>> hat(np.array([1.0, 2.0, 3.0])) @ np.array([0.0, 0.0, 1.0])
        array([ 2., -1.,  0.])
    """
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def energy(problem: ReferenceProblem, q: Array, w: Array) -> float:
    """E = 1/2 sum_ij M_ij (qdot_i . qdot_j) + V(q), with qdot_i = w_i x q_i.

    Example:
        >>> p = ReferenceProblem(np.array([[2.0]]), lambda q: 0 * q, lambda q: 0.0)
        >>> energy(p, np.array([[1.0, 0, 0]]), np.array([[0, 0, 3.0]]))
        9.0
    """
    q = np.asarray(q, dtype=float)
    qdot = _cross(np.asarray(w, dtype=float), q)
    kinetic = 0.5 * float(np.sum(problem.M * (qdot @ qdot.T)))
    return kinetic + float(problem.potential(q))


def angular_momentum(problem: ReferenceProblem, q: Array, w: Array) -> Array:
    """Total angular momentum J = sum_i q_i x sum_j M_ij qdot_j, shape (3,).

    Example:
        >>> p = ReferenceProblem(np.array([[2.0]]), lambda q: 0 * q, lambda q: 0.0)
        >>> angular_momentum(p, np.array([[1.0, 0, 0]]), np.array([[0, 0, 3.0]]))
        array([0., 0., 6.])
    """
    q = np.asarray(q, dtype=float)
    qdot = _cross(np.asarray(w, dtype=float), q)
    return np.sum(_cross(q, problem.M @ qdot), axis=0)


def inertia_operator(M: Array, q: Array) -> Array:
    """The 3n x 3n matrix A(q): A_ii = M_ii I, A_ij = -M_ij hat(q_i) hat(q_j) (paper ELwm).

    Example:
        >>> A = inertia_operator(np.array([[2.0, 1.0], [1.0, 1.0]]), np.eye(3)[[0, 2]])
        >>> A.shape, bool(np.allclose(A, A.T))
        ((6, 6), True)
    """
    H = _hats(q)
    return _assemble(-M[:, :, None, None] * np.einsum("iab,jbc->ijac", H, H), np.diag(M))


def _hats(q: Array) -> Array:
    """hat(q_i) for each row of q: shape (n, 3, 3)."""
    H = np.zeros((q.shape[0], 3, 3), dtype=np.result_type(q, float))
    H[:, 0, 1], H[:, 0, 2], H[:, 1, 2] = -q[:, 2], q[:, 1], -q[:, 0]
    H[:, 1, 0], H[:, 2, 0], H[:, 2, 1] = q[:, 2], -q[:, 1], q[:, 0]
    return H


def _assemble(blocks: Array, diagonal: Array | list[Array]) -> Array:
    """The 3n x 3n matrix with 3x3 blocks blocks[i, j] (i != j) and diagonal[i] (i == j).

    A scalar diagonal[i] stands for diagonal[i] * I.
    """
    n = blocks.shape[0]
    blocks = blocks.copy()
    for i in range(n):
        blocks[i, i] = diagonal[i] * np.eye(3) if np.ndim(diagonal[i]) == 0 else diagonal[i]
    return blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)


def _off_diagonal(M: Array) -> Array:
    return M - np.diag(np.diag(M))
