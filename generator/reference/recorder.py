"""The output grid, the recorded states and the fixed-step loop shared by all methods.

Input: a `ReferenceProblem`, a method name, the output spacing h and the number of steps N.
Output: `RefTrajectory` (t, q, omega, energy, stats) built by a `_Recorder` from the states
y_k = (q_k, w_k) (flat vectors of length 6n) recorded on the grid t_k = k h; `_vector_field`
(the continuous field on flat states, counting evaluations) and `_run_fixed` (advance a
fixed-step method N times; failures become `ReferenceIntegrationError`s carrying the partial
trajectory: a failed linear solve `SingularSystem`, a non-finite state `NonFiniteState`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from s2gen.reference.errors import NonFiniteState, ReferenceIntegrationError, SingularSystem
from s2gen.reference.field import continuous_rhs
from s2gen.reference.geometry import energy
from s2gen.reference.problem import Array, ReferenceProblem, numbers

__all__ = ["RefTrajectory"]


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

    def fail(
        self, kind: type[ReferenceIntegrationError], message: str
    ) -> ReferenceIntegrationError:
        """An error of type `kind` for the step after the last recorded point, carrying the
        partial result."""
        return kind(self.last, message, self.trajectory())


def _state(q: Array, w: Array) -> Array:
    return np.concatenate([numbers(q).ravel(), numbers(w).ravel()])


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
            raise rec.fail(SingularSystem, f"linear solve failed ({exc})") from exc
        if not np.all(np.isfinite(y1)):
            raise rec.fail(NonFiniteState, "non-finite state")
        rec.push(y1)
        rec.stats["steps"] += 1
