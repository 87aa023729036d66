"""Print the records of the step Jacobians (``m.jac``, read by ``c/_jacobian.jinja``).

Input: a lowered sphere `Module` whose parts include ``jacobian``. Output: the fixed-step
explicit methods it differentiates, each with its tableau as arrays of round-trip literals
(a zero-padded to stages x stages, b, c) and whether q_i is normalized after the step; the
C lines that differ between a closed module and a driven one (the step that computes
(q+, w+), the inputs held in the context, the time of a stage and that of field_jacobian());
the lines that assemble the second derivatives (the terms' member loops) and the VI's
equations' blocks; and the sizes of the derivative's columns (the state's 6n, then the
inputs', then the parameters'). Empty for a module without it.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> jac = print_jacobian(lower_system(builtin("double_pendulum").with_jacobians()))
    >>> [x["c_name"] for x in jac["methods"]][:3], jac["columns"]
    (['METHOD_RK2', 'METHOD_RK2_PROJ', 'METHOD_RK4'], '17')
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.ir import Module
from s2gen.methods import METHODS, Family, Method, driven_methods, fixed_methods
from s2gen.printing.jacobian_lines import (
    call_of,
    force_lines,
    hessian_lines,
    vi_coupled_lines,
    vi_diagonal_lines,
)

__all__ = [
    "JACOBIAN_PART",
    "JACOBIAN_SITES",
    "composition_record",
    "print_jacobian",
    "tableau_record",
]

#: The name of the part that emits step_jacobian()
JACOBIAN_PART = "jacobian"

#: The call sites whose C this record writes into its lines (with the terms' t<k>_hessian)
JACOBIAN_SITES = frozenset({"hessian", "force_jacobian", "vi_jacobian", "vi_jacobian_pair"})

_KEYS = (
    "methods",
    "count",
    "max_stages",
    "columns",
    "ninputs",
    "step",
    "setup",
    "stage_time",
    "stage_force",
    "stage_field",
    "field_time",
    "vi_methods",
    "vi_count",
    "max_sub",
    "ny",
    "vi_substep",
    "other",
    "hessian",
    "force",
    "vi_force",
    "vi_end_time",
    "vi_start_time",
    "yq",
    "yw",
    "nparams",
    "vi_equations",
)


def _lits(values: list[Fraction]) -> str:
    return ", ".join(repr(float(v)) for v in values)


def tableau_record(m: Method) -> dict[str, str]:
    """A fixed-step method's row of a differentiating function's method table: its enum
    name, its tableau (a zero-padded to stages x stages, row-major; b; c) as C literals and
    whether it normalizes q_i after the step."""
    t = m.tableau
    assert t is not None, "fixed-step methods have a tableau"
    s = t.stages
    a = [row[j] if j < len(row) else Fraction(0) for row in t.a for j in range(s)]
    return {
        "c_name": m.c_name,
        "name": m.name,
        "stages": str(s),
        "a": _lits(a),
        "b": _lits(list(t.b)),
        "c": _lits(list(t.c)),
        "project": "1" if m.project else "0",
    }


def composition_record(m: Method) -> dict[str, str]:
    """A composed geometric method's row of a differentiating function's method table: its
    enum name, its substep count and fractions as C literals."""
    assert m.composition is not None, "composed methods have a composition"
    fractions = m.composition.fractions
    return {
        "c_name": m.c_name,
        "name": m.name,
        "count": str(len(fractions)),
        "fractions": ", ".join(repr(float(x)) for x in fractions),
    }


def print_jacobian(module: Module) -> dict[str, Any]:
    """The ``m.jac`` record of a module (every key empty without the ``jacobian`` part)."""
    if JACOBIAN_PART not in module.parts:
        return dict.fromkeys(_KEYS, ())
    name, upper = module.name, module.name.upper()
    driven = module.drive is not None
    if driven:
        rows = [m for m in METHODS if m.name in driven_methods() and m.tableau is not None]
    else:
        rows = list(fixed_methods(module.kind.value))
    methods = [tableau_record(m) for m in rows]
    drive = module.drive
    ninputs = len(drive.inputs) if drive is not None else 0
    step: tuple[str, ...]
    setup: tuple[str, ...] = (f"status = {upper}_OK;",)
    stage_time: tuple[str, ...] = ()
    field_time: tuple[str, ...] = ("(void)t;", "(void)u;")
    stage_force: tuple[str, ...] = ()
    if drive is None:
        # the step leaves its stages' fields in its workspace: step_jacobian() copies them
        k_at = module.layout("rk_step").offset("rk") + module.layout("rk_fixed").offset("k")
        step = ("(void)opt;", "(void)t;", "(void)u;")
        step += (f"status = {name}_rk_step(p, method, h, q, w, qn, wn, work);",)
        step += (f"{name}_copy(k, work + {k_at}, jm->stages * ns);",)
    else:
        step = (f"status = {name}_step(p, opt, method, t, h, u, q, w, qn, wn, NULL, work, NULL);",)
        setup = (f"status = {name}_hold(cx, u);",)
        stage_time = ("cx->tu[0] = t + jm->c[i] * h;",)
        field_time = ("cx->tu[0] = t;",)
    if drive is not None and drive.forces:
        # the forces' terms of the field, added as the driven Runge-Kutta step adds them
        lay = module.layout("driven")
        forces = f"work + {lay.offset('F')}, work + {lay.offset('Fw')}"
        stage_force = (
            f"status = {name}_stage_force(cx, ys, ys + n3, ki + n3, {forces}, work);",
            f"if (status != {upper}_OK) {{",
            "    return status;",
            "}",
        )
    stage_field: tuple[str, ...] = ()
    if drive is not None:
        stage_field = (
            f"status = {name}_field(cx, ys, ki, work);",
            f"if (status != {upper}_OK) {{",
            "    return status;",
            "}",
            *stage_force,
        )
    return {
        **_vi(module),
        "stage_field": stage_field,
        "hessian": hessian_lines(module),
        "force": force_lines(module),
        "methods": tuple(methods),
        "count": str(len(methods)),
        "max_stages": str(max(int(m["stages"]) for m in methods)),
        "columns": str(6 * module.n + ninputs + len(module.parameter_names)),
        "ninputs": str(ninputs),
        "nparams": str(len(module.parameter_names)),
        "step": step,
        "setup": setup,
        "stage_time": stage_time,
        "stage_force": stage_force,
        "field_time": field_time,
    }


def _vi(module: Module) -> dict[str, Any]:
    """The VI family's entries of ``m.jac``: each method's substeps (step fractions), the
    size of the unknowns of one step's equations (``ny``; the section ``jacobian_vi``
    differentiates them, absent without the ``vi_jacobian`` kernel: structured M) and the C
    lines of one
    substep from (qs, ws) at ts into (qd, wd), the Cayley parameters into f."""
    name, upper, n = module.name, module.name.upper(), module.n
    if "vi_jacobian" not in {k.name for k in module.kernels}:
        return {
            "vi_equations": (),
            "vi_force": (),
            "vi_end_time": (),
            "vi_start_time": (),
            "yq": "0",
            "yw": "0",
            "vi_methods": (),
            "vi_count": "0",
            "max_sub": "1",
            "ny": "0",
            "vi_substep": (),
            "other": (f"return {upper}_ERR_ARGUMENT;",),
        }
    drive = module.drive
    rows = [
        m
        for m in METHODS
        if m.family is Family.VI
        and m.composition is not None
        and (drive is None or m.name in driven_methods())
    ]
    methods = tuple(composition_record(m) for m in rows if m.composition is not None)
    coupled = module.solver is not InertiaKind.DIAGONAL
    if drive is None:
        substep: tuple[str, ...] = (
            f"{name}_gradient_cx(cx, qs, g);",
            f"status = {name}_vi_advance(cx, opt, hs, qs, ws, g, qd, wd, gn, f, 0, work, &its);",
        )
    else:
        f_at = f"work + {module.layout('driven').offset('f')}"
        substep = (
            f"status = {name}_driven_vi(cx, opt, ts, hs, qs, ws, qd, wd, &part, work, &its);",
            *((f"{name}_copy(f, {f_at}, {upper}_N3);",) if coupled else ()),
            "cx->tu[0] = ts;",
        )
    n3, ny = 3 * n, (9 if coupled else 6) * n
    yq = n3 if coupled else 0
    ns = 6 * n
    force: tuple[str, ...] = ()
    ni = len(drive.inputs) if drive is not None else 0
    npar = len(module.parameter_names)
    if call_of(module, "force_jacobian") is not None:
        force = (
            f"{name}_jac_mul_add(ny, {n3}, {n3}, 1.0, efn, {n3}, fq, {n3}, ey + {yq}, ny);",
            f"{name}_jac_mul_add(ny, {n3}, {n3}, 1.0, efn, {n3}, fw, {n3}, ey + {yq + n3}, ny);",
            f"{name}_jac_mul_add(ny, {n3}, {ni}, 1.0, efn, {n3}, fu, {ni}, ex + {ns}, nc);",
            (
                f"{name}_jac_mul_add(ny, {n3}, {npar}, 1.0, efn, {n3}, fp, {npar}, "
                f"ex + {ns + ni}, nc);"
            ),
        )
    timed = drive is not None
    return {
        "vi_equations": vi_coupled_lines(module) if coupled else vi_diagonal_lines(module),
        "vi_force": force,
        "vi_end_time": ("cx->tu[0] = ts + hs;",) if timed else (),
        "vi_start_time": ("cx->tu[0] = ts;",) if timed else (),
        "yq": str(yq),
        "yw": str(yq + n3),
        "vi_methods": methods,
        "vi_count": str(len(methods)),
        "max_sub": str(max(int(m["count"]) for m in methods)),
        "ny": str(ny),
        "vi_substep": substep,
        "other": (
            f"return {name}_jac_vi_step(p, opt, method, t, h, u, q, w, qn, wn, A, B, P, work);",
        ),
    }
