"""A paper example's chaos band: its printed runs as ensembles of perturbed initial states.

Input: the name of an example of `s2gen reproduce` (default ``elastic_rod``), the number of
perturbed members (default 64), the relative perturbation (default 1e-13 on both q and omega)
and where to run (as `ensemble`). Output: one `Band` per full run of the example (for the rod:
VI at h = 1e-4 and RK45 with MATLAB ode45's control and default tolerances, output spacing
1e-4, T = 3): the min, median and max over the perturbed members of mean |E - E0| in the
paper's energy units (the example's `energy_unit`), the unperturbed member's value and the
paper's printed one; ``band.md``, ``band.csv`` and ``band.png`` in the output folder, and each run's store
and summary (divergence, Lyapunov exponent, figures) under ``<method>_h<h>/``.

The statistics come from the workers, over every sample of each member; the stores keep every
k-th sample (about `STORED_SAMPLES` per member) for the divergence figure.

Example:
    >>> bands = chaos_band("elastic_rod", members=64, workers=2)  # doctest: +SKIP
    >>> [(b.method, f"{b.median:.2e}") for b in bands]  # doctest: +SKIP
    [('vi', '1.6e-06'), ('rk45', '3.9e-04')]
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import s2gen
from s2gen.ensemble import (
    CONNECT_TIMEOUT,
    DEFAULT_OUT,
    EnsembleError,
    EnsembleStore,
    Progress,
    ProgressBar,
    connect,
    ensemble,
    summarize,
)

from .paper import EXAMPLES

__all__ = [
    "DEFAULT_MEMBERS",
    "DEFAULT_PERTURB",
    "STORED_SAMPLES",
    "Band",
    "band_figure",
    "band_markdown",
    "chaos_band",
    "paper_example",
    "run_band",
    "write_band",
]

#: Perturbed members per run.
DEFAULT_MEMBERS = 64
#: Relative perturbation of the initial state.
DEFAULT_PERTURB: Mapping[str, float] = {"q": 1e-13, "omega": 1e-13}
#: Samples stored per member (every k-th of the run's grid).
STORED_SAMPLES = 300


@dataclass(frozen=True)
class Band:
    """One run's band: mean |E - E0| (paper units) over the perturbed members."""

    example: str
    method: str
    h: float
    T: float
    rtol: float
    atol: float
    control: str
    members: int
    failed: int
    minimum: float
    median: float
    maximum: float
    reference: float
    paper: float | None
    seconds: float
    store: Path
    #: each perturbed member's mean |E - E0| (paper units), for the band figure
    values: tuple[float, ...] = ()

    def contains_paper(self) -> bool | None:
        """Whether the paper's printed value lies in [minimum, maximum] (None if not printed)."""
        if self.paper is None:
            return None
        return self.minimum <= self.paper <= self.maximum


def paper_example(name: str) -> Any:
    """The `s2gen reproduce` example `name` (an `EnsembleError` if there is none).

    Example:
        >>> [run.method for run in paper_example("elastic_rod").runs]
        ['vi', 'rk45']
    """
    if name not in EXAMPLES:
        raise EnsembleError(
            f"--chaos-band needs a paper example, not {name!r}; choose from {', '.join(EXAMPLES)}"
        )
    return EXAMPLES[name]


def stride(steps: int, samples: int) -> int:
    """The largest stride that divides `steps` and keeps at least `samples` + 1 samples (the
    last sample is then stored, as `s2gen.runtime.check_run` requires).

    Example:
        >>> stride(10000, 300), stride(100, 300)
        (25, 1)
    """
    return next(k for k in range(max(1, steps // samples), 0, -1) if steps % k == 0)


def chaos_band(
    example: str = "elastic_rod",
    members: int = DEFAULT_MEMBERS,
    perturb: Mapping[str, float] | None = None,
    client: Any = None,
    workers: int | None = None,
    out: str | Path = "out/chaos_band",
    *,
    seed: int = 0,
    progress: Progress | None = None,
    timeout: float = CONNECT_TIMEOUT,
    overwrite: bool = False,
    figures: bool = True,
    log: Any = print,
) -> tuple[Band, ...]:
    """Run each full run of `example` as an ensemble of `members` perturbed members (plus the
    unperturbed reference) and write band.md and band.csv into `out`, and each run's summary
    (with its divergence and Lyapunov fit) beside its store."""
    ex = paper_example(example)
    if members < 1:
        raise EnsembleError(f"members must be at least 1 (got {members})")
    system = s2gen.load(ex.system)
    folder = Path(out)
    bands = []
    address = client if isinstance(client, str) else None
    given = None if isinstance(client, str) else client
    with connect(given, address, workers, timeout) as c:
        for run in ex.runs:
            steps = round(run.T / run.h)
            log(f"{example}: {run.method}, h = {run.h:g}, T = {run.T:g}, {members} members ...")
            start = time.perf_counter()
            result = ensemble(
                system,
                members=members + 1,
                perturb=dict(perturb or DEFAULT_PERTURB),
                method=run.method,
                h=run.h,
                T=run.T,
                every=stride(steps, STORED_SAMPLES),
                client=c,
                workers=0 if c is None else None,
                out=folder / f"{run.method}_h{run.h:g}",
                seed=seed,
                options=s2gen.Options(rtol=run.rtol, atol=run.atol, control=run.control),
                progress=progress,
                overwrite=overwrite,
                command=f"chaos band of {example}",
            )
            seconds = time.perf_counter() - start
            summarize(EnsembleStore.open(result.path), result.path.parent, result, figures)
            band = _band(ex, run, result.path, seconds)
            log(f"  {_line(band)}")
            bands.append(band)
    write_band(tuple(bands), folder)
    return tuple(bands)


def _band(ex: Any, run: Any, path: Path, seconds: float) -> Band:
    per = EnsembleStore.open(path).per_member()
    unit = float(ex.energy_unit)
    perturbed = per["replica"] > 0
    ok = perturbed & (per["status"] == 0)
    values = per["mean_dE"][ok] / unit
    ref = per["mean_dE"][(per["replica"] == 0)] / unit
    lo, med, hi = (
        (float(values.min()), float(np.median(values)), float(values.max()))
        if len(values)
        else (math.nan,) * 3
    )
    return Band(
        example=ex.name,
        method=run.method,
        h=run.h,
        T=run.T,
        rtol=run.rtol,
        atol=run.atol,
        control=run.control,
        members=int(ok.sum()),
        failed=int((perturbed & (per["status"] != 0)).sum()),
        minimum=lo,
        median=med,
        maximum=hi,
        reference=float(ref[0]) if len(ref) else math.nan,
        paper=run.paper.get("mean_dE"),
        seconds=seconds,
        store=path,
        values=tuple(float(v) for v in values),
    )


def _line(b: Band) -> str:
    paper = f", paper {b.paper:.4e}" if b.paper is not None else ""
    return (
        f"{b.method}: mean |E-E0| min {b.minimum:.4e}, median {b.median:.4e}, max "
        f"{b.maximum:.4e} over {b.members} members (unperturbed {b.reference:.4e}{paper}), "
        f"{b.seconds:.1f} s"
    )


def band_markdown(bands: tuple[Band, ...]) -> str:
    """The bands as a Markdown table."""
    lines = [
        (
            "| example | method | h | T | members | min | median | max | unperturbed | paper "
            "| paper in band |"
        ),
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for b in bands:
        inside = {None: "", True: "yes", False: "no"}[b.contains_paper()]
        method = b.method if b.method != "rk45" else f"rk45 (rtol {b.rtol:g}, {b.control})"
        paper = f"{b.paper:.4e}" if b.paper is not None else ""
        lines.append(
            f"| {b.example} | {method} | {b.h:g} | {b.T:g} | {b.members} | {b.minimum:.4e} "
            f"| {b.median:.4e} | {b.maximum:.4e} | {b.reference:.4e} | {paper} | {inside} |"
        )
    return "\n".join(lines) + "\n"


def band_figure(bands: tuple[Band, ...], path: Path) -> Path:
    """band.png: one row per run, every perturbed member's mean |E - E0| on a log axis, the
    band's min, median and max, the unperturbed member and the paper's printed value."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(bands), 1, figsize=(7.5, 1.2 + 1.3 * len(bands)), squeeze=False)
    rng = np.random.default_rng(0)  # vertical jitter only, so the dots do not hide each other
    for ax, b in zip(axes[:, 0], bands, strict=True):
        v = np.asarray(b.values)
        ax.scatter(
            v,
            rng.uniform(-0.25, 0.25, v.size),
            s=12,
            color="tab:blue",
            alpha=0.7,
            label=f"{b.members} perturbed members",
        )
        for x, style in ((b.minimum, ":"), (b.median, "-"), (b.maximum, ":")):
            ax.axvline(x, color="tab:blue", linestyle=style, linewidth=1)
        ax.plot([b.reference], [0], "D", color="black", label="unperturbed")
        if b.paper is not None:
            ax.axvline(b.paper, color="tab:red", linewidth=2, label="paper")
        ax.set_xscale("log")
        ax.set_yticks([])
        ax.set_ylim(-0.45, 0.9)  # the legend above the members
        name = b.method if b.method != "rk45" else f"rk45 (rtol {b.rtol:g})"
        ax.set_title(f"{b.example}: {name}, h = {b.h:g}, T = {b.T:g}", fontsize=10)
        ax.legend(loc="upper left", fontsize=7, ncol=3, frameon=False)
    axes[-1, 0].set_xlabel("mean |E − E0| over the run (paper's units); lines: min, median, max")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_band(bands: tuple[Band, ...], out: Path) -> list[Path]:
    """band.md (the table and its definition), band.csv and band.png in `out`."""
    out.mkdir(parents=True, exist_ok=True)
    md = out / "band.md"
    md.write_text(
        "# Chaos bands\n\nMean |E − E0| over every sample (paper units), over members whose "
        "initial state was perturbed (relative size in each run's store attributes); "
        "'unperturbed' is the member with the exact initial state.\n\n" + band_markdown(bands),
        encoding="utf-8",
    )
    path = out / "band.csv"
    fields = ["example", "method", "h", "T", "rtol", "atol", "control", "members", "failed"]
    fields += ["minimum", "median", "maximum", "reference", "paper", "seconds"]
    with path.open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(fields)
        for b in bands:
            w.writerow([getattr(b, k) if getattr(b, k) is not None else "" for k in fields])
    paths = [md, path]
    if any(b.values for b in bands):
        paths.append(band_figure(bands, out / "band.png"))
    return paths


def run_band(args: argparse.Namespace, perturb: dict[str, float]) -> int:
    """Carry out `s2gen ensemble SPEC --chaos-band` (arguments checked by the ensemble
    command, which the command line gives this runner): the bands of example SPEC with a
    progress bar, their table on stdout; exit code 1 if a band has no finite median."""
    members = args.members or DEFAULT_MEMBERS
    out = args.out if args.out != DEFAULT_OUT else "out/chaos_band"
    runs = len(paper_example(args.spec).runs)
    bar = ProgressBar(runs * (members + 1), f"{args.spec} bands")
    try:
        bands = chaos_band(
            args.spec,
            members=members,
            perturb=perturb or None,
            client=args.scheduler,
            workers=args.workers,
            out=out,
            seed=args.seed,
            progress=bar,
            timeout=args.timeout,
            overwrite=args.overwrite,
            figures=not args.no_figures,
            log=bar.write,
        )
    finally:
        bar.close()
    print(band_markdown(bands), end="")
    print(f"  {out}/band.md, {out}/band.csv, {out}/band.png")
    return 0 if all(math.isfinite(b.median) for b in bands) else 1
