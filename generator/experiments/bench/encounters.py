"""Close encounters over a long horizon: energy error against cost, time-transformed VI and DOP853.

Input: a `LongSetup` whose system's emitted C has the time-transformed driver, and the window
ends of the long runs (the same horizon). Output: the runs (`LongSeries`): DOP853 at
tolerances 1e-6 ... 1e-13, 10^(1/2) apart, and vi4-, vi6- and vi8-adaptive at eps = 0.4 ...
0.05, 2^(1/2) apart (each sweep stops once a run keeps the error 10x below the smallest target),
and one `EnergyCost` per target relative energy error: the cheapest measured run of each side
whose largest relative energy error over the whole horizon, max |E - E0| / |E0| over the
window maxima, stays within the target, and the ratio of their gradient evaluations.

The time-transformed RATTLE methods (rattle4-, rattle8-adaptive) are not swept here: they take
the VI's discrete flow (the same steps and energy errors, to round-off; the long runs of
`long_study` show rattle4-adaptive's beside vi4-adaptive's), so their rows would repeat the
VI's errors at the same evaluations and double the study's run time.

Measured, not interpolated: a side's cost is that of a run it made, so each ratio is within one
grid step (about 1.4-1.6x in evaluations) of the one an exact tuning would give; the tables
keep every run, so the reader can check. Energies are sampled as the long runs sample them
(about 32 times a window for the adaptive methods), so an encounter's peak between two samples
is missed alike by both sides.

Example:
    >>> cost = EnergyCost("x", 1e-8, "dop853 tol=1e-11", 5000, 8e-9, "vi8-adaptive eps=0.1", 1000, 2e-9)
    >>> cost.ratio
    5.0
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .common import Log, _fmt, _print, _table
from .long_runs import _long_adaptive, _long_transformed, _tracker, _windows
from .long_study import long_setup
from .model import LongSeries, LongSetup

#: Relative energy errors the two sides are compared at.
ENERGY_TARGETS = (1e-6, 1e-8, 1e-10)
#: DOP853's tolerances, loose to tight.
DOP_TOLERANCES = tuple(10.0 ** (-6 - k / 2) for k in range(15))
#: The time-transformed methods and their fictitious steps, coarse to fine.
TRANSFORMED = ("vi4-adaptive", "vi6-adaptive", "vi8-adaptive")
EPSILONS = tuple(0.4 / 2 ** (k / 2) for k in range(7))


@dataclass(frozen=True)
class EnergyCost:
    """At relative energy error `target`: DOP853's and the time-transformed VI's cheapest runs
    that keep it over the horizon (label, gradient evaluations, their largest error); an
    empty label when no run of that side did."""

    example: str
    target: float
    dop_label: str
    dop_evals: int
    dop_max: float
    tt_label: str
    tt_evals: int
    tt_max: float

    @property
    def ratio(self) -> float:
        """DOP853's evaluations over the time-transformed run's (nan when a side has none)."""
        if not (self.dop_label and self.tt_label):
            return math.nan
        return self.dop_evals / self.tt_evals


def relative_max(series: LongSeries, e0: float) -> float:
    """The run's largest |E - E0| / |E0| over its windows (inf when it did not finish).

    Example:
        >>> s = LongSeries("x", "r", "dop853", math.nan, 1e-9, [1.0, 2.0], [1e-9, 3e-9])
        >>> relative_max(s, -2.0)
        1.5e-09
    """
    if series.status != "ok" or not series.dE:
        return math.inf
    return max(series.dE) / abs(e0)


def energy_runs(setup: LongSetup, ends: Sequence[float], log: Log) -> list[LongSeries]:
    """DOP853 over its tolerances and each time-transformed method over eps, to the last of
    `ends`; a sweep stops after its first run within a tenth of the smallest target."""
    floor = min(ENERGY_TARGETS) / 10
    out: list[LongSeries] = []
    sweeps: list[tuple[str, Sequence[float]]] = [("dop853", DOP_TOLERANCES)]
    sweeps += [(name, EPSILONS) for name in TRANSFORMED]
    for method, settings in sweeps:
        for value in settings:
            if method == "dop853":
                tr = _tracker(setup, f"dop853 tol={value:.2g}", method, math.nan, value)
                run = _long_adaptive(tr, ends, log)
            else:
                tr = _tracker(setup, f"{method} eps={value:.3g}", method, value, math.nan)
                run = _long_transformed(tr, ends, log)
            out.append(run)
            err = relative_max(run, tr.e0)
            log(f"    {run.label:26s} {run.evals:>11,d} evals  max rel dE {err:.2e}  {run.status}")
            if err < floor:
                break
    return out


def energy_costs(name: str, runs: Sequence[LongSeries], e0: float) -> list[EnergyCost]:
    """One `EnergyCost` per target of `ENERGY_TARGETS` from the runs of `energy_runs`.

    Example:
        >>> a = LongSeries("x", "dop853 tol=1e-10", "dop853", math.nan, 1e-10, [1.0], [1e-9])
        >>> a.evals = 900
        >>> b = LongSeries("x", "vi8-adaptive eps=0.1", "vi8-adaptive", 0.1, math.nan, [1.0], [1e-9])
        >>> b.evals = 300
        >>> [c.ratio for c in energy_costs("x", [a, b], 1.0)]
        [3.0, 3.0, nan]
    """

    def cheapest(runs: list[LongSeries], target: float) -> tuple[str, int, float]:
        ok = [r for r in runs if relative_max(r, e0) <= target]
        if not ok:
            return "", 0, math.nan
        best = min(ok, key=lambda r: r.evals)
        return best.label, best.evals, relative_max(best, e0)

    dop = [r for r in runs if r.method == "dop853"]
    tt = [r for r in runs if r.method != "dop853"]
    return [
        EnergyCost(name, target, *cheapest(dop, target), *cheapest(tt, target))
        for target in ENERGY_TARGETS
    ]


def encounter_study(
    name: str, steps: int, log: Log = _print
) -> tuple[list[LongSeries], list[EnergyCost], float]:
    """`energy_runs` over the long runs' horizon (`steps` of the system's h from the long
    runs' state), then `energy_costs`; returns the runs, the costs and E0.

    Example:
        >>> runs, costs, e0 = encounter_study("three_bodies", 2000, log=lambda s: None)
        >>> [c.target for c in costs] == list(ENERGY_TARGETS), e0 < 0
        (True, False)
    """
    setup = long_setup(name, steps, log)
    ends = list(np.cumsum(_windows(steps)) * setup.h)
    log(f"{name}: close encounters over T = {ends[-1]:g}, DOP853 against the time-transformed VI")
    runs = energy_runs(setup, ends, log)
    e0 = _tracker(setup, "", "vi", setup.h, math.nan).e0
    return runs, energy_costs(name, runs, e0), e0


def md_encounters(runs: Sequence[LongSeries], costs: Sequence[EnergyCost], e0: float) -> list[str]:
    """The section's Markdown: the cost table, then every run.

    Example:
        >>> md_encounters([], [], 1.0)
        []
    """
    if not runs:
        return []
    name = runs[0].example
    head = (
        "rel. energy error",
        "DOP853 run",
        "evals",
        "its max",
        "time-transformed run",
        "evals",
        "its max",
        "DOP853 / time-transformed",
    )
    rows = [
        [
            f"{c.target:g}",
            c.dop_label or "none reaches it",
            str(c.dop_evals or "—"),
            _fmt(c.dop_max, ".2g"),
            c.tt_label or "none reaches it",
            str(c.tt_evals or "—"),
            _fmt(c.tt_max, ".2g"),
            _fmt(c.ratio, ".2f") + ("×" if np.isfinite(c.ratio) else ""),
        ]
        for c in costs
    ]
    run_rows = [
        [
            r.label,
            str(r.steps),
            str(r.evals),
            f"{r.wall:.2f} s",
            _fmt(relative_max(r, e0), ".2e"),
            _fmt(r.slope(), ".2f"),
            r.status,
        ]
        for r in runs
    ]
    run_head = ("run", "steps", "grad evals", "wall", "max rel. dE", "drift slope", "status")
    horizon = max((r.t[-1] for r in runs if r.t), default=math.nan)
    return [
        f"### Close encounters over the long horizon ({name}) ![energy](encounters_{name}.png)",
        "",
        (
            f"Energy error against cost over T = {horizon:g}: the cheapest measured run of "
            "DOP853 (tolerances 10^(1/2) apart) and of the time-transformed VI (vi4-, vi6-, "
            "vi8-adaptive, eps 2^(1/2) apart) whose largest relative energy error "
            "max |E − E0| / |E0| over the whole horizon (window maxima of about 32 samples a "
            "window) stays within the target. Measured runs, not interpolated: a ratio is "
            "within one grid step of the exact one."
        ),
        "",
        *_table(head, rows),
        "",
        *_table(run_head, run_rows),
        "",
    ]
