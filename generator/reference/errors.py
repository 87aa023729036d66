"""Why a reference integration stopped.

Input: the step that failed, a message and (filled in by the driver) the trajectory so far.
Output: `ReferenceIntegrationError`, raised by `integrate`, `vi_step` and the Runge-Kutta
drivers; ``exc.step`` is the failed step (from t_step to t_step+1), ``exc.partial`` the
`RefTrajectory` up to and including t_step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from s2gen.reference.recorder import RefTrajectory

__all__ = ["ReferenceIntegrationError"]


class ReferenceIntegrationError(RuntimeError):
    """An integration failed at step `step` (the step from t_step to t_step+1).

    `partial` is the `RefTrajectory` up to and including t_step (set by `integrate`).
    """

    def __init__(self, step: int, message: str, partial: RefTrajectory | None = None) -> None:
        super().__init__(f"step {step}: {message}")
        self.step = step
        self.message = message
        self.partial = partial
