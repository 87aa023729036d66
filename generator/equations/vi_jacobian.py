"""The exact Jacobian of one variational-integrator step, by the implicit function theorem.

Input: a `System` with step Jacobians (at most `JACOBIAN_MAX_BODIES` bodies), M diagonal,
dense, banded or max-index (the same equations whichever solver solves them).
Output: the kernels of the derivatives of the equations one VI step of size h from (q, w) at
time t to (q+, w+) at t + h solves, E(y; x, u, p) = 0, in its unknowns y, in x = (q, w) and
in the parameters, with G = g(q, t) - F(q, w, t, u) at the start, g+ = g(q+, t + h) and
F+ = F(q+, w+, t + h, u) held, and in G, g+ and F+. The ``jacobian`` part assembles them at
run time, multiplies the last three into the derivatives of G, g+ and F+ (the Hessian of V
and dg/dp assembled per term member, the forces', `s2gen.equations.hessian`), solves
dy/d(x, u, p) = -E_y^-1 E_(x,u,p), whose last 6n rows are d(q+, w+)/d(x, u, p), and multiplies
the substeps' of a composition (vi4, vi6, vi8).

The equations are the emitted step's own, from the kernels of `s2gen.equations.discrete`:

- coupled M (Newton on the Cayley parameters), y = (f, q+, w+): R(f; q, w, G) = 0
  (``d_body``, ``d_pair``, ``res_body``, ``res_pair``: the residual Newton solves),
  q+ - cayley(f, q) = 0, and A(q+) w+ - c(q, f, q+, g+) - h/2 q+ x F+ = 0 (``c_body``,
  ``c_pair``, ``a_body``, the blocks -M_ij hat(q_i+) hat(q_j+)); E is a sum of one-body and
  pair parts, each differentiated once for a generic body and pair (`coupled_kernels`) and
  placed at run time at each body and each pair M couples;
- diagonal M (the explicit update), y = (q+, w+): q+ - a x q - sqrt(1 - a.a) q = 0 with
  a = h w - h^2/(2 M_ii) q x G (``vi_pos``), and M_ii (w+ - a/h) + h/2 q+ x (g+ - F+) = 0
  (``vi_vel`` with the forced end velocity); each body's rows involve it alone
  (`body_kernel`).

The parameters enter E through M (dE/dM_ii, dE/dM_ij, times dM/dp) and through G, g+, F+.
SymPy takes every derivative, nothing is differenced; the derivation does not grow with n.

Example:
    >>> from s2gen.systems import builtin
    >>> [k.name for k in vi_jacobian_kernels(builtin("double_pendulum").with_jacobians())]
    ['vi_jacobian', 'vi_jacobian_pair']
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import sympy as sp

from s2gen.equations.continuous import continuous_kernels
from s2gen.equations.discrete import explicit_kernels, newton_kernels
from s2gen.equations.hessian import sparse_jacobian
from s2gen.equations.jacobian import has_jacobian
from s2gen.inertia import InertiaKind
from s2gen.ir import Argument, KernelDef, Output
from s2gen.system import System

__all__ = ["body_kernel", "coupled_kernels", "has_vi_jacobian", "vi_jacobian_kernels"]


def has_vi_jacobian(system: System, solver: InertiaKind) -> bool:
    """Whether the emitted C differentiates the VI family's steps: whenever it has step
    Jacobians, for every solver of M (the equations are the same; a structured solver only
    solves them differently, and its Cayley parameters are the dense path's).

    Example:
        >>> from s2gen.systems import builtin
        >>> has_vi_jacobian(builtin("double_pendulum").with_jacobians(), InertiaKind.DENSE)
        True
    """
    return has_jacobian(system)


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


def _check_lower(
    groups: list[list[sp.Expr]], unknowns: list[list[sp.Symbol]], ends: list[sp.Symbol]
) -> None:
    """Assert that E's rows, in the groups of its unknowns (coupled: f, q+, w+; diagonal: q+,
    w+), involve no unknown of a later group, and, but for the last group's (w+), none of the
    end quantities g+, F+ (functions of q+ and w+): E_y is then block lower triangular, which
    the C's block forward substitution (``jac_vi_solve``) relies on."""
    for k, rows in enumerate(groups):
        later = {x for u in unknowns[k + 1 :] for x in u}
        if k < len(groups) - 1:
            later |= set(ends)
        for e in rows:
            assert not (e.free_symbols & later), "E_y is block lower triangular"


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def vi_jacobian_kernels(system: System, solver: InertiaKind | None = None) -> list[KernelDef]:
    """The kernels of the VI's equations' derivatives: a diagonal M's generic body
    (`body_kernel`), a coupled M's generic body and pair (`coupled_kernels`); none when
    `has_vi_jacobian` is false."""
    from s2gen.equations.structure import choose_solver

    solver = choose_solver(system) if solver is None else solver
    if not has_vi_jacobian(system, solver):
        return []
    if solver is InertiaKind.DIAGONAL:
        return [body_kernel()]
    return list(coupled_kernels())


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
    _check_lower([rows[:3], rows[3:]], [v["qn"], v["wn"]], v["gn"] + v["Fn"])
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


def coupled_kernels() -> tuple[KernelDef, KernelDef]:
    """The coupled M's VI equations' blocks, derived once for a generic body and a generic
    pair: E is a sum of one-body parts (rows r_i, cay_i, vel_i of body i: the residual with
    the one-body known side d_body, the Cayley update, a_body w+ - h/2 q+ x F+ - c_body) and
    pair parts (rows r_i, vel_i and r_j, vel_j: -d_pair + res_pair, the blocks -M_ij
    hat(q_i+) hat(q_j+) times w_j+ (and transposed) - c_pair; r is linear in d with
    coefficient -1). ``vi_jacobian`` (the body: 9 rows) has the derivatives in f, q+, w+
    (b_f, b_qn, b_wn), q, w (b_q, b_w), G, g+, F+ (b_G, b_gn, b_Fn), each 9 x 3, and in M_ii
    (b_m); ``vi_jacobian_pair`` (18 rows, body i's 9 then j's) those in each body's f, q+,
    w+, q, w (p_<name><i or j>, 18 x 3) and in M_ij (p_m), row-major.

    Example:
        >>> body, pair = coupled_kernels()
        >>> [o.name for o in body.outputs][:3], len(pair.outputs)
        (['b_f', 'b_qn', 'b_wn'], 11)
    """
    return _coupled_blocks()


@functools.lru_cache(maxsize=1)
def _coupled_blocks() -> tuple[KernelDef, KernelDef]:
    k = {kd.name: kd for kd in newton_kernels()}
    k["a_pair"] = next(kd for kd in continuous_kernels(coupled=True) if kd.name == "a_pair")
    h, m, mij = sp.Symbol("h", positive=True), sp.Symbol("m", positive=True), sp.Symbol("mij")
    v = {name: sp.Matrix(_vec(name, 1)) for name in _BODY_VARS + ("G", "gn", "Fn")}
    d_sym = sp.Matrix(_vec("d", 1))
    res = _apply(k, "res_body", "r", m=m, q=v["q"], f=v["f"], d=d_sym)
    assert res.jacobian(d_sym) == -sp.eye(3), "the residual is linear in d, coefficient -1"
    d = _apply(k, "d_body", "d", h=h, m=m, q=v["q"], w=v["w"], g=v["G"])
    r = res.xreplace(dict(zip(d_sym, d)))
    cay = v["qn"] - _apply(k, "cayley", "qn", q=v["q"], f=v["f"])
    c = _apply(k, "c_body", "c", h=h, m=m, q=v["q"], f=v["f"], qn=v["qn"], gn=v["gn"])
    aw = _apply(k, "a_body", "a", m=m, q=v["qn"])[0] * v["wn"] - h / 2 * v["qn"].cross(v["Fn"])
    rows = [*r, *cay, *(aw - c)]
    unknowns = [list(v[name]) for name in ("f", "qn", "wn")]
    _check_lower([rows[:3], rows[3:6], rows[6:]], unknowns, [*v["gn"], *v["Fn"]])
    body_cols = [*_BODY_VARS, "G", "gn", "Fn"]
    body = KernelDef(
        "vi_jacobian",
        "one body's part of the VI step's equations (9 rows: residual, Cayley update, "
        "velocity) differentiated in its variables and in M_ii (row-major)",
        (
            Argument("h", (h,), scalar=True),
            Argument("m", (m,), scalar=True),
            *(Argument(name, tuple(v[name])) for name in body_cols),
        ),
        (
            *(
                Output(f"b_{name}", _flat(sparse_jacobian(rows, list(v[name]))))
                for name in body_cols
            ),
            Output("b_m", tuple(sp.diff(e, m) for e in rows)),
        ),
    )
    pv = {f"{name}{b}": sp.Matrix(_vec(f"{name}{b}", 1)) for name in _BODY_VARS for b in "ij"}
    dp = {"h": h, "mij": mij, "qi": pv["qi"], "wi": pv["wi"], "qj": pv["qj"], "wj": pv["wj"]}
    rp = {"mij": mij, "qi": pv["qi"], "fi": pv["fi"], "qj": pv["qj"], "fj": pv["fj"]}
    cp = {**rp, "h": h, "qni": pv["qni"], "qnj": pv["qnj"]}
    blk = _apply(k, "a_pair", "a", mij=mij, qi=pv["qni"], qj=pv["qnj"]).reshape(3, 3)
    zero = sp.zeros(3, 1)
    rows_i = [
        -_apply(k, "d_pair", "di", **dp) + _apply(k, "res_pair", "ri", **rp),
        zero,
        blk * pv["wnj"] - _apply(k, "c_pair", "ci", **cp),
    ]
    rows_j = [
        -_apply(k, "d_pair", "dj", **dp) + _apply(k, "res_pair", "rj", **rp),
        zero,
        blk.T * pv["wni"] - _apply(k, "c_pair", "cj", **cp),
    ]
    prow = [e for block in (*rows_i, *rows_j) for e in block]
    unknowns = [[*pv[f"{name}i"], *pv[f"{name}j"]] for name in ("f", "qn", "wn")]
    groups = [prow[9 * b + 3 * g : 9 * b + 3 * g + 3] for b in (0, 1) for g in range(3)]
    _check_lower(
        [groups[0] + groups[3], groups[1] + groups[4], groups[2] + groups[5]], unknowns, []
    )
    names = [f"{name}{b}" for name in _BODY_VARS for b in "ij"]
    pair = KernelDef(
        "vi_jacobian_pair",
        "one coupled pair's part of the VI step's equations (18 rows: body i's, then j's) "
        "differentiated in both bodies' variables and in M_ij (row-major)",
        (
            Argument("h", (h,), scalar=True),
            Argument("mij", (mij,), scalar=True),
            *(Argument(name, tuple(pv[name])) for name in names),
        ),
        (
            *(Output(f"p_{name}", _flat(sparse_jacobian(prow, list(pv[name])))) for name in names),
            Output("p_m", tuple(sp.diff(e, mij) for e in prow)),
        ),
    )
    return body, pair


#: A body's variables in the coupled VI's equations: the unknowns f, q+, w+, then q, w
_BODY_VARS = ("f", "qn", "wn", "q", "w")
