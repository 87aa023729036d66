"""Divergence of an ensemble's perturbed members from their reference, and a Lyapunov fit.

Input: an `EnsembleStore` and its per-member arrays. Output: one `Divergence` curve (with its
`LyapunovFit`) per sweep point, and the labels of sweep points.

Input: an `EnsembleStore` (and optionally the `EnsembleResult` of the run, for timings).
Output: `Divergence` curves and `LyapunovFit`s per sweep point, ``members.csv`` (one row per
member), ``summary.md`` (settings, statistics, sweep table, fits, failures, figures) and, via
`figures`, the PNGs.

Divergence of member m from its reference (replica 0 of the same sweep point), at each stored
sample: d_m(t) = max_i |q_i^m(t) - q_i^ref(t)|. The ensemble's curve is the mean over the
perturbed members of ln d_m(t) (a geometric mean; samples where d_m = 0 or either member
has no sample are left out).

Lyapunov fit: a least-squares line through that mean log divergence against t, over the
exponential-growth window, chosen from the curve itself: it starts at the first sample one
decade above the first positive divergence (past the transient in which the perturbation turns
into the growing direction) and ends at the first sample two decades below the largest
divergence reached (before saturation: q_i are unit vectors, so d <= 2). No fit is made when
the divergence grows by less than three decades in all or the window holds fewer than
`FIT_MIN_SAMPLES` samples; the report then says why.

Example:
    >>> t = np.linspace(0, 10, 101)
    >>> fit = fit_lyapunov(t, np.log(1e-12 * np.exp(2.0 * t)).clip(max=0.0))
    >>> round(fit.rate, 6), fit.samples > 50
    (2.0, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .store import NOT_WRITTEN, EnsembleStore

__all__ = [
    "CURVES",
    "FIT_MIN_SAMPLES",
    "Divergence",
    "LyapunovFit",
    "divergence",
    "fit_lyapunov",
    "param_names",
    "point_label",
    "swept_names",
]

#: Member divergence curves kept per sweep point for the figure (the mean uses all of them).
CURVES = 64
#: Fewest samples in the growth window for a Lyapunov fit.
FIT_MIN_SAMPLES = 5
_LN10 = math.log(10.0)


@dataclass(frozen=True)
class LyapunovFit:
    """A fitted exponent (1 / time unit) over [t_start, t_end], or `rate` None and `reason`."""

    rate: float | None
    intercept: float
    t_start: float
    t_end: float
    samples: int
    reason: str = ""


@dataclass(frozen=True)
class Divergence:
    """Divergence from the reference of one sweep point's perturbed members over time."""

    point: int
    t: np.ndarray
    log_mean: np.ndarray
    low: np.ndarray
    high: np.ndarray
    curves: np.ndarray
    members: int
    fit: LyapunovFit


def fit_lyapunov(t: np.ndarray, log_d: np.ndarray) -> LyapunovFit:
    """Least-squares exponent of a mean log divergence over its growth window (module doc)."""
    ok = np.isfinite(log_d) & (t > 0)
    if ok.sum() < FIT_MIN_SAMPLES:
        return LyapunovFit(None, math.nan, math.nan, math.nan, 0, "too few samples")
    idx = np.flatnonzero(ok)
    first, top = log_d[idx[0]], float(np.max(log_d[idx]))
    if top - first < 3 * _LN10:
        return LyapunovFit(
            None, math.nan, math.nan, math.nan, 0, "divergence grew by less than 3 decades"
        )
    start = idx[np.argmax(log_d[idx] >= first + _LN10)]
    after = idx[idx >= start]
    end = after[np.argmax(log_d[after] >= top - 2 * _LN10)]
    window = idx[(idx >= start) & (idx <= end)]
    if len(window) < FIT_MIN_SAMPLES:
        return LyapunovFit(
            None, math.nan, math.nan, math.nan, len(window), "growth window too short"
        )
    slope, intercept = np.polyfit(t[window], log_d[window], 1)
    return LyapunovFit(float(slope), float(intercept), float(t[start]), float(t[end]), len(window))


def divergence(store: EnsembleStore, point: int, per: dict[str, np.ndarray]) -> Divergence | None:
    """The divergence of sweep point `point` (None without a written reference and at least
    one perturbed member). Reads a chunk of members at a time."""
    mine = per["point"] == point
    written = per["status"] != NOT_WRITTEN
    refs = np.flatnonzero(mine & written & (per["replica"] == 0))
    others = np.flatnonzero(mine & written & (per["replica"] > 0))
    if len(refs) == 0 or len(others) == 0:
        return None
    ref = store.member(int(refs[0]), ("t", "q"))
    q_ref = ref["q"]
    total = np.zeros(q_ref.shape[0])
    count = np.zeros(q_ref.shape[0])
    low = np.full(q_ref.shape[0], np.inf)
    high = np.full(q_ref.shape[0], -np.inf)
    curves: list[np.ndarray] = []
    for _, stored in store.members(others, ("q",)):
        q = stored["q"]
        d = np.linalg.norm(q - q_ref, axis=2).max(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            ld = np.where(d > 0, np.log(d), np.nan)
        ok = np.isfinite(ld)
        total[ok] += ld[ok]
        count[ok] += 1
        low[ok] = np.minimum(low[ok], d[ok])
        high[ok] = np.maximum(high[ok], d[ok])
        if len(curves) < CURVES:
            curves.append(d)
    with np.errstate(invalid="ignore"):
        log_mean = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    low[count == 0] = np.nan
    high[count == 0] = np.nan
    t = ref["t"]
    return Divergence(
        point, t, log_mean, low, high, np.array(curves), len(others), fit_lyapunov(t, log_mean)
    )


# -------------------------------------------------------------------------------------- labels
def swept_names(per: dict[str, np.ndarray]) -> list[str]:
    """The per-member arrays that vary over sweep points: param_NAME, and h if swept."""
    names = sorted(k for k in per if k.startswith("param_"))
    return names + (["h"] if len(np.unique(per["h"])) > 1 else [])


def point_label(per: dict[str, np.ndarray], point: int, sep: str = ", ") -> str:
    """The swept values of a sweep point, e.g. ``gamma = 17.7`` ("" without sweeps)."""
    i = int(np.flatnonzero(per["point"] == point)[0])
    return sep.join(f"{n.removeprefix('param_')} = {per[n][i]:.4g}" for n in swept_names(per))


def param_names(per: dict[str, np.ndarray]) -> list[str]:
    """The swept parameters' per-member arrays, param_NAME (sorted)."""
    return sorted(k for k in per if k.startswith("param_"))
