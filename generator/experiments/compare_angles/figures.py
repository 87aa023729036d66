"""The PNG figures of `s2gen compare-angles` (matplotlib `Figure`, no display).

Input: a `Comparison` and a path. Output: the figure written there: ``accuracy.png`` (state
and energy error against time for the spec's state), ``pole_steps.png`` (RK45 steps and
|sin θ| near a pole, whole run and zoomed), ``pole_error.png`` (error near a pole) and
``scaling.png`` (chains: derivation time, operations, vector-field time against n).

Example:
    >>> _window(np.array([[0.0, 1, 0], [1.0, 5, 1], [2.0, 9, 3]]), 0.5, 2.0).tolist()
    [[1.0, 0.0, 0.0], [2.0, 4.0, 2.0]]
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .model import Comparison, PoleCase, Run
from .settings import _LABELS, FORMS, ZOOM

_FORM_STYLE: dict[str, dict[str, Any]] = {
    "s2": {"color": "tab:red", "linestyle": "-"},
    "angles": {"color": "tab:blue", "linestyle": "--"},
    "angles-simplified": {"color": "tab:green", "linestyle": ":"},
}


def _save(fig: Any, path: Path) -> Path:
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def _positive(y: np.ndarray) -> np.ndarray:
    return np.maximum(y, 1e-17)


def _time_axes(ax: Any) -> None:
    """t on the x axis, a log quantity from 1e-12 up, a light grid."""
    ax.set_xlabel("t")
    ax.set_ylim(bottom=1e-12)
    ax.grid(True, which="both", alpha=0.3)


def _error_curve(ax: Any, r: Run, *fmt: str, ms: float | None = None, **style: Any) -> None:
    """The error of one run against t, with an x (size `ms`) where a failed run stopped."""
    ax.semilogy(r.t, _positive(r.error), *fmt, **style)
    if r.status != "ok":
        size = {} if ms is None else {"ms": ms}
        ax.plot(r.t[-1], _positive(r.error[-1:])[0], "x", color=style["color"], **size)


def _error_panel(ax: Any, runs: Sequence[Run], method: str, title: str) -> None:
    for r in runs:
        if r.method != method or not r.t.size:
            continue
        _error_curve(ax, r, ms=9, label=_LABELS[r.form], **_FORM_STYLE[r.form])
    ax.set_title(title)
    ax.set_ylabel("max ‖qᵢ − qᵢ,ref‖")
    _time_axes(ax)


def accuracy_figure(result: Comparison, path: Path) -> Path:
    """State and energy error against time, RK45 and RK4, both forms, for the spec's state."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 7), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    for col, method in enumerate(("rk45", "rk4")):
        ax, ax_e = axes[0, col], axes[1, col]
        _error_panel(ax, result.accuracy, method, f"{result.system}: {method.upper()}")
        for r in (r for r in result.accuracy if r.method == method and r.t.size):
            ax_e.semilogy(
                r.t, _positive(r.energy_error), label=_LABELS[r.form], **_FORM_STYLE[r.form]
            )
        for r in (r for r in result.accuracy if r.method == method and r.status == "PoleError"):
            note = f"{_LABELS[r.form]}: cannot start, {r.message.split(':')[0]}"
            color = _FORM_STYLE[r.form]["color"]
            ax.text(0.02, 0.02, note, transform=ax.transAxes, fontsize=8, color=color)
        ax.legend(fontsize=8)
        ax_e.set_ylabel("|E − E₀|")
        _time_axes(ax_e)
    return _save(fig, path)


def _case_colors(cases: Sequence[PoleCase]) -> dict[str, Any]:
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    return {c.label: cmap(k / max(1, len(cases) - 1)) for k, c in enumerate(cases)}


def _window(data: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Rows of (t, ...) data with lo <= t <= hi, counts relative to the first of them."""
    rows = data[(data[:, 0] >= lo - 1e-12) & (data[:, 0] <= hi + 1e-12)]
    return rows - np.r_[0.0, rows[0, 1:]] if len(rows) else rows


def _steps_column(axes: Any, result: Comparison, zoom: bool) -> None:
    """Accepted and rejected steps and |sin theta| of every case, over [0, T] or the zoom."""
    colors = _case_colors(result.pole)
    tp = result.pole[0].passage_time
    lo, hi = (tp - ZOOM, tp + ZOOM) if zoom else (0.0, result.settings.T)
    for c in result.pole:
        for r in (r for r in c.runs if r.method == "rk45" and r.counts.size):
            data = _window(r.counts, lo, hi)
            if not len(data):
                continue
            ls = "-" if r.form == "angles" else "--"
            axes[0].plot(
                data[:, 0],
                data[:, 1],
                ls,
                color=colors[c.label],
                label=f"{c.label}: {_LABELS[r.form]}",
            )
            axes[1].plot(data[:, 0], data[:, 2], ls, color=colors[c.label])
            if r.status != "ok":
                axes[0].plot(data[-1, 0], data[-1, 1], "x", color=colors[c.label], ms=10)
        t = result.settings.h * np.arange(len(c.sin_theta))
        keep = (t >= lo) & (t <= hi)
        axes[2].semilogy(
            t[keep], _positive(c.sin_theta[keep]), color=colors[c.label], label=c.label
        )
    since = f" since t = {lo:.3g}" if zoom else ""
    axes[0].set_ylabel(f"accepted RK45 steps{since}")
    axes[1].set_ylabel(f"rejected RK45 steps{since}")
    axes[2].set_ylabel(f"|sin θ{result.pole[0].body + 1}| (reference)")
    axes[2].set_xlabel("t")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)


def pole_steps_figure(result: Comparison, path: Path) -> Path:
    """Accepted and rejected RK45 steps and |sin theta| of the reference per case: over the
    whole run (left) and around the designed pass (right)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 9), layout="constrained")
    grid = fig.subplots(3, 2, sharex="col")
    _steps_column(grid[:, 0], result, zoom=False)
    _steps_column(grid[:, 1], result, zoom=True)
    fig.suptitle(
        f"{result.system}: RK45 near a pole (solid: angle form, dashed: S² form; x: failure); "
        f"right: t = {result.pole[0].passage_time:.3g} ± {ZOOM:g}"
    )
    grid[0, 0].legend(fontsize=7, ncol=2)
    grid[2, 1].legend(fontsize=7, ncol=3)
    return _save(fig, path)


def pole_error_figure(result: Comparison, path: Path) -> Path:
    """Error against time near a pole: RK45 and RK4, both forms, every case."""
    from matplotlib.figure import Figure

    cases = result.pole
    colors = _case_colors(cases)
    fig = Figure(figsize=(11, 4.5), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    for ax, method in zip(axes, ("rk45", "rk4")):
        for c in cases:
            for r in c.runs:
                if r.method != method or not r.t.size:
                    continue
                ls = "-" if r.form == "angles" else "--"
                label = f"{c.label}: {_LABELS[r.form]}"
                _error_curve(ax, r, ls, color=colors[c.label], label=label)
        ax.set_title(f"{method.upper()} (solid: angle form, dashed: S² form; x: failure)")
        _time_axes(ax)
    axes[0].set_ylabel("max ‖qᵢ − qᵢ,ref‖")
    axes[0].legend(fontsize=7, ncol=2)
    return _save(fig, path)


def scaling_figure(result: Comparison, path: Path) -> Path:
    """Derivation time, operations and vector-field time against n for the chains."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4), layout="constrained")
    axes = fig.subplots(1, 3)
    metrics_ = (
        ("seconds", "derivation + cse (s)"),
        ("ops_evaluated", "operations after cse, per call"),
        ("rhs_ns", "vector field (ns, C)"),
    )
    for ax, (key, label) in zip(axes, metrics_):
        for form in FORMS:
            done = [c for c in result.chains if c.form == form and c.status == "ok"]
            if done:
                ax.semilogy(
                    [c.n for c in done],
                    [getattr(c, key) for c in done],
                    "o",
                    label=_LABELS[form],
                    **_FORM_STYLE[form],
                )
            if done and form == "s2" and key == "ops_evaluated":
                ax.semilogy(
                    [c.n for c in done],
                    [c.ops for c in done],
                    "s:",
                    color="tab:red",
                    label="S² form, kernels (text)",
                )
            over = [c for c in result.chains if c.form == form and c.status != "ok"]
            if over and key == "seconds":
                ax.plot(over[0].n, result.settings.budget, "^", color=_FORM_STYLE[form]["color"])
        ax.set_xlabel("bodies n")
        ax.set_title(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].axhline(result.settings.budget, color="gray", lw=0.8)
    axes[0].legend(fontsize=8, title="▲: over budget", loc="lower right")
    axes[1].legend(fontsize=8)
    return _save(fig, path)
