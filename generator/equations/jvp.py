"""Forward-mode (tangent) kernels of the continuous field, for O(n) Jacobian-vector products.

Input: a `System` with step Jacobians asked for (`System.with_jacobians`) whose field is
solved without dense matrices: a diagonal M, or a banded or max-index M with the structured
solvers, closed (no forces, inputs or time), no V written as one expression of all positions
and no pair terms within a cutoff (`jvp_refusal`). Output: the kernels that the ``jvp`` parts
call to propagate a tangent direction (dq, dw) through the field, member by member and body by
body, never forming a matrix of the whole system:

- ``t<k>_hvp`` for structured term k whose Hessian is not zero (a term linear in the
  positions, such as gravity, has none): one member's Hessian-vector product, d(dV_k/dx)[t]
  for the member's local positions x and a tangent t of them (``t_q``, ``t_qi``, ``t_qj``),
  called in the term's own member loop (as ``t<k>_gradient``) and added into dg at the
  member's bodies; so dg = H dq costs what a gradient costs;
- diagonal M: ``jvp_diag`` (one body: the tangents of qdot = w x q and wdot = -q x g / M_ii
  in q, w and g);
- structured M (A(q) = E + H (M_off (x) I) K, `s2gen.equations.operators`): ``jvp_src``
  (the tangent of the pair sums' source u = |w|^2 q), ``jvp_ka`` (K(q) a and its tangent
  dK[dq] a at the field's wdot = a) and ``jvp_rhs`` (the tangents of qdot and of the
  right-hand side b = -q x g + q x z, less dA a = dH[dq] zy + H dzy with
  zy = (M_off (x) I) K a). The tangent of wdot then solves A(q) da = db - dA a with the
  field's own structured solve (its blocks E, H, K as the field built them), and z, zy and
  their tangents are products with M_off (``m_apply``, O(n));
- diagonal M, the explicit VI step (`_vi_diagonal`): the tangents of its position and
  velocity updates, body by body;
- structured M, the VI step (`_vi_structured`): the tangents of the step's own equations
  (known side, residual at the Cayley parameters held, Cayley update, velocity side, A(q+) w+
  at w+ held), for the implicit function theorem at the converged parameters.

SymPy takes every derivative of the kernels the field itself is printed from; nothing is
differenced.

Example:
    >>> from s2gen.systems import builtin
    >>> ks = jvp_kernels(builtin("rope", n=4, solver="structured").with_jacobians())
    >>> [k.name for k in ks][:4], len(ks)
    (['t1_hvp', 'jvp_src', 'jvp_ka', 'jvp_rhs'], 12)
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from s2gen.inertia import InertiaKind
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import q_symbols
from s2gen.system import System

__all__ = ["has_jvp", "jvp_kernels", "jvp_refusal", "tangent"]


def jvp_refusal(system: System) -> str | None:
    """Why `system`'s C cannot carry step_jvp(), or None.

    Example:
        >>> from s2gen.systems import builtin
        >>> print(jvp_refusal(builtin("double_pendulum")))
        double_pendulum: step_jvp() needs a diagonal M or the structured solvers of a banded or max-index M, not a dense M
        >>> jvp_refusal(builtin("rope", n=1000)) is None
        True
    """
    from s2gen.equations.structure import choose_solver, has_general_potential

    if system.driven:
        return f"{system.name}: step_jvp() covers closed systems (no forces, inputs or time)"
    solver = choose_solver(system)
    if solver is InertiaKind.DENSE:
        return (
            f"{system.name}: step_jvp() needs a diagonal M or the structured solvers of a "
            "banded or max-index M, not a dense M"
        )
    if has_general_potential(system) and system.potential.free_symbols & set(q_symbols(system.n)):
        return f"{system.name}: step_jvp() needs V written as terms (its general part is dense)"
    cutoff = [t.label for t in system.terms if not t.selection.fixed]
    if cutoff:
        return f"{system.name}: {cutoff[0]}: step_jvp() does not take terms within a cutoff"
    return None


def has_jvp(system: System) -> bool:
    """Whether the emitted C of `system` carries step_jvp(): asked for with the step
    Jacobians (`System.with_jacobians`) and covered (`jvp_refusal`), whatever n.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("rope", n=100)
        >>> has_jvp(s), has_jvp(s.with_jacobians())
        (False, True)
    """
    return system.jacobians and jvp_refusal(system) is None


def tangent(
    exprs: Sequence[sp.Expr], by: Sequence[tuple[Sequence[sp.Symbol], Sequence[sp.Symbol]]]
) -> tuple[sp.Expr, ...]:
    """The directional derivative of `exprs` along `by`: pairs (variables, their tangents),
    sum over variables x of d(expr)/dx t_x.

    Example:
        >>> x, y, tx, ty = sp.symbols("x y tx ty")
        >>> tangent([x * y], [((x, y), (tx, ty))])
        (tx*y + ty*x,)
    """
    out = []
    for e in exprs:
        e = sp.sympify(e)
        total = sp.Integer(0)
        for xs, ts in by:
            for x, t in zip(xs, ts):
                if x in e.free_symbols:
                    total += sp.diff(e, x) * t
        out.append(total)  # not expanded: expanding a second derivative can multiply its size
    return tuple(out)


def _vec(name: str) -> tuple[sp.Symbol, ...]:
    return tuple(sp.symbols(f"{name}_0:3", real=True))


def _arg(name: str, symbols: Sequence[sp.Symbol]) -> Argument:
    return Argument(name, tuple(symbols))


def _hvp_kernels(system: System) -> list[KernelDef]:
    """``t<k>_hvp`` per term with members: inputs the term's value kernel's, then a tangent
    ``t_<role>`` per position role; output ``hv`` (3 a) = the Hessian times the tangent."""
    from s2gen.equations.structure import term_kernels

    out = []
    for k, term in enumerate(system.terms):
        if term.count(system.n) == 0:
            continue
        value = term_kernels(system, k, term)[0]
        roles = term.roles()
        positions = term.position_symbols()
        ts = {role: _vec(f"t_{role}") for role in roles}
        by = [(positions[3 * r : 3 * r + 3], ts[role]) for r, role in enumerate(roles)]
        grad = [sp.diff(term.expr, s) for s in positions]
        hv = tangent(grad, by)
        if all(e == 0 for e in hv):
            continue
        out.append(
            KernelDef(
                f"t{k}_hvp",
                f"{term.label}: one member's Hessian in its positions times a tangent of them",
                (*value.inputs, *(_arg(f"t_{role}", ts[role]) for role in roles)),
                (Output("hv", hv),),
                stages=value.stages,
            )
        )
    return out


def _diagonal() -> list[KernelDef]:
    from s2gen.equations.continuous import continuous_kernels

    rhs = next(k for k in continuous_kernels(coupled=False) if k.name == "rhs_diag")
    _, q, w, g = (a.symbols for a in rhs.inputs)
    dq, dw, dg = _vec("dq"), _vec("dw"), _vec("dg")
    by = [(q, dq), (w, dw), (g, dg)]
    outs = {o.name: o.exprs for o in rhs.outputs}
    return [
        KernelDef(
            "jvp_diag",
            "one body's field's tangent (diagonal M): d(w x q) and d(-q x g / M_ii) along "
            "(dq, dw, dg)",
            (*rhs.inputs, _arg("dq", dq), _arg("dw", dw), _arg("dg", dg)),
            (Output("tq", tangent(outs["dq"], by)), Output("tw", tangent(outs["dw"], by))),
        )
    ]


def _vi_diagonal() -> list[KernelDef]:
    """The tangents of one explicit VI step (diagonal M): the positions and half-step
    velocity (``jvp_vpos``: q+ and w_h along (dq, dw, dg), w_h itself) and the end velocity
    (``jvp_vvel``: w+ along (dw_h, dq+, dg+))."""
    from s2gen.equations.discrete import explicit_kernels

    k = {kd.name: kd for kd in explicit_kernels()}
    pos, vel = k["vi_pos"], k["vi_vel"]
    _, _, q, w, g = (a.symbols for a in pos.inputs)
    _, _, wh, qn, gn = (a.symbols for a in vel.inputs)
    dq, dw, dg, dwh, dqn, dgn = (_vec(x) for x in ("dq", "dw", "dg", "dwh", "dqn", "dgn"))
    po = {o.name: o.exprs for o in pos.outputs}
    by = [(q, dq), (w, dw), (g, dg)]
    return [
        _kernel(
            "jvp_vpos",
            "the explicit VI's q+ and half-step velocity w_h, with their tangents along "
            "(dq, dw, dg)",
            [*pos.inputs, _arg("dq", dq), _arg("dw", dw), _arg("dg", dg)],
            [
                Output("wh", po["wh"]),
                Output("dqn", tangent(po["qn"], by)),
                Output("dwh", tangent(po["wh"], by)),
            ],
        ),
        _kernel(
            "jvp_vvel",
            "the tangent of the explicit VI's end velocity along (dw_h, dq+, dg+)",
            [*vel.inputs, _arg("dwh", dwh), _arg("dqn", dqn), _arg("dgn", dgn)],
            [Output("dwn", tangent(vel.outputs[0].exprs, [(wh, dwh), (qn, dqn), (gn, dgn)]))],
        ),
    ]


def _structured(solver: InertiaKind) -> list[KernelDef]:
    from s2gen.equations.assemble import generic_kernel_defs

    k = {kd.name: kd for kd in generic_kernel_defs(True, solver)}
    src, rhs, blocks = k["src_rhs"], k["rhs_coupled"], k["a_blocks"]
    q, w = (a.symbols for a in src.inputs)
    dq, dw, dg, dz = _vec("dq"), _vec("dw"), _vec("dg"), _vec("dz")
    a, zy, dzy = _vec("a"), _vec("zy"), _vec("dzy")
    # the blocks at this body's q (a_blocks' own symbol for q)
    bq = blocks.inputs[1].symbols
    at = dict(zip(bq, q))
    bo = {o.name: sp.Matrix(3, 3, [e.xreplace(at) for e in o.exprs]) for o in blocks.outputs}
    ka = list(bo["kq"] * sp.Matrix(a))
    hzy = list(bo["hq"] * sp.Matrix(zy))
    rq, rw, rg, rz = (x.symbols for x in rhs.inputs)
    assert tuple(rq) == tuple(q) and tuple(rw) == tuple(w), "one scheme of symbols"
    ro = {o.name: o.exprs for o in rhs.outputs}
    by = [(q, dq), (w, dw), (rg, dg), (rz, dz)]
    db = tangent(ro["b"], by)
    lift = tangent(hzy, [(q, dq), (zy, dzy)])
    return [
        KernelDef(
            "jvp_src",
            "the tangent of the pair sums' source u = |w|^2 q along (dq, dw)",
            (*src.inputs, _arg("dq", dq), _arg("dw", dw)),
            (Output("du", tangent(src.outputs[0].exprs, [(q, dq), (w, dw)])),),
        ),
        KernelDef(
            "jvp_ka",
            "K(q) a and its tangent dK[dq] a at the field's wdot a",
            (_arg("q", q), _arg("a", a), _arg("dq", dq)),
            (Output("ka", tuple(ka)), Output("dka", tangent(ka, [(q, dq)]))),
        ),
        KernelDef(
            "jvp_rhs",
            "the tangents of qdot and of b - A a at a held: db - dH[dq] zy - H dzy",
            (*rhs.inputs, _arg("zy", zy), _arg("dq", dq), _arg("dw", dw), _arg("dg", dg))
            + (_arg("dz", dz), _arg("dzy", dzy)),
            (
                Output("tq", tangent(ro["dq"], by)),
                Output("tb", tuple(sp.expand(x - y) for x, y in zip(db, lift))),
            ),
        ),
    ]


def _kernel(name: str, doc: str, inputs: list[Argument], outputs: list[Output]) -> KernelDef:
    return KernelDef(name, doc, tuple(inputs), tuple(outputs))


def _vi_structured(solver: InertiaKind) -> list[KernelDef]:
    """The tangents of one VI step's equations with a structured M (the emitted step's own
    kernels, `s2gen.equations.operators`), for the implicit function theorem at the converged
    Cayley parameters f: the known side d (``jvp_vel``, ``jvp_d``), the residual at f held
    (``jvp_dispq``, ``jvp_res``; Newton's own Jacobian then gives df), the Cayley update
    (``jvp_cay``), the velocity side c (``jvp_disp``, ``jvp_c``) and A(q+) w+ at w+ held
    (``jvp_vrhs``: dc - dA w+, A's diagonal a = M_ii |q+|^2 and its pair part)."""
    from s2gen.equations.assemble import generic_kernel_defs

    k = {kd.name: kd for kd in generic_kernel_defs(True, solver)}
    vel, dco, disp, res = k["vel"], k["d_coupled"], k["disp"], k["res_coupled"]
    cay, cco, abody, blocks = k["cayley"], k["c_coupled"], k["a_body"], k["a_blocks"]
    t = {name: _vec(f"d{name}") for name in ("q", "w", "g", "z", "d", "f", "qn", "gn", "wn")}
    t["zy"] = _vec("dzy")

    def args(kd: KernelDef) -> dict[str, tuple[sp.Symbol, ...]]:
        return {a.name: a.symbols for a in kd.inputs}

    def along(kd: KernelDef, out: str, names: tuple[str, ...]) -> tuple[sp.Expr, ...]:
        a = args(kd)
        exprs = next(o.exprs for o in kd.outputs if o.name == out)
        return tangent(exprs, [(a[x], t[x]) for x in names])

    def targs(*names: str) -> list[Argument]:
        return [_arg(f"d{x}", t[x]) for x in names]

    v = vel.outputs[0].exprs
    a_c = args(cco)
    # A(q+) w+ at body i: a w+ + hat(q+) zy, a = a_body(m, q+), zy = M_off K(q+) w+
    qn, wn, zy = a_c["qn"], _vec("wn"), _vec("zy")
    adiag = abody.outputs[0].exprs[0].xreplace(dict(zip(args(abody)["q"], qn)))
    bq = dict(zip(args(blocks)["q"], qn))
    hq = sp.Matrix(3, 3, [e.xreplace(bq) for e in blocks.outputs[1].exprs])
    aw = list(adiag * sp.Matrix(wn) + hq * sp.Matrix(zy))
    lift = tangent(aw, [(qn, t["qn"]), (zy, t["zy"])])
    m = args(abody)["m"]
    return [
        _kernel(
            "jvp_vel",
            "v = w x q and its tangent along (dq, dw)",
            [*vel.inputs, *targs("q", "w")],
            [Output("v", v), Output("dv", along(vel, "v", ("q", "w")))],
        ),
        _kernel(
            "jvp_d",
            "the tangent of the known side d along (dq, dw, dg, dz)",
            [*dco.inputs, *targs("q", "w", "g", "z")],
            [Output("dd", along(dco, "d", ("q", "w", "g", "z")))],
        ),
        _kernel(
            "jvp_dispq",
            "the tangent of the Cayley displacement F q - q along dq at f held",
            [*disp.inputs, *targs("q")],
            [Output("duq", along(disp, "u", ("q",)))],
        ),
        _kernel(
            "jvp_res",
            "the tangent of the residual at f held, along (dq, dd, dz)",
            [*res.inputs, *targs("q", "d", "z")],
            [Output("dr", along(res, "r", ("q", "d", "z")))],
        ),
        _kernel(
            "jvp_cay",
            "the tangent of q+ = cayley(f, q) along (dq, df)",
            [*cay.inputs, *targs("q", "f")],
            [Output("dqn", along(cay, "qn", ("q", "f")))],
        ),
        _kernel(
            "jvp_disp",
            "the tangent of the Cayley displacement F q - q along (dq, df)",
            [*disp.inputs, *targs("q", "f")],
            [Output("du", along(disp, "u", ("q", "f")))],
        ),
        _kernel(
            "jvp_c",
            "the tangent of the velocity side c along (dq, df, dq+, dg+, dz)",
            [*cco.inputs, *targs("q", "f", "qn", "gn", "z")],
            [Output("dc", along(cco, "c", ("q", "f", "qn", "gn", "z")))],
        ),
        _kernel(
            "jvp_vrhs",
            "dc - dA w+ at w+ held: the tangent of a w+ + hat(q+) zy along (dq+, dzy)",
            [
                Argument("m", (m,), scalar=True),
                _arg("qn", qn),
                _arg("wn", wn),
                _arg("zy", zy),
                *targs("qn", "zy"),
                _arg("dc", _vec("dc")),
            ],
            [Output("tb", tuple(c - x for c, x in zip(_vec("dc"), lift)))],
        ),
    ]


def jvp_kernels(system: System) -> list[KernelDef]:
    """The tangent kernels of `system`'s field (`has_jvp`), or none."""
    from s2gen.equations.structure import choose_solver

    if not has_jvp(system):
        return []
    solver = choose_solver(system)
    if solver is InertiaKind.DIAGONAL:
        return [*_hvp_kernels(system), *_diagonal(), *_vi_diagonal()]
    return [*_hvp_kernels(system), *_structured(solver), *_vi_structured(solver)]
