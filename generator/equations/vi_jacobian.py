"""The exact Jacobian of one variational-integrator step, by the implicit function theorem.

Input: a `System` of at most `JACOBIAN_MAX_BODIES` bodies whose M is diagonal or solved densely.
Output: the whole-system kernel ``vi_jacobian``: for one VI step of size h from (q, w) at time
t to (q+, w+) at t + h, the derivatives of the equations the emitted step solves,
E(y; x, u) = 0, in its unknowns y and in x = (q, w) and the inputs u. The step Jacobian is then
dy/d(x, u) = -E_y^-1 E_(x,u), whose last 6n rows are d(q+, w+)/d(x, u); the ``jacobian`` part
solves it in C and multiplies the substeps' of a composition (vi4, vi6, vi8).

The equations are the emitted step's own, assembled for the whole system from the kernels of
`s2gen.equations.discrete` (and, driven, the forces of `s2gen.equations.driven`), with
G = g(q, t) - F(q, w, t, u) at the start and g+ = g(q+, t + h), F+ = F(q+, w+, t + h, u):

- coupled M (Newton on the Cayley parameters), y = (f, q+, w+):
  R(f; q, w, G) = 0 (``d_body``, ``d_pair``, ``res_body``, ``res_pair``: the residual Newton
  solves, so E_f is its matrix), q+ - cayley(f, q) = 0, and
  A(q+) w+ - c(q, f, q+, g+) - h/2 q+ x F+ = 0 (``c_body``, ``c_pair``, ``a_body``, the blocks
  -M_ij hat(q_i+) hat(q_j+));
- diagonal M (the explicit update), y = (q+, w+): q+ - a x q - sqrt(1 - a.a) q = 0 with
  a = h w - h^2/(2 M_ii) q x G (``vi_pos``), and M_ii (w+ - a/h) + h/2 q+ x (g+ - F+) = 0
  (``vi_vel`` with the forced end velocity).

E is written in symbols standing for G, g+ and F+; the kernel returns its derivatives with
them held and in them, and the C multiplies the latter into dG/d(q, w, u) (the Hessian of V at
the start less dF), dg+/dq+ (the Hessian at the end) and dF+/d(q+, w+, u), assembled per term
member at run time (`s2gen.equations.hessian`). SymPy takes every derivative, each row only in
the symbols it reads.

Example:
    >>> from s2gen.systems import builtin
    >>> k = vi_jacobian_kernels(builtin("double_pendulum").with_jacobians())[0]
    >>> k.name, [o.size for o in k.outputs]
    ('vi_jacobian', [324, 216, 108, 108, 72])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from s2gen.equations.continuous import continuous_kernels
from s2gen.equations.discrete import explicit_kernels, newton_kernels
from s2gen.equations.hessian import sparse_jacobian
from s2gen.equations.jacobian import has_jacobian
from s2gen.inertia import InertiaKind
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import q_symbols, w_symbol
from s2gen.system import System

__all__ = ["has_vi_jacobian", "vi_jacobian_kernels", "vi_step_equations"]


def has_vi_jacobian(system: System, solver: InertiaKind) -> bool:
    """Whether the emitted C differentiates the VI family's steps (M diagonal or dense).

    Example:
        >>> from s2gen.systems import builtin
        >>> has_vi_jacobian(builtin("double_pendulum").with_jacobians(), InertiaKind.DENSE)
        True
    """
    return has_jacobian(system) and solver in (InertiaKind.DIAGONAL, InertiaKind.DENSE)


def _vec(name: str, n: int) -> list[sp.Symbol]:
    return list(sp.symbols(f"{name}_0:{3 * n}", real=True))


def _apply(kernels: dict[str, KernelDef], name: str, output: str, **args: Any) -> sp.Matrix:
    """Output `output` of kernel `name` with its inputs replaced by `args` (vectors or
    scalars, by argument name)."""
    k = kernels[name]
    subs: dict[sp.Symbol, sp.Expr] = {}
    for a in k.inputs:
        value = args[a.name]
        values = [value] if a.scalar else list(value)
        subs.update(zip(a.symbols, values))
    out = next(o for o in k.outputs if o.name == output)
    return sp.Matrix([e.xreplace(subs) for e in out.exprs])


@dataclass(frozen=True)
class _Step:
    """The symbols of one step: per body i, its 3-vectors (`at`), M, h and the symbols that
    stand for G = g - F at the start, g+ and F+."""

    n: int
    M: sp.Matrix
    h: sp.Symbol
    vectors: dict[str, list[sp.Symbol]]

    def at(self, name: str, i: int) -> sp.Matrix:
        return sp.Matrix(self.vectors[name][3 * i : 3 * i + 3])


def vi_step_equations(system: System, coupled: bool) -> dict[str, Any]:
    """E (a column), the unknowns y, the variables x = (q, w), the symbol h and the symbols
    standing for G = g - F at the start, g+ and F+ in E (`inner`), of one VI step of
    `system`, as in the module docstring.

    Example:
        >>> from s2gen.systems import builtin
        >>> eq = vi_step_equations(builtin("four_pendula"), coupled=False)
        >>> eq["E"].shape, len(eq["y"]), sorted(eq["inner"])
        ((24, 1), 24, ['Fn', 'G', 'gn'])
    """
    n = system.n
    qs = q_symbols(n)
    ws = [w_symbol(i, c) for i in range(1, n + 1) for c in range(3)]
    names = ("f", "qn", "wn", "G", "gn", "Fn")
    st = _Step(n, system.inertia, sp.Symbol("h", positive=True), {"q": qs, "w": ws})
    st.vectors.update({name: _vec(name, n) for name in names})
    # E is written in symbols standing for G, g+ and F+: their derivatives (the Hessian of V,
    # the forces') are assembled per term member at run time and multiplied in by the C
    if coupled:
        eqs = _coupled(st)
        unknowns = st.vectors["f"] + st.vectors["qn"] + st.vectors["wn"]
    else:
        eqs = _diagonal(st)
        unknowns = st.vectors["qn"] + st.vectors["wn"]
    inner = {name: st.vectors[name] for name in ("G", "gn", "Fn")}
    return {"E": eqs, "y": unknowns, "x": qs + ws, "h": st.h, "inner": inner}


def _coupled(st: _Step) -> sp.Matrix:
    """E of the Newton step: residual, Cayley update, velocity equations."""
    k = {kd.name: kd for kd in newton_kernels()}
    k["a_pair"] = next(kd for kd in continuous_kernels(coupled=True) if kd.name == "a_pair")
    n, M, h, at = st.n, st.M, st.h, st.at
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n) if M[i, j] != 0]
    d = [
        _apply(k, "d_body", "d", h=h, m=M[i, i], q=at("q", i), w=at("w", i), g=at("G", i))
        for i in range(n)
    ]
    for i, j in pairs:
        args = {"h": h, "mij": M[i, j], "qi": at("q", i), "wi": at("w", i)}
        args.update({"qj": at("q", j), "wj": at("w", j)})
        d[i] += _apply(k, "d_pair", "di", **args)
        d[j] += _apply(k, "d_pair", "dj", **args)
    r = [
        _apply(k, "res_body", "r", m=M[i, i], q=at("q", i), f=at("f", i), d=d[i]) for i in range(n)
    ]
    c = [
        _apply(
            k,
            "c_body",
            "c",
            h=h,
            m=M[i, i],
            q=at("q", i),
            f=at("f", i),
            qn=at("qn", i),
            gn=at("gn", i),
        )
        for i in range(n)
    ]
    aw = [
        _apply(k, "a_body", "a", m=M[i, i], q=at("qn", i))[0] * at("wn", i)
        - h / 2 * at("qn", i).cross(at("Fn", i))
        for i in range(n)
    ]
    for i, j in pairs:
        args = {"mij": M[i, j], "qi": at("q", i), "fi": at("f", i), "qj": at("q", j)}
        args["fj"] = at("f", j)
        r[i] += _apply(k, "res_pair", "ri", **args)
        r[j] += _apply(k, "res_pair", "rj", **args)
        args.update({"h": h, "qni": at("qn", i), "qnj": at("qn", j)})
        c[i] += _apply(k, "c_pair", "ci", **args)
        c[j] += _apply(k, "c_pair", "cj", **args)
        blk = _apply(k, "a_pair", "a", mij=M[i, j], qi=at("qn", i), qj=at("qn", j)).reshape(3, 3)
        aw[i] += blk * at("wn", j)
        aw[j] += blk.T * at("wn", i)
    cay = [at("qn", i) - _apply(k, "cayley", "qn", q=at("q", i), f=at("f", i)) for i in range(n)]
    rows = [*r, *cay, *(aw[i] - c[i] for i in range(n))]
    return sp.Matrix([e for v in rows for e in v])


def _diagonal(st: _Step) -> sp.Matrix:
    """E of the explicit update: positions, then the (forced) end velocities."""
    k = {kd.name: kd for kd in explicit_kernels()}
    pos, vel = [], []
    for i in range(st.n):
        m = st.M[i, i]
        args = {"h": st.h, "m": m, "q": st.at("q", i), "w": st.at("w", i), "g": st.at("G", i)}
        qn, wn = st.at("qn", i), st.at("wn", i)
        pos.append(qn - _apply(k, "vi_pos", "qn", **args))
        wh = _apply(k, "vi_pos", "wh", **args)
        vel.append(m * (wn - wh) + st.h / 2 * qn.cross(st.at("gn", i) - st.at("Fn", i)))
    return sp.Matrix([e for v in (*pos, *vel) for e in v])


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def vi_jacobian_kernels(system: System, solver: InertiaKind | None = None) -> list[KernelDef]:
    """The ``vi_jacobian`` kernel: for a diagonal M the generic body's (`body_kernel`), else
    the whole system's: ey = dE/dy (ny x ny), ex = dE/dx (ny x 6n) with G, g+ and
    F+ held, eg, egn, efn = dE/dG, dE/dg+, dE/dF+ (ny x 3n; efn with forces only) and
    ep = dE/dp with G, g+, F+ held (ny x parameters: M's dependence), row-major; none when `has_vi_jacobian` is false. The C multiplies the last three into the
    derivatives of G, g+ and F+ (the Hessian of V and the forces' derivatives, assembled per
    term member, `s2gen.equations.hessian`)."""
    from s2gen.equations.structure import choose_solver

    solver = choose_solver(system) if solver is None else solver
    if not has_vi_jacobian(system, solver):
        return []
    n = system.n
    coupled = solver is not InertiaKind.DIAGONAL
    if not coupled:
        return [body_kernel()]
    eq = vi_step_equations(system, coupled)
    E, y, x, h, inner = eq["E"], eq["y"], eq["x"], eq["h"], eq["inner"]
    if not system.forces:  # F+ = 0
        E = E.xreplace(dict.fromkeys(inner["Fn"], sp.Integer(0)))
    rows = list(E)
    outputs = [
        Output("ey", _flat(sparse_jacobian(rows, y))),
        Output("ex", _flat(sparse_jacobian(rows, x))),
        Output("eg", _flat(sparse_jacobian(rows, inner["G"]))),
        Output("egn", _flat(sparse_jacobian(rows, inner["gn"]))),
    ]
    if system.forces:
        outputs.append(Output("efn", _flat(sparse_jacobian(rows, inner["Fn"]))))
    if system.parameter_symbols:  # through M (G, g+ and F+ held)
        outputs.append(Output("ep", _flat(sparse_jacobian(rows, list(system.parameter_symbols)))))
    qns, wns = _vec("qn", n), _vec("wn", n)
    args = [
        Argument("h", (h,), scalar=True),
        Argument("q", tuple(q_symbols(n))),
        Argument("w", tuple(w_symbol(i, c) for i in range(1, n + 1) for c in range(3))),
        *((Argument("f", tuple(_vec("f", n))),) if coupled else ()),
        Argument("qn", tuple(qns)),
        Argument("wn", tuple(wns)),
        Argument("G", tuple(inner["G"])),
        Argument("gn", tuple(inner["gn"])),
        *((Argument("Fn", tuple(inner["Fn"])),) if system.forces else ()),
    ]
    return [
        KernelDef(
            "vi_jacobian",
            "one VI step's equations E(y; x, u) = 0 in G = g - F, g+ and F+: ey = dE/dy, "
            "ex = dE/d(q, w), eg = dE/dG, egn = dE/dg+, efn = dE/dF+, ep = dE/dp (row-major)",
            (Argument("p", system.parameter_symbols), *args),
            tuple(outputs),
            system=True,
            stages=(("p", 0),),
        )
    ]


def body_kernel() -> KernelDef:
    """The diagonal M's ``vi_jacobian`` kernel, derived once for a generic body (its
    equations involve no other body): with the body's 6 rows of E (position, then velocity)
    and its mass m, ey = dE/d(q+, w+), ex = dE/d(q, w) (6 x 6), eg, egn, efn = dE/d(G, g+, F+)
    (6 x 3) and em = dE/dm (6), row-major; the C places them at the body's rows and columns
    (and multiplies em into dM_ii/dp).

    Example:
        >>> [(o.name, o.size) for o in body_kernel().outputs]
        [('bey', 36), ('bex', 36), ('beg', 18), ('begn', 18), ('befn', 18), ('bem', 6)]
    """
    m = sp.Symbol("m", positive=True)
    st = _Step(1, sp.Matrix([[m]]), sp.Symbol("h", positive=True), {})
    names = ("q", "w", "qn", "wn", "G", "gn", "Fn")
    st.vectors.update({name: _vec(name, 1) for name in names})
    rows = list(_diagonal(st))
    v = st.vectors
    outputs = (
        Output("bey", _flat(sparse_jacobian(rows, v["qn"] + v["wn"]))),
        Output("bex", _flat(sparse_jacobian(rows, v["q"] + v["w"]))),
        Output("beg", _flat(sparse_jacobian(rows, v["G"]))),
        Output("begn", _flat(sparse_jacobian(rows, v["gn"]))),
        Output("befn", _flat(sparse_jacobian(rows, v["Fn"]))),
        Output("bem", tuple(sp.diff(e, m) for e in rows)),
    )
    return KernelDef(
        "vi_jacobian",
        "one body's rows of the VI step's equations (diagonal M): bey = dE/d(q+, w+), "
        "bex = dE/d(q, w), beg, begn, befn = dE/d(G, g+, F+), bem = dE/dm (row-major)",
        (
            Argument("h", (st.h,), scalar=True),
            Argument("m", (m,), scalar=True),
            *(Argument(name, tuple(v[name])) for name in names),
        ),
        outputs,
    )
