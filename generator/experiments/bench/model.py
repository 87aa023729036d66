"""The records of `s2gen bench` and the constants that describe its methods.

Input: nothing (definitions only). Output: the method lists (`FIXED`, `VI_FAMILY`, `RK_C`,
`TIME_TRANSFORMED`),
their expected orders and gradient evaluations per step (from `s2gen.methods`), and the
dataclasses every other module of
the package passes around: `WPRow` (one work-precision run), `Reference`, `ExampleBench`
(everything measured on one example), `LongSeries`/`LongSetup` (long-time runs),
`StabilityCase`/`StabRow` (stability envelope), `ScaleRow` (scaling) and `BenchReport`.

Example:
    >>> r = WPRow("x", "vi", "s2gen", 0.01, float("nan"), 1.0, 100, 100, 2.0, 1e-3, 1e-5, 0, 0)
    >>> r.setting, r.ok
    ('h=0.01', True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from s2gen import METHODS, System
from s2gen.inspect import Family, method

#: The structure-preserving methods (the VI, RATTLE and their compositions), VI first, by order.
VI_FAMILY = tuple(
    m.name
    for m in sorted(METHODS, key=lambda m: (m.family is Family.RATTLE, m.order))
    if m.geometric and "c" in m.backends and m.family not in (Family.TIME_VI, Family.TIME_RATTLE)
)
#: Every fixed-step method of the emitted C: the VI family, then the fixed-step Runge-Kutta
#: methods (highest order first).
FIXED = (
    *VI_FAMILY,
    *(
        m.name
        for m in sorted(METHODS, key=lambda m: -m.order)
        if m.family is Family.FIXED_RK and "c" in m.backends
    ),
)
#: The time-transformed VI methods of the emitted C (swept over their fictitious step eps, on
#: the systems whose emitted C has their driver).
TIME_TRANSFORMED = tuple(
    m.name
    for m in sorted(METHODS, key=lambda m: m.order)
    if m.family is Family.TIME_VI and "c" in m.backends
)
#: The Runge-Kutta runs on the emitted C that the VI family is measured against (by row name).
RK_C = ("rk4", "rk45-hairer", "rk45-matlab", "dop853")
ORDERS = {m: float(method(m).order) for m in (*FIXED, *TIME_TRANSFORMED)}
#: Gradient evaluations per step of the fixed-step methods.
EVALS_PER_STEP = {m: method(m).evals for m in FIXED}
#: Tolerance of the reference runs (C DOP853).
REF_RTOL = 3e-14
SAMPLES = 200


@dataclass
class WPRow:
    """One run of a work-precision sweep."""

    example: str
    method: str
    family: str
    h: float
    rtol: float
    T: float
    steps: int
    evals: int
    newton_per_step: float
    wall: float
    state_err: float
    max_dE: float
    rel_dE: float
    status: str = "ok"

    @property
    def setting(self) -> str:
        """The swept setting as text: h for fixed-step methods, eps for the time-transformed
        ones, else the tolerance."""
        if self.method in TIME_TRANSFORMED:
            return f"eps={self.h:.4g}"
        return f"h={self.h:.4g}" if self.method in FIXED else f"tol={self.rtol:.0e}"

    @property
    def ok(self) -> bool:
        """Finished, with a finite error below 1."""
        return self.status == "ok" and np.isfinite(self.state_err) and self.state_err < 1.0


@dataclass
class Reference:
    """The converged solution of one example and how well it is known."""

    system: System
    T: float
    state: np.ndarray
    accuracy: float
    kinetic_scale: float
    energy0: float
    wall: float


@dataclass
class ExampleBench:
    """Everything measured on one example."""

    name: str
    system: System
    reference: Reference
    rows: list[WPRow] = field(default_factory=list)
    per_step: list[dict[str, Any]] = field(default_factory=list)
    newton: dict[str, float] = field(default_factory=dict)  # iterations per substep, own h
    pydy: dict[str, Any] = field(default_factory=dict)
    long: list[LongSeries] = field(default_factory=list)
    long_notes: list[str] = field(default_factory=list)
    crossovers: list[Any] = field(default_factory=list)  # crossover.Crossover records
    encounters: list[LongSeries] = field(default_factory=list)  # encounters.energy_runs
    energy_costs: list[Any] = field(default_factory=list)  # encounters.EnergyCost records
    energy0: float = math.nan  # E0 of the long runs (the encounter runs' scale)
    call_overhead: float = math.nan


@dataclass
class LongSeries:
    """A long run, kept as per-window maxima (windows double in length, so they are evenly
    spread on a log time axis) instead of every sample."""

    example: str
    label: str
    method: str
    h: float
    rtol: float
    t: list[float] = field(default_factory=list)
    dE: list[float] = field(default_factory=list)
    unit: list[float] = field(default_factory=list)
    qw: list[float] = field(default_factory=list)
    dL: list[float] = field(default_factory=list)
    steps: int = 0
    evals: int = 0
    wall: float = 0.0
    status: str = "ok"

    def running_max(self) -> np.ndarray:
        """max |E - E0| over [0, t_k] at each window end t_k."""
        return np.maximum.accumulate(np.asarray(self.dE)) if self.dE else np.zeros(0)

    def slope(self, decades: float = 2.0) -> float:
        """Fitted drift slope d log(max |E - E0|) / d log t over the last `decades` of time."""
        t, e = np.asarray(self.t), self.running_max()
        keep = (t >= t[-1] / 10**decades) & (e > 0) if len(t) else np.zeros(0, bool)
        if keep.sum() < 3:
            return math.nan
        return float(np.polyfit(np.log(t[keep]), np.log(e[keep]), 1)[0])


@dataclass
class LongSetup:
    """What every long run of one example shares: system, step, horizon, initial state."""

    name: str
    system: System
    h: float
    steps: int
    q0: np.ndarray
    w0: np.ndarray
    conserved: tuple[int, ...] = ()
    note: str = ""

    @property
    def T(self) -> float:
        return self.steps * self.h


@dataclass
class StabilityCase:
    """A hard case: a system with parameter values, a horizon and what makes it hard."""

    label: str
    system: System
    params: np.ndarray
    T: float
    note: str
    skipped: str = ""


@dataclass
class StabRow:
    """One run of a stability sweep."""

    case: str
    method: str
    h: float
    steps: int
    h_wmax: float
    err: float
    newton_per_step: float
    newton_max: int
    status: str


@dataclass
class ScaleRow:
    """Generation and run cost of one system size."""

    family: str
    n: int
    create_s: float
    emit_s: float
    gcc_s: float
    c_bytes: int
    vi_us: float
    rk4_us: float
    status: str = "ok"
    solver: str = ""  # the inertia's coupled solves: dense, banded, max-index (or diagonal)
    h: float = float("nan")  # step size of the per-step timings
    newton: float = float("nan")  # Newton iterations per VI step in the timed run


@dataclass
class BenchReport:
    """What one `s2gen bench` run measured and wrote."""

    out: Path
    command: str
    examples: list[ExampleBench] = field(default_factory=list)
    stability: list[StabRow] = field(default_factory=list)
    stability_cases: list[StabilityCase] = field(default_factory=list)
    scaling: list[ScaleRow] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
