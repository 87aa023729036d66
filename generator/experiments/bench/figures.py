"""The PNG figures of `s2gen bench` (matplotlib, Agg backend).

Input: a `BenchReport`. Output: ``wp_<example>.png`` (work-precision, four log-log panels),
``long_<example>.png`` (long-time invariants), ``stability.png`` (Newton iterations against
h per hard case) and ``scaling.png`` (generation and step time against n), for the sections
that ran.

Example:
    >>> _style("vi")["lw"], _style("scipy-RK45")["ls"], _style("vi8-adaptive")["marker"]
    (2.2, '--', 'D')
    >>> _style("rattle4-adaptive")["ls"], _style("rattle4-adaptive")["mfc"]
    (':', 'none')
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .envelope import largest_stable
from .model import (
    FIXED,
    TIME_RATTLE,
    TIME_TRANSFORMED,
    VI_FAMILY,
    BenchReport,
    ExampleBench,
    ScaleRow,
    StabRow,
)

_COLORS = {
    "vi": "C0",
    "vi4": "C1",
    "vi6": "#1f4e79",
    "vi8": "#0b2545",
    "rattle": "C2",
    "rattle4": "#7fbf7f",
    "rattle6": "#2e7d32",
    "rattle8": "#0d3b12",
    "rk4": "C3",
    "rk2": "C4",
    "rk2-proj": "C5",
    "rk45-hairer": "C6",
    "rk45-matlab": "C7",
    "dop853": "#b8860b",
    "scipy-RK45": "C8",
    "scipy-DOP853": "C9",
    "vi-adaptive": "#dd3497",
    "vi4-adaptive": "#ae017e",
    "vi6-adaptive": "#7a0177",
    "vi8-adaptive": "#49006a",
    "rattle4-adaptive": "#1c9099",
    "rattle8-adaptive": "#014636",
}

#: Our adaptive methods on the emitted C (rows named by method, or rk45-<control>).
_OUR_ADAPTIVE = ("rk45", "dop853")


def _style(method: str) -> dict[str, Any]:
    color = _COLORS.get(method, "k" if "lsoda" in method else "0.5")
    if method in TIME_RATTLE:  # the VI's flow: dotted with open marks, so both lines show
        return {"color": color, "ls": ":", "lw": 2.2, "marker": "o", "ms": 6, "mfc": "none"}
    if method in TIME_TRANSFORMED:  # geometric and adaptive: the VI's weight, their own mark
        return {"color": color, "ls": "-.", "lw": 2.2, "marker": "D", "ms": 4}
    ours = method.startswith(_OUR_ADAPTIVE)
    ls = "-" if method in FIXED or ours else "--"
    lw = 2.2 if method in VI_FAMILY else 1.2
    marker = "o" if method in FIXED else "s" if ours else "^"
    return {"color": color, "ls": ls, "lw": lw, "marker": marker, "ms": 4}


def _pyplot() -> Any:
    """matplotlib.pyplot on the Agg backend (files only, no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _label(ax: Any, xlabel: str, ylabel: str) -> None:
    """Axis labels and the light grid every panel of the bench uses."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)


def _save(fig: Any, path: Path) -> Path:
    fig.savefig(path, dpi=110)
    _pyplot().close(fig)
    return path


def _plot_wp(ex: ExampleBench, path: Path) -> Path:
    fig, axes = _pyplot().subplots(2, 2, figsize=(12, 9))
    panels = (
        ("wall", "state_err"),
        ("evals", "state_err"),
        ("wall", "rel_dE"),
        ("evals", "rel_dE"),
    )
    labels = {
        "wall": "wall time [s] (best of k)",
        "evals": "gradient evaluations",
        "state_err": "state error at T",
        "rel_dE": "max |E - E0| / max kinetic energy",
    }
    methods = list(dict.fromkeys(r.method for r in ex.rows))
    for ax, (x, y) in zip(axes.flat, panels):
        for m in methods:
            pts = [(getattr(r, x), getattr(r, y)) for r in ex.rows if r.method == m and r.ok]
            pts = [(a, b) for a, b in pts if a > 0 and b > 0]
            if pts:
                ax.loglog(*zip(*sorted(pts)), label=m, **_style(m))
        if y == "state_err":
            ax.axhline(ex.reference.accuracy, color="0.6", lw=0.8, ls=":")
        _label(ax, labels[x], labels[y])
    handles, names = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, names, loc="lower center", ncol=8, fontsize=8)
    fig.suptitle(
        f"{ex.name}: work-precision over T = {ex.reference.T:g} (dotted: reference accuracy)"
    )
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    return _save(fig, path)


def _plot_long(ex: ExampleBench, path: Path) -> Path:
    fig, axes = _pyplot().subplots(2, 2, figsize=(12, 9))
    what = (
        ("dE", "max |E - E0| (running max)"),
        ("unit", "| |q_i| - 1 | (window max)"),
        ("qw", "|q_i . omega_i| (window max)"),
        ("dL", "|L - L0|, conserved components"),
    )
    for ax, (key, label) in zip(axes.flat, what):
        for s in ex.long:
            y = s.running_max() if key == "dE" else np.asarray(getattr(s, key))
            t = np.asarray(s.t)
            good = np.isfinite(y) & (y > 0)
            if good.any():
                lw = 2 if s.method in (*VI_FAMILY, *TIME_RATTLE) else 1.2
                ls = "--" if "(=" in s.label else "-"  # an equal-cost run
                ls = ":" if s.method in TIME_RATTLE else ls  # on its VI's line: dotted
                style = {"lw": lw, "ls": ls, "color": _COLORS.get(s.method)}
                ax.loglog(t[good], y[good], label=s.label, **style)
        _label(ax, "t", label)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"{ex.name}: long-time behaviour")
    fig.tight_layout()
    return _save(fig, path)


def _plot_encounters(ex: ExampleBench, path: Path) -> Path:
    """Largest relative energy error over the horizon, and its drift slope, against gradient
    evaluations: one line per method through its runs from loose to tight (DOP853 over its
    tolerance, the time-transformed VI over eps; on a chaotic system the evaluations a run
    needs are not monotone in its setting, since each run meets its own encounters)."""
    fig, axes = _pyplot().subplots(1, 2, figsize=(12, 5))
    e0 = abs(ex.energy0)
    for m in dict.fromkeys(s.method for s in ex.encounters):
        runs = [s for s in ex.encounters if s.method == m and s.status == "ok" and s.dE]
        pts = [(s.evals, max(s.dE) / e0, s.slope()) for s in runs]  # loose to tight
        if pts:
            evals, err, slope = zip(*pts)
            axes[0].loglog(evals, err, label=m, **_style(m))
            axes[1].semilogx(evals, slope, label=m, **_style(m))
    for c in ex.energy_costs:
        axes[0].axhline(c.target, color="0.6", lw=0.8, ls=":")
    axes[1].axhline(0.0, color="0.6", lw=0.8, ls=":")
    _label(axes[0], "gradient evaluations", "max |E - E0| / |E0| over the horizon")
    _label(axes[1], "gradient evaluations", "drift slope (log max |dE| against log t)")
    axes[0].legend(fontsize=8)
    horizon = max((s.t[-1] for s in ex.encounters if s.t), default=math.nan)
    fig.suptitle(f"{ex.name}: energy error against cost over T = {horizon:g} (dotted: targets)")
    fig.tight_layout()
    return _save(fig, path)


def _plot_stability(rows: Sequence[StabRow], path: Path) -> Path:
    from matplotlib.ticker import NullFormatter

    cases = list(dict.fromkeys(r.case for r in rows))
    cols = 3
    nrows = math.ceil(len(cases) / cols)
    fig, axes = _pyplot().subplots(nrows, cols, figsize=(5 * cols, 3.6 * nrows), squeeze=False)
    for ax, case in zip(axes.flat, cases):
        for m in ("vi", "vi4", "rattle"):
            pts = sorted(
                (r.h, r.newton_per_step)
                for r in rows
                if r.case == case and r.method == m and r.status == "ok"
            )
            if pts and max(p[1] for p in pts) > 0:
                ax.semilogx(*zip(*pts), label=m, **_style(m))
            best = largest_stable([r for r in rows if r.case == case and r.method == m])
            if best:
                ax.axvline(best.h, color=_style(m)["color"], lw=0.8, ls=":")
        ax.set_title(case, fontsize=9)
        ax.xaxis.set_minor_formatter(NullFormatter())
        _label(ax, "h (dotted: largest stable h)", "Newton iterations per step")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
        else:
            ax.text(
                0.5,
                0.5,
                "explicit methods only\n(diagonal M: no Newton)",
                ha="center",
                transform=ax.transAxes,
            )
    for ax in list(axes.flat)[len(cases) :]:
        ax.axis("off")
    fig.tight_layout()
    return _save(fig, path)


def _plot_scaling(rows: Sequence[ScaleRow], path: Path) -> Path:
    fig, (a, b) = _pyplot().subplots(1, 2, figsize=(12, 4.5))
    for fam in dict.fromkeys(r.family for r in rows):
        pts = [r for r in rows if r.family == fam and r.status == "ok"]
        if not pts:
            continue
        ns = [r.n for r in pts]
        a.loglog(ns, [r.emit_s + r.gcc_s for r in pts], "o-", label=f"{fam}: derive+emit+gcc")
        a.loglog(ns, [r.gcc_s for r in pts], "x:", label=f"{fam}: gcc only")
        b.loglog(ns, [r.vi_us for r in pts], "o-", label=f"{fam}: vi")
        b.loglog(ns, [r.rk4_us for r in pts], "s--", label=f"{fam}: rk4")
    for ax, ylabel in ((a, "generation time [s]"), (b, "time per step [us]")):
        _label(ax, "n (bodies)", ylabel)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


def write_plots(report: BenchReport) -> list[Path]:
    """The PNG figures of every section that ran."""
    files = []
    for ex in report.examples:
        if ex.rows:
            files.append(_plot_wp(ex, report.out / f"wp_{ex.name}.png"))
        if ex.long:
            files.append(_plot_long(ex, report.out / f"long_{ex.name}.png"))
        if ex.encounters:
            files.append(_plot_encounters(ex, report.out / f"encounters_{ex.name}.png"))
    if report.stability:
        files.append(_plot_stability(report.stability, report.out / "stability.png"))
    if report.scaling:
        files.append(_plot_scaling(report.scaling, report.out / "scaling.png"))
    return files
