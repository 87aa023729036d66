"""One step of the forced variational integrator and of forced RATTLE, from t to t + h.

Input: a `DrivenProblem`, a state (q, w) ((n, 3) arrays) at time t, the step h, the inputs u
held over the step, and the tolerance and iteration limit of the implicit solves.
Output: (q+, w+, iterations) from `forced_vi_step` and `forced_rattle_step`; `step_work`, the
work of one step consistent with both. Failures raise `InfeasibleStep` or `NewtonFailure`.

Forced VI (discrete Lagrange-d'Alembert principle, Marsden & West 2001, Acta Numerica 10,
section 3.2): with the conservative L_d of `vi.py` (V at t and at t + h, both with u) and the
trapezoidal discrete forces f_d^- = (h/2) F(q, w, t, u), f_d^+ = (h/2) F(q+, w+, t + h, u), the
forced discrete Legendre transforms p = -D_1 L_d - f_d^-, p+ = D_2 L_d + f_d^+ read, projected by
q_i x and q_i+ x (as in `vi.py`):
    sum_j M_ij q_i x (q_j+ - q_j) = d_i + (h^2/2) q_i x F_i,                    (position)
    A(q+) w+ = c + (h/2) q+ x F(q+, w+, t + h, u),                                (velocity)
with d and c those of the conservative step. Diagonal M: a_i = (d_i + h^2/2 q_i x F_i)/M_ii,
q_i+ = a_i x q_i + sqrt(1 - a_i.a_i) q_i and
    w_i+ = w_i - h/(2M_ii)(q_i x g_i + q_i+ x g_i+) + h/(2M_ii)(q_i x F_i + q_i+ x F_i+).
Coupled M: Newton on the Cayley parameters with the forced d (the residual of `vi.py`).
RATTLE on Cartesian x_i = q_i, v_i = qdot_i = w_i x q_i, constraints |x_i|^2 = 1:
    v' = v + h/2 M^-1 (F - g - lambda x),   x+ = x + h v',   |x_i+|^2 = 1,
    v+ = v' + h/2 M^-1 (F+ - g+ - mu x+),   x_i+ . v_i+ = 0,   w+ = x+ x v+,
the multipliers by Newton (position, n unknowns) and a linear solve (velocity).
When F depends on w the velocity update is implicit in w+: it is solved by Newton's method
(Jacobian by forward differences in w+) until max|update| <= tol max(1, max|w+|).
Both steps are symmetric (the forces enter with weight h/2 at the step's two ends, at their own
times, with the same u), so symmetric compositions of them keep their orders; `step_work` is
the trapezoidal rule (h/2)(P(t) + P(t + h)) of the power P, which is the discrete work of f_d^-
and f_d^+ against the end velocities plus that of dV/dt, symmetric as well.

Example:
    >>> from s2gen.reference.forced import DrivenProblem
    >>> from s2gen.reference.problem import ReferenceProblem
    >>> free = DrivenProblem(ReferenceProblem(np.eye(1), lambda q: 0 * q, lambda q: 0.0))
    >>> q1, w1, its = forced_vi_step(free, np.array([[1.0, 0, 0]]), np.array([[0, 0, 0.6]]),
    ...                              0.0, 1.0, np.zeros(0))
    >>> q1.round(12).tolist(), its
    ([[0.8, 0.6, 0.0]], 0)
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s2gen.reference.errors import InfeasibleStep
from s2gen.reference.forced import DrivenProblem
from s2gen.reference.geometry import _cross, _off_diagonal, inertia_operator
from s2gen.reference.newton import newton
from s2gen.reference.problem import Array, numbers
from s2gen.reference.vi import _cayley_apply, _newton_cayley

__all__ = ["forced_rattle_step", "forced_vi_step", "step_work"]


def _newton_velocity(
    phi: Callable[[Array], Array], w0: Array, tol: float, maxiter: int, step: int
) -> tuple[Array, int]:
    """Solve w = phi(w) by Newton's method on G(w) = w - phi(w), forward-difference Jacobian.

    Stops when max|update| <= tol max(1, max|w|); raises `NewtonFailure` after `maxiter`
    iterations, on a non-finite iterate or a singular Jacobian.
    """
    m = np.size(w0)

    def linearize(w: Array) -> tuple[Array, Array]:
        G = (w - phi(w)).ravel()
        J = np.empty((m, m))  # real: an approximate Jacobian, also for a complex w (below)
        for c in range(m):
            e = 1e-7 * max(1.0, abs(float(w.flat[c].real)))
            wc = w.copy()
            wc.flat[c] += e
            J[:, c] = (((wc - phi(wc)).ravel() - G) / e).real
        return G, J

    return newton(np.array(numbers(w0)), linearize, tol, maxiter, step, "velocity update")


def _end_velocity(
    problem: DrivenProblem,
    q1: Array,
    w_free: Array,
    force_map: Callable[[Array], Array],
    t1: float,
    u: Array,
    tol: float,
    maxiter: int,
    step: int,
) -> tuple[Array, int]:
    """w+ = w_free + force_map(F(q+, w+, t1, u)); explicit unless F depends on w."""
    F1 = problem.F(q1, w_free, t1, u)
    if F1 is None:
        return w_free, 0
    if not problem.implicit_velocity:
        return w_free + force_map(F1), 0
    phi = lambda w: w_free + force_map(problem.F(q1, w, t1, u))
    return _newton_velocity(phi, phi(w_free), tol, maxiter, step)


def forced_vi_step(
    problem: DrivenProblem,
    q: Array,
    w: Array,
    t: float,
    h: float,
    u: Array,
    *,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
    step: int = 0,
) -> tuple[Array, Array, int]:
    """One forced VI step (q, w) at t -> (q+, w+) at t + h with u held; (q+, w+, iterations).

    The equations are those of the module docstring; without forces and added potential every
    floating-point operation is the conservative `vi_step`'s.

    Example:
        >>> from s2gen.reference.forced import DrivenProblem
        >>> from s2gen.reference.problem import ReferenceProblem
        >>> rotor = ReferenceProblem(np.eye(1), lambda q: 0 * q, lambda q: 0.0)
        >>> spin = DrivenProblem(rotor, force=lambda q, w, t, u: np.cross([0, 0, u[0]], q),
        ...                      velocity_dependent=False, n_inputs=1)
        >>> q1, w1, _ = forced_vi_step(spin, np.array([[1.0, 0, 0]]), np.zeros((1, 3)), 0.0,
        ...                            0.1, np.array([2.0]))
        >>> w1.round(12).tolist()  # w+ = h tau / m
        [[0.0, 0.0, 0.2]]
    """
    q = numbers(q)
    w = numbers(w)
    M = problem.M
    g0 = problem.dVdq(q, t, u)
    F0 = problem.F(q, w, t, u)
    coupling = _off_diagonal(M) @ _cross(w, q)
    d = h * np.diag(M)[:, None] * w + h * _cross(q, coupling) - 0.5 * h * h * _cross(q, g0)
    if F0 is not None:
        d = d + 0.5 * h * h * _cross(q, F0)
    t1 = t + h
    if problem.base.is_diagonal:
        m = np.diag(M)[:, None]
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
        g1 = problem.dVdq(q1, t1, u)
        w1 = w - h / (2.0 * m) * _cross(q, g0) - h / (2.0 * m) * _cross(q1, g1)
        if F0 is not None:
            w1 = w1 + h / (2.0 * m) * _cross(q, F0)

        def diagonal_map(F: Array) -> Array:
            return h / (2.0 * m) * _cross(q1, F)

        w1, its = _end_velocity(
            problem, q1, w1, diagonal_map, t1, u, newton_tol, newton_maxiter, step
        )
        return q1, w1, its
    f, iterations = _newton_cayley(M, q, d, newton_tol, newton_maxiter, step)
    q1 = _cayley_apply(f, q)
    g1 = problem.dVdq(q1, t1, u)
    A = inertia_operator(M, q1)
    c = _cross(q1, M @ (q1 - q)) / h - 0.5 * h * _cross(q1, g1)
    w1 = np.linalg.solve(A, c.ravel()).reshape(q.shape)

    def force_map(F: Array) -> Array:
        return np.linalg.solve(A, (0.5 * h * _cross(q1, F)).ravel()).reshape(q.shape)

    w1, its = _end_velocity(problem, q1, w1, force_map, t1, u, newton_tol, newton_maxiter, step)
    return q1, w1, iterations + its


def _rattle_position(
    Minv: Array, x: Array, y: Array, tol: float, maxiter: int, step: int
) -> tuple[Array, int]:
    """x+ = y - Minv (s x) with |x_i+|^2 = 1: Newton on the n scalars s from s = 0."""

    def linearize(s: Array) -> tuple[Array, Array]:
        xn = y - Minv @ (s[:, None] * x)
        r = np.sum(xn * xn, axis=1) - 1.0
        return r, -2.0 * Minv * (xn @ x.T)  # dr_i/ds_j = -2 Minv_ij x+_i . x_j

    s, its = newton(np.zeros(x.shape[0]), linearize, tol, maxiter, step, "RATTLE position")
    return y - Minv @ (s[:, None] * x), its


def forced_rattle_step(
    problem: DrivenProblem,
    q: Array,
    w: Array,
    t: float,
    h: float,
    u: Array,
    *,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
    step: int = 0,
) -> tuple[Array, Array, int]:
    """One forced RATTLE step (module docstring) in (q, w) form; (q+, w+, iterations).

    Example:
        >>> from s2gen.reference.forced import DrivenProblem
        >>> from s2gen.reference.problem import ReferenceProblem
        >>> free = DrivenProblem(ReferenceProblem(np.eye(1), lambda q: 0 * q, lambda q: 0.0))
        >>> q1, w1, _ = forced_rattle_step(free, np.array([[1.0, 0, 0]]),
        ...                                np.array([[0, 0, 1.0]]), 0.0, 0.1, np.zeros(0))
        >>> bool(abs(np.linalg.norm(q1) - 1) < 1e-15), round(float(w1[0, 2]), 12)
        (True, 1.0)
    """
    x = numbers(q)
    w = numbers(w)
    Minv = np.linalg.inv(problem.M)
    v = _cross(w, x)
    a0 = -problem.dVdq(x, t, u)
    F0 = problem.F(x, w, t, u)
    if F0 is not None:
        a0 = a0 + F0
    y = x + h * v + 0.5 * h * h * (Minv @ a0)
    x1, its = _rattle_position(Minv, x, y, newton_tol, newton_maxiter, step)
    t1 = t + h
    v_half = (x1 - x) / h
    g1 = problem.dVdq(x1, t1, u)
    B = Minv * (x1 @ x1.T)  # B_ij = Minv_ij x+_i . x+_j

    def project(p: Array) -> Array:
        """v' + h/2 Minv p with the multiplier that makes x_i+ . v_i+ = 0."""
        un = v_half + 0.5 * h * (Minv @ p)
        mu = np.linalg.solve(B, np.sum(x1 * un, axis=1))
        return un - Minv @ (mu[:, None] * x1)

    if problem.force is None:
        return x1, _cross(x1, project(-g1)), its
    w_free = _cross(x1, project(-g1 + problem.F(x1, _cross(x1, v_half), t1, u)))
    if not problem.implicit_velocity:
        return x1, w_free, its

    def phi(wn: Array) -> Array:
        return _cross(x1, project(-g1 + problem.F(x1, wn, t1, u)))

    w1, vits = _newton_velocity(phi, w_free, newton_tol, newton_maxiter, step)
    return x1, w1, its + vits


def step_work(
    problem: DrivenProblem, q: Array, w: Array, q1: Array, w1: Array, t: float, h: float, u: Array
) -> float:
    """(h/2)(P(q, w, t, u) + P(q+, w+, t + h, u)), P = dV/dt + sum_i F_i . qdot_i.

    Example:
        >>> from s2gen.reference.forced import DrivenProblem
        >>> from s2gen.reference.problem import ReferenceProblem
        >>> p = ReferenceProblem(np.eye(1), lambda q: 0 * q, lambda q: 0.0)
        >>> lin = DrivenProblem(p, lambda q, t, u: t, lambda q, t, u: 0 * q, lambda q, t, u: 1.0)
        >>> z = np.zeros((1, 3))
        >>> step_work(lin, z, z, z, z, 0.0, 0.5, np.zeros(0))  # V = t: W = h
        0.5
    """
    return 0.5 * h * (problem.power(q, w, t, u) + problem.power(q1, w1, t + h, u))
