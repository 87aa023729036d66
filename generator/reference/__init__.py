"""Independent plain-NumPy reference integrators for Lagrangian mechanics on (S^2)^n.

This module is the project's yardstick. It is written directly from Lee, Leok & McClamroch,
"Lagrangian mechanics and variational integrators on two-spheres" (sections 2 and 3), and shares
no code with the rest of the package: it uses only NumPy, SymPy (to differentiate a `System`'s
potential) and the `System` record itself.

Input: a `ReferenceProblem` (inertia matrix M, potential V(q) and its gradient dV/dq), usually
built from a `System` by `problem_from_system` (structured terms are evaluated vectorized over
their members, never expanded); an initial state q0, w0 (arrays of shape (n, 3), unit vectors
q_i and angular velocities w_i with q_i . w_i = 0); a step h and a number of steps.
Output: a `RefTrajectory` (t, q, omega, energy, stats) from `integrate`, or single pieces:
`energy`, `angular_momentum`, `continuous_rhs`, `vi_step`, the Cayley residual and Jacobian.

Methods (`integrate(..., method=...)`):

* ``"vi"``: the variational integrator (paper eqs. DELw1, qikpw, DELw2m). Explicit when M is
  diagonal (eqs. qikpexp, wikpexp), Newton's method on the Cayley residual otherwise. Nothing is
  ever renormalized.
* ``"rk2"`` (explicit midpoint), ``"rk2-proj"`` (rk2, then each q_i normalized), ``"rk4"``
  (classical) and ``"rk45"`` (Dormand-Prince 5(4), adaptive, FSAL, Shampine's dense output on
  the grid t_k = k h, with MATLAB ode45 or Hairer/SciPy step-size control), all on the
  continuous vector field y = (q, w) in R^{6n} of paper eqs. ELq and ELwm.

Conventions: q and w are (n, 3) arrays, body i in row i-1; g_i = dV/dq_i; qdot_i = w_i x q_i;
the 3n x 3n matrix A(q) has blocks A_ii = M_ii I and A_ij = -M_ij hat(q_i) hat(q_j).
Failures raise `ReferenceIntegrationError(step, message)`; ``exc.partial`` holds the trajectory
up to the last good point t_step.

Derivation notes (checked against the discrete Legendre transforms of
L_d = 1/(2h) sum M_ij (q_i+ - q_i).(q_j+ - q_j) - h/2 V(q) - h/2 V(q+)):
q_i x (-D_1 L_d)_i gives d_i (`vi_d`) and q_i+ x (D_2 L_d)_i gives the right side of DELw2m
(`_vi_velocity`); both equal (A(q) w)_i. The Cayley residual keeps the factor q_i.q_i of
q_i x (f_i x q_i) = (q_i.q_i) f_i (f_i _|_ q_i) instead of setting it to 1: the two agree on
the sphere, but with the factor the discrete momentum map stays conserved when |q_i| carries
round-off (over 10^4 double-pendulum steps: e3.J drift 5e-13 relative instead of 9e-12).

Example:
    >>> import numpy as np
    >>> free = ReferenceProblem(M=np.array([[1.0]]), grad=lambda q: np.zeros_like(q),
    ...                         potential=lambda q: 0.0)
    >>> tr = integrate(free, "vi", [[1.0, 0, 0]], [[0, 0, 1.0]], h=0.01, nsteps=100)
    >>> tr.q.shape, bool(abs(tr.energy[-1] - 0.5) < 1e-14)
    ((101, 1, 3), True)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from s2gen.symbols import q_symbols
from s2gen.system import System, Term

__all__ = [
    "CONTROLS",
    "METHODS",
    "RefTrajectory",
    "ReferenceIntegrationError",
    "ReferenceProblem",
    "angular_momentum",
    "continuous_rhs",
    "energy",
    "hat",
    "inertia_operator",
    "integrate",
    "problem_from_system",
    "vi_d",
    "vi_jacobian",
    "vi_residual",
    "vi_step",
]

METHODS = ("vi", "rk2", "rk2-proj", "rk4", "rk45")
CONTROLS = ("matlab", "hairer")

Array = np.ndarray
GradFn = Callable[[Array], Array]
PotentialFn = Callable[[Array], float]


# ---------------------------------------------------------------------------------- records
class ReferenceIntegrationError(RuntimeError):
    """An integration failed at step `step` (the step from t_step to t_step+1).

    `partial` is the `RefTrajectory` up to and including t_step (set by `integrate`).
    """

    def __init__(self, step: int, message: str, partial: RefTrajectory | None = None) -> None:
        super().__init__(f"step {step}: {message}")
        self.step = step
        self.message = message
        self.partial = partial


@dataclass(frozen=True)
class ReferenceProblem:
    """A mechanical system on (S^2)^n in numbers: L = 1/2 sum M_ij qdot_i.qdot_j - V(q).

    `grad` maps q (n, 3) to dV/dq (n, 3); `potential` maps q (n, 3) to V (float).

    Example:
        >>> p = ReferenceProblem(np.eye(2), lambda q: np.zeros_like(q), lambda q: 0.0)
        >>> p.n, p.is_diagonal
        (2, True)
    """

    M: Array
    grad: GradFn
    potential: PotentialFn

    def __post_init__(self) -> None:
        M = np.array(self.M, dtype=float)
        if M.ndim != 2 or M.shape[0] != M.shape[1] or M.shape[0] < 1:
            raise ValueError(f"ReferenceProblem: M must be a square matrix, got shape {M.shape}")
        if not np.array_equal(M, M.T):
            raise ValueError("ReferenceProblem: M must be symmetric")
        object.__setattr__(self, "M", M)

    @property
    def n(self) -> int:
        """Number of bodies."""
        return int(self.M.shape[0])

    @property
    def is_diagonal(self) -> bool:
        """True when every off-diagonal entry of M is exactly zero (explicit VI)."""
        return bool(np.count_nonzero(self.M - np.diag(np.diag(self.M))) == 0)


@dataclass
class RefTrajectory:
    """Samples at t (N+1,) of q (N+1, n, 3), omega (N+1, n, 3) and energy (N+1,).

    `stats` has the integer counts ``steps`` (accepted steps), ``rejected``,
    ``rhs_evaluations`` (continuous vector field), ``newton_iterations_total`` and
    ``newton_iterations_max``.
    """

    t: Array
    q: Array
    omega: Array
    energy: Array
    stats: dict[str, int] = field(default_factory=dict)
    method: str = ""


def _new_stats() -> dict[str, int]:
    keys = ("steps", "rejected", "rhs_evaluations", "newton_iterations_total")
    return {**{k: 0 for k in keys}, "newton_iterations_max": 0}


# ---------------------------------------------------------------------------------- problem
def problem_from_system(
    system: System,
    parameter_values: Sequence[float] | Mapping[str, float] | None = None,
) -> ReferenceProblem:
    """Numeric M, V and dV/dq of a `System` (sympy.diff + sympy.lambdify, NumPy module).

    `parameter_values` overrides the spec's values: a sequence in declared order, or a
    mapping from some parameter names to values.

    The general part `system.potential` is differentiated in the 3n global symbols (skipped
    when it is 0). Each structured term of `system.terms` is differentiated once in its own
    local symbols (q, or qi and qj) and evaluated vectorized over all its members, with
    per-body gradients accumulated by `numpy.bincount`; nothing is expanded per member, so
    large systems (e.g. all 205,761 pairs of 642 bodies) stay cheap.

    Example:
        >>> import sympy as sp
        >>> from s2gen.system import System
        >>> from s2gen.symbols import q_symbol
        >>> m, g = sp.symbols("m g", real=True)
        >>> s = System.create(name="p", n=1, parameters={"m": 2.0, "g": 10.0},
        ...                   inertia=sp.Matrix([[m]]), potential=-m * g * q_symbol(1, 2))
        >>> problem_from_system(s).grad(np.array([[0.0, 0.0, 1.0]])).tolist()
        [[0.0, 0.0, -20.0]]

        A pair term (a spring of stiffness k between neighbours, V = k/2 |qi - qj|^2):

        >>> from s2gen.system import Term
        >>> from s2gen.symbols import local_vector
        >>> qi, qj = sp.Matrix(local_vector("qi")), sp.Matrix(local_vector("qj"))
        >>> k = sp.Symbol("k", real=True)
        >>> spring = Term("pair", k / 2 * (qi - qj).dot(qi - qj), select="chain")
        >>> s = System.create(name="c", n=3, parameters={"k": 2.0}, inertia=sp.eye(3),
        ...                   potential=sp.Integer(0), terms=[spring])
        >>> p = problem_from_system(s)
        >>> q = np.eye(3)
        >>> p.potential(q), p.grad(q).tolist()
        (4.0, [[2.0, -2.0, 0.0], [-2.0, 4.0, -2.0], [0.0, -2.0, 2.0]])
    """
    values = _parameter_values(system, parameter_values)
    n = system.n
    ps = [sp.Symbol(p, real=True) for p in system.parameter_names]
    pvals = list(values)
    general = _general_part(system, ps, pvals)
    kernels = [_compile_term(t, n, ps, values) for t in system.terms if t.count(n) > 0]

    def potential(q: Array) -> float:
        qa = np.asarray(q, dtype=float)
        total = 0.0 if general is None else general[0](qa)
        if kernels:
            qT = np.ascontiguousarray(qa.reshape(n, 3).T)
            total += sum(k.potential(qT) for k in kernels)
        return float(total)

    def grad(q: Array) -> Array:
        qa = np.asarray(q, dtype=float)
        if not kernels:
            return np.zeros((n, 3)) if general is None else general[1](qa)
        qT = np.ascontiguousarray(qa.reshape(n, 3).T)
        out = np.zeros((3, n))
        for k in kernels:
            k.add_grad(qT, out)
        g = np.ascontiguousarray(out.T)
        return g if general is None else g + general[1](qa)

    return ReferenceProblem(M=system.inertia_numeric(values), grad=grad, potential=potential)


def _parameter_values(
    system: System, parameter_values: Sequence[float] | Mapping[str, float] | None
) -> tuple[float, ...]:
    """The parameter values in declared order: the spec's, overridden as described in
    `problem_from_system`."""
    if parameter_values is None:
        return tuple(system.parameter_values)
    if isinstance(parameter_values, Mapping):
        unknown = set(parameter_values) - set(system.parameter_names)
        if unknown:
            raise ValueError(f"problem_from_system: unknown parameters {sorted(unknown)}")
        merged = {**system.parameters, **parameter_values}
        return tuple(float(merged[p]) for p in system.parameter_names)
    values = tuple(float(v) for v in parameter_values)
    if len(values) != len(system.parameter_names):
        raise ValueError(
            f"problem_from_system: expected {len(system.parameter_names)} parameter values, "
            f"got {len(values)}"
        )
    return values


def _general_part(
    system: System, ps: list[sp.Symbol], pvals: list[float]
) -> tuple[PotentialFn, GradFn] | None:
    """V and dV/dq of `system.potential` in the 3n global symbols, or None when it is 0."""
    V = sp.sympify(system.potential)
    if V == 0:
        return None
    n = system.n
    qs = q_symbols(n)
    v_fn = sp.lambdify([qs, ps], V, modules="numpy", dummify=True)
    g_fn = sp.lambdify([qs, ps], [sp.diff(V, s) for s in qs], modules="numpy", dummify=True)

    def potential(q: Array) -> float:
        return float(v_fn(list(np.asarray(q, dtype=float).ravel()), pvals))

    def grad(q: Array) -> Array:
        flat = g_fn(list(np.asarray(q, dtype=float).ravel()), pvals)
        return np.array(flat, dtype=float).reshape(n, 3)

    return potential, grad


def _term_indices(term: Term, n: int) -> tuple[Array, ...]:
    """0-based body index arrays of a term's members, one per role, in `member_list` order."""
    if term.select == "list":
        members = np.array(term.members, dtype=np.intp).reshape(len(term.members), -1)
        return tuple(np.ascontiguousarray(members[:, r]) for r in range(members.shape[1]))
    if term.kind == "body":
        return (np.arange(n, dtype=np.intp),)
    if term.select == "chain":
        return np.arange(n - 1, dtype=np.intp), np.arange(1, n, dtype=np.intp)
    i, j = np.triu_indices(n, k=1)  # row-major i < j: the order of Term.member_list
    return i.astype(np.intp), j.astype(np.intp)


@dataclass(frozen=True)
class _TermKernel:
    """One term compiled for vectorized evaluation over all of its members.

    `value` and `gradient` are lambdified functions of (local position components, data
    symbols, parameters), each argument a scalar or a (count,) array; `gradient` returns the
    derivatives in the local position symbols (3 per role).
    """

    n: int
    index: tuple[Array, ...]
    data: tuple[Array, ...]
    params: tuple[float, ...]
    value: Callable[..., Any]
    gradient: Callable[..., Any]
    cutoff: float | None = None

    def _active(self, qT: Array) -> tuple[Array, ...]:
        """The members' index arrays; with a cutoff, only the pairs closer than it (a plain
        vectorized distance test over all pairs)."""
        if self.cutoff is None:
            return self.index
        i, j = self.index
        d2 = sum((qT[c].take(i) - qT[c].take(j)) ** 2 for c in range(3))
        keep = d2 < self.cutoff**2
        return i[keep], j[keep]

    def _args(self, qT: Array, index: tuple[Array, ...]) -> list[Any]:
        """Arguments for `value`/`gradient` from qT (3, n): gathered position columns, data,
        parameters."""
        cols = [qT[c].take(idx) for idx in index for c in range(3)]
        return [*cols, *self.data, *self.params]

    @staticmethod
    def _members(x: Any, count: int) -> Array:
        """A lambdified result (possibly a constant) as a (count,) float array."""
        return np.broadcast_to(np.asarray(x, dtype=float), (count,))

    def potential(self, qT: Array) -> float:
        """Sum of the term over its members at positions qT (3, n)."""
        index = self._active(qT)
        return float(np.sum(self._members(self.value(*self._args(qT, index)), index[0].size)))

    def add_grad(self, qT: Array, out: Array) -> None:
        """Add the term's gradient at positions qT (3, n) into out (3, n)."""
        index = self._active(qT)
        parts = self.gradient(*self._args(qT, index))
        for r, idx in enumerate(index):
            for c in range(3):
                weights = self._members(parts[3 * r + c], idx.size)
                out[c] += np.bincount(idx, weights=weights, minlength=self.n)


def _compile_term(term: Term, n: int, ps: list[sp.Symbol], values: Sequence[float]) -> _TermKernel:
    """Differentiate `term.expr` once in its local position symbols and lambdify value and
    gradient; gather index arrays and per-member data columns."""
    index = _term_indices(term, n)
    count = int(index[0].size)
    columns: list[Array] = []
    for d in term.data:
        table = np.array(d.values, dtype=float).reshape(count, d.width)
        columns.extend(np.ascontiguousarray(table[:, k]) for k in range(d.width))
    positions = list(term.position_symbols())
    data_syms = list(term.data_symbols())
    # A datum shadows a parameter of the same name (as in Term.instance): give the parameter a
    # fresh placeholder so the argument list has no duplicate symbols.
    taken = set(data_syms) | set(positions)
    params = [sp.Dummy() if s in taken else s for s in ps]
    args = [*positions, *data_syms, *params]
    expr = sp.sympify(term.expr)
    derivatives = [sp.diff(expr, s) for s in positions]
    value = sp.lambdify(args, expr, modules="numpy", dummify=True, cse=True)
    gradient = sp.lambdify(args, derivatives, modules="numpy", dummify=True, cse=True)
    return _TermKernel(
        n=n,
        index=index,
        data=tuple(columns),
        params=tuple(float(v) for v in values),
        value=value,
        gradient=gradient,
        cutoff=term.cutoff,
    )


# ---------------------------------------------------------------------------------- geometry
def _cross(a: Array, b: Array) -> Array:
    """Row-wise cross product a x b of (..., 3) arrays (np.cross without its overhead)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
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
    H = np.zeros((q.shape[0], 3, 3))
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


# ---------------------------------------------------------------------------------- continuous
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
    q = np.asarray(q, dtype=float)
    w = np.asarray(w, dtype=float)
    M = problem.M
    g = np.asarray(problem.grad(q), dtype=float)
    ww = np.sum(w * w, axis=1)
    b = _cross(q, (_off_diagonal(M) * ww[None, :]) @ q) - _cross(q, g)
    if problem.is_diagonal:  # A = diag(M_ii) I: the solve is a division
        return _cross(w, q), b / np.diag(M)[:, None]
    wdot = np.linalg.solve(inertia_operator(M, q), b.ravel()).reshape(q.shape)
    return _cross(w, q), wdot


# ---------------------------------------------------------------------------------- VI pieces
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
    g = np.asarray(problem.grad(q), dtype=float)
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
    """Solve vi_residual(M, q, f, d) = 0 by Newton from f_i = d_i/(2 M_ii)."""
    f = d / (2.0 * np.diag(M)[:, None])
    for it in range(1, maxiter + 1):
        r = vi_residual(M, q, f, d)
        delta = np.linalg.solve(vi_jacobian(M, q, f), -r.ravel()).reshape(f.shape)
        f = f + delta
        if not np.all(np.isfinite(f)):
            raise ReferenceIntegrationError(step, f"Newton iterate not finite at iteration {it}")
        if np.max(np.abs(delta)) <= tol * max(1.0, float(np.max(np.abs(f)))):
            return f, it
    raise ReferenceIntegrationError(
        step, f"Newton's method did not converge in {maxiter} iterations"
    )


def _vi_explicit(
    problem: ReferenceProblem, q: Array, w: Array, h: float, d: Array, step: int
) -> tuple[Array, Array]:
    """Paper eqs. qikpexp, wikpexp (diagonal M): a_i = d_i/M_ii, no solve needed."""
    m = np.diag(problem.M)[:, None]
    a = d / m
    aa = np.sum(a * a, axis=1)
    for i in range(problem.n):
        if aa[i] > 1.0:
            raise ReferenceIntegrationError(
                step,
                f"explicit VI step infeasible for body {i + 1}: |a|^2 = {aa[i]:.6g} > 1 "
                f"(step size h = {h:g} too large)",
            )
    q1 = _cross(a, q) + np.sqrt(1.0 - aa)[:, None] * q
    g0 = np.asarray(problem.grad(q), dtype=float)
    g1 = np.asarray(problem.grad(q1), dtype=float)
    w1 = w - h / (2.0 * m) * _cross(q, g0) - h / (2.0 * m) * _cross(q1, g1)
    return q1, w1


def _vi_velocity(problem: ReferenceProblem, q: Array, q1: Array, h: float) -> Array:
    """Paper eq. DELw2m: solve A(q1) w1 = c for w1, where

    c_i = (1/h) q1_i x sum_j M_ij (q1_j - q_j) - (h/2) q1_i x g_i(q1).
    """
    g1 = np.asarray(problem.grad(q1), dtype=float)
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
    q = np.asarray(q, dtype=float)
    w = np.asarray(w, dtype=float)
    d = vi_d(problem, q, w, h)
    if problem.is_diagonal:
        q1, w1 = _vi_explicit(problem, q, w, h, d, step)
        return q1, w1, 0
    f, iterations = _newton_cayley(problem.M, q, d, newton_tol, newton_maxiter, step)
    q1 = _cayley_apply(f, q)
    return q1, _vi_velocity(problem, q, q1, h), iterations


# ---------------------------------------------------------------------------------- recording
class _Recorder:
    """Output grid t_k = k h (k = 0..N) and the states y_k = (q_k, w_k) filled so far."""

    def __init__(self, problem: ReferenceProblem, method: str, h: float, nsteps: int) -> None:
        self.problem = problem
        self.method = method
        self.n = problem.n
        self.t = np.arange(nsteps + 1) * h
        self.y = np.full((nsteps + 1, 6 * self.n), np.nan)
        self.count = 0
        self.stats = _new_stats()

    @property
    def last(self) -> int:
        """Index of the last recorded grid point."""
        return self.count - 1

    def push(self, y: Array) -> None:
        self.y[self.count] = y
        self.count += 1

    def split(self, y: Array) -> tuple[Array, Array]:
        """(q, w), each (n, 3), from a state vector y of length 6n."""
        m = 3 * self.n
        return y[:m].reshape(self.n, 3), y[m:].reshape(self.n, 3)

    def trajectory(self) -> RefTrajectory:
        c, n = self.count, self.n
        q = self.y[:c, : 3 * n].reshape(c, n, 3).copy()
        w = self.y[:c, 3 * n :].reshape(c, n, 3).copy()
        e = np.array([energy(self.problem, q[k], w[k]) for k in range(c)])
        return RefTrajectory(self.t[:c].copy(), q, w, e, dict(self.stats), self.method)

    def fail(self, message: str) -> ReferenceIntegrationError:
        """An error for the step after the last recorded point, carrying the partial result."""
        return ReferenceIntegrationError(self.last, message, self.trajectory())


def _state(q: Array, w: Array) -> Array:
    return np.concatenate([np.asarray(q, dtype=float).ravel(), np.asarray(w, dtype=float).ravel()])


def _vector_field(rec: _Recorder) -> Callable[[Array], Array]:
    """y -> (qdot, wdot) flattened, counting evaluations in rec.stats."""

    def fun(y: Array) -> Array:
        rec.stats["rhs_evaluations"] += 1
        dq, dw = continuous_rhs(rec.problem, *rec.split(y))
        return _state(dq, dw)

    return fun


# ---------------------------------------------------------------------------------- fixed step
def _run_fixed(rec: _Recorder, advance: Callable[[Array, int], Array], nsteps: int) -> None:
    """Apply `advance(y_k, k) -> y_k+1` nsteps times, turning failures into rich errors."""
    for k in range(nsteps):
        try:
            y1 = advance(rec.y[k], k)
        except ReferenceIntegrationError as exc:
            exc.partial = rec.trajectory()
            raise
        except np.linalg.LinAlgError as exc:
            raise rec.fail(f"linear solve failed ({exc})") from exc
        if not np.all(np.isfinite(y1)):
            raise rec.fail("non-finite state")
        rec.push(y1)
        rec.stats["steps"] += 1


def _rk_advance(rec: _Recorder, method: str, h: float) -> Callable[[Array, int], Array]:
    """One step of "rk4" (classical), "rk2" (explicit midpoint) or "rk2-proj"."""
    fun = _vector_field(rec)

    def rk4(y: Array, k: int) -> Array:
        k1 = fun(y)
        k2 = fun(y + 0.5 * h * k1)
        k3 = fun(y + 0.5 * h * k2)
        k4 = fun(y + h * k3)
        return y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    def rk2(y: Array, k: int) -> Array:
        return y + h * fun(y + 0.5 * h * fun(y))

    def rk2_proj(y: Array, k: int) -> Array:
        y1 = rk2(y, k)
        q, w = rec.split(y1)
        return _state(q / np.linalg.norm(q, axis=1)[:, None], w)

    return {"rk4": rk4, "rk2": rk2, "rk2-proj": rk2_proj}[method]


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


# ---------------------------------------------------------------------------------- rk45
# Dormand-Prince 5(4): nodes, stage matrix (row 6 = the 5th-order weights: FSAL), weights,
# error weights E = b5 - b4, and Shampine's 4th-order continuous extension (MATLAB ntrp45):
# y(t + s h) = y + h sum_i K_i (BI[i] . [s, s^2, s^3, s^4]).
_DP_A = np.array(
    [
        [0, 0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
    ]
)
_DP_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
_DP_E = np.array([71 / 57600, 0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])
_DP_BI = np.array(
    [
        [1, -183 / 64, 37 / 12, -145 / 128],
        [0, 0, 0, 0],
        [0, 1500 / 371, -1000 / 159, 1000 / 371],
        [0, -125 / 32, 125 / 12, -375 / 64],
        [0, 9477 / 3392, -729 / 106, 25515 / 6784],
        [0, -11 / 7, 11 / 3, -55 / 28],
        [0, 3 / 2, -4, 5 / 2],
    ]
)


def _dp_attempt(
    rec: _Recorder, fun: Callable[[Array], Array], y: Array, k1: Array, h: float
) -> tuple[Array, Array]:
    """One Dormand-Prince attempt: (y_new (5th order), K (7, m)) with K[6] = f(y_new)."""
    K = np.empty((7, y.size))
    K[0] = k1
    try:
        for s in range(1, 6):
            K[s] = fun(y + h * (_DP_A[s, :s] @ K[:s]))
        y_new = y + h * (_DP_B @ K[:6])
        K[6] = fun(y_new)
    except np.linalg.LinAlgError as exc:
        raise rec.fail(f"linear solve failed ({exc})") from exc
    if not (np.all(np.isfinite(y_new)) and np.all(np.isfinite(K))):
        raise rec.fail(f"non-finite state in a Dormand-Prince step of size {h:g}")
    return y_new, K


def _emit_dense(
    rec: _Recorder, t: float, y: Array, t_new: float, y_new: Array, K: Array, h: float
) -> None:
    """Record every grid point t_k in (t, t_new] (Shampine's interpolant; y_new at t_new)."""
    while rec.count < rec.t.size and rec.t[rec.count] <= t_new:
        tk = rec.t[rec.count]
        if tk == t_new:
            rec.push(y_new)
        else:
            s = (tk - t) / h
            rec.push(y + h * (K.T @ (_DP_BI @ np.array([s, s**2, s**3, s**4]))))


def _matlab_initial_step(
    k1: Array, y0: Array, T: float, rtol: float, threshold: float, hmax: float
) -> float:
    """ode45's first step: min(hmax, T), cut to 1/rh where

    rh = max_i |f0_i| / max(|y0_i|, threshold) / (0.8 rtol^(1/5)).
    """
    absh = min(hmax, T)
    rh = float(np.max(np.abs(k1) / np.maximum(np.abs(y0), threshold))) / (0.8 * rtol**0.2)
    if absh * rh > 1.0:
        absh = 1.0 / rh
    return max(absh, 16.0 * float(np.spacing(0.0)))


def _matlab_step(
    rec: _Recorder,
    fun: Callable[[Array], Array],
    t: float,
    y: Array,
    k1: Array,
    absh: float,
    done: bool,
    T: float,
    rtol: float,
    threshold: float,
) -> tuple[float, Array, Array, float, float, float, bool, bool]:
    """Attempt until accepted; returns (t_new, y_new, K, h, absh, err, nofailed, done)."""
    h = T - t if done else absh
    nofailed = True
    while True:
        hmin = 16.0 * float(np.spacing(t))
        y_new, K = _dp_attempt(rec, fun, y, k1, h)
        t_new = T if done else t + h
        h = t_new - t  # "purify" h, as ode45 does
        scale = np.maximum(np.maximum(np.abs(y), np.abs(y_new)), threshold)
        err = absh * float(np.max(np.abs(K.T @ _DP_E) / scale))
        if err <= rtol:
            return t_new, y_new, K, h, absh, err, nofailed, done
        rec.stats["rejected"] += 1
        if absh <= hmin:
            raise rec.fail(f"step size {absh:g} at t = {t:g} fell below hmin = {hmin:g}")
        if nofailed:
            absh = max(hmin, absh * max(0.1, 0.8 * (rtol / err) ** 0.2))
        else:
            absh = max(hmin, 0.5 * absh)
        nofailed, done, h = False, False, absh


def _rk45_matlab(
    rec: _Recorder, y0: Array, T: float, rtol: float, atol: float, hmax: float
) -> None:
    """Dormand-Prince with MATLAB ode45's error norm and step-size logic."""
    fun = _vector_field(rec)
    threshold = atol / rtol
    t, y, k1 = 0.0, y0, fun(y0)
    absh = _matlab_initial_step(k1, y0, T, rtol, threshold, hmax)
    done = False
    while not done:
        absh = min(hmax, max(16.0 * float(np.spacing(t)), absh))
        if 1.1 * absh >= T - t:  # stretch the last step to hit T
            absh, done = T - t, True
        t_new, y_new, K, h, absh, err, nofailed, done = _matlab_step(
            rec, fun, t, y, k1, absh, done, T, rtol, threshold
        )
        rec.stats["steps"] += 1
        _emit_dense(rec, t, y, t_new, y_new, K, h)
        if nofailed:
            temp = 1.25 * (err / rtol) ** 0.2
            absh = absh / temp if temp > 0.2 else 5.0 * absh
        t, y, k1 = t_new, y_new, K[6]


def _rms(x: Array) -> float:
    return float(np.linalg.norm(x)) / x.size**0.5


def _hairer_initial_step(
    fun: Callable[[Array], Array],
    y0: Array,
    k1: Array,
    T: float,
    hmax: float,
    rtol: float,
    atol: float,
) -> float:
    """Hairer-Norsett-Wanner (II.4) starting step for an order-4 error estimator (as SciPy)."""
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(k1 / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, T)
    d2 = _rms((fun(y0 + h0 * k1) - k1) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.2
    return min(100.0 * h0, h1, T, hmax)


def _hairer_step(
    rec: _Recorder,
    fun: Callable[[Array], Array],
    t: float,
    y: Array,
    k1: Array,
    h_abs: float,
    T: float,
    rtol: float,
    atol: float,
    hmax: float,
) -> tuple[float, Array, Array, float, float]:
    """Attempt until accepted; returns (t_new, y_new, K, h, next h_abs)."""
    min_step = 10.0 * abs(float(np.nextafter(t, np.inf)) - t)
    h_abs = hmax if h_abs > hmax else max(h_abs, min_step)
    rejected = False
    while True:
        if h_abs < min_step:
            raise rec.fail(f"step size {h_abs:g} at t = {t:g} fell below {min_step:g}")
        t_new = min(t + h_abs, T)  # clip the last step at T
        h = t_new - t
        y_new, K = _dp_attempt(rec, fun, y, k1, h)
        scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
        err = _rms(h * (K.T @ _DP_E) / scale)
        if err <= 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err**-0.2)
            if rejected:
                factor = min(1.0, factor)
            return t_new, y_new, K, h, h * factor
        rec.stats["rejected"] += 1
        h_abs = h * max(0.2, 0.9 * err**-0.2)
        rejected = True


def _rk45_hairer(
    rec: _Recorder, y0: Array, T: float, rtol: float, atol: float, hmax: float
) -> None:
    """Dormand-Prince with Hairer's (SciPy's) RMS error norm and step-size logic."""
    fun = _vector_field(rec)
    t, y, k1 = 0.0, y0, fun(y0)
    h_abs = _hairer_initial_step(fun, y0, k1, T, hmax, rtol, atol)
    while t < T:
        t_new, y_new, K, h, h_abs = _hairer_step(rec, fun, t, y, k1, h_abs, T, rtol, atol, hmax)
        rec.stats["steps"] += 1
        _emit_dense(rec, t, y, t_new, y_new, K, h)
        t, y, k1 = t_new, y_new, K[6]


# ---------------------------------------------------------------------------------- driver
def _check_inputs(
    problem: ReferenceProblem,
    method: str,
    q0: Array,
    w0: Array,
    h: float,
    nsteps: int,
    control: str,
) -> None:
    if method not in METHODS:
        raise ValueError(f"integrate: unknown method {method!r}; choose from {METHODS}")
    if control not in CONTROLS:
        raise ValueError(f"integrate: unknown control {control!r}; choose from {CONTROLS}")
    for name, a in (("q0", q0), ("w0", w0)):
        if a.shape != (problem.n, 3):
            raise ValueError(f"integrate: {name} must have shape ({problem.n}, 3), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"integrate: {name} contains a non-finite value")
    if not (np.isfinite(h) and h > 0.0):
        raise ValueError(f"integrate: the step h must be positive and finite, got {h!r}")
    if int(nsteps) != nsteps or nsteps < 0:
        raise ValueError(f"integrate: nsteps must be a non-negative integer, got {nsteps!r}")


def integrate(
    problem: ReferenceProblem,
    method: str,
    q0: Array | Sequence[Sequence[float]],
    w0: Array | Sequence[Sequence[float]],
    h: float,
    nsteps: int,
    *,
    rtol: float = 1e-3,
    atol: float = 1e-6,
    control: str = "matlab",
    hmax: float | None = None,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> RefTrajectory:
    """Integrate from (q0, w0) at t = 0 and sample at t_k = k h, k = 0..nsteps.

    `method` is one of METHODS. For "rk45", h is only the output spacing; steps are adaptive
    with tolerances rtol/atol, `control` "matlab" (ode45; hmax defaults to T/10) or "hairer"
    (SciPy's RK45; hmax defaults to infinity). For "vi" with coupled M, Newton stops when
    max|update| <= newton_tol * max(1, max|f|) and fails after newton_maxiter iterations.
    The initial state is used as given (not normalized). Raises ReferenceIntegrationError
    (with .step and .partial) on infeasible explicit steps, Newton failure or non-finite states.

    Example:
        >>> e3 = np.array([0.0, 0.0, 1.0])
        >>> pend = ReferenceProblem(np.array([[1.0]]), lambda q: -9.81 * e3[None, :],
        ...                         lambda q: -9.81 * q[0, 2])
        >>> tr = integrate(pend, "rk45", [[1.0, 0, 0]], [[0, 0, 0.0]], h=0.1, nsteps=10)
        >>> float(tr.t[-1]), tr.stats["steps"] > 0
        (1.0, True)
    """
    q0a = np.array(q0, dtype=float)
    w0a = np.array(w0, dtype=float)
    _check_inputs(problem, method, q0a, w0a, h, nsteps, control)
    rec = _Recorder(problem, method, h, int(nsteps))
    y0 = _state(q0a, w0a)
    rec.push(y0)
    if method == "vi":
        _run_fixed(rec, _vi_advance(rec, h, newton_tol, newton_maxiter), int(nsteps))
    elif method != "rk45":
        _run_fixed(rec, _rk_advance(rec, method, h), int(nsteps))
    elif nsteps > 0:
        T = float(rec.t[-1])
        if control == "matlab":
            _rk45_matlab(rec, y0, T, rtol, atol, 0.1 * T if hmax is None else hmax)
        else:
            _rk45_hairer(rec, y0, T, rtol, atol, np.inf if hmax is None else hmax)
    return rec.trajectory()
