"""Print a driven module's own records: its inputs and their defaults, the driven methods'
tables (the VI family's step fractions, the explicit Runge-Kutta tableaus as arrays, which
method takes which) and the lines of the velocity equations' Newton iteration (C's here,
NumPy's from `s2gen.printing.numpy.py_drive`).

Input: a lowered `Module` with a `Drive`. Output: the dict the `driven` partial (and its
sections) read as ``m.drive``; empty for a closed module.

Example:
    >>> from s2gen.spec import define_system
    >>> from s2gen.passes import lower_system
    >>> s = define_system(name="spin", bodies=1, parameters={}, inputs={"tau": 1.5},
    ...                   diagonal=["2"], potential=0, forces={"F1": "tau*cross(e3, q1)"})
    >>> d = print_drive(lower_system(s))
    >>> d["defaults"], d["limit"], [x["c_name"] for x in d["methods"]][:2]
    ('0.0, 1.5', '1', ['METHOD_VI', 'METHOD_RK45'])
"""

from __future__ import annotations

from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.ir import Module
from s2gen.methods import METHODS, Family, driven_methods
from s2gen.printing.numpy import py_drive
from s2gen.tableaus import DOP853, DOPRI5

__all__ = ["print_drive"]

#: The keys of ``m.drive`` (a closed module's are all empty).
_KEYS = (
    "header_doc",
    "declarations",
    "width",
    "inputs",
    "defaults",
    "velocity_doc",
    "limit",
    "exact",
    "jacobian",
    "tableaus",
    "compositions",
    "methods",
    "dp_c",
    "dop_c",
    "dop_b",
    "vi_methods",
    "rk_methods",
)


def _lits(values: Any) -> str:
    return ", ".join(repr(float(v)) for v in values)


def print_drive(module: Module) -> dict[str, Any]:
    """The ``m.drive`` record of a driven module (empty dict for a closed one)."""
    drive = module.drive
    if drive is None:
        return {**dict.fromkeys(_KEYS, ()), **py_drive(None)}
    name, upper = module.name, module.name.upper()
    rattle = not drive.forces or module.solver is InertiaKind.DIAGONAL
    rows = [m for m in METHODS if m.name in driven_methods(rattle)]
    tableaus = {m.tableau.name: m.tableau for m in rows if m.tableau is not None}
    comps = {m.composition.name: m.composition for m in rows if m.composition is not None}
    methods = []
    for m in rows:
        if m.family is Family.ADAPTIVE_RK:
            methods.append(
                {
                    "c_name": m.c_name,
                    "adaptive": 1 if m.name == "rk45" else 2,
                    "rattle": 0,
                    "count": 0,
                    "stages": 0,
                    "a": "NULL",
                    "b": "NULL",
                    "c": "NULL",
                }
            )
            continue
        if m.composition is not None:
            a, b, c = f"{name}_drive_{m.composition.name}", "NULL", "NULL"
            count, stages = len(m.composition.fractions), 0
        else:
            assert m.tableau is not None
            t = f"{name}_drive_{m.tableau.name}"
            a, b, c, count, stages = f"{t}_a", f"{t}_b", f"{t}_c", 0, m.tableau.stages
        methods.append(
            {
                "c_name": m.c_name,
                "adaptive": 0,
                "rattle": int(m.family is Family.RATTLE),
                "count": count,
                "stages": stages,
                "a": a,
                "b": b,
                "c": c,
            }
        )
    n3 = 3 * module.n
    jacobian = (
        (
            f"for (e = 0; e < {upper}_N3; ++e) {{",
            f"    for (f = 0; f < {upper}_N3; ++f) {{",
            f"        jm[e * {upper}_LD3 + f] -= jc[e * {n3} + f];",
            "    }",
            "}",
        )
        if drive.velocity
        else ()
    )
    inputs = drive.inputs
    header_doc = (
        "Driven system (forces, inputs or time t): integrate() and step() take the time and the",
        f"inputs u[{upper}_NINPUTS], held over each step (zero-order hold), in this order:",
        *(
            f"  u[{k}] = {u} (default {v!r})"
            for k, (u, v) in enumerate(zip(inputs, drive.defaults))
        ),
        "potential(), gradient(), energy() and rhs() evaluate at t = 0 with the default inputs.",
    )
    return {
        "header_doc": header_doc,
        "declarations": (
            "/* The input names in the order of u (NULL-terminated). */",
            f"extern const char *const {name}_input_names[];",
            "",
            "/* State feedback for integrate(): writes the inputs u held over the step that starts",
            " * at time t from the state (q, w) there; ctx is the caller's (integrate's fctx). */",
            f"typedef void (*{name}_feedback)(void *ctx, double t, const double *q, const double *w,",
            "        double *u);",
        ),
        "width": drive.width,
        "inputs": drive.inputs,
        "defaults": _lits((0.0, *drive.defaults)),
        "velocity_doc": "F depends on w" if drive.velocity else "F does not depend on w: one solve",
        "limit": "opt->newton_maxiter" if drive.velocity else "1",
        "exact": "0" if drive.velocity else "1",
        "jacobian": jacobian,
        "tableaus": tuple(
            {
                "name": t.name,
                "title": t.title,
                "stages": t.stages,
                "a": _lits(
                    t.a[i][j] if j < len(t.a[i]) else 0
                    for i in range(t.stages)
                    for j in range(t.stages)
                ),
                "b": _lits(t.b),
                "c": _lits(t.c),
            }
            for t in tableaus.values()
        ),
        "compositions": tuple(
            {
                "name": c.name,
                "source": c.source,
                "order": c.order,
                "count": len(c.fractions),
                "fractions": _lits(c.fractions),
            }
            for c in comps.values()
        ),
        "methods": tuple(methods),
        "dp_c": _lits(DOPRI5.c),
        "dop_c": _lits(DOP853.c),
        "dop_b": _lits(DOP853.b),
        # per method: its enum constant, its table and its gradient (or field) evaluations
        "vi_methods": tuple(
            {
                "c_name": m.c_name,
                "table": m.composition.name,
                "evals": 2 * len(m.composition.fractions),
            }
            for m in rows
            if m.composition is not None and m.family is Family.VI
        ),
        "rk_methods": tuple(
            {"c_name": m.c_name, "table": m.tableau.name, "evals": m.tableau.stages}
            for m in rows
            if m.tableau is not None
        ),
        **py_drive(drive),
    }
