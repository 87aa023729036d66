"""The driver of driven problems: inputs held over each step, every method, the work W(t).

Input: a `DrivenProblem`, a method (the VI family "vi", "vi4", "vi6", "vi8", the RATTLE family
"rattle", "rattle4", "rattle6", "rattle8", or a fixed-step Runge-Kutta method "rk2",
"rk2-proj", "rk3", "rk4"), an initial state at t0, a step h, a number of steps N and the inputs
U (shape (N, n_inputs): row k is u_k, held on [t_k, t_k+1) — zero-order hold).
Output: a `DrivenTrajectory`: the samples of `RefTrajectory` plus the work `work` and the
inputs. Conventions:

* every evaluation inside step k (the VI's and RATTLE's two ends, each composition substep at
  its own time t_k + (gamma_1 + ... + gamma_l) h, each Runge-Kutta stage at t_k + c_i h) uses
  u_k, never u_k+1;
* the energy at t_k (k >= 1) is E(q_k, w_k, t_k, u_k-1), the left limit (u_0 at t_0);
* W_k = sum over steps j < k of the step's work + sum over 1 <= j < k of the jumps
  V(q_j, t_j, u_j) - V(q_j, t_j, u_j-1) of the potential when the held input changes, so that
  E_k - E_0 - W_k is the energy-balance error;
* the step's work: the VI family and RATTLE, the trapezoidal (h/2)(P + P+) of each basic step
  (see `forced_steps.py`); Runge-Kutta, the same tableau applied to W' = P (W is one more
  state component, so it has the method's order).

Compositions use the step fractions of `s2gen.methods` (Yoshida's triple jump and order-6
solution A, Kahan and Li's order-8 scheme) applied to the forced basic step.

Example:
    >>> from s2gen.reference.problem import ReferenceProblem
    >>> e3 = np.array([0.0, 0.0, 1.0])
    >>> rotor = ReferenceProblem(np.array([[2.0]]), lambda q: 0 * q, lambda q: 0.0)
    >>> spin = DrivenProblem(rotor, force=lambda q, w, t, u: u[0] * np.cross(e3, q),
    ...                      velocity_dependent=False, n_inputs=1)
    >>> tr = integrate_driven(spin, "vi", [[1.0, 0, 0]], [[0, 0, 0.0]], 0.01, 100,
    ...                       inputs=np.full((100, 1), 4.0))
    >>> round(float(tr.omega[-1, 0, 2]), 12)  # w = tau t / m = 4 * 1 / 2
    2.0
    >>> bool(abs(tr.energy[-1] - tr.energy[0] - tr.work[-1]) < 1e-3)
    True
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from s2gen.methods import Family
from s2gen.methods import method as method_row
from s2gen.reference.errors import NonFiniteState, ReferenceIntegrationError, SingularSystem
from s2gen.reference.forced import DrivenProblem, driven_rhs
from s2gen.reference.forced_steps import forced_rattle_step, forced_vi_step, step_work
from s2gen.reference.problem import Array, scalar
from s2gen.reference.recorder import RefTrajectory, _new_stats
from s2gen.reference.rk import _weighted

__all__ = ["DRIVEN_METHODS", "DrivenTrajectory", "integrate_driven"]

#: Methods of `integrate_driven`.
DRIVEN_METHODS: tuple[str, ...] = (
    "vi",
    "vi4",
    "vi6",
    "vi8",
    "rattle",
    "rattle4",
    "rattle6",
    "rattle8",
    "rk2",
    "rk2-proj",
    "rk3",
    "rk4",
)

Step = Callable[[Array, Array, float, float, int, Array], tuple[Array, Array, float]]


@dataclass
class DrivenTrajectory(RefTrajectory):
    """A `RefTrajectory` with the work `work` (N+1,) (W_0 = 0) and the inputs (N, n_inputs)."""

    work: Array = field(default_factory=lambda: np.zeros(0))
    inputs: Array = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def balance(self) -> Array:
        """The energy-balance error E_k - E_0 - W_k (N+1,)."""
        return self.energy - self.energy[0] - self.work


def _inputs(
    problem: DrivenProblem, inputs: Array | Sequence[Sequence[float]] | None, n: int
) -> Array:
    if inputs is None:
        if problem.n_inputs:
            raise ValueError(f"integrate_driven: {problem.n_inputs} inputs per step expected")
        return np.zeros((n, 0))
    U = np.array(inputs, dtype=float)
    if U.shape != (n, problem.n_inputs):
        raise ValueError(
            f"integrate_driven: inputs must have shape ({n}, {problem.n_inputs}), got {U.shape}"
        )
    if not np.all(np.isfinite(U)):
        raise ValueError("integrate_driven: inputs contain a non-finite value")
    return U


def _geometric(
    problem: DrivenProblem, name: str, tol: float, maxiter: int, stats: dict[str, int]
) -> Step:
    """One step of the composed VI or RATTLE: the basic step at each fraction of h."""
    row = method_row(name)
    basic = forced_vi_step if row.family is Family.VI else forced_rattle_step
    fractions = row.composition.fractions if row.composition is not None else (1.0,)

    def advance(
        q: Array, w: Array, t: float, h: float, k: int, u: Array
    ) -> tuple[Array, Array, float]:
        work = 0.0
        for gamma in fractions:
            hs = gamma * h
            q1, w1, its = basic(
                problem, q, w, t, hs, u, newton_tol=tol, newton_maxiter=maxiter, step=k
            )
            stats["newton_iterations_total"] += its
            stats["newton_iterations_max"] = max(stats["newton_iterations_max"], its)
            if problem.driven:
                work += step_work(problem, q, w, q1, w1, t, hs, u)
            q, w, t = q1, w1, t + hs
        return q, w, work

    return advance


def _runge_kutta(problem: DrivenProblem, name: str, stats: dict[str, int]) -> Step:
    """One step of the tableau on y = (q, w, W) with W' = P; stage i at t + c_i h."""
    row = method_row(name)
    tab = row.tableau
    assert tab is not None
    a = [[float(x) for x in r] for r in tab.a]
    b = [float(x) for x in tab.b]
    c = [float(x) for x in tab.c]
    n = problem.n

    def fun(t: float, y: Array, u: Array) -> Array:
        stats["rhs_evaluations"] += 1
        q, w = y[: 3 * n].reshape(n, 3), y[3 * n : 6 * n].reshape(n, 3)
        dq, dw = driven_rhs(problem, t, q, w, u)
        return np.concatenate([dq.ravel(), dw.ravel(), [problem.power(q, w, t, u)]])

    def advance(
        q: Array, w: Array, t: float, h: float, k: int, u: Array
    ) -> tuple[Array, Array, float]:
        y = np.concatenate([q.ravel(), w.ravel(), [0.0]])
        ks: list[Array] = []
        for ci, r in zip(c, a):
            ks.append(fun(t + ci * h, y + h * _weighted(r, ks, y), u))
        y1 = y + h * _weighted(b, ks, y)
        q1, w1 = y1[: 3 * n].reshape(n, 3), y1[3 * n : 6 * n].reshape(n, 3)
        if row.project:
            q1 = q1 / np.sqrt(np.sum(q1 * q1, axis=1))[:, None]  # |q_i|, also for complex q
        return q1, w1, scalar(y1[-1])

    return advance


def integrate_driven(
    problem: DrivenProblem,
    method: str,
    q0: Array | Sequence[Sequence[float]],
    w0: Array | Sequence[Sequence[float]],
    h: float,
    nsteps: int,
    *,
    inputs: Array | Sequence[Sequence[float]] | None = None,
    t0: float = 0.0,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> DrivenTrajectory:
    """Integrate from (q0, w0) at t0 and sample at t_k = t0 + k h, k = 0..nsteps.

    `inputs` has one row u_k per step (required when the problem has inputs). The implicit
    solves (Cayley parameters, RATTLE multipliers, velocity-dependent forces) stop when
    max|update| <= newton_tol max(1, max|iterate|). Raises ValueError on bad arguments and a
    `ReferenceIntegrationError` (with .step, .status, .partial) when a step fails.

    Example:
        >>> from s2gen.reference.problem import ReferenceProblem
        >>> free = DrivenProblem(ReferenceProblem(np.eye(1), lambda q: 0 * q, lambda q: 0.0))
        >>> tr = integrate_driven(free, "rattle4", [[1.0, 0, 0]], [[0, 0, 1.0]], 0.1, 10)
        >>> tr.q.shape, float(tr.work[-1])
        ((11, 1, 3), 0.0)
    """
    if method not in DRIVEN_METHODS:
        raise ValueError(
            f"integrate_driven: unknown method {method!r}; choose from {DRIVEN_METHODS}"
        )
    q = np.array(q0, dtype=float)
    w = np.array(w0, dtype=float)
    n = problem.n
    for name, arr in (("q0", q), ("w0", w)):
        if arr.shape != (n, 3) or not np.all(np.isfinite(arr)):
            raise ValueError(f"integrate_driven: {name} must be a finite ({n}, 3) array")
    if not (np.isfinite(h) and h > 0.0):
        raise ValueError(f"integrate_driven: the step h must be positive and finite, got {h!r}")
    if int(nsteps) != nsteps or nsteps < 0:
        raise ValueError(f"integrate_driven: nsteps must be a non-negative integer, got {nsteps!r}")
    N = int(nsteps)
    U = _inputs(problem, inputs, N)
    stats = _new_stats()
    if method_row(method).geometric:
        advance = _geometric(problem, method, newton_tol, newton_maxiter, stats)
    else:
        advance = _runge_kutta(problem, method, stats)
    t = t0 + np.arange(N + 1) * h
    qs, ws = np.full((N + 1, n, 3), np.nan), np.full((N + 1, n, 3), np.nan)
    E, W = np.full(N + 1, np.nan), np.zeros(N + 1)
    u_first = U[0] if N else np.zeros(problem.n_inputs)
    qs[0], ws[0], E[0] = q, w, problem.energy(q, w, t[0], u_first)

    def partial(c: int) -> DrivenTrajectory:
        return DrivenTrajectory(
            t[:c].copy(),
            qs[:c].copy(),
            ws[:c].copy(),
            E[:c].copy(),
            dict(stats),
            method,
            W[:c].copy(),
            U.copy(),
        )

    work = 0.0
    for k in range(N):
        if k > 0 and problem.potential is not None:
            work += problem.V(q, t[k], U[k]) - problem.V(q, t[k], U[k - 1])
        try:
            q, w, dW = advance(q, w, float(t[k]), h, k, U[k])
        except ReferenceIntegrationError as exc:
            exc.partial = partial(k + 1)
            raise
        except np.linalg.LinAlgError as exc:
            raise SingularSystem(k, f"linear solve failed ({exc})", partial(k + 1)) from exc
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(w))):
            raise NonFiniteState(k, "non-finite state", partial(k + 1))
        work += dW
        qs[k + 1], ws[k + 1], W[k + 1] = q, w, work
        E[k + 1] = problem.energy(q, w, t[k + 1], U[k])
        stats["steps"] += 1
    return partial(N + 1)
