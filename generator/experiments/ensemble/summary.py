"""Summaries of an ensemble store: divergence and a Lyapunov fit, tables, the report.

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

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .store import NOT_WRITTEN, STATISTICS, EnsembleStore

if TYPE_CHECKING:
    from .dispatch import EnsembleResult

__all__ = [
    "CURVES",
    "FIT_MIN_SAMPLES",
    "Divergence",
    "LyapunovFit",
    "Summary",
    "divergence",
    "fit_lyapunov",
    "summarize",
    "write_members_csv",
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


@dataclass(frozen=True)
class Summary:
    """The files written and the numbers behind them."""

    files: tuple[Path, ...]
    divergences: tuple[Divergence, ...]
    markdown: str


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
    one perturbed member). Reads one member at a time."""
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
    for m in others:
        q = store.member(int(m), ("q",))["q"]
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


# -------------------------------------------------------------------------------------- tables
def swept_names(per: dict[str, np.ndarray]) -> list[str]:
    """The per-member arrays that vary over sweep points: param_NAME, and h if swept."""
    names = sorted(k for k in per if k.startswith("param_"))
    return names + (["h"] if len(np.unique(per["h"])) > 1 else [])


def point_label(per: dict[str, np.ndarray], point: int, sep: str = ", ") -> str:
    """The swept values of a sweep point, e.g. ``gamma = 17.7`` ("" without sweeps)."""
    i = int(np.flatnonzero(per["point"] == point)[0])
    return sep.join(f"{n.removeprefix('param_')} = {per[n][i]:.4g}" for n in swept_names(per))


def _param_names(per: dict[str, np.ndarray]) -> list[str]:
    return sorted(k for k in per if k.startswith("param_"))


def write_members_csv(per: dict[str, np.ndarray], path: Path) -> Path:
    """members.csv: one row per member, coordinates then statistics."""
    coords = ["member", "point", "replica", *_param_names(per), "h", "perturb_q", "perturb_omega"]
    columns = coords + [c for c in STATISTICS if c != "setup_time"]
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow([c.removeprefix("param_") if c.startswith("param_") else c for c in columns])
        for i in range(len(per["member"])):
            w.writerow([_cell(per[c][i]) for c in columns])
    return path


def _cell(x: object) -> str:
    if isinstance(x, (float, np.floating)):
        return "" if math.isnan(float(x)) else f"{float(x):.6e}"
    return str(x)


def _fmt(x: float | None, spec: str = ".3e") -> str:
    return "–" if x is None or not math.isfinite(x) else format(x, spec)


def _band(values: np.ndarray) -> tuple[float, float, float]:
    v = values[np.isfinite(values)]
    if len(v) == 0:
        return math.nan, math.nan, math.nan
    return float(v.min()), float(np.median(v)), float(v.max())


def _settings(attrs: dict[str, Any], per: dict[str, np.ndarray]) -> list[str]:
    perturb = attrs.get("perturb") or {}
    sweeps = attrs.get("sweeps") or {}
    pert = ", ".join(f"{k} {v:g}" for k, v in perturb.items())
    swp = "; ".join(f"{k}: {len(v)} values {min(v):g} .. {max(v):g}" for k, v in sweeps.items())
    every = int(attrs["every"])
    stored = "every sample" if every == 1 else f"1 sample in {every}"
    points = len(per["member"]) // int(attrs["replicas"])
    lines = [
        (
            f"- system `{attrs['system']}` (n = {attrs['n']}), method `{attrs['method']}`, "
            f"h = {attrs['h']:g}, T = {attrs['T']:g}; {stored} stored ({attrs['samples']} per "
            "member; statistics use every sample)"
        ),
        (
            f"- {len(per['member'])} members: {attrs['replicas']} replica(s) (replica 0 the "
            f"unperturbed reference) x {points} sweep point(s)"
        ),
        f"- perturbation (relative): {pert or 'none'}; seed {attrs['seed']}",
        f"- sweeps: {swp or 'none'}",
    ]
    if attrs.get("command"):
        lines.append(f"- command: `{attrs['command']}`")
    return lines


def _statistics(per: dict[str, np.ndarray], attrs: dict[str, Any]) -> list[str]:
    status = per["status"]
    written = status != NOT_WRITTEN
    codes = attrs.get("status_codes", {})
    counts = {int(c): int((status == c).sum()) for c in np.unique(status[written])}
    outcome = ", ".join(f"{n} {codes.get(str(c), c) if c else 'ok'}" for c, n in counts.items())
    rows = [
        ("mean \\|E − E0\\|", _band(per["mean_dE"][written]), ".3e"),
        ("max \\|E − E0\\|", _band(per["max_dE"][written]), ".3e"),
        ("max \\| \\|q\\| − 1 \\|", _band(per["max_unit"][written]), ".3e"),
        ("steps", _band(per["steps"][written].astype(float)), ".0f"),
        ("integration wall time (s)", _band(per["wall_time"][written]), ".4f"),
    ]
    lines = [
        f"{int(written.sum())} of {len(status)} members written: {outcome or 'none'}.",
        "",
        "| per member | min | median | max |",
        "|---|---:|---:|---:|",
    ]
    lines += [
        f"| {name} | {_fmt(a, f)} | {_fmt(b, f)} | {_fmt(c, f)} |" for name, (a, b, c), f in rows
    ]
    return lines


def _sweep_table(per: dict[str, np.ndarray], fits: dict[int, LyapunovFit]) -> list[str]:
    names = swept_names(per)
    head = [n.removeprefix("param_") for n in names]
    lines = [
        "| " + " | ".join(head) + " | members | failed | mean \\|ΔE\\| min | median | max "
        "(members that reached T) | Lyapunov |",
        "|" + "---|" * len(head) + "---:|" * 6,
    ]
    for point in np.unique(per["point"]):
        sel = per["point"] == point
        written = sel & (per["status"] != NOT_WRITTEN)
        failed = int((sel & (per["status"] > 0)).sum())
        a, b, c = _band(per["mean_dE"][sel & (per["status"] == 0)])
        fit = fits.get(int(point))
        lyap = _fmt(fit.rate, ".3g") if fit and fit.rate is not None else "–"
        first = int(np.flatnonzero(sel)[0])
        vals = " | ".join(f"{per[n][first]:g}" for n in names)
        lines.append(
            f"| {vals} | {int(written.sum())} | {failed} | {_fmt(a)} | {_fmt(b)} | {_fmt(c)} "
            f"| {lyap} |"
        )
    return lines


def _fit_lines(divs: tuple[Divergence, ...], per: dict[str, np.ndarray]) -> list[str]:
    lines = []
    for d in divs:
        f = d.fit
        where = f"{point_label(per, d.point)}: " if len(divs) > 1 else ""
        if f.rate is None:
            lines.append(f"- {where}no fit ({f.reason}; {d.members} perturbed members)")
        else:
            lines.append(
                f"- {where}λ = {f.rate:.4g} per time unit (e-folding time {1 / f.rate:.3g}), "
                f"least squares over t = {f.t_start:.4g} .. {f.t_end:.4g} ({f.samples} samples, "
                f"{d.members} perturbed members)"
            )
    return lines


def _failures(per: dict[str, np.ndarray], attrs: dict[str, Any], limit: int = 20) -> list[str]:
    bad = np.flatnonzero((per["status"] != 0) & (per["status"] != NOT_WRITTEN))
    if len(bad) == 0:
        return []
    codes = attrs.get("status_codes", {})
    errors = attrs.get("task_errors", {})
    lines = ["## Failed members", ""]
    for i in bad[:limit]:
        why = errors.get(str(i)) if per["status"][i] == -2 else codes.get(str(per["status"][i]))
        params = ", ".join(f"{n.removeprefix('param_')} = {per[n][i]:g}" for n in _param_names(per))
        lines.append(
            f"- member {i} (replica {per['replica'][i]}{', ' + params if params else ''}, "
            f"h = {per['h'][i]:g}): {why}; {per['samples'][i]} valid samples kept"
        )
    if len(bad) > limit:
        lines.append(f"- ... and {len(bad) - limit} more (members.csv lists all)")
    return lines + [""]


def summarize(
    store: EnsembleStore,
    out: str | Path,
    result: EnsembleResult | None = None,
    figures: bool = True,
) -> Summary:
    """Write members.csv, the figures and summary.md for a store into `out`."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    per = store.per_member()
    attrs = store.attrs
    divs = tuple(
        d for p in np.unique(per["point"]) if (d := divergence(store, int(p), per)) is not None
    )
    files = [write_members_csv(per, folder / "members.csv")]
    pictures: list[Path] = []
    if figures:
        from .figures import write_figures

        pictures = write_figures(per, divs, attrs, folder)
    lines = ["# Ensemble", "", *_settings(attrs, per)]
    if result is not None:
        where = f"{result.workers} Dask worker(s)" if result.workers else "serially, one process"
        lines.append(
            f"- run: {where}; set-up {result.setup_time:.2f} s, members {result.wall_time:.2f} s "
            f"(their integrations add up to {result.integration_time:.2f} s)"
        )
    lines += ["", "## Statistics", "", *_statistics(per, attrs), ""]
    if len(np.unique(per["point"])) > 1:
        fits = {d.point: d.fit for d in divs}
        lines += ["## Sweep", "", *_sweep_table(per, fits), ""]
    if divs:
        lines += [
            "## Divergence and Lyapunov exponent",
            "",
            (
                "Divergence d(t) = max_i |q_i(t) − q_i^ref(t)| from the unperturbed member of the "
                "same sweep point; λ is the least-squares slope of the mean ln d(t) over the "
                "growth window (from one decade above the first divergence to two decades below "
                "the largest)."
            ),
            "",
            *_fit_lines(divs, per),
            "",
        ]
    lines += _failures(per, attrs)
    lines += [f"![{p.stem}]({p.name})" for p in pictures]
    text = "\n".join(lines).rstrip() + "\n"
    md = folder / "summary.md"
    md.write_text(text, encoding="utf-8")
    return Summary((md, *files, *pictures), divs, text)
