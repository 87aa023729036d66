"""Why a reference integration stopped, as a type and a status code.

Input: the step that failed, a message and (filled in by the driver) the trajectory so far.
Output: `ReferenceIntegrationError` and one subclass per cause, raised by `integrate`,
`vi_step` and the Runge-Kutta drivers. ``exc.step`` is the failed step (from t_step to
t_step+1), ``exc.partial`` the `RefTrajectory` up to and including t_step, ``exc.status`` the
`s2gen.methods.Status` every backend reports for that cause:

* `InfeasibleStep` (INFEASIBLE): an explicit VI step with |a_i|^2 > 1 for some body;
* `NewtonFailure` (NEWTON): Newton on the Cayley residual did not converge, an iterate became
  non-finite, or its Jacobian was singular;
* `NonFiniteState` (NONFINITE): the state (or a Runge-Kutta stage) became non-finite;
* `SingularSystem` (SINGULAR): a linear solve outside Newton failed (the velocity solve of the
  VI, the continuous field's A(q) wdot = b);
* `StepSizeUnderflow` (STEPSIZE): an adaptive step fell below its minimum (RK45, DOP853) or
  the run spent its step budget (more than max_steps attempts between two samples), or
  a time-transformed method's step-size variable has no valid value.

Example:
    >>> exc = NewtonFailure(3, "Newton's method did not converge in 50 iterations")
    >>> str(exc), exc.status.name, isinstance(exc, ReferenceIntegrationError)
    ("step 3: Newton's method did not converge in 50 iterations", 'NEWTON', True)
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from s2gen.methods import Status

if TYPE_CHECKING:
    from s2gen.reference.recorder import RefTrajectory

__all__ = [
    "InfeasibleStep",
    "NewtonFailure",
    "NonFiniteState",
    "ReferenceIntegrationError",
    "SingularSystem",
    "StepSizeUnderflow",
]


class ReferenceIntegrationError(RuntimeError):
    """An integration failed at step `step` (the step from t_step to t_step+1).

    `partial` is the `RefTrajectory` up to and including t_step (set by `integrate`);
    `status` says why. The reference raises only the subclasses, each with its own status;
    the base class, raised directly, reports `status` (default NONFINITE).
    """

    status: Status = Status.NONFINITE

    def __init__(
        self,
        step: int,
        message: str,
        partial: RefTrajectory | None = None,
        *,
        status: Status | None = None,
    ) -> None:
        super().__init__(f"step {step}: {message}")
        self.step = step
        self.message = message
        self.partial = partial
        if status is not None:
            self.status = status


class InfeasibleStep(ReferenceIntegrationError):
    """An explicit VI step (diagonal M) has |a_i|^2 > 1 for some body: h is too large."""

    status = Status.INFEASIBLE


class NewtonFailure(ReferenceIntegrationError):
    """Newton on the Cayley residual failed: no convergence within the iteration limit, a
    non-finite iterate, or a singular Jacobian (counted as Newton's failure, not the system's:
    a `System` has its M checked positive definite)."""

    status = Status.NEWTON


class NonFiniteState(ReferenceIntegrationError):
    """The state or a Runge-Kutta stage became non-finite."""

    status = Status.NONFINITE


class SingularSystem(ReferenceIntegrationError):
    """A linear solve with the inertia operator A(q) failed outside Newton (the VI's velocity
    solve or the continuous field)."""

    status = Status.SINGULAR


class StepSizeUnderflow(ReferenceIntegrationError):
    """An adaptive step size fell below its minimum (MATLAB's hmin or SciPy's min_step), or
    the run attempted more than max_steps steps between two samples, or a time-transformed
    method's step-size variable xi has no valid value (`adaptive`)."""

    status = Status.STEPSIZE
