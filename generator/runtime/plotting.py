"""The figure of one trajectory: its motion beside its errors (matplotlib, no pyplot).

Input: a `Trajectory`. Output: a matplotlib Figure (written as a PNG when a path is given) with
five panels: each body's path on the unit sphere seen from above (x, y) and from the side
(x, z), the heights q_i . e3 against t, |E - E_0| and max_i | |q_i| - 1 | against t on log
axes. At most `MAX_BODIES_SHOWN` bodies are drawn, evenly chosen, and the title says so.

Example:
    >>> import numpy as np
    >>> from s2gen.runtime.trajectory import Trajectory
    >>> q = np.tile([[[1.0, 0, 0]]], (3, 1, 1))
    >>> fig = trajectory_figure(Trajectory(np.arange(3.0), q, q, np.ones(3), "vi", "c", 1.0))
    >>> [ax.get_xlabel() for ax in fig.axes]
    ['x', 'x', 't', 't', 't']
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MAX_BODIES_SHOWN", "trajectory_figure"]

#: Most bodies whose paths and heights are drawn (evenly chosen beyond it).
MAX_BODIES_SHOWN = 12


def _shown(n: int) -> np.ndarray:
    """Indices of the bodies drawn: all, or `MAX_BODIES_SHOWN` evenly spread."""
    if n <= MAX_BODIES_SHOWN:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, MAX_BODIES_SHOWN).round().astype(int))


def _log_panel(ax: Any, t: np.ndarray, err: np.ndarray, label: str, color: str) -> None:
    """An error curve on a log axis (exact zeros, such as t = 0, have no place there)."""
    shown = np.where(err > 0, err, np.nan)
    if np.any(np.isfinite(shown)):
        ax.semilogy(t, shown, lw=0.8, color=color)
    else:
        ax.text(0.5, 0.5, "exactly zero", transform=ax.transAxes, ha="center")
    ax.set_ylabel(label)
    ax.set_xlabel("t")
    ax.grid(True, which="major", alpha=0.3)


def trajectory_figure(tr: Any, path: str | Path | None = None) -> Any:
    """The five-panel Figure of `tr` (module docstring), saved to `path` when given."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 9))
    grid = fig.add_gridspec(3, 2, height_ratios=[1.3, 0.8, 0.8])
    top, side = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])
    heights = fig.add_subplot(grid[1, :])
    ax_e, ax_q = fig.add_subplot(grid[2, 0]), fig.add_subplot(grid[2, 1])
    n = tr.q.shape[1]
    bodies = _shown(n)
    circle = np.linspace(0.0, 2 * np.pi, 200)
    for ax, k, name in ((top, 1, "y"), (side, 2, "z")):
        ax.plot(np.cos(circle), np.sin(circle), color="0.8", lw=0.8)
        for i in bodies:
            line = ax.plot(tr.q[:, i, 0], tr.q[:, i, k], lw=0.7, label=f"body {i + 1}")
            if len(tr.t):
                ax.plot(tr.q[0, i, 0], tr.q[0, i, k], "o", ms=4, color=line[0].get_color())
        ax.set_aspect("equal")
        ax.set_xlim(-1.08, 1.08)
        ax.set_ylim(-1.08, 1.08)
        ax.set_xlabel("x")
        ax.set_ylabel(name)
        ax.set_title("from above" if k == 1 else "from the side (dots: t = 0)", fontsize=9)
    for i in bodies:
        heights.plot(tr.t, tr.q[:, i, 2], lw=0.8, label=f"body {i + 1}")
    heights.set_ylabel(r"$q_i \cdot e_3$")
    heights.set_xlabel("t")
    heights.grid(True, alpha=0.3)
    if 0 < len(bodies) <= 8:
        heights.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    energy = np.full(len(tr.t), np.nan) if tr.energy is None else tr.energy
    dE = np.abs(energy - energy[0]) if len(energy) else energy
    _log_panel(ax_e, tr.t, dE, r"$|E - E_0|$", "C0")
    _log_panel(ax_q, tr.t, tr.unit_length_error(), r"$\max_i\,|\,\|q_i\| - 1\,|$", "C1")
    title = f"{tr.system or 'trajectory'}: {tr.method} on {tr.backend}, h = {tr.h:g}"
    if len(bodies) < n:
        title += f" ({len(bodies)} of {n} bodies drawn)"
    fig.suptitle(title)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
