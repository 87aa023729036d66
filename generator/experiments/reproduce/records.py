"""The records of `s2gen reproduce`: one run, one example, the whole report.

Input: nothing (definitions only). Output: `RunResult`, `ExampleResult`, `Report`, filled by
`runner.py` and read by `figures.py` and the tables.

Example:
    >>> Report(out=Path("out")).ok
    True
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from s2gen import System, Trajectory

from .paper import Example, PaperRun

__all__ = ["ExampleResult", "Report", "RunResult"]


@dataclass
class RunResult:
    """One run of one example: its settings, metrics (paper units), cost and trajectory."""

    example: str
    run: PaperRun
    metrics: dict[str, float] = field(default_factory=dict)
    steps: int = 0
    rejected: int = 0
    wall_time: float = 0.0
    trajectory: Trajectory | None = None
    error: str | None = None
    #: The paper's printed values to show beside ours (the run's own, or, for a quick run,
    #: those of the full run with the same method and step: shown, but not compared).
    paper: dict[str, float] = field(default_factory=dict)
    comparable: bool = False

    @property
    def label(self) -> str:
        """`example method h=.. T=..`, for log lines."""
        return f"[{self.example}] {self.run.method} h={self.run.h:g} T={self.run.T:g}"

    def ratio(self, metric: str) -> float | None:
        """Ours / paper's for a printed metric of a comparable run, else None."""
        ref = self.paper.get(metric)
        ours = self.metrics.get(metric)
        if not self.comparable or ref is None or ours is None or ref == 0:
            return None
        return ours / ref


@dataclass
class ExampleResult:
    """The runs of one example, its system (None if it could not be built) and its figures."""

    example: Example
    quick: bool
    runs: list[RunResult] = field(default_factory=list)
    system: System | None = None
    error: str | None = None
    figures: list[Path] = field(default_factory=list)

    @property
    def failures(self) -> list[str]:
        """Every error line of this example (system, runs, figures)."""
        out = [self.error] if self.error else []
        return out + [f"{r.label}: {r.error}" for r in self.runs if r.error]


@dataclass
class Report:
    """Everything `reproduce` did: per-example results, files written, errors."""

    out: Path
    examples: list[ExampleResult] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    bands: list[str] = field(default_factory=list)  # results.md lines of the chaos bands

    @property
    def ok(self) -> bool:
        """True when every system was built, every run finished and every figure was drawn."""
        return not self.errors and all(not e.failures for e in self.examples)
