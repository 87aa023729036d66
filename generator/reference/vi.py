"""The variational integrator of Lee, Leok & McClamroch on (S^2)^n, one step at a time.

Input: a `ReferenceProblem`, a state (q_k, w_k) ((n, 3) arrays), a step h and Newton's
tolerance and iteration limit.
Output: (q_k+1, w_k+1, Newton iterations) from `vi_step` (explicit update, paper eqs. qikpexp
and wikpexp, when M is diagonal; Newton on the Cayley residual, eqs. imp/impf, then the
velocity solve, eq. DELw2m, otherwise), and the pieces: the known side d (`vi_d`), the Cayley
residual and its analytic Jacobian. A failed step raises `InfeasibleStep` or `NewtonFailure`
(a singular velocity solve raises numpy's LinAlgError, reported by the fixed-step driver of
`recorder.py` as `SingularSystem`); `_vi_advance` adapts `vi_step` to that driver.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s2gen.reference.errors import InfeasibleStep
from s2gen.reference.geometry import _assemble, _cross, _hats, _off_diagonal, inertia_operator
from s2gen.reference.newton import newton
from s2gen.reference.problem import Array, ReferenceProblem, numbers
from s2gen.reference.recorder import _Recorder, _state

__all__ = ["vi_d", "vi_jacobian", "vi_residual", "vi_step"]


def _cayley_apply(f: Array, q: Array) -> Array:
    """F_i q_i = ((1 - f_i.f_i) q_i + 2 f_i x q_i) / (1 + f_i.f_i) for each body (f_i _|_ q_i)."""
    s = np.sum(f * f, axis=1)[:, None]
    return ((1.0 - s) * q + 2.0 * _cross(f, q)) / (1.0 + s)


def vi_d(problem: ReferenceProblem, q: Array, w: Array, h: float) -> Array:
    """The known side d of paper eq. DELw1 (signs from the discrete Legendre transform):

    d_i = h M_ii w_i + h sum_{j!=i} M_ij q_i x (w_j x q_j) - (h^2/2) q_i x g_i(q).

    Example:
        >>> p = ReferenceProblem(np.array([[2.0]]), lambda q: 0 * q, lambda q: 0.0)
        >>> vi_d(p, np.array([[1.0, 0, 0]]), np.array([[0, 0, 3.0]]), 0.1).round(12).tolist()
        [[0.0, 0.0, 0.6]]
    """
    M = problem.M
    g = numbers(problem.grad(q))
    coupling = _off_diagonal(M) @ _cross(w, q)
    return h * np.diag(M)[:, None] * w + h * _cross(q, coupling) - 0.5 * h * h * _cross(q, g)


def vi_residual(M: Array, q: Array, f: Array, d: Array) -> Array:
    """Cayley residual of paper eq. imp/impf, r = 0 at the VI update:

    r_i(f) = 2 M_ii (q_i.q_i) f_i/(1+f_i.f_i) + sum_{j!=i} M_ij q_i x (F_j q_j - q_j) - d_i.

    The first term is M_ii q_i x F_i q_i = 2 M_ii q_i x (f_i x q_i)/(1+f_i.f_i) for f_i _|_ q_i.
    The factor q_i.q_i (= 1 on the sphere) keeps that identity exact when |q_i| carries
    round-off; without it the momentum drift grows like N^1.5 (see `vi_step`).

    Example:
        >>> q, f = np.array([[1.0, 0, 0]]), np.array([[0, 0, 0.5]])
        >>> vi_residual(np.array([[1.0]]), q, f, np.array([[0, 0, 0.8]])).tolist()
        [[0.0, 0.0, 0.0]]
    """
    s = np.sum(f * f, axis=1)[:, None]
    qq = np.sum(q * q, axis=1)[:, None]
    coupling = _off_diagonal(M) @ (_cayley_apply(f, q) - q)
    return 2.0 * np.diag(M)[:, None] * qq * f / (1.0 + s) + _cross(q, coupling) - d


def vi_jacobian(M: Array, q: Array, f: Array) -> Array:
    """Analytic 3n x 3n Jacobian dr/df of `vi_residual` (s_i = f_i.f_i):

    J_ii = M_ii (q_i.q_i) (2 I/(1+s_i) - 4 f_i f_i^T/(1+s_i)^2),
    J_ij = M_ij hat(q_i) D_j (j != i), D_j = d(F_j q_j)/df_j
         = -2 (q_j f_j^T + hat(q_j))/(1+s_j) - 2 (F_j q_j) f_j^T/(1+s_j).

    Example:
        >>> J = vi_jacobian(np.array([[2.0]]), np.array([[1.0, 0, 0]]), np.zeros((1, 3)))
        >>> J.tolist() == (4 * np.eye(3)).tolist()
        True
    """
    s = 1.0 + np.sum(f * f, axis=1)[:, None, None]  # 1 + s_j, shape (n, 1, 1)
    qq = np.sum(q * q, axis=1)[:, None, None]
    qf = np.einsum("ja,jb->jab", q, f)
    Fqf = np.einsum("ja,jb->jab", _cayley_apply(f, q), f)
    D = -2.0 * (qf + _hats(q)) / s - 2.0 * Fqf / s
    off = M[:, :, None, None] * np.einsum("iab,jbc->ijac", _hats(q), D)
    ff = np.einsum("ja,jb->jab", f, f)
    diag = np.diag(M)[:, None, None] * qq * (2.0 * np.eye(3) / s - 4.0 * ff / s**2)
    return _assemble(off, list(diag))


def _newton_cayley(
    M: Array, q: Array, d: Array, tol: float, maxiter: int, step: int
) -> tuple[Array, int]:
    """Solve vi_residual(M, q, f, d) = 0 by Newton from f_i = d_i/(2 M_ii).

    Raises `NewtonFailure` when it does not converge in `maxiter` iterations, when an iterate
    is not finite and when the Jacobian is singular.
    """
    f0 = d / (2.0 * np.diag(M)[:, None])
    return newton(
        f0,
        lambda f: (vi_residual(M, q, f, d), vi_jacobian(M, q, f)),
        tol,
        maxiter,
        step,
        "Newton's method",
    )


def _vi_explicit(
    problem: ReferenceProblem, q: Array, w: Array, h: float, d: Array, step: int
) -> tuple[Array, Array]:
    """Paper eqs. qikpexp, wikpexp (diagonal M): a_i = d_i/M_ii, no solve needed."""
    m = np.diag(problem.M)[:, None]
    a = d / m
    aa = np.sum(a * a, axis=1)
    for i in range(problem.n):
        if aa.real[i] > 1.0:
            raise InfeasibleStep(
                step,
                f"explicit VI step infeasible for body {i + 1}: |a|^2 = {aa.real[i]:.6g} > 1 "
                f"(step size h = {h:g} too large)",
            )
    q1 = _cross(a, q) + np.sqrt(1.0 - aa)[:, None] * q
    g0 = numbers(problem.grad(q))
    g1 = numbers(problem.grad(q1))
    w1 = w - h / (2.0 * m) * _cross(q, g0) - h / (2.0 * m) * _cross(q1, g1)
    return q1, w1


def _vi_velocity(problem: ReferenceProblem, q: Array, q1: Array, h: float) -> Array:
    """Paper eq. DELw2m: solve A(q1) w1 = c for w1, where

    c_i = (1/h) q1_i x sum_j M_ij (q1_j - q_j) - (h/2) q1_i x g_i(q1).
    """
    g1 = numbers(problem.grad(q1))
    c = _cross(q1, problem.M @ (q1 - q)) / h - 0.5 * h * _cross(q1, g1)
    return np.linalg.solve(inertia_operator(problem.M, q1), c.ravel()).reshape(q.shape)


def vi_step(
    problem: ReferenceProblem,
    q: Array,
    w: Array,
    h: float,
    *,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
    step: int = 0,
) -> tuple[Array, Array, int]:
    """One variational-integrator step (q_k, w_k) -> (q_k+1, w_k+1); returns (q1, w1, iterations).

    Diagonal M: explicit update (0 iterations). Coupled M: Newton on the Cayley residual until
    max|update| <= newton_tol * max(1, max|f|). `step` only labels errors.

    Example:
        >>> p = ReferenceProblem(np.array([[1.0]]), lambda q: 0 * q, lambda q: 0.0)
        >>> q1, w1, its = vi_step(p, np.array([[1.0, 0, 0]]), np.array([[0, 0, 0.6]]), 1.0)
        >>> q1.round(12).tolist(), its
        ([[0.8, 0.6, 0.0]], 0)
    """
    q = numbers(q)
    w = numbers(w)
    d = vi_d(problem, q, w, h)
    if problem.is_diagonal:
        q1, w1 = _vi_explicit(problem, q, w, h, d, step)
        return q1, w1, 0
    f, iterations = _newton_cayley(problem.M, q, d, newton_tol, newton_maxiter, step)
    q1 = _cayley_apply(f, q)
    return q1, _vi_velocity(problem, q, q1, h), iterations


def _vi_advance(
    rec: _Recorder, h: float, newton_tol: float, newton_maxiter: int
) -> Callable[[Array, int], Array]:
    def advance(y: Array, k: int) -> Array:
        q, w = rec.split(y)
        q1, w1, its = vi_step(
            rec.problem, q, w, h, newton_tol=newton_tol, newton_maxiter=newton_maxiter, step=k
        )
        rec.stats["newton_iterations_total"] += its
        rec.stats["newton_iterations_max"] = max(rec.stats["newton_iterations_max"], its)
        return _state(q1, w1)

    return advance
