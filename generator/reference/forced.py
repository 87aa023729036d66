"""Driven systems in numbers: a conservative problem plus V(q, t, u) and forces F_i(q, w, t, u).

Input: a `ReferenceProblem` (M, V0(q), dV0/dq) and, optionally, an added potential V1(q, t, u)
with its gradient dV1/dq and its partial derivative dV1/dt, and generalized forces
F_i(q, w, t, u) in R^3 conjugate to q_i (virtual work sum_i F_i . delta q_i; only the part of
F_i orthogonal to q_i acts); u is the vector of inputs (shape (n_inputs,)), held over each step.
Output: a `DrivenProblem` and its pieces in numbers: V, dV/dq, dV/dt, F, the power
P = dV/dt + sum_i F_i . qdot_i (qdot_i = w_i x q_i), the energy E = T + V(q, t, u), and the
forced continuous field (`driven_rhs`).

The continuous equations (Lagrange-d'Alembert: delta int L dt + int sum_i F_i . delta q_i dt
= 0 with delta q_i = xi_i x q_i) are q_i x (sum_j M_ij qddot_j + dV/dq_i - F_i) = 0; they
differ from the conservative ones (paper eqs. ELq, ELwm) only by g_i -> g_i - F_i in the right
side: A(q) wdot = b + q x F. Along solutions dE/dt = dV/dt + sum_i F_i . qdot_i = P.

Nothing here shares code with `s2gen.equations`; the conservative parts are those of
`s2gen.reference` (same operations in the same order, so a problem without drive gives the
conservative reference's results bit for bit).

Example:
    >>> e3 = np.array([0.0, 0.0, 1.0])
    >>> rotor = ReferenceProblem(np.array([[2.0]]), lambda q: 0 * q, lambda q: 0.0)
    >>> torque = DrivenProblem(rotor, force=lambda q, w, t, u: u[0] * np.cross(e3, q),
    ...                        velocity_dependent=False, n_inputs=1)
    >>> dq, dw = driven_rhs(torque, 0.0, np.array([[1.0, 0, 0]]), np.zeros((1, 3)), [3.0])
    >>> dw.tolist()  # 2 wdot = q x F = 3 e3
    [[0.0, 0.0, 1.5]]
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from s2gen.reference.geometry import _cross, _off_diagonal, energy, inertia_operator
from s2gen.reference.problem import Array, ReferenceProblem, numbers, scalar

__all__ = ["DrivenProblem", "ForceFn", "TimeGradFn", "TimePotentialFn", "driven_rhs"]

#: V1(q, t, u) -> float and dV1/dt(q, t, u) -> float
TimePotentialFn = Callable[[Array, float, Array], float]
#: dV1/dq(q, t, u) -> (n, 3)
TimeGradFn = Callable[[Array, float, Array], Array]
#: F(q, w, t, u) -> (n, 3)
ForceFn = Callable[[Array, Array, float, Array], Array]


@dataclass(frozen=True)
class DrivenProblem:
    """A conservative `base` problem driven by an added potential and generalized forces.

    V(q, t, u) = base.potential(q) + potential(q, t, u); `grad` is dV1/dq (n, 3) and
    `potential_t` is dV1/dt (the three are given together or not at all). `force` maps
    (q, w, t, u) to F (n, 3); `velocity_dependent` False promises that F does not depend on w
    (the velocity updates of the VI and RATTLE are then explicit). `n_inputs` is the length of
    u. Without potential, force and inputs the problem is `base` itself.

    Example:
        >>> p = ReferenceProblem(np.eye(1), lambda q: 0 * q, lambda q: 0.0)
        >>> DrivenProblem(p).driven, DrivenProblem(p, n_inputs=2).n_inputs
        (False, 2)
    """

    base: ReferenceProblem
    potential: TimePotentialFn | None = None
    grad: TimeGradFn | None = None
    potential_t: TimePotentialFn | None = None
    force: ForceFn | None = None
    velocity_dependent: bool = True
    n_inputs: int = 0

    def __post_init__(self) -> None:
        parts = (self.potential, self.grad, self.potential_t)
        if any(p is None for p in parts) and not all(p is None for p in parts):
            raise ValueError("DrivenProblem: give potential, grad and potential_t together")
        if int(self.n_inputs) != self.n_inputs or self.n_inputs < 0:
            raise ValueError(f"DrivenProblem: n_inputs must be >= 0, got {self.n_inputs!r}")

    @property
    def n(self) -> int:
        """Number of bodies."""
        return self.base.n

    @property
    def M(self) -> Array:
        """The inertia matrix (n, n)."""
        return self.base.M

    @property
    def driven(self) -> bool:
        """True when anything beyond the conservative base acts (potential or force)."""
        return self.potential is not None or self.force is not None

    @property
    def implicit_velocity(self) -> bool:
        """True when the force depends on w (the VI and RATTLE velocity updates iterate)."""
        return self.force is not None and self.velocity_dependent

    def V(self, q: Array, t: float, u: Array) -> float:
        """The potential V0(q) + V1(q, t, u)."""
        v = scalar(self.base.potential(q))
        return v if self.potential is None else v + scalar(self.potential(q, t, u))  # type: ignore[no-any-return]

    def dVdq(self, q: Array, t: float, u: Array) -> Array:
        """dV/dq (n, 3) at time t with inputs u."""
        g = numbers(self.base.grad(q))
        return g if self.grad is None else g + numbers(self.grad(q, t, u))

    def dVdt(self, q: Array, t: float, u: Array) -> float:
        """The partial derivative dV/dt (0 without an added potential)."""
        return 0.0 if self.potential_t is None else scalar(self.potential_t(q, t, u))

    def F(self, q: Array, w: Array, t: float, u: Array) -> Array | None:
        """The generalized forces (n, 3), or None when there are none."""
        if self.force is None:
            return None
        return numbers(self.force(q, w, t, u)).reshape(self.n, 3)

    def power(self, q: Array, w: Array, t: float, u: Array) -> float:
        """P = dV/dt + sum_i F_i . qdot_i with qdot_i = w_i x q_i: the rate of the work W."""
        p = self.dVdt(q, t, u)
        F = self.F(q, w, t, u)
        return p if F is None else p + scalar(np.sum(F * _cross(w, q)))  # type: ignore[no-any-return]

    def energy(self, q: Array, w: Array, t: float, u: Array) -> float:
        """E = 1/2 sum_ij M_ij qdot_i . qdot_j + V(q, t, u)."""
        e = energy(self.base, q, w)
        return e if self.potential is None else e + scalar(self.potential(q, t, u))  # type: ignore[no-any-return]


def driven_rhs(
    problem: DrivenProblem, t: float, q: Array, w: Array, u: Array | Sequence[float]
) -> tuple[Array, Array]:
    """The forced field (qdot, wdot) at time t with inputs u.

    qdot_i = w_i x q_i and A(q) wdot = b with b_i = sum_{j!=i} M_ij (w_j.w_j) q_i x q_j
    - q_i x g_i + q_i x F_i (the last term only when there are forces).

    Example:
        >>> e3 = np.array([[0.0, 0.0, 1.0]])
        >>> p = ReferenceProblem(np.array([[2.0]]), lambda q: -e3, lambda q: -q[0, 2])
        >>> dq, dw = driven_rhs(DrivenProblem(p), 0.0, np.array([[1.0, 0, 0]]),
        ...                     np.zeros((1, 3)), [])
        >>> dw.tolist()
        [[0.0, -0.5, 0.0]]
    """
    q = numbers(q)
    w = numbers(w)
    ua = numbers(u)
    M = problem.M
    g = problem.dVdq(q, t, ua)
    ww = np.sum(w * w, axis=1)
    b = _cross(q, (_off_diagonal(M) * ww[None, :]) @ q) - _cross(q, g)
    F = problem.F(q, w, t, ua)
    if F is not None:
        b = b + _cross(q, F)
    if problem.base.is_diagonal:
        return _cross(w, q), b / np.diag(M)[:, None]
    wdot = np.linalg.solve(inertia_operator(M, q), b.ravel()).reshape(q.shape)
    return _cross(w, q), wdot
