"""The records of `s2gen compare-angles` and the names of the forms it compares.

Input: nothing (definitions only). Output: `FORMS` and their labels, the reference
tolerances, `Settings` (what to run), `Cost` (derivation and run cost of one form), `Run`
(one integration measured against the reference), `PoleCase` (one near-pole case) and
`Comparison` (every result of one `compare` call).

Example:
    >>> from s2gen.experiments.compare_angles.settings import FORMS, _LABELS
    >>> Settings().options().rtol, FORMS[0], _LABELS["s2"]
    (1e-06, 's2', 'S² form')
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .settings import Settings


@dataclass(frozen=True)
class Cost:
    """The cost of one form of one system; `status` is "ok", "> budget" or an error."""

    form: str
    n: int
    status: str
    seconds: float = float("nan")
    module_seconds: float = float("nan")
    ops_before: int = 0
    ops: int = 0
    ops_evaluated: int = 0
    solve_flops: int = 0
    c_bytes: int = 0
    c_lines: int = 0
    gcc_seconds: float = float("nan")
    rhs_ns: float = float("nan")


@dataclass
class Run:
    """One integration of one form, measured against the reference on the output grid."""

    form: str
    method: str
    status: str
    message: str = ""
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    error: np.ndarray = field(default_factory=lambda: np.zeros(0))  # max_i |q_i - q_i,ref|
    energy_error: np.ndarray = field(default_factory=lambda: np.zeros(0))  # |E - E0|
    counts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # t, accepted, rejected
    summary: dict[str, float] = field(default_factory=dict)
    steps: int = 0
    rejected: int = 0
    evals: int = 0
    wall: float = float("nan")

    def max_error(self) -> float:
        return float(np.max(self.error)) if self.error.size else float("nan")

    def brief(self) -> dict[str, Any]:
        """The scalar results (for the JSON file)."""
        keys = ("form", "method", "status", "message", "steps", "rejected", "evals", "wall")
        out = {k: getattr(self, k) for k in keys}
        reached = float(self.t[-1]) if self.t.size else 0.0
        return {**out, "max_error": self.max_error(), "t_reached": reached, **self.summary}


@dataclass
class PoleCase:
    """One near-pole case: its label, tilt, the reference's pass of the pole, the runs."""

    label: str
    beta: float
    body: int
    passage: float  # distance of the designed pass from the pole (signed)
    passage_time: float
    sin_theta: np.ndarray  # |sin theta_body(t)| of the reference on the output grid
    runs: list[Run]


@dataclass
class Comparison:
    """Every result of one `compare` call."""

    system: str
    n: int
    settings: Settings
    costs: list[Cost]
    accuracy: list[Run]
    pole: list[PoleCase]
    chains: list[Cost]
    files: list[Path] = field(default_factory=list)
