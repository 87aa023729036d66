"""The result of an integration: samples, statistics, and the error that keeps a partial run.

Input: arrays and counts from a backend. Output: `Trajectory` (t, q, omega, energy, stats,
wall time) and `IntegrationError` (raised on failure, holding the valid samples in `.partial`).

Example:
    >>> import numpy as np
    >>> tr = Trajectory(np.zeros(1), np.zeros((1, 1, 3)), np.zeros((1, 1, 3)), np.zeros(1),
    ...                 "vi", "c", 0.1)
    >>> tr.q.shape
    (1, 1, 3)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["IntegrationError", "Trajectory"]


@dataclass(frozen=True)
class Trajectory:
    """Samples on the grid t_k = k h every: q and omega (N+1, n, 3), energy (N+1,) or None when
    it was not asked for."""

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray | None
    method: str
    backend: str
    h: float
    stats: dict[str, int] = field(default_factory=dict)
    wall_time: float = 0.0


class IntegrationError(RuntimeError):
    """An integration failed; `.partial` holds the valid samples computed before the failure,
    `.status` the `s2gen.methods.Status` code and `.step` the first sample not computed."""

    def __init__(self, message: str, status: int, step: int, partial: Trajectory) -> None:
        super().__init__(message)
        self.status = status
        self.step = step
        self.partial = partial
