"""Summaries of an ensemble store: tables and the report.

Input: an `EnsembleStore` (and optionally the `EnsembleResult` of the run, for timings).
Output: ``members.csv`` (one row per member), ``summary.md`` (settings, statistics, sweep
table, the `divergence` curves' Lyapunov fits, failures, figures) and, via `figures`, the PNGs.

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

from .divergence import (
    Divergence,
    LyapunovFit,
    divergence,
    fit_lyapunov,
    param_names,
    point_label,
    swept_names,
)
from .figures import write_figures
from .store import NOT_WRITTEN, STATISTICS, EnsembleStore

if TYPE_CHECKING:
    from .dispatch import EnsembleResult

__all__ = ["Summary", "fit_lyapunov", "summarize", "write_members_csv"]


@dataclass(frozen=True)
class Summary:
    """The files written and the numbers behind them."""

    files: tuple[Path, ...]
    divergences: tuple[Divergence, ...]
    markdown: str


def write_members_csv(per: dict[str, np.ndarray], path: Path) -> Path:
    """members.csv: one row per member, coordinates then statistics."""
    coords = ["member", "point", "replica", *param_names(per), "h", "perturb_q", "perturb_omega"]
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
    lines = [f"{int(written.sum())} of {len(status)} members written: {outcome or 'none'}.", ""]
    if written.any() and not (status[written] == 0).any():
        note = (
            "**No member reached T**: every written member failed (see Failed members); the "
            "figures show what the failed members kept."
        )
        lines += [note, ""]
    lines += [
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
        params = ", ".join(f"{n.removeprefix('param_')} = {per[n][i]:g}" for n in param_names(per))
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
