"""``bench.md``: the command, the machine, the definitions and every section that ran.

Input: a `BenchReport`. Output: the path of ``bench.md``, written into the report's folder:
per-example sections (`report_example.py`), then the stability envelope and the scaling
tables with their generated summaries.

Example:
    >>> _md_scaling([])[0]
    '## Scaling with n'
"""

from __future__ import annotations

import contextlib
import os
import platform
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .common import _fmt, _table
from .envelope import _first_failure, largest_stable
from .model import EVALS_PER_STEP, FIXED, BenchReport, ScaleRow, StabilityCase, StabRow
from .report_example import _md_example
from .sizes import DENSE_ROD, STRUCTURED_ROD

#: Published figures for n = 20 (quoted, not measured here).
PUBLISHED_N20 = (
    ("PyDy", "about 33 s to generate and compile"),
    ("CasADi", "about 28 s of gcc"),
)


def _envelope_summary(rows: Sequence[StabRow], case: StabilityCase) -> str:
    """'; widest envelope: M (h = ...); the VI's: ... (x of it)' from the measured sweeps."""
    best = {
        m: largest_stable([r for r in rows if r.case == case.label and r.method == m])
        for m in FIXED
    }
    found = {m: b for m, b in best.items() if b is not None}
    if case.skipped or not found:
        return ""
    top = max(found, key=lambda m: found[m].h)
    vi = found.get("vi")
    text = f"; widest envelope: {top} (h = {found[top].h:.3g})"
    if vi is not None and top != "vi":
        text += f", the VI's h = {vi.h:.3g} is {vi.h / found[top].h:.2f} of it"
    per_eval = max(found, key=lambda m: found[m].h / EVALS_PER_STEP[m])
    text += f"; per gradient evaluation: {per_eval} (h/evals = "
    return text + f"{found[per_eval].h / EVALS_PER_STEP[per_eval]:.3g})"


def _md_stability(rows: Sequence[StabRow], cases: Sequence[StabilityCase]) -> list[str]:
    table = []
    for case in (c for c in cases if not c.skipped):
        for m in FIXED:
            part = [r for r in rows if r.case == case.label and r.method == m]
            best = largest_stable(part)
            fail = _first_failure(part, best)
            table.append(
                [
                    case.label,
                    m,
                    _fmt(best.h if best else None, ".3g"),
                    _fmt(best.h_wmax if best else None, ".3g"),
                    _fmt(best.h / EVALS_PER_STEP[m] if best else None, ".3g"),
                    _fmt(best.newton_per_step if best else None, ".2f"),
                    fail.status if fail else "none up to the sweep's end",
                ]
            )
    head = (
        "case",
        "method",
        "largest stable h",
        "h·max‖ω‖",
        "h per gradient eval",
        "Newton/step there",
        "what broke first",
    )
    notes = [
        f"- {c.label}: {c.note}, T = {c.T:g}"
        + (f"; not swept: {c.skipped}" if c.skipped else "")
        + _envelope_summary(rows, c)
        for c in cases
    ]
    return [
        "## Stability envelope",
        "",
        (
            "h grows by 2^(1/4) from a stable start until the run fails: explicit update infeasible, "
            "Newton not converged, non-finite state, or error > 1 (error: the largest of |q − q_ref|∞ "
            "at T, |ω − ω_ref|∞/max‖ω‖ and max|E − E0|/max kinetic energy; reference: C RK45, tol "
            "1e-11). max‖ω‖ is taken along the reference. ![stability](stability.png)"
        ),
        "",
        *notes,
        "",
        *_table(head, table),
        "",
    ]


def fitted_exponent(ns: Sequence[float], values: Sequence[float]) -> float:
    """The slope of log(value) against log(n), least squares (nan with fewer than 2 points).

    Example:
        >>> round(fitted_exponent([10, 100, 1000], [1.0, 10.0, 100.0]), 6)
        1.0
    """
    if len(ns) < 2:
        return float("nan")
    return float(np.polyfit(np.log(ns), np.log(values), 1)[0])


def _rod_summary(rows: Sequence[ScaleRow]) -> str:
    """The dense and structured rods side by side: per-step ratio, fitted exponent, and the
    largest structured rod's generation time, from this run's rows."""
    ok = [r for r in rows if r.status == "ok"]
    dense = {r.n: r for r in ok if r.family == DENSE_ROD}
    structured = {r.n: r for r in ok if r.family == STRUCTURED_ROD}
    if not structured:
        return "The rods were not measured in this run."
    ns = sorted(structured)
    slope = fitted_exponent(ns, [structured[n].vi_us for n in ns])
    big = structured[ns[-1]]
    first = (
        f"Structured rod, VI per step against n = {ns[0]} … {ns[-1]}: fitted exponent "
        f"{slope:.2f}; at n = {big.n} {big.vi_us / 1e3:.3g} ms per step, generated in "
        f"{big.emit_s + big.gcc_s:.2f} s (derive + emit {big.emit_s:.2f} s, gcc "
        f"{big.gcc_s:.2f} s), {big.c_bytes} bytes of C."
    )
    parts = [first]
    both = [n for n in sorted(dense) if n in structured]
    if both:
        ratios = ", ".join(f"{dense[n].vi_us / structured[n].vi_us:.3g}× at n = {n}" for n in both)
        parts.append(f"Dense over structured, time per VI step: {ratios}.")
    return " ".join(parts)


def _md_scaling(rows: Sequence[ScaleRow]) -> list[str]:
    table = [
        [
            r.family,
            str(r.n),
            r.solver or "—",
            f"{r.create_s:.2f}",
            _fmt(r.emit_s, ".2f"),
            _fmt(r.gcc_s, ".2f"),
            str(r.c_bytes),
            _fmt(r.vi_us),
            _fmt(r.newton, ".2f"),
            _fmt(r.rk4_us),
            _fmt(r.h, ".0e"),
            r.status,
        ]
        for r in rows
    ]
    head = (
        "system",
        "n",
        "solves",
        "build System [s]",
        "derive+emit [s]",
        "gcc [s]",
        "C bytes",
        "vi µs/step",
        "Newton/step",
        "rk4 µs/step",
        "h",
        "status",
    )
    rod20 = next(
        (r for r in rows if r.family == STRUCTURED_ROD and r.n == 20 and r.status == "ok"), None
    )
    ours = (
        f"Ours for the rod at n = 20, measured in this run: derive + emit {rod20.emit_s:.2f} s, "
        f"gcc {rod20.gcc_s:.2f} s."
        if rod20
        else "The rod at n = 20 was not measured in this run."
    )
    quoted = "; ".join(f"{name}: {what}" for name, what in PUBLISHED_N20)
    return [
        "## Scaling with n",
        "",
        (
            "Generation in a fresh build cache (SymPy caches cleared between sizes); per step: best "
            "of 3 on the emitted C. Times are CPU seconds (this process; gcc's as its child), "
            "immune to other load on the machine. ![scaling](scaling.png)"
        ),
        "",
        *_table(head, table),
        "",
        _rod_summary(rows),
        "",
        f"{ours} Published figures for n = 20, quoted and not measured here: {quoted}.",
        "",
    ]


def _machine() -> str:
    from s2gen.inspect import compiler

    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    import scipy
    import sympy

    vers = (
        f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}, "
    )
    vers += f"SymPy {sympy.__version__}"
    with contextlib.suppress(Exception):
        import pydy

        vers += f", PyDy {pydy.__version__}"
    return f"{cpu}, {os.cpu_count()} cores; {compiler()[1]}; {vers}"


def write_markdown(report: BenchReport) -> Path:
    """bench.md: the command, the machine, and every section that ran."""
    lines = [
        "# s2gen bench",
        "",
        f"Command: `{report.command}`",
        "",
        f"Machine: {_machine()}.",
        "",
        (
            "Every number below was measured by this command in this run; ratios compare runs made "
            "side by side. Timings are best-of-k wall times of the integration call on a noisy "
            "2-core machine; our methods' timed calls keep only the final state and evaluate no "
            "energy."
        ),
        "",
        (
            "Definitions: state error = ‖(q, ω)(T) − reference‖₂ over all 6n components; energy "
            "error = max |E − E0| over every step (fixed-step methods) or over T/200-spaced samples "
            "(RK45, DOP853, scipy, PyDy; for ours from a second run that keeps them), and "
            "relative: divided by the largest kinetic energy along the reference; gradient "
            "evaluations: ours from the integrator's counters, peers' = right-hand-side "
            "evaluations. The VI family: vi (the paper's VI), rattle (RATTLE, the same discrete "
            "flow) and their symmetric compositions vi4/rattle4 (Yoshida's triple jump), "
            "vi6/rattle6 (Yoshida's order-6 solution A) and vi8/rattle8 (Kahan and Li's order 8); "
            "rk45-hairer/-matlab = our Dormand–Prince 5(4) with scipy/Hairer's or MATLAB's error "
            "control; dop853 = our Dormand–Prince 8(5,3) as Hairer's dop853.f; scipy-* = "
            "`solve_ivp` on the emitted NumPy `rhs`; pydy-* = PyDy's generated right-hand side in "
            "angles, integrated with odeint (LSODA) or DOP853."
        ),
        "",
    ]
    for ex in report.examples:
        lines += _md_example(ex, report.out)
    if report.stability:
        lines += _md_stability(report.stability, report.stability_cases)
    if report.scaling:
        lines += _md_scaling(report.scaling)
    path = report.out / "bench.md"
    path.write_text("\n".join(lines).rstrip() + "\n")
    return path
