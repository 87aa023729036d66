"""The long-time section of one example in ``bench.md``: crossovers and the runs' invariants.

Input: an `ExampleBench` whose long runs and crossovers were measured. Output: Markdown lines:
the crossovers with RK at equal energy error (`crossover.py`), the table of every long run
(steps, evaluations, wall time, largest energy error, drift slope, unit length, q . omega,
conserved momentum) and the notes.

Example:
    >>> from s2gen.experiments.bench import ExampleBench, Reference, example_system
    >>> s = example_system("double_pendulum")
    >>> _md_crossovers(ExampleBench("x", s, Reference(s, 0.0, np.zeros(0), 0, 1, 0, 0)))
    []
"""

from __future__ import annotations

import math

import numpy as np

from .common import _fmt, _table
from .model import ExampleBench


def _md_crossovers(ex: ExampleBench) -> list[str]:
    """The crossovers with RK at equal energy error (s2gen.bench.crossover), as a table."""
    if not ex.crossovers:
        return []
    rows = [
        [
            f"{c.target:g}",
            c.rk,
            f"{c.vi_method} (h={c.vi_h:.3g})" if c.vi_method else "—",
            _fmt(c.vi_cost * 1e6),
            _fmt(c.rk_tol, ".2g"),
            _fmt(c.rk_cost * 1e6),
            _fmt(c.horizon, ".4g") if c.status == "ok" else c.status,
            _fmt(c.chased, ".4g"),
            _fmt(c.vi_reached, ".4g"),
            _fmt(c.vi_max, ".2g"),
        ]
        for c in ex.crossovers
    ]
    head = (
        "rel. energy error",
        "RK",
        "cheapest VI family",
        "µs per unit time",
        "tightest RK tol as cheap",
        "µs per unit time",
        "it exceeds the error at t",
        "RK runs to",
        "VI runs to",
        "VI max rel. error",
    )
    intro = (
        "Crossover at equal error: the cheapest VI-family run (largest step of each method whose "
        "energy error stays within a quarter of the target over 10⁴ of the system's steps) "
        "against the "
        "tightest RK tolerances that cost no more per unit of simulated time; those RK runs go "
        "on, the horizon doubling, until their energy error exceeds the target: from that time "
        "on the VI family is the cheaper at that error (measured, not extrapolated). The VI run "
        "goes on to the same time to check it stays below the target."
    )
    return [intro, "", *_table(head, rows), ""]


def _md_long(ex: ExampleBench) -> list[str]:
    rows = []
    for s in ex.long:
        final = s.running_max()[-1] if s.dE else math.nan
        rows.append(
            [
                s.label,
                str(s.steps or "—"),
                str(s.evals),
                f"{s.wall:.2f} s",
                _fmt(final, ".2e"),
                _fmt(s.slope(), ".2f"),
                _fmt(max(s.unit, default=math.nan), ".1e"),
                _fmt(max(s.qw, default=math.nan), ".1e"),
                _fmt(np.nanmax(s.dL) if s.dL else math.nan, ".1e"),
                s.status,
            ]
        )
    head = (
        "run",
        "steps",
        "grad evals",
        "wall",
        "max abs dE",
        "drift slope",
        "max unit err",
        "max q.w",
        "max dL",
        "status",
    )
    return [
        f"### Long time ({ex.name}) ![long](long_{ex.name}.png)",
        "",
        *_md_crossovers(ex),
        "",
        (
            "Drift slope: least-squares slope of log(running max |E − E0|) against log t over the "
            "last two decades of time (0: bounded; 1: linear drift). dL: conserved components only. "
            "Runs go in windows that double in length (each continues from the last state); the "
            "table keeps window maxima. rk45 (Hairer control) and dop853: our C."
        ),
        "",
        *_table(head, rows),
        "",
        "Notes:",
        "",
        *[f"- {n}" for n in ex.long_notes],
        "",
    ]
