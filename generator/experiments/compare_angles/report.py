"""The written results of `s2gen compare-angles`: Markdown report and JSON numbers.

Input: a `Comparison` (and the figure paths, linked from the report). Output:
``compare_angles.md`` text (`markdown`: cost, accuracy, near-pole and chain tables with
their explanations) and ``compare_angles.json`` (`to_json`, `write_json`: the scalar
results).

Example:
    >>> _num(float("nan")), _num(0.000123, ".2e")
    ('–', '1.23e-04')
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from .model import Comparison, Cost, PoleCase, Run
from .settings import _LABELS, _REFERENCE_ATOL, _REFERENCE_RTOL, FORMS


def to_json(result: Comparison) -> dict[str, Any]:
    """The scalar results as plain JSON data."""
    return {
        "system": result.system,
        "settings": asdict(result.settings),
        "costs": [asdict(c) for c in result.costs],
        "accuracy": [r.brief() for r in result.accuracy],
        "pole": [
            {"label": c.label, "beta": c.beta, "body": c.body + 1, "passage": c.passage}
            | {"passage_time": c.passage_time}
            | {"runs": [r.brief() for r in c.runs]}
            for c in result.pole
        ],
        "chains": [asdict(c) for c in result.chains],
    }


def write_json(result: Comparison, path: Path) -> Path:
    path.write_text(json.dumps(to_json(result), indent=1, default=float) + "\n")
    return path


def _num(x: float, spec: str = ".3g") -> str:
    return "–" if x is None or not np.isfinite(x) else format(x, spec)


def _result(r: Run) -> str:
    if r.status == "ok":
        return "ok"
    if r.status == "PoleError":
        return "cannot start (body at a pole)"
    reached = float(r.t[-1]) if r.t.size else 0.0
    why = r.message.split(": ", 1)[-1].split(";")[0]
    return f"failed at t ≈ {reached:.3g}: {why}"


def _shown(c: Cost, fn: Callable[[Cost], str]) -> str:
    """A number of a form that ran (`fn`), else why it did not ("> 120 s", an error)."""
    return fn(c) if c.status == "ok" else c.status


def _cost_rows(costs: Sequence[Cost]) -> list[str]:
    by = {c.form: c for c in costs}
    cols = [by[f] for f in FORMS if f in by]

    def row(name: str, fn: Callable[[Cost], str]) -> str:
        return f"| {name} | " + " | ".join(_shown(c, fn) for c in cols) + " |"

    head = "| | " + " | ".join(_LABELS[c.form] for c in cols) + " |"
    return [
        head,
        "|---|" + "---:|" * len(cols),
        row("derivation + cse of the vector field (s)", lambda c: f"{c.seconds:.2f}"),
        row("… of every kernel of the emitted module (s)", lambda c: f"{c.module_seconds:.2f}"),
        row("vector-field kernel operations, as derived", lambda c: f"{c.ops_before}"),
        row("… after cse", lambda c: f"{c.ops}"),
        row("… after cse, as evaluated per call", lambda c: f"{c.ops_evaluated}"),
        row("linear solve per call (≈ flops)", lambda c: f"{c.solve_flops}"),
        row("emitted C, .c + .h (bytes / lines)", lambda c: f"{c.c_bytes} / {c.c_lines}"),
        row("gcc -O2 -shared (s)", lambda c: f"{c.gcc_seconds:.2f}"),
        row("time per vector-field evaluation (ns, C)", lambda c: f"{c.rhs_ns:.0f}"),
    ]


def _run_rows(runs: Sequence[Run], prefix: str = "") -> list[str]:
    rows = []
    for r in runs:
        sm = r.summary
        rows.append(
            f"| {prefix}{_LABELS[r.form]} | {r.method.upper()} | {_result(r)} | "
            f"{_num(r.max_error(), '.2e')} | {_num(sm.get('mean_dE', np.nan), '.2e')} | "
            f"{_num(sm.get('max_dE', np.nan), '.2e')} | "
            f"{_num(sm.get('max_norm', np.nan), '.1e')} | "
            f"{r.steps} | {r.rejected} | {r.evals} | {_num(1e3 * r.wall, '.2f')} |"
        )
    return rows


_RUN_HEAD = [
    (
        "| form | method | result | max ‖q − q_ref‖ | mean \\|E − E₀\\| | max \\|E − E₀\\| | "
        "max \\| \\|q\\| − 1 \\| | steps | rejected | evaluations | wall (ms) |"
    ),
    "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
]


def _pole_rows(cases: Sequence[PoleCase]) -> list[str]:
    head = [
        (
            "| case | pass distance | at t | form | method | result | max ‖q − q_ref‖ | "
            "max \\|E − E₀\\| | steps | rejected |"
        ),
        "|---|---:|---:|---|---|---|---:|---:|---:|---:|",
    ]
    rows = []
    for c in cases:
        for r in c.runs:
            rows.append(
                f"| {c.label} | {_num(abs(c.passage), '.2e')} | {_num(c.passage_time, '.3f')} | "
                f"{_LABELS[r.form]} | {r.method.upper()} | {_result(r)} | "
                f"{_num(r.max_error(), '.2e')} | {_num(r.summary.get('max_dE', np.nan), '.2e')} | "
                f"{r.steps} | {r.rejected} |"
            )
    return head + rows


def _chain_rows(chains: Sequence[Cost]) -> list[str]:
    ns = sorted({c.n for c in chains})
    by = {(c.form, c.n): c for c in chains}
    head = (
        "| n | derive + cse (s): S² / angles / simplified | S² kernel ops after cse | "
        "ops after cse per call: S² / angles / simplified | "
        "vector field (ns): S² / angles / simplified | gcc (s): S² / angles |"
    )
    rows = [head, "|---:|---|---:|---|---|---|"]

    def cell(n: int, fn: Callable[[Cost], str], forms: Sequence[str] = FORMS) -> str:
        out = []
        for f in forms:
            c = by.get((f, n))
            out.append("–" if c is None else _shown(c, fn))
        return " / ".join(out)

    for n in ns:
        rows.append(
            f"| {n} | {cell(n, lambda c: f'{c.seconds:.2f}')} | "
            f"{cell(n, lambda c: f'{c.ops}', FORMS[:1])} | "
            f"{cell(n, lambda c: f'{c.ops_evaluated}')} | {cell(n, lambda c: f'{c.rhs_ns:.0f}')} | "
            f"{cell(n, lambda c: f'{c.gcc_seconds:.2f}', FORMS[:2])} |"
        )
    return rows


def markdown(result: Comparison, figures: Sequence[Path]) -> str:
    """The report as Markdown text."""
    s = result.settings
    pole = result.pole[0] if result.pole else None
    lines = [
        f"# The (S²)ⁿ form against the spherical-angle form: {result.system}",
        "",
        (
            f"Both forms are generated from the same (M, V) of `{result.system}` "
            f"(n = {result.n}) and run as emitted C. Angle form: "
            "qᵢ = (sin θᵢ cos φᵢ, sin θᵢ sin φᵢ, cos θᵢ), "
            "M(θ, φ) ẍ = F solved by LU with partial pivoting; results are mapped back to "
            "(qᵢ, ωᵢ = qᵢ × q̇ᵢ) and every metric, the energy included, is computed on those as "
            "for the S² form."
        ),
        "",
        (
            f"Settings: T = {s.T:g}, h = {s.h:g} (RK4 step and RK45 output grid), RK45 rtol = "
            f"{s.rtol:g}, atol = {s.atol:g} ({s.control} error control); reference: S² RK45 at "
            f"rtol {_REFERENCE_RTOL:g}, atol {_REFERENCE_ATOL:g}; derivation budget {s.budget:g} s."
        ),
        "",
        "## Cost",
        "",
        *_cost_rows(result.costs),
        "",
        (
            "Derivation times are measured in a fresh process (cold SymPy caches). The S² "
            "vector field is its generic per-body and per-pair kernels (derived for a generic "
            "body and pair, whatever n) plus M and ∂V/∂q; its module also holds the variational "
            "integrators' kernels, so its module time, C size and gcc time cover more than the "
            "vector field. Operations are SymPy `count_ops` of the vector-field kernels; per call, "
            "the S² per-body and per-pair kernels count once per body and per coupled pair. "
            "Linear solve: S² LU (partial pivoting) of the 3n × 3n matrix A(q) (coupled M only), angle form LU "
            "of the 2n × 2n M(θ, φ). Times per evaluation: the forms timed side by side, best of "
            f"{s.repeats} loops of about 20 ms, at a state away from the poles."
        ),
        "",
        f"## Accuracy over T = {s.T:g}",
        "",
        *_RUN_HEAD,
        *_run_rows(result.accuracy),
        "",
    ]
    if pole is not None:
        lines += [
            f"## Near a pole: body {pole.body + 1}",
            "",
            (
                f"The spec's own state is in the accuracy table above. Here body "
                f"{pole.body + 1} is turned onto its nearest pole, moved back along its motion "
                f"by α = {s.alpha:g} rad and tilted by β about its direction of motion. "
                "`through` uses the tilt β* (bisection on the side of the pass; "
                f"β* = {pole.beta:.12g}) whose trajectory passes through the pole; case δ uses "
                "β* + δ. Pass distance: |L_z|/|v_xy| of the reference at its sample closest to "
                "the pole (the distance of the local tangent line; exact between samples)."
            ),
            "",
            *_pole_rows(result.pole),
            "",
        ]
    if result.chains:
        lines += [
            "## Scaling: chains of n spherical pendula",
            "",
            (
                "M_ij = (Σ_{k ≥ max(i,j)} m_k) l_i l_j, V = −Σ_i (Σ_{k ≥ i} m_k) g l_i e₃·q_i "
                "(`compare_angles.chain_system`). A form that exceeds the derivation budget is not "
                "tried for larger n."
            ),
            "",
            *_chain_rows(result.chains),
            "",
        ]
    lines += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in figures] + [""]
    return "\n".join(lines)
