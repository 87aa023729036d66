"""Print the NumPy records of the step Jacobians (``m.py_jac``, read by ``numpy/_jacobian.jinja``).

Input: a lowered sphere `Module` whose parts include ``jacobian``. Output: the methods the
NumPy module's step_jacobian() differentiates (the C's: `s2gen.printing.jacobian`), each
explicit one with its tableau as round-trip literals and the VI family's with its step
fractions, and the NumPy lines that differ by module: the Hessian of V and dg/d(u, p) from
V's general part and each term's member loop (the ``t<k>_hessian`` kernels called on all
members at once, their blocks scattered with ``numpy.add.at``), the forces' part of
G = g - F and its derivatives, the VI's equations' derivatives from the generic body's (and,
coupled M, pair's) blocks evaluated on all bodies (pairs) at once and placed at their rows
and columns, the substep the VI family takes and the time and inputs of a driven module. The
kernels are the ones the C calls (`s2gen.equations.jacobian`, `s2gen.equations.hessian`,
`s2gen.equations.vi_jacobian`); the call sites' text comes from `s2gen.printing.numpy.py_call`.
Empty for a module without the part.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> jac = print_numpy_jacobian(lower_system(builtin("double_pendulum").with_jacobians()))
    >>> [x["c_name"] for x in jac["rk"]][:2], jac["hessian"][0]
    (['METHOD_RK2', 'METHOD_RK2_PROJ'], 'H, gp = _k_hessian(q, cc)')
"""

from __future__ import annotations

from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.ir import Call, Module
from s2gen.methods import METHODS, Family, driven_methods, fixed_methods
from s2gen.printing.numpy import py_call

__all__ = ["print_numpy_jacobian"]

_KEYS = (
    "rk",
    "vi",
    "ninputs",
    "mass_out",
    "mass",
    "hessian",
    "force",
    "setup",
    "step",
    "stage_time",
    "stage_force",
    "field_time",
    "vi_substep",
    "vi_end_time",
    "vi_start_time",
    "vi_equations",
    "vi_force",
    "ny",
    "yq",
)


def _call(module: Module, site: str) -> Call | None:
    return next((c for c in module.calls if c.site == site), None)


def _lits(values: Any) -> str:
    return ", ".join(repr(float(v)) for v in values) + ","


def print_numpy_jacobian(module: Module) -> dict[str, Any]:
    """The ``m.py_jac`` record of a module (every key empty without the ``jacobian`` part)."""
    if "jacobian" not in module.parts:
        return dict.fromkeys(_KEYS, ())
    drive = module.drive
    if drive is None:
        rows = list(fixed_methods(module.kind.value))
    else:
        rows = [m for m in METHODS if m.name in driven_methods() and m.tableau is not None]
    rk = []
    for m in rows:
        t = m.tableau
        assert t is not None, "fixed-step methods have a tableau"
        s = t.stages
        a = [row[j] if j < len(row) else 0 for row in t.a for j in range(s)]
        rk.append(
            {
                "c_name": m.c_name,
                "name": m.name,
                "a": _lits(a),
                "b": _lits(t.b),
                "c": _lits(t.c),
                "project": repr(m.project),
            }
        )
    ni = len(drive.inputs) if drive is not None else 0
    params = bool(module.parameter_names)
    mass_out = "mm, mp" if params else "mm"
    mass = ["mm = mm.reshape(NBODIES, NBODIES)"]
    mass.append(
        "mp = mp.reshape(NBODIES, NBODIES, NPARAMS)"
        if params
        else "mp = numpy.zeros((NBODIES, NBODIES, 0))"
    )
    if drive is None:
        setup: tuple[str, ...] = ("tu = None",)
        step = ("status, qn, wn = rk_step(p, method, h, q, w)",)
        stage_time: tuple[str, ...] = ()
        field_time: tuple[str, ...] = ()
    else:
        setup = (
            "tu = TU_DEFAULTS.copy()",
            "if u is not None:",
            "    tu[1:] = numpy.asarray(u, dtype=float).reshape(NINPUTS)",
        )
        step = (
            (
                "status, qn, wn, _, _ = step(p, method, t, h, q, w, tu[1:], newton_tol, "
                "newton_maxiter)"
            ),
        )
        stage_time = ("tu[0] = t + c[i] * h",)
        field_time = ("tu[0] = t",)
    stage_force: tuple[str, ...] = ()
    if drive is not None and drive.forces:
        stage_force = (
            "if status == OK:",
            "    status, ki, _ = _stage_force(p, cc, ys[:NBODIES], ys[NBODIES:], ki, tu)",
        )
    return {
        **_vi(module),
        "rk": tuple(rk),
        "ninputs": str(ni),
        "mass_out": mass_out,
        "mass": tuple(mass),
        "hessian": _hessian_lines(module),
        "force": _force_lines(module),
        "setup": setup,
        "step": step,
        "stage_time": stage_time,
        "stage_force": stage_force,
        "field_time": field_time,
    }


def _hessian_lines(module: Module) -> tuple[str, ...]:
    """Lines setting H (3n x 3n) and gp (3n x (inputs + parameters)): V's general part or
    zeros, then each term's members' blocks added at their bodies."""
    nz = len(module.parameter_names) + (len(module.drive.inputs) if module.drive else 0)
    general = _call(module, "hessian")
    n3 = "3 * NBODIES"
    if general is None:
        lines = [f"H = numpy.zeros(({n3}, {n3}))", f"gp = numpy.zeros(({n3}, {nz}))"]
    elif nz:
        lines = [
            f"H, gp = {py_call(general)}",
            f"H, gp = H.reshape({n3}, {n3}), gp.reshape({n3}, {nz})",
        ]
    else:
        lines = [f"H = {py_call(general)}.reshape({n3}, {n3})", f"gp = numpy.zeros(({n3}, 0))"]
    for t in module.terms:
        call = _call(module, f"t{t.index}_hessian")
        assert call is not None, "every term of a module with step Jacobians has its Hessian"
        names = [f"T{t.index}_{i.upper()}" for i in t.loop.kind.kind.indices]
        size = 3 * len(names)
        lines += [
            f"hb, gpb = {py_call(call)}" if nz else f"hb = {py_call(call)}",
            (
                f"at = (3 * numpy.stack([{', '.join(names)}], axis=-1)[:, :, None]"
                " + numpy.arange(3)).reshape(-1, "
                f"{size})"
            ),
            f"numpy.add.at(H, (at[:, :, None], at[:, None, :]), hb.reshape(-1, {size}, {size}))",
        ]
        if nz:
            lines.append(f"numpy.add.at(gp, at, gpb.reshape(-1, {size}, {nz}))")
    return tuple(lines)


def _force_lines(module: Module) -> tuple[str, ...]:
    """Lines taking the forces out of G and gx = dG/d(q, w, u, p), keeping F and its
    derivatives (fq, fw, fu, fp); none without forces."""
    call = _call(module, "force_jacobian")
    if call is None:
        return ()
    ni = len(module.drive.inputs) if module.drive is not None else 0
    npar = len(module.parameter_names)
    outs = ["F", "fq", "fw", *(("fu",) if ni else ()), *(("fp",) if npar else ())]
    n3 = "3 * NBODIES"
    lines = [
        f"{', '.join(outs)} = {py_call(call)}",
        f"fq, fw = fq.reshape({n3}, {n3}), fw.reshape({n3}, {n3})",
    ]
    if ni:
        lines.append(f"fu = fu.reshape({n3}, {ni})")
    if npar:
        lines.append(f"fp = fp.reshape({n3}, NPARAMS)")
    lines += [
        "G = G - F.reshape(NBODIES, 3)",
        f"gx[:, :{n3}] -= fq",
        f"gx[:, {n3}:6 * NBODIES] = -fw",
        *((f"gx[:, 6 * NBODIES:6 * NBODIES + {ni}] -= fu",) if ni else ()),
        *((f"gx[:, 6 * NBODIES + {ni}:] -= fp",) if npar else ()),
    ]
    return tuple(lines)


def _vi(module: Module) -> dict[str, Any]:
    """The VI family's entries: its methods' step fractions, the size of a substep's unknowns
    (ny), where q+ starts among them (yq), the lines of one substep from (qs, ws) at ts into
    (qd, wd) with its Cayley parameters f, and those of its equations' derivatives."""
    names = {k.name for k in module.kernels}
    if "vi_jacobian" not in names:
        return {
            "vi": (),
            "vi_substep": (),
            "vi_end_time": (),
            "vi_start_time": (),
            "vi_equations": (),
            "vi_force": (),
            "ny": "0",
            "yq": "0",
        }
    drive = module.drive
    vi = tuple(
        {"c_name": m.c_name, "name": m.name, "fractions": _lits(m.composition.fractions)}
        for m in METHODS
        if m.family is Family.VI
        and m.composition is not None
        and (drive is None or m.name in driven_methods())
    )
    coupled = module.solver is not InertiaKind.DIAGONAL
    advance = "status, qd, wd, _, its, f = _vi_advance(p, hs, qs, ws, g, newton_tol, newton_maxiter"
    if drive is None:
        substep: tuple[str, ...] = ("g = gradient(p, qs)", f"{advance})")
    else:
        substep = (
            "tu[0] = ts",
            "g = gradient(p, qs, tu)",
            *(
                (
                    "F0, _ = _forces(p, cc, qs, ws, tu)",
                    "g = g - F0.reshape(NBODIES, 3)",
                )
                if drive.forces
                else ()
            ),
            "tu[0] = ts + hs",
            f"{advance}, None, tu)",
            *(
                (
                    "if status == OK:",
                    (
                        "    status, wd, _, its = _end_velocity(p, cc, hs, qd, wd, tu, newton_tol, "
                        "newton_maxiter)"
                    ),
                )
                if drive.forces
                else ()
            ),
            "tu[0] = ts",
        )
    n3 = "3 * NBODIES"
    yq = n3 if coupled else "0"
    force: tuple[str, ...] = ()
    if _call(module, "force_jacobian") is not None:
        ni = len(drive.inputs) if drive is not None else 0
        force = (
            f"ey[:, {yq}:{yq} + {n3}] += efn @ fq",
            f"ey[:, {yq} + {n3}:{yq} + 6 * NBODIES] += efn @ fw",
            *((f"ex[:, 6 * NBODIES:6 * NBODIES + {ni}] += efn @ fu",) if ni else ()),
            *((f"ex[:, 6 * NBODIES + {ni}:] += efn @ fp",) if module.parameter_names else ()),
        )
    timed = drive is not None
    return {
        "vi": vi,
        "vi_substep": substep,
        "vi_end_time": ("tu[0] = ts + hs",) if timed else (),
        "vi_start_time": ("tu[0] = ts",) if timed else (),
        "vi_equations": _coupled_lines(module) if coupled else _diagonal_lines(module),
        "vi_force": force,
        "ny": f"{9 if coupled else 6} * NBODIES",
        "yq": yq,
    }


def _diagonal_lines(module: Module) -> tuple[str, ...]:
    """The diagonal M's equations' derivatives: the generic body's blocks on all bodies,
    placed at each body's rows (position 3i, velocity 3n + 3i) and columns."""
    call = _call(module, "vi_jacobian")
    assert call is not None, "a module that differentiates the VI calls vi_jacobian"
    return (
        "mii = numpy.diag(mm)",
        f"bey, bex, beg, begn, befn, bem = {py_call(call)}",
        "body = 3 * numpy.arange(NBODIES)[:, None] + numpy.arange(3)",
        "rows = numpy.concatenate([body, 3 * NBODIES + body], axis=1)",
        "ey[rows[:, :, None], rows[:, None, :]] = bey.reshape(-1, 6, 6)",
        "ex0[rows[:, :, None], rows[:, None, :]] = bex.reshape(-1, 6, 6)",
        "eg[rows[:, :, None], body[:, None, :]] = beg.reshape(-1, 6, 3)",
        "egn[rows[:, :, None], body[:, None, :]] = begn.reshape(-1, 6, 3)",
        "efn[rows[:, :, None], body[:, None, :]] = befn.reshape(-1, 6, 3)",
        "index = numpy.arange(NBODIES)",
        "ep[rows] = bem.reshape(-1, 6, 1) * mp[index, index][:, None, :]",
    )


#: Where a variable's columns start: (matrix, offset of body 0's first column)
_TARGET = {
    "f": ("ey", "0"),
    "qn": ("ey", "3 * NBODIES"),
    "wn": ("ey", "6 * NBODIES"),
    "q": ("ex0", "0"),
    "w": ("ex0", "3 * NBODIES"),
    "G": ("eg", "0"),
    "gn": ("egn", "0"),
    "Fn": ("efn", "0"),
}


def _coupled_lines(module: Module) -> tuple[str, ...]:
    """A coupled M's equations' derivatives: the generic body's blocks on all bodies and the
    generic pair's on the pairs i < j that M (or dM/dp) couples, added at their rows
    (residual 0, Cayley update 3n, velocity 6n, plus 3 times the body) and columns."""
    body_call, pair_call = _call(module, "vi_jacobian"), _call(module, "vi_jacobian_pair")
    assert body_call is not None and pair_call is not None, "the coupled VI's blocks"
    body_out = ["f", "qn", "wn", "q", "w", "G", "gn", "Fn"]
    pair_out = [(x, b) for x in ("f", "qn", "wn", "q", "w") for b in "ij"]
    lines = [
        "mii = numpy.diag(mm)",
        f"{', '.join(f'b_{x}' for x in body_out)}, b_m = {py_call(body_call)}",
        "index = numpy.arange(NBODIES)",
        "local = numpy.arange(9)",
        "rows = (local // 3 * 3 * NBODIES + local % 3)[None, :] + 3 * index[:, None]",
        "cols = 3 * index[:, None] + numpy.arange(3)",
    ]
    for x in body_out:
        mat, off = _TARGET[x]
        lines.append(
            f"numpy.add.at({mat}, (rows[:, :, None], {off} + cols[:, None, :]), "
            f"b_{x}.reshape(-1, 9, 3))"
        )
    lines += [
        "numpy.add.at(ep, rows, b_m.reshape(-1, 9, 1) * mp[index, index][:, None, :])",
        "# the pairs i < j M couples (or whose M_ij the parameters move)",
        "PAIR_I, PAIR_J = numpy.nonzero(numpy.triu((mm != 0.0) | numpy.any(mp != 0.0, axis=2), 1))",
        "mij = mm[PAIR_I, PAIR_J]",
        f"{', '.join(f'p_{x}{b}' for x, b in pair_out)}, p_m = {py_call(pair_call)}",
        "local = numpy.arange(18)",
        (
            "rows = (local % 9 // 3 * 3 * NBODIES + local % 3)[None, :] + 3 * numpy.where("
            "local < 9, PAIR_I[:, None], PAIR_J[:, None])"
        ),
        "cols_i = 3 * PAIR_I[:, None] + numpy.arange(3)",
        "cols_j = 3 * PAIR_J[:, None] + numpy.arange(3)",
    ]
    for x, b in pair_out:
        mat, off = _TARGET[x]
        lines.append(
            f"numpy.add.at({mat}, (rows[:, :, None], {off} + cols_{b}[:, None, :]), "
            f"p_{x}{b}.reshape(-1, 18, 3))"
        )
    lines.append("numpy.add.at(ep, rows, p_m.reshape(-1, 18, 1) * mp[PAIR_I, PAIR_J][:, None, :])")
    return tuple(lines)
