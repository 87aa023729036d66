"""Print the records of the step Jacobians (``m.jac``, read by ``c/_jacobian.jinja``).

Input: a lowered sphere `Module` whose parts include ``jacobian``. Output: the fixed-step
explicit methods it differentiates, each with its tableau as arrays of round-trip literals
(a zero-padded to stages x stages, b, c) and whether q_i is normalized after the step; the
C lines that differ between a closed module and a driven one (the step that computes
(q+, w+), the inputs held in the context, the time of a stage); the lines that assemble
the second derivatives (the terms' member loops) and the VI's equations' blocks; and the sizes
of the derivative's columns (the state's 6n, then the inputs', then the parameters'). Empty
for a module without it.

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
from s2gen.ir import Call, Module
from s2gen.methods import METHODS, Family, driven_methods, fixed_methods
from s2gen.printing.c import c_loop
from s2gen.printing.c_calls import c_call

__all__ = ["JACOBIAN_PART", "JACOBIAN_SITES", "print_jacobian"]

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
    methods = []
    for m in rows:
        t = m.tableau
        assert t is not None, "fixed-step methods have a tableau"
        s = t.stages
        a = [row[j] if j < len(row) else Fraction(0) for row in t.a for j in range(s)]
        methods.append(
            {
                "c_name": m.c_name,
                "name": m.name,
                "stages": str(s),
                "a": _lits(a),
                "b": _lits(list(t.b)),
                "c": _lits(list(t.c)),
                "project": "1" if m.project else "0",
            }
        )
    drive = module.drive
    ninputs = len(drive.inputs) if drive is not None else 0
    step: tuple[str, ...]
    setup: tuple[str, ...] = (f"status = {upper}_OK;",)
    stage_time: tuple[str, ...] = ()
    stage_force: tuple[str, ...] = ()
    if drive is None:
        step = ("(void)opt;", "(void)t;", "(void)u;")
        step += (f"status = {name}_rk_step(p, method, h, q, w, qn, wn, work);",)
    else:
        step = (f"status = {name}_step(p, opt, method, t, h, u, q, w, qn, wn, NULL, work, NULL);",)
        setup = (f"status = {name}_hold(cx, u);",)
        stage_time = ("cx->tu[0] = t + jm->c[i] * h;",)
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
    return {
        **_vi(module),
        "hessian": _hessian(module),
        "force": _force(module),
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
    methods = tuple(
        {
            "c_name": m.c_name,
            "name": m.name,
            "count": str(len(m.composition.fractions)),
            "fractions": ", ".join(repr(float(x)) for x in m.composition.fractions),
        }
        for m in rows
        if m.composition is not None
    )
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
    if _call(module, "force_jacobian") is not None:
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
        "vi_equations": _vi_coupled(module) if coupled else _vi_equations(module),
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


def _call(module: Module, site: str) -> Call | None:
    return next((c for c in module.calls if c.site == site), None)


def _hessian(module: Module) -> tuple[str, ...]:
    """The C lines that set H (N3 x N3) to the Hessian of V at q and gp (N3 x parameters) to
    dg/dp: V's general part (the ``hessian`` kernel, which writes every entry) or zeros, then
    each term's member loop, which calls the term's ``t<k>_hessian`` and adds its blocks at the
    member's bodies."""
    name, upper = module.name, module.name.upper()
    npar = len(module.parameter_names)
    general = _call(module, "hessian")
    if general is not None:
        lines = [f"{c_call(name, general)};"]
    else:
        lines = [f"for (r = 0; r < {upper}_N3 * {upper}_N3; ++r) {{", "    H[r] = 0.0;", "}"]
        lines += [f"for (r = 0; r < {upper}_N3 * {npar}; ++r) {{", "    gp[r] = 0.0;", "}"]
    for t in module.terms:
        call = _call(module, f"t{t.index}_hessian")
        assert call is not None, "every term of a module with step Jacobians has its Hessian"
        indices = t.loop.kind.kind.indices
        size = 3 * len(indices)
        head, tail = c_loop(name, t, module.n)
        at = "3 * at[r / 3] + r % 3"
        inner = [
            f"double hb[{size * size}];",
            *((f"double gpb[{size * npar}];",) if npar else ()),
            f"const long at[{len(indices)}] = {{{', '.join(indices)}}};",
            f"{c_call(name, call)};",
            f"for (r = 0; r < {size}; ++r) {{",
            f"    for (c = 0; c < {size}; ++c) {{",
            f"        H[({at}) * {upper}_N3 + 3 * at[c / 3] + c % 3] += hb[{size} * r + c];",
            "    }",
            *(
                (
                    f"    for (c = 0; c < {npar}; ++c) {{",
                    f"        gp[({at}) * {npar} + c] += gpb[{npar} * r + c];",
                    "    }",
                )
                if npar
                else ()
            ),
            "}",
        ]
        lines += [line[4:] for line in head]
        lines += [f"        {line}" for line in inner]
        lines += [line[4:] for line in tail]
    return tuple(lines)


def _force(module: Module) -> tuple[str, ...]:
    """The C lines that take the forces out of G and gx = dG/d(q, w, u, p)
    (``force_jacobian``: F, fq, fw, fu, fp at q, w and the context's time and inputs); none
    without forces."""
    call = _call(module, "force_jacobian")
    if call is None:
        return ()
    upper = module.name.upper()
    ni = len(module.drive.inputs) if module.drive is not None else 0
    ns, npar = 6 * module.n, len(module.parameter_names)
    return (
        f"{c_call(module.name, call)};",
        f"for (r = 0; r < {upper}_N3; ++r) {{",
        "    G[r] -= F[r];",
        f"    for (c = 0; c < {upper}_N3; ++c) {{",
        f"        gx[r * nc + c] -= fq[r * {upper}_N3 + c];",
        f"        gx[r * nc + {upper}_N3 + c] = -fw[r * {upper}_N3 + c];",
        "    }",
        f"    for (c = 0; c < {ni}; ++c) {{",
        f"        gx[r * nc + {ns} + c] = -fu[r * {ni} + c];",
        "    }",
        f"    for (c = 0; c < {npar}; ++c) {{",
        f"        gx[r * nc + {ns + ni} + c] -= fp[r * {npar} + c];",
        "    }",
        "}",
    )


def _vi_call(module: Module) -> str:
    call = _call(module, "vi_jacobian")
    assert call is not None, "a module that differentiates the VI calls vi_jacobian"
    return f"{c_call(module.name, call)};"


def _vi_equations(module: Module) -> tuple[str, ...]:
    """The C lines of the diagonal M's VI equations' derivatives: every matrix zeroed, then
    each body's blocks from the generic body's kernel (its mass from ``jac_mass``) placed at
    its rows (position 3i, velocity 3n + 3i) and columns, dE/dp = dE/dm dM_ii/dp."""
    n, npar = module.n, len(module.parameter_names)
    n3, ns = 3 * n, 6 * n
    lay = module.layout("jacobian")
    mass = _call(module, "jac_mass")
    assert mass is not None, "the step Jacobians read M's entries"
    zero = [("ey", ns * ns), ("ex", ns * ns), ("eg", ns * n3), ("egn", ns * n3)]
    zero += [("efn", ns * n3), ("ep", ns * npar)]
    return (
        f"double *mm = work + {lay.offset('mm')}, *mp = work + {lay.offset('mp')};",
        "double bey[36], bex[36], beg[18], begn[18], befn[18], bem[6];",
        "long i, r, c;",
        "(void)mp;",
        *(line for b, size in zero for line in _zero(b, size)),
        f"{c_call(module.name, mass)};",
        f"for (i = 0; i < {n}; ++i) {{",
        f"    const double mii = mm[i * {n} + i];",
        f"    {_vi_call(module)}",
        "    for (r = 0; r < 6; ++r) {",
        f"        const long row = r < 3 ? 3 * i + r : {n3} + 3 * i + r - 3;",
        "        for (c = 0; c < 6; ++c) {",
        f"            const long col = c < 3 ? 3 * i + c : {n3} + 3 * i + c - 3;",
        f"            ey[row * {ns} + col] = bey[6 * r + c];",
        f"            ex[row * {ns} + col] = bex[6 * r + c];",
        "        }",
        "        for (c = 0; c < 3; ++c) {",
        f"            eg[row * {n3} + 3 * i + c] = beg[3 * r + c];",
        f"            egn[row * {n3} + 3 * i + c] = begn[3 * r + c];",
        f"            efn[row * {n3} + 3 * i + c] = befn[3 * r + c];",
        "        }",
        f"        for (c = 0; c < {npar}; ++c) {{",
        f"            ep[row * {npar} + c] = bem[r] * mp[(i * {n} + i) * {npar} + c];",
        "        }",
        "    }",
        "}",
    )


def _zero(buffer: str, size: int) -> tuple[str, ...]:
    return (f"for (r = 0; r < {size}; ++r) {{", f"    {buffer}[r] = 0.0;", "}")


def _vi_coupled(module: Module) -> tuple[str, ...]:
    """The C lines of a coupled M's VI equations' derivatives: every matrix zeroed, then each
    body's blocks (``vi_jacobian``) and each coupled pair's (``vi_jacobian_pair``, pairs
    i0 < j0 with M_ij != 0) added at their rows (residual 0, Cayley update 3n, velocity 6n,
    plus 3 times the body) and columns (y = (f, q+, w+), x = (q, w), G, g+, F+), and
    dE/dp = dE/dM_ij dM_ij/dp."""
    n, npar = module.n, len(module.parameter_names)
    n3, ns, ny = 3 * n, 6 * n, 9 * n
    lay = module.layout("jacobian")
    mass = _call(module, "jac_mass")
    pair = _call(module, "vi_jacobian_pair")
    assert mass is not None and pair is not None, "the coupled VI's blocks read M's entries"
    zero = [("ey", ny * ny), ("ex", ny * ns), ("eg", ny * n3), ("egn", ny * n3)]
    zero += [("efn", ny * n3), ("ep", ny * npar)]
    body_out = ["b_f", "b_qn", "b_wn", "b_q", "b_w", "b_G", "b_gn", "b_Fn"]
    pair_out = [f"p_{x}{b}" for x in ("f", "qn", "wn", "q", "w") for b in "ij"]
    # (matrix, its row length, the column of the vector's first component at body b)
    target = {
        "f": ("ey", ny, 0),
        "qn": ("ey", ny, n3),
        "wn": ("ey", ny, 2 * n3),
        "q": ("ex", ns, 0),
        "w": ("ex", ns, n3),
        "G": ("eg", n3, 0),
        "gn": ("egn", n3, 0),
        "Fn": ("efn", n3, 0),
    }

    def add(out: str, var: str, body: str) -> str:
        mat, width, col = target[var]
        return f"{mat}[row * {width} + {col} + 3 * {body} + c] += {out}[3 * r + c];"

    lines = [
        f"double *mm = work + {lay.offset('mm')}, *mp = work + {lay.offset('mp')};",
        f"double {', '.join(f'{b}[27]' for b in body_out)}, b_m[9];",
        f"double {', '.join(f'{b}[54]' for b in pair_out)}, p_m[18];",
        "long i, i0, j0, r, c;",
        "(void)mp;",
        *(line for b, size in zero for line in _zero(b, size)),
        f"{c_call(module.name, mass)};",
        f"for (i = 0; i < {n}; ++i) {{",
        f"    const double mii = mm[i * {n} + i];",
        f"    {_vi_call(module)}",
        "    for (r = 0; r < 9; ++r) {",
        f"        const long row = (r / 3) * {n3} + 3 * i + r % 3;",
        "        for (c = 0; c < 3; ++c) {",
        *(f"            {add(out, out[2:], 'i')}" for out in body_out),
        "        }",
        f"        for (c = 0; c < {npar}; ++c) {{",
        f"            ep[row * {npar} + c] += b_m[r] * mp[(i * {n} + i) * {npar} + c];",
        "        }",
        "    }",
        "}",
        f"for (i0 = 0; i0 < {n}; ++i0) {{",
        f"    for (j0 = i0 + 1; j0 < {n}; ++j0) {{",
        f"        const double mij = mm[i0 * {n} + j0];",
        "        if (mij == 0.0) {",
        "            continue;",
        "        }",
        f"        {c_call(module.name, pair)};",
        "        for (r = 0; r < 18; ++r) {",
        f"            const long row = (r % 9 / 3) * {n3} + 3 * (r < 9 ? i0 : j0) + r % 3;",
        "            for (c = 0; c < 3; ++c) {",
        *(f"                {add(out, out[2:-1], out[-1] + '0')}" for out in pair_out),
        "            }",
        f"            for (c = 0; c < {npar}; ++c) {{",
        f"                ep[row * {npar} + c] += p_m[r] * mp[(i0 * {n} + j0) * {npar} + c];",
        "            }",
        "        }",
        "    }",
        "}",
    ]
    return tuple(lines)
