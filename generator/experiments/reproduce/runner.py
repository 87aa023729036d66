"""Reproduce the paper's numerical examples: run them, compare with the printed values, report.

Input: example names from `paper.EXAMPLES` (all by default), an output folder, the quick switch
and a backend. Output: ``results.csv`` (one row per example, method and step), ``results.md``
(the same table beside the paper's values, with definitions and notes) and the PNG figures of
`figures.py`, all in the output folder; one progress line per run as it starts and finishes,
and every few seconds on long runs (read from the running C, which is one call either way).

A failing run (integration error, missing system) is reported on one line and recorded in the
tables; the other runs go on and every file is still written.

Example:
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:  # doctest: +SKIP
    ...     report = reproduce(["double_pendulum"], d, quick=True)
    ...     report.ok
    True
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import s2gen
from s2gen import IntegrationError, Options, System, Trajectory, metrics, simulate
from s2gen.inspect import get_backend

from .paper import EXAMPLES, Example, PaperRun
from .records import ExampleResult, Report, RunResult

__all__ = [
    "CSV_COLUMNS",
    "METRICS",
    "ExampleResult",
    "Report",
    "RunResult",
    "integrate",
    "reproduce",
    "select_examples",
    "write_csv",
    "write_markdown",
]

#: Metric keys of `metrics.summary`, in report order.
METRICS = ("mean_dE", "max_dE", "mean_dot", "mean_norm", "max_dot", "max_norm")


def _printed_metrics() -> tuple[str, ...]:
    """Metrics that get paper/ratio columns: mean_dE, mean_dot and any other the paper prints."""
    keys = {"mean_dE", "mean_dot"} | {k for e in EXAMPLES.values() for r in e.runs for k in r.paper}
    return tuple(m for m in METRICS if m in keys)


#: Metrics the paper prints (a `PaperRun.paper` key), which get paper and ratio columns.
PAPER_METRICS = _printed_metrics()

#: results.csv columns, in order.
CSV_COLUMNS = (
    "example",
    "method",
    "h",
    "T",
    "rtol",
    "atol",
    "steps",
    "rejected",
    *METRICS,
    "wall_s",
    *(f"{kind}_{m}" for m in PAPER_METRICS for kind in ("paper", "ratio")),
    "status",
)

#: What each column means (results.md prints this list).
COLUMN_DEFINITIONS = {
    "method": "vi: variational integrator; rk45: Dormand-Prince 5(4), variable step; "
    "rk2: 2nd-order fixed-step Runge-Kutta; rk2-proj: rk2 with q_i normalized after each step",
    "h": "step size (rk45: spacing of the output samples, the steps themselves are adaptive)",
    "T": "final time",
    "steps": "integrator steps taken (rk45: accepted steps; rejected ones in `rejected`)",
    "mean_dE / max_dE": "mean / max over all samples t_k = k h (t = 0 included) of |E_k - E_0|, "
    "in the paper's energy units (our energy divided by the example's energy unit)",
    "mean_dot / max_dot": "mean / max over samples and bodies of |q_i . q_i - 1|: the paper's "
    "unit-length error",
    "mean_norm / max_norm": "mean / max over samples and bodies of | |q_i| - 1 |: the geometric "
    "unit-length error (about half of the above)",
    "wall_s": "integration wall time in seconds (emitted code only; no compile, no I/O)",
    "paper_X / ratio_X": "the value the paper prints for metric X, and ours / paper's",
    "status": "ok, or why the run failed (metrics then cover the samples computed before)",
}

_DAGGER_NOTE = (
    "- ΔE = |E − E0|; † marks a value the paper prints for the full-length run of the same "
    "method and step (not comparable with a quick run, so no ratio)."
)

Log = Callable[[str], None]

#: At most one progress line this many seconds on long runs.
PROGRESS_SECONDS = 3.0
#: Methods with a variable step; every other method takes steps of exactly h.
ADAPTIVE = ("rk45",)


def _print(line: str) -> None:
    print(line, flush=True)


# ------------------------------------------------------------------------------------ selection
def select_examples(names: Sequence[str] = ()) -> list[Example]:
    """The examples to run, in registry order (all when `names` is empty).

    Example:
        >>> [e.name for e in select_examples(["double_pendulum"])]
        ['double_pendulum']
    """
    unknown = [n for n in names if n not in EXAMPLES]
    if unknown:
        raise ValueError(
            f"unknown example(s) {', '.join(unknown)}; choose from {', '.join(EXAMPLES)}"
        )
    return [e for name, e in EXAMPLES.items() if not names or name in names]


def _paper_values(example: Example, run: PaperRun, quick: bool) -> tuple[dict[str, float], bool]:
    """The paper's values for a run and whether they compare (same run as the paper's)."""
    if run.paper:
        return dict(run.paper), True
    if quick:
        for full in example.runs:
            if full.method == run.method and math.isclose(full.h, run.h) and full.paper:
                return dict(full.paper), False
    return {}, False


# ---------------------------------------------------------------------------------- integration
def integrate(system: System, run: PaperRun, backend: str = "c", log: Log = _print) -> Trajectory:
    """Integrate one run in one call, with a progress line every `PROGRESS_SECONDS` on long
    runs (the emitted C reports how far it has come while it runs; the result does not
    depend on it). A failure raises `IntegrationError` with the valid samples in `.partial`.

    Example:
        >>> import s2gen
        >>> tr = integrate(s2gen.load("double_pendulum"), PaperRun("vi", 0.01, 1.0), log=print)
        >>> tr.q.shape
        (101, 2, 3)
    """
    opts = Options(rtol=run.rtol, atol=run.atol, control=run.control)
    start = time.perf_counter()
    last = [start]

    def progress(fraction: float) -> None:
        now = time.perf_counter()
        if fraction < 1.0 and now - last[0] >= PROGRESS_SECONDS:
            last[0] = now
            log(
                f"    ... {run.method} h={run.h:g}: t = {fraction * run.T:.6g} / {run.T:g} "
                f"({100 * fraction:.0f} %), {now - start:.1f} s"
            )

    return simulate(system, run.method, backend, h=run.h, T=run.T, options=opts, progress=progress)


def _measure(result: RunResult, tr: Trajectory, energy_unit: float) -> None:
    """Fill a result's metrics (paper units), step counts and wall time from a trajectory."""
    result.trajectory = tr
    result.wall_time = tr.wall_time
    fixed = result.run.method not in ADAPTIVE
    result.steps = len(tr.t) - 1 if fixed else int(tr.stats.get("steps", 0))
    result.rejected = int(tr.stats.get("rejected", 0))
    if len(tr.t) == 0:
        return
    m = metrics.summary(tr.q, tr.energy)
    m["mean_dE"] /= energy_unit
    m["max_dE"] /= energy_unit
    result.metrics = m


def run_one(
    example: Example,
    system: System,
    run: PaperRun,
    quick: bool,
    backend: str = "c",
    log: Log = _print,
) -> RunResult:
    """Run one `PaperRun` of an example, log its start and end, and measure it."""
    paper, comparable = _paper_values(example, run, quick)
    result = RunResult(example.name, run, paper=paper, comparable=comparable)
    nsteps = round(run.T / run.h)
    what = f"{nsteps} steps" if run.method not in ADAPTIVE else f"{nsteps} output samples"
    log(f"{result.label}: start ({what})")
    try:
        tr = integrate(system, run, backend, log)
    except IntegrationError as exc:
        result.error = str(exc)
        _measure(result, exc.partial, example.energy_unit)
        log(f"{result.label}: FAILED: {exc}")
        return result
    _measure(result, tr, example.energy_unit)
    log(f"{result.label}: done, {_finish_line(result)}")
    return result


def _finish_line(r: RunResult) -> str:
    """`N steps in X s, mean |E-E0| = ... (paper ..., ratio ...)`."""
    line = f"{r.steps} steps in {r.wall_time:.3f} s, mean |E-E0| = {r.metrics['mean_dE']:.4e}"
    ratio = r.ratio("mean_dE")
    if ratio is not None:
        line += f" (paper {r.paper['mean_dE']:.4e}, ratio {ratio:.4f})"
    return line + f", mean |q.q-1| = {r.metrics['mean_dot']:.3e}"


def run_example(
    example: Example, quick: bool = False, backend: str = "c", log: Log = _print
) -> ExampleResult:
    """Build an example's system and its backend, then run each of its (quick) runs."""
    result = ExampleResult(example, quick)
    runs = example.quick if quick and example.quick else example.runs
    try:
        start = time.perf_counter()
        result.system = s2gen.load(example.system)
        get_backend(result.system, backend)
        log(f"[{example.name}] system {example.system} (n = {result.system.n}) ready on "
            f"{backend} in {time.perf_counter() - start:.2f} s")  # fmt: skip
    except Exception as exc:  # noqa: BLE001 (a broken system must not stop the other examples)
        result.error = f"[{example.name}] cannot build system {example.system!r}: {exc}"
        log(f"error: {result.error}")
        return result
    for run in runs:
        try:
            result.runs.append(run_one(example, result.system, run, quick, backend, log))
        except Exception as exc:  # noqa: BLE001 (e.g. a bad run definition: record it, go on)
            failed = RunResult(example.name, run, error=f"{type(exc).__name__}: {exc}")
            log(f"error: {failed.label}: {failed.error}")
            result.runs.append(failed)
    return result


# ----------------------------------------------------------------------------------- reporting
def _fmt(x: float | None, spec: str = ".4e") -> str:
    return "" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def _csv_row(r: RunResult) -> dict[str, str]:
    row = {
        "example": r.example,
        "method": r.run.method,
        "h": f"{r.run.h:g}",
        "T": f"{r.run.T:g}",
        "rtol": f"{r.run.rtol:g}" if r.run.method == "rk45" else "",
        "atol": f"{r.run.atol:g}" if r.run.method == "rk45" else "",
        "steps": str(r.steps),
        "rejected": str(r.rejected),
        "wall_s": _fmt(r.wall_time, ".4f"),
        "status": "ok" if r.error is None else f"failed: {r.error}",
    }
    row.update({m: _fmt(r.metrics.get(m), ".6e") for m in METRICS})
    for m in PAPER_METRICS:
        row[f"paper_{m}"] = _fmt(r.paper.get(m) if r.comparable else None, ".6e")
        row[f"ratio_{m}"] = _fmt(r.ratio(m), ".6f")
    return row


def write_csv(results: Sequence[ExampleResult], path: str | Path) -> Path:
    """Write results.csv: one row per (example, method, h), columns `CSV_COLUMNS`.

    Example:
        >>> write_csv([], "/tmp/empty.csv").read_text().split(",")[:3]
        ['example', 'method', 'h']
    """
    path = Path(path)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CSV_COLUMNS, lineterminator="\n")
        writer.writeheader()
        for ex in results:
            for r in ex.runs:
                writer.writerow(_csv_row(r))
    return path


def _paper_cell(r: RunResult, metric: str) -> tuple[str, str]:
    """(paper value, ratio) cells; a quick run shows the full run's value marked with †."""
    ref = r.paper.get(metric)
    if ref is None:
        return "", ""
    ratio = r.ratio(metric)
    return (f"{ref:.4e}" if r.comparable else f"{ref:.4e} †"), _fmt(ratio, ".4f")


_MD_HEAD = (
    "| method | h | T | steps | mean ΔE | paper | ratio | max ΔE | mean \\|q·q−1\\| | paper "
    "| ratio | mean \\|‖q‖−1\\| | max \\|q·q−1\\| | wall (s) | status |"
)


def _md_row(r: RunResult) -> str:
    m = r.metrics
    pe, re_ = _paper_cell(r, "mean_dE")
    pd, rd = _paper_cell(r, "mean_dot")
    steps = f"{r.steps}" + (f" (+{r.rejected} rej.)" if r.rejected else "")
    cells = [
        r.run.method,
        f"{r.run.h:g}",
        f"{r.run.T:g}",
        steps,
        _fmt(m.get("mean_dE")),
        pe,
        re_,
        _fmt(m.get("max_dE")),
        _fmt(m.get("mean_dot")),
        pd,
        rd,
        _fmt(m.get("mean_norm")),
        _fmt(m.get("max_dot")),
        _fmt(r.wall_time, ".3f"),
        "ok" if r.error is None else "**failed**",
    ]
    return "| " + " | ".join(cells) + " |"


def _md_example(ex: ExampleResult, out: Path) -> list[str]:
    e = ex.example
    lines = [f"## {e.title}: `{e.name}`", ""]
    unit = "" if e.energy_unit == 1.0 else f" Energies are divided by {e.energy_unit:g}."
    lines += [f"System `{e.system}`.{unit}", ""]
    if ex.error:
        return lines + [f"**Error:** {ex.error}", ""]
    lines += [_MD_HEAD, "|" + "---|" * _MD_HEAD.count(" | ") + "---|"]
    lines += [_md_row(r) for r in ex.runs]
    lines += [""] + [f"- **{r.label}** failed: {r.error}" for r in ex.runs if r.error]
    lines += _md_printed(e, ex.runs)
    if e.notes:
        lines += [f"Notes: {e.notes}", ""]
    lines += [f"![{p.stem}]({p.relative_to(out)})" for p in ex.figures] + [""]
    return lines


def _md_printed(e: Example, results: Sequence[RunResult]) -> list[str]:
    """The paper's printed values of every full run, with ours and the ratio when we ran it."""
    ours = {(r.run.method, r.run.h, r.run.T): r for r in results if r.comparable}
    items = []
    for run in e.runs:
        got = ours.get((run.method, run.h, run.T))
        vals = []
        for k, v in run.paper.items():
            ratio = got.ratio(k) if got else None
            ours_text = f" (ours {got.metrics[k]:.4e}, ratio {ratio:.4f})" if got and ratio else ""
            vals.append(f"{k} = {v:.4e}{ours_text}")
        if vals:
            items.append(f"- {run.method}, h = {run.h:g}, T = {run.T:g}: {'; '.join(vals)}")
    return ["The paper's printed values (full runs):", "", *items, ""] if items else []


def write_markdown(
    results: Sequence[ExampleResult], path: str | Path, quick: bool, bands: Sequence[str] = ()
) -> Path:
    """Write results.md: definitions, then per example the table, printed values, notes, figures.

    Example:
        >>> "Definitions" in write_markdown([], "/tmp/empty.md", quick=True).read_text()
        True
    """
    path = Path(path)
    kind = "quick runs (shortened horizons; the paper's values are shown for orientation)"
    command = f"`s2gen reproduce{' --quick' if quick else ''}`"
    lines = [
        "# Reproduction of the paper's numerical examples",
        "",
        f"Runs: {kind if quick else 'the paper’s full runs'}. Produced by {command}.",
        "",
        "## Definitions",
        "",
        *(f"- `{k}`: {v}" for k, v in COLUMN_DEFINITIONS.items()),
        _DAGGER_NOTE,
        "",
    ]
    for ex in results:
        lines += _md_example(ex, path.parent)
    lines += bands
    path.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    return path


# ---------------------------------------------------------------------------------------- main
def reproduce(
    names: Sequence[str] = (),
    out: str | Path = "out/reproduce",
    quick: bool = False,
    backend: str = "c",
    log: Log = _print,
    figures: bool = True,
    bands: int = 0,
) -> Report:
    """Run the selected examples, write results.csv, results.md and the figures into `out`;
    with `bands` > 0 (full runs, the rod selected), also the rod's chaos bands: each of its
    runs as an ensemble of `bands` members perturbed by 1e-13 (`band`, on `s2gen.ensemble`,
    on a local Dask cluster), in results.md and under out/chaos_band.

    The tables are rewritten after each example, so an interrupted run keeps what it did.
    """
    from . import figures as plots

    report = Report(Path(out))
    report.out.mkdir(parents=True, exist_ok=True)
    for example in select_examples(names):
        ex = run_example(example, quick, backend, log)
        report.examples.append(ex)
        if figures and ex.system is not None and any(r.trajectory for r in ex.runs):
            try:
                ex.figures = plots.example_figures(ex, report.out)
                log(f"[{example.name}] figures: {', '.join(p.name for p in ex.figures)}")
            except Exception as exc:  # noqa: BLE001 (a figure must not lose the numbers)
                msg = f"[{example.name}] figures failed: {type(exc).__name__}: {exc}"
                report.errors.append(msg)
                log(f"error: {msg}")
        _write_tables(report, quick)
    if bands and not quick and any(e.name == "elastic_rod" for e in select_examples(names)):
        _chaos_bands(report, bands, log)
    _write_tables(report, quick)
    return report


def _chaos_bands(report: Report, members: int, log: Log) -> None:
    """The rod's runs as ensembles of perturbed members: their band of mean |E - E0|."""
    from .band import band_markdown, chaos_band

    try:
        found = chaos_band(
            "elastic_rod", members=members, out=report.out / "chaos_band", overwrite=True, log=log
        )
    except Exception as exc:  # noqa: BLE001 (the bands must not lose the tables)
        report.errors.append(f"[elastic_rod] chaos bands failed: {type(exc).__name__}: {exc}")
        return
    inside = all(b.contains_paper() is not False for b in found)
    report.bands = [
        f"## The rod's chaos bands ({members} perturbed members per run)",
        "",
        (
            "Mean |E − E0| of each of the rod's runs, integrated again from initial states "
            "perturbed by 1e-13 (relative, in q and ω; `s2gen ensemble elastic_rod "
            "--chaos-band`): the motion is chaotic over 3 s, so the band, not one trajectory's "
            f"figure, is what can be reproduced. The paper's figures "
            f"{'lie' if inside else 'do not all lie'} inside the bands."
        ),
        "",
        band_markdown(found),
    ]


def _write_tables(report: Report, quick: bool) -> None:
    csv_path = write_csv(report.examples, report.out / "results.csv")
    md_path = write_markdown(report.examples, report.out / "results.md", quick, report.bands)
    figs = [p for ex in report.examples for p in ex.figures]
    bands = sorted((report.out / "chaos_band").glob("band.*")) if report.bands else []
    report.files = [csv_path, md_path, *figs, *bands]
