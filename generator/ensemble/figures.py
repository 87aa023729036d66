"""The ensemble's figures (matplotlib, PNG): energy error per member, divergence, sweep.

Input: the per-member arrays of a store, the `Divergence` curves of `summary`, the store's
settings and a folder. Output: ``energy.png`` (each member's mean |E - E0| against the member
index, the swept value, or the sweep point of a grid (see `_member_x`), with a histogram
beside it), ``divergence.png`` (perturbed members' divergence from their reference
against time, the ensemble's geometric mean and the fitted exponential) when members were
perturbed, and ``sweep.png`` (mean |E - E0| against each swept quantity: median over the
replicas, their range as a bar, failures marked) when something was swept.

Example:
    >>> write_figures(per, divergences, attrs, "out/ensemble")  # doctest: +SKIP
    [PosixPath('out/ensemble/energy.png'), ...]
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .divergence import Divergence, point_label, swept_names
from .store import NOT_WRITTEN

__all__ = [
    "divergence_figure",
    "energy_figure",
    "energy_plot",
    "sweep_figure",
    "write_figures",
]

_DPI = 120


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _log_scale(ax: Any, values: Any, per: dict[str, np.ndarray]) -> bool:
    """A log y scale when some of `values` are finite and positive (matplotlib cannot
    log-scale nothing); otherwise a linear axis from 0 to 1. Either way the axes say so when
    every written member failed, and a linear one says that there is nothing to show.
    Whether the axis got its log scale."""
    v = np.asarray(values, dtype=float).ravel()
    logged = bool((np.isfinite(v) & (v > 0)).any())
    if logged:
        ax.set_yscale("log")
    else:
        ax.set_ylim(0, 1)
    written = per["status"] != NOT_WRITTEN
    failed = int((written & (per["status"] != 0)).sum())
    if failed and failed == int(written.sum()):
        note = f"all {failed} members failed: none reached T (see summary.md)"
        ax.text(0.5, 0.92, note, transform=ax.transAxes, ha="center", va="top", color="tab:red")
    if not logged:
        ax.text(0.5, 0.5, "no positive finite values to show", transform=ax.transAxes,
                ha="center", va="center")  # fmt: skip
    return logged


def _title(attrs: dict[str, Any]) -> str:
    return f"{attrs['system']}, {attrs['method']}, h = {attrs['h']:g}, T = {attrs['T']:g}"


def _member_x(per: dict[str, np.ndarray]) -> tuple[np.ndarray, str]:
    """Each member's x in the energy strip and the axis label. Without a sweep, the member
    index (0: the reference); over one swept quantity, its value, unmoved (a numeric axis);
    over a grid of them, the sweep point as a category, the perturbed members spread
    sideways within it (the references stay on the point) so that they do not hide each other.
    """
    names = swept_names(per)
    if not names:
        return per["member"].astype(float), "member (0: the unperturbed reference)"
    if len(names) == 1:
        return per[names[0]].astype(float), names[0].removeprefix("param_")
    rng = np.random.default_rng(0)
    spread = np.where(per["replica"] == 0, 0.0, rng.uniform(-0.25, 0.25, len(per["point"])))
    return per["point"] + spread, "sweep point (perturbed members spread sideways)"


def energy_figure(per: dict[str, np.ndarray], attrs: dict[str, Any], path: Path) -> Path:
    """`energy_plot` written to `path`."""
    plt = _plt()
    fig = energy_plot(per, attrs)
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


def energy_plot(per: dict[str, np.ndarray], attrs: dict[str, Any]) -> Any:
    """Mean |E - E0| of every member: a strip (x: see `_member_x`) and a histogram (log
    bins); the Figure."""
    plt = _plt()
    written = per["status"] != NOT_WRITTEN
    ok = written & (per["status"] == 0)
    bad = written & (per["status"] != 0)
    y = per["mean_dE"]
    fig, (ax, hx) = plt.subplots(
        1, 2, figsize=(9, 4), gridspec_kw={"width_ratios": [3, 1]}, sharey=True
    )
    x, xlabel = _member_x(per)
    ref = per["replica"] == 0
    ax.scatter(x[ok & ~ref], y[ok & ~ref], s=12, alpha=0.5, label="perturbed")
    ax.scatter(  # hollow: the perturbed members at the same x show through
        x[ok & ref], y[ok & ref], s=60, marker="D", facecolors="none", edgecolors="k",
        linewidths=1.4, label="reference",
    )  # fmt: skip
    if bad.any():
        ax.scatter(x[bad], y[bad], s=30, marker="x", color="tab:red", label="failed (partial)")
    _log_scale(ax, y[written], per)
    ax.set_ylabel("mean |E − E0| over the run")
    ax.set_xlabel(xlabel)
    names = swept_names(per)
    if len(names) == 1:  # a numeric axis: the swept values where they are
        values = per[names[0]]
        if values.min() > 0 and values.max() / values.min() > 100:
            ax.set_xscale("log")
    elif len(names) > 1:  # sweep points as categories, labelled by their values
        points = np.unique(per["point"])
        ticks = points[:: int(np.ceil(len(points) / 12))]
        labels = [point_label(per, int(p), "\n") for p in ticks]
        ax.set_xticks(ticks, labels, fontsize=8, rotation=30 if len(ticks) > 6 else 0)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(_title(attrs), fontsize=10)
    finite = y[written & np.isfinite(y) & (y > 0)]
    if len(finite):
        lo, hi = np.log10(finite.min()), np.log10(finite.max())
        bins = np.logspace(lo - 0.05, hi + 0.05, 20) if hi > lo else 10
        hx.hist(finite, bins=bins, orientation="horizontal", color="tab:blue", alpha=0.7)
    hx.set_xlabel("members")
    fig.tight_layout()
    return fig


def divergence_figure(
    divs: Sequence[Divergence], per: dict[str, np.ndarray], attrs: dict[str, Any], path: Path
) -> Path:
    """Divergence from the reference against time (log scale) with the fitted exponent."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 4.5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    single = len(divs) == 1
    for k, d in enumerate(divs[:8]):
        color = "k" if single else colors[k % len(colors)]
        t = d.t
        if single:
            for c in d.curves:
                ax.plot(t, np.where(c > 0, c, np.nan), color="tab:blue", lw=0.5, alpha=0.3)
            ax.fill_between(t, d.low, d.high, color="tab:blue", alpha=0.1, label="range")
        where = point_label(per, d.point)
        label = "geometric mean" if single else where
        ax.plot(t, np.exp(d.log_mean), color=color, lw=1.8, label=label)
        f = d.fit
        if f.rate is not None:
            tt = np.linspace(f.t_start, f.t_end, 50)
            ax.plot(
                tt,
                np.exp(f.intercept + f.rate * tt),
                "--",
                color="tab:red" if single else color,
                lw=2,
                label=f"fit λ = {f.rate:.3g}" + ("" if single else f" ({where})"),
            )
            if single:
                ax.axvspan(f.t_start, f.t_end, color="tab:red", alpha=0.06)
    shown = [np.exp(d.log_mean) for d in divs[:8]]
    _log_scale(ax, shown, per)
    ax.set_xlabel("t")
    ax.set_ylabel("max_i |q_i − q_i^ref|")
    members = sum(d.members for d in divs)
    ax.set_title(f"{_title(attrs)}: {members} perturbed members", fontsize=10)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


def sweep_figure(per: dict[str, np.ndarray], attrs: dict[str, Any], path: Path) -> Path:
    """Mean |E - E0| against each swept quantity (median over replicas, range as a bar)."""
    plt = _plt()
    names = swept_names(per)
    fig, axes = plt.subplots(1, len(names), figsize=(5.5 * len(names), 4), squeeze=False)
    written = per["status"] != NOT_WRITTEN
    for ax, name in zip(axes[0], names):
        xs, med, lo, hi, failed = [], [], [], [], []
        for point in np.unique(per["point"]):
            sel = (per["point"] == point) & written
            if not sel.any():
                continue
            x = float(per[name][sel][0])
            v = per["mean_dE"][sel & (per["status"] == 0)]
            v = v[np.isfinite(v)]
            if len(v):
                xs.append(x)
                med.append(np.median(v))
                lo.append(np.median(v) - v.min())
                hi.append(v.max() - np.median(v))
            if (per["status"][sel] != 0).any():
                failed.append(x)
        if xs:
            ax.errorbar(xs, med, yerr=[lo, hi], fmt="o-", ms=4, capsize=3, label="median (range)")
        for k, x in enumerate(failed):
            ax.axvline(x, color="tab:red", ls=":", lw=1, label="failures" if k == 0 else None)
        _log_scale(ax, med, per)
        positive = [x for x in xs + failed if x > 0]
        if positive and max(positive) / min(positive) > 100:
            ax.set_xscale("log")
        ax.set_xlabel(name.removeprefix("param_"))
        ax.set_ylabel("mean |E − E0|")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="best", fontsize=8)
    fig.suptitle(_title(attrs), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=_DPI)
    plt.close(fig)
    return path


def write_figures(
    per: dict[str, np.ndarray], divs: Sequence[Divergence], attrs: dict[str, Any], out: Path
) -> list[Path]:
    """Every figure that applies, written into `out`."""
    paths = [energy_figure(per, attrs, out / "energy.png")]
    if divs:
        paths.append(divergence_figure(divs, per, attrs, out / "divergence.png"))
    if len(np.unique(per["point"])) > 1:
        paths.append(sweep_figure(per, attrs, out / "sweep.png"))
    return paths
