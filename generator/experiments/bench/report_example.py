"""The Markdown sections of one example in ``bench.md``, generated from its measured rows.

Input: an `ExampleBench`. Output: lists of Markdown lines: the winners per accuracy target,
the VI family against the Runge-Kutta methods of the emitted C, generated findings (where a VI
wins, loses or ties), fitted orders, time to an energy error against scipy's DOP853, time per
step per backend, PyDy's derivation cost, every run, and the long-time table with its
crossover notes (`report_long.py`).

Example:
    >>> a = WPRow("x", "vi", "s2gen", 0.1, 0, 1, 10, 10, 0, 0.5, 1e-3, 0, 0)
    >>> _verdict("somewhere", a, a)[:8]
    '- **tie*'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from .common import _fmt, _ms, _table, _times
from .encounters import md_encounters
from .kernels import md_kernel_ops
from .model import (
    FIXED,
    ORDERS,
    REF_RTOL,
    RK_C,
    TIME_TRANSFORMED,
    VI_FAMILY,
    ExampleBench,
    WPRow,
)
from .per_step import NEWTON_STEPS
from .report_long import _md_long
from .sweeps import fitted_orders


def cheapest(rows: Sequence[WPRow], metric: str, target: float, cost: str = "wall") -> WPRow | None:
    """The measured run with the smallest `cost` whose `metric` is at most `target`.

    Example:
        >>> a = WPRow("x", "vi", "s2gen", 0.1, 0, 1, 10, 10, 0, 0.5, 1e-3, 0, 0)
        >>> b = WPRow("x", "rk4", "s2gen", 0.1, 0, 1, 10, 40, 0, 0.2, 1e-5, 0, 0)
        >>> cheapest([a, b], "state_err", 1e-2).method
        'rk4'
    """
    ok = [r for r in rows if r.ok and getattr(r, metric) <= target]
    return min(ok, key=lambda r: getattr(r, cost)) if ok else None


def _targets(ex: ExampleBench, metric: str) -> list[float]:
    if metric == "state_err":
        floor = 30 * ex.reference.accuracy
        return [10.0**-k for k in range(2, 13, 2) if 10.0**-k >= floor]
    return [10.0**-k for k in range(3, 12, 2)]


def _winner_rows(ex: ExampleBench, metric: str) -> list[list[str]]:
    out = []
    for target in _targets(ex, metric):
        win = cheapest(ex.rows, metric, target)
        ev = cheapest(ex.rows, metric, target, "evals")
        vi = cheapest([r for r in ex.rows if r.method in VI_FAMILY], metric, target)
        if win is None:
            continue
        ratio = _fmt(vi.wall / win.wall, ".2f") + "×" if vi else "not reached"
        out.append(
            [
                f"≤ {target:.0e}",
                f"{win.method} ({win.setting})",
                _ms(win.wall),
                f"{ev.method} ({ev.evals})" if ev else "—",
                f"{vi.method} ({vi.setting}): {_ms(vi.wall)}" if vi else "not reached",
                ratio,
            ]
        )
    return out


def _against(
    ex: ExampleBench,
    metric: str,
    mine: Callable[[str], bool],
    theirs: Callable[[str], bool],
    cell: Callable[[WPRow], str],
) -> list[list[str]]:
    """Per target of `metric`: the cheapest run of the methods `mine` picks and of those
    `theirs` picks (each written by `cell`, "not reached" when none did) and the ratio of
    their wall times; targets neither side reached are left out."""
    out = []
    for target in _targets(ex, metric):
        a = cheapest([r for r in ex.rows if mine(r.method)], metric, target)
        b = cheapest([r for r in ex.rows if theirs(r.method)], metric, target)
        if a is None and b is None:
            continue
        out.append(
            [
                f"≤ {target:.0e}",
                cell(a) if a else "not reached",
                cell(b) if b else "not reached",
                _fmt(a.wall / b.wall, ".2f") + "×" if a and b else "—",
            ]
        )
    return out


def _versus_rk(ex: ExampleBench, metric: str) -> list[list[str]]:
    """Per target of `metric`: the cheapest VI-family run, the cheapest Runge-Kutta run of the
    emitted C (`RK_C`) and the ratio of their wall times."""
    return _against(
        ex, metric, VI_FAMILY.__contains__, RK_C.__contains__,
        lambda r: f"{r.method} ({r.setting}): {_ms(r.wall)}",
    )  # fmt: skip


def _md_versus_rk(ex: ExampleBench) -> list[str]:
    head = ("{}", "best VI family", "best RK (emitted C)", "VI family / RK")
    title = (
        "The VI family (VI, RATTLE and their compositions) against the Runge-Kutta methods of "
        "the emitted C (rk4, rk45 under both controls, dop853): the cheapest run of each that "
        "reaches the target, wall time of the call keeping only the final state."
    )
    return [
        "### The VI family against Runge-Kutta (emitted C)",
        "",
        title,
        "",
        *_table((head[0].format("state error"), *head[1:]), _versus_rk(ex, "state_err")),
        "",
        *_table((head[0].format("rel. energy error"), *head[1:]), _versus_rk(ex, "rel_dE")),
        "",
    ]


def _md_transformed(ex: ExampleBench) -> list[str]:
    """Per state-error target: the cheapest time-transformed run and the cheapest DOP853 run
    (wall time, gradient evaluations) and the ratio of their times; nothing when the example
    has no time-transformed rows."""
    if not any(r.method in TIME_TRANSFORMED for r in ex.rows):
        return []
    table = _against(
        ex, "state_err", TIME_TRANSFORMED.__contains__, "dop853".__eq__,
        lambda r: f"{r.method} ({r.setting}): {_ms(r.wall)}, {r.evals}",
    )  # fmt: skip
    head = (
        "state error",
        "best time-transformed VI or RATTLE (wall, gradient evals)",
        "best DOP853 (wall, gradient evals)",
        "time-transformed / DOP853",
    )
    title = (
        "The time-transformed VI and RATTLE (steps eps / xi in time, xi tracking the monitor "
        "of the system's pair terms; RATTLE takes the VI's flow by other operations) against "
        "DOP853, all on the emitted C: the cheapest run of each that reaches the target."
    )
    head_line = "### The time-transformed VI and RATTLE against DOP853"
    return [head_line, "", title, "", *_table(head, table), ""]


#: Wall-time ratios within this factor of 1 are reported as ties (timing noise).
TIE = 1.15


def findings(ex: ExampleBench, metric: str) -> list[str]:
    """Generated sentences: at each accuracy target, whether the VI family (`VI_FAMILY`) is the
    cheapest in wall time, and by how much it wins or loses against the cheapest other method (a ratio
    within `TIE` of 1 is a tie)."""
    what = "state error" if metric == "state_err" else "relative energy error"
    lines = []
    for target in _targets(ex, metric):
        vi = cheapest([r for r in ex.rows if r.method in VI_FAMILY], metric, target)
        other = cheapest([r for r in ex.rows if r.method not in VI_FAMILY], metric, target)
        where = f"{what} ≤ {target:.0e} over T = {ex.reference.T:g}"
        if vi and other:
            lines.append(_verdict(where, vi, other))
        elif other:
            lines.append(
                f"- **VI loses** at {where}: no VI run in the sweep reached it; "
                f"{other.method} ({other.setting}) did in {_ms(other.wall)}."
            )
        elif vi:
            lines.append(
                f"- **VI wins** at {where}: only {vi.method} ({vi.setting}) reached it "
                f"({_ms(vi.wall)})."
            )
    return lines


def _verdict(where: str, vi: WPRow, other: WPRow) -> str:
    ratio = vi.wall / other.wall
    pair = (
        f"{vi.method} ({vi.setting}) {_ms(vi.wall)}, fastest other {other.method} "
        f"({other.setting}) {_ms(other.wall)}"
    )
    if 1 / TIE <= ratio <= TIE:
        return f"- **tie** at {where}: {pair} (within {TIE:g}×, timing noise)."
    if ratio < 1:
        return f"- **VI wins** at {where}: {pair}; the other takes {1 / ratio:.2f}× longer."
    return f"- **VI loses** at {where}: {pair}; the VI takes {ratio:.2f}× longer."


def _vi_vs_rattle(ex: ExampleBench) -> str:
    floor = 1e4 * ex.reference.accuracy
    vi = {round(r.h, 12): r for r in ex.rows if r.method == "vi" and r.ok}
    ra = {round(r.h, 12): r for r in ex.rows if r.method == "rattle" and r.ok}
    common = sorted(h for h in set(vi) & set(ra) if ra[h].state_err > floor)
    if not common:
        return ""
    diff = max(abs(vi[h].state_err - ra[h].state_err) / ra[h].state_err for h in common)
    cost = [vi[h].wall / ra[h].wall for h in common if ra[h].wall > 0]
    return (
        f"- vi and RATTLE are variational integrators of the same discrete Lagrangian: at the "
        f"{len(common)} common step sizes whose error is above 10⁴× the reference accuracy "
        f"their state errors differ by at most {diff:.1e} (relative), and the VI's wall time is "
        f"{min(cost):.2f}–{max(cost):.2f}× RATTLE's."
    )


def _md_orders(ex: ExampleBench) -> list[str]:
    orders = fitted_orders(ex.rows, ex.reference.accuracy)
    swept = [m for m in TIME_TRANSFORMED if any(r.method == m for r in ex.rows)]
    rows = [[m, _fmt(orders.get(m), ".3f"), f"{ORDERS[m]:g}"] for m in (*FIXED, *swept)]
    title = "Fitted order (slope of log state error against log h, or log eps for the "
    title += "time-transformed methods, errors in 100× reference accuracy … 1e-2):"
    return [title, "", *_table(("method", "fitted", "expected"), rows)]


def _md_energy_vs_scipy(ex: ExampleBench) -> list[str]:
    peer = "scipy-DOP853"
    methods = list(dict.fromkeys(r.method for r in ex.rows))
    head = ["method", *[f"≤ {t:.0e}" for t in _targets(ex, "rel_dE")]]
    rows = []
    base = {
        t: cheapest([r for r in ex.rows if r.method == peer], "rel_dE", t)
        for t in _targets(ex, "rel_dE")
    }
    for m in methods:
        cells = [m]
        for t in _targets(ex, "rel_dE"):
            r = cheapest([x for x in ex.rows if x.method == m], "rel_dE", t)
            b = base[t]
            ratio = f" ({_speedup(b.wall / r.wall)})" if r and b and m != peer else ""
            cells.append(_ms(r.wall) + ratio if r else "—")
        rows.append(cells)
    title = (
        f"Time to reach a relative energy error (cheapest measured run; in brackets: how many "
        f"times faster than {peer} on the emitted NumPy right-hand side, measured in this run):"
    )
    return [title, "", *_table(head, rows)]


def _speedup(ratio: float) -> str:
    return f"{ratio:.3g}× faster" if ratio >= 1 else f"{1 / ratio:.3g}× slower"


def _md_per_step(ex: ExampleBench) -> list[str]:
    rows = [
        [
            r["method"],
            _fmt(r.get("c_us")),
            _fmt(r.get("numpy_us")),
            _times(r.get("numpy_over_c")),
            _fmt(r.get("reference_us")),
            _times(r.get("reference_over_c")),
        ]
        for r in ex.per_step
    ]
    head = (
        "method",
        "C µs/step",
        "NumPy µs/step",
        "NumPy / C",
        "reference µs/step",
        "reference / C",
    )
    first = ex.per_step[0] if ex.per_step else {"h": math.nan, "steps": 0}
    title = (
        f"Time per step: the same {first['steps']} steps of h = {first['h']:.4g} on each backend, "
        "side by side in this run; (best of N steps − best of 1 step)/(N − 1), so the per-call "
        "overhead is excluded (rk45: tol 1e-8, best wall / accepted steps):"
    )
    lines = [title, "", *_table(head, rows)]
    if ex.newton:
        its = ", ".join(f"{m} {v:.2f}" for m, v in ex.newton.items())
        h = ex.system.run.h or 0.01
        lines += [
            "",
            (
                f"Newton iterations per substep (emitted C, the system's own h = {h:g}, "
                f"{NEWTON_STEPS} steps; 0: explicit steps): {its}."
            ),
        ]
    return lines


def _md_pydy(ex: ExampleBench) -> list[str]:
    p = ex.pydy
    if p.get("status") != "ok":
        return [f"PyDy: {p.get('status', 'not run')}."]
    line = (
        f"PyDy ({p['generator']} generator): derivation with Kane's method "
        f"{p['derive_s']:.2f} s, code generation + compilation {p['generate_s']:.2f} s"
    )
    if "lambdify_generate_s" in p:
        line += f" (lambdify generator: {p['lambdify_generate_s']:.2f} s)"
    line += f". {p['note']}" if p.get("note") else "."
    line += (
        f" Angles: q = Ry(b) Rx(a) e3, poles at ±e2; the trajectory stays "
        f"{p.get('pole_distance', math.nan):.3f} rad from them."
    )
    return [line]


def _md_example(ex: ExampleBench, out: Path) -> list[str]:
    ref = ex.reference
    intro = (
        f"Reference: our C DOP853 (tol {REF_RTOL:g}); vi8 or rattle8 at small steps agrees "
        f"to {ref.accuracy:.2e} (state norm). Largest kinetic energy along it "
        f"{ref.kinetic_scale:.4g} (divides energy errors). ![work-precision](wp_{ex.name}.png)"
    )
    if np.isfinite(ex.call_overhead):
        intro += (
            f" Each of our timings includes a fixed per-call cost (output arrays, ctypes) of "
            f"{ex.call_overhead * 1e6:.0f} µs, measured as the best one-step call; it dominates "
            "the runs below about ten times that."
        )
    lines = [f"## {ex.name} (n = {ex.system.n}, T = {ref.T:g})", "", intro, ""] if ex.rows else []
    if ex.rows:
        head = (
            "state error",
            "fastest (wall)",
            "its time",
            "fewest gradient evals",
            "best VI",
            "best VI / fastest",
        )
        lines += ["### Winners per accuracy", "", *_table(head, _winner_rows(ex, "state_err")), ""]
        head2 = ("rel. energy error", *head[1:])
        lines += [*_table(head2, _winner_rows(ex, "rel_dE")), ""]
        lines += _md_versus_rk(ex)
        lines += _md_transformed(ex)
        lines += ["### Where the VI loses and where it wins (generated from the rows above)", ""]
        lines += findings(ex, "state_err") + findings(ex, "rel_dE")
        lines += [_vi_vs_rattle(ex), ""]
        lines += _md_orders(ex) + [""] + _md_energy_vs_scipy(ex) + [""]
        lines += _md_per_step(ex) + [""] + md_kernel_ops(ex.system) + [""]
        lines += _md_pydy(ex) + [""]
        lines += _md_all_runs(ex)
    if ex.long:
        lines += _md_long(ex)
        lines += md_encounters(ex.encounters, ex.energy_costs, ex.energy0)
    return lines


def _md_all_runs(ex: ExampleBench) -> list[str]:
    rows = [
        [
            r.method,
            r.setting,
            str(r.steps),
            str(r.evals),
            _fmt(r.newton_per_step, ".2f"),
            _ms(r.wall),
            _fmt(r.state_err, ".2e"),
            _fmt(r.max_dE, ".2e"),
            _fmt(r.rel_dE, ".2e"),
            r.status,
        ]
        for r in ex.rows
    ]
    head = (
        "method",
        "setting",
        "steps",
        "grad evals",
        "Newton/step",
        "wall",
        "state error",
        "max abs dE",
        "rel dE",
        "status",
    )
    return ["<details><summary>All runs</summary>", "", *_table(head, rows), "", "</details>", ""]
