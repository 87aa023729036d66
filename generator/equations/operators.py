"""The coupled equations in factored form, for the structured (O(n)) solvers.

Input: nothing system-specific. Output: `KernelDef`s for one body that the structured
templates apply in loops, and the proof (SymPy assertions, run once per process) that they
are the same equations as the pair kernels of `continuous.py` and `discrete.py`.

Every pair term of the (S^2)^n equations is M_ij times something of body i applied to a
*source* of body j: the sums over pairs are matrix-vector products z = M_off u, which a
structured M does in O(n) (prefix and suffix sums for MAX_INDEX, a loop over the few coupled
pairs for BANDED):
    known side   d_i += h q_i x z_i,          u_j = omega_j x q_j
    residual     r_i += q_i x z_i,            u_j = F_j q_j - q_j (Cayley displacement)
    velocity     c_i += q_i+ x z_i / h,       u_j = F_j q_j - q_j
    field        b_i += q_i x z_i,            u_j = |omega_j|^2 q_j
    energy       T   += 1/2 v_i . z_i,        u_j = v_j = omega_j x q_j
    momentum     J   += q_i x z_i,            u_j = v_j.
Every coupled linear operator has the form L = E + H (M_off (x) I_r) K with E, H, K block
diagonal (one block per body): the Newton Jacobian (E_i = dr_i/df_i, H_i = hat(q_i),
K_j = d(F_j q_j)/df_j), A(q) (E_i = a_i I, H_i = hat(q_i), K_j = -hat(q_j)), RATTLE's
multiplier systems (E_i = [[M_ii I, -x_i], [s xn_i^T, 0]] with H = [I; 0], K = [I, 0]) and M
itself (E_i = M_ii, H = K = 1). The kernels below give the sources, the per-body parts and the
blocks; `s2gen.equations.assemble` picks the templates that sum and solve them.

Example:
    >>> sorted(k.name for k in operator_kernels(chain=True))[:4]
    ['a_blocks', 'c_coupled', 'd_coupled', 'disp']
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import sympy as sp

from s2gen.equations.continuous import continuous_kernels
from s2gen.equations.discrete import newton_kernels
from s2gen.equations.geometry import cayley_displacement, dot, hat
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import vector

__all__ = ["operator_kernels", "verify_factorization"]

H = sp.Symbol("h", positive=True)
M_II = sp.Symbol("m", positive=True)
M_IJ = sp.Symbol("mij", real=True)
A_DIAG = sp.Symbol("a", real=True)
AC = sp.Symbol("ac", real=True)


def _s(sym: sp.Symbol) -> Argument:
    return Argument(sym.name, (sym,), scalar=True)


def _a(name: str) -> Argument:
    return Argument(name, tuple(vector(name)))


def _o(name: str, v: sp.Matrix) -> Output:
    return Output(name, tuple(v))


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def _zero(v: sp.Matrix) -> bool:
    return bool(v.applyfunc(lambda e: sp.expand(e)) == sp.zeros(*v.shape))


@functools.cache
def verify_factorization() -> bool:
    """Assert (SymPy) that each pair kernel is M_ij times the factored form used here.

    Example:
        >>> verify_factorization()
        True
    """
    kernels = {k.name: k for k in (*continuous_kernels(coupled=True), *newton_kernels())}
    qi, qj, wi, wj, fj, qni = (vector(s) for s in ("qi", "qj", "wi", "wj", "fj", "qni"))
    out = {name: {o.name: sp.Matrix(o.exprs) for o in k.outputs} for name, k in kernels.items()}
    vj, disp_j = wj.cross(qj), cayley_displacement(fj, qj)
    checks = [
        (out["d_pair"]["di"], H * qi.cross(M_IJ * vj)),
        (out["res_pair"]["ri"], qi.cross(M_IJ * disp_j)),
        (out["c_pair"]["ci"], qni.cross(M_IJ * disp_j) / H),
        (out["rhs_pair"]["bi"], qi.cross(M_IJ * dot(wj, wj) * qj)),
        (out["mom_pair"]["j"], qi.cross(M_IJ * vj) + qj.cross(M_IJ * wi.cross(qi))),
        (out["kin_pair"]["t"], sp.Matrix([M_IJ * dot(wi.cross(qi), vj)])),
        (out["a_pair"]["a"], sp.Matrix(_flat(M_IJ * hat(qi) * -hat(qj)))),
        (out["res_pair"]["jij"], sp.Matrix(_flat(M_IJ * hat(qi) * disp_j.jacobian(fj)))),
    ]
    for pair, factored in checks:
        assert _zero(pair - factored), "a pair kernel is not M_ij (body i) x (source of j)"
    return True


def _body_parts(coupled: Sequence[KernelDef]) -> dict[str, sp.Matrix]:
    """The one-body parts of the coupled kernels (M_ij = 0), in the body's own symbols."""
    kernels = {k.name: k for k in coupled}
    return {
        f"{name}.{o.name}": sp.Matrix(o.exprs)
        for name in ("d_body", "res_body", "c_body", "rhs_body")
        for o in kernels[name].outputs
    }


def operator_kernels(chain: bool, coupled: Sequence[KernelDef] | None = None) -> list[KernelDef]:
    """Per-body kernels of the structured solvers; `chain` adds MAX_INDEX's energy sweeps.
    `coupled` are the dense path's kernels (derived here when not given), whose one-body parts
    these extend; `verify_factorization` proves the pair parts equal (run by the tests).

    Example:
        >>> [k.name for k in operator_kernels(chain=False)][-1]
        'rattle_vel_blocks'
    """
    if coupled is None:
        coupled = (*continuous_kernels(coupled=True), *newton_kernels())
    parts = _body_parts(coupled)
    q, w, f, z = (vector(s) for s in ("q", "w", "f", "z"))
    qn, x, xn = vector("qn"), vector("x"), vector("xn")
    v = w.cross(q)
    u = cayley_displacement(f, q)
    eye3 = sp.eye(3)

    def rattle(sign: int, left: sp.Matrix) -> sp.Matrix:
        e = sp.zeros(4, 4)
        e[:3, :3] = M_II * eye3
        e[:3, 3] = -left
        e[3, :3] = sign * xn.T
        return e

    ks = [
        KernelDef(
            "vel",
            "velocity of one body, omega x q (the source of the known side's pair sums)",
            (_a("q"), _a("w")),
            (_o("v", v),),
        ),
        KernelDef(
            "d_coupled",
            "known side d_i: one-body part plus h q_i x z_i, z_i = sum_j M_ij omega_j x q_j",
            (_s(H), _s(M_II), _a("q"), _a("w"), _a("g"), _a("z")),
            (_o("d", parts["d_body.d"] + H * q.cross(z)),),
        ),
        KernelDef(
            "disp",
            "Cayley displacement F q - q of one body and its Jacobian in f (row-major): the "
            "source of the residual's pair sums and the block K of the Newton Jacobian",
            (_a("q"), _a("f")),
            (_o("u", u), Output("kd", _flat(u.jacobian(f)))),
        ),
        KernelDef(
            "res_coupled",
            "residual r_i = one-body part + q_i x z_i (z_i = sum_j M_ij (F_j q_j - q_j)); the "
            "diagonal block E_i = dr_i/df_i and H_i = hat(q_i) of the Newton Jacobian",
            (_s(M_II), _a("q"), _a("f"), _a("d"), _a("z")),
            (
                _o("r", parts["res_body.r"] + q.cross(z)),
                Output("e", tuple(parts["res_body.jac"])),
                Output("hq", _flat(hat(q))),
            ),
        ),
        KernelDef(
            "c_coupled",
            "velocity right side c_i: one-body part plus q_i+ x z_i / h",
            (_s(H), _s(M_II), _a("q"), _a("f"), _a("qn"), _a("gn"), _a("z")),
            (_o("c", parts["c_body.c"] + qn.cross(z) / H),),
        ),
        KernelDef(
            "src_rhs",
            "source of the field's pair sums, |omega|^2 q",
            (_a("q"), _a("w")),
            (_o("u", dot(w, w) * q),),
        ),
        KernelDef(
            "rhs_coupled",
            "vector field: qdot = omega x q and b_i = -q_i x g_i + q_i x z_i",
            (_a("q"), _a("w"), _a("g"), _a("z")),
            (_o("dq", parts["rhs_body.dq"]), _o("b", parts["rhs_body.b"] + q.cross(z))),
        ),
        KernelDef(
            "a_blocks",
            "blocks of A(q) = E + H (M_off x I) K: E_i = a I, H_i = hat(q), K_i = -hat(q)",
            (_s(A_DIAG), _a("q")),
            (
                Output("e", _flat(A_DIAG * eye3)),
                Output("hq", _flat(hat(q))),
                Output("kq", _flat(-hat(q))),
            ),
        ),
        KernelDef(
            "rattle_pos_blocks",
            "RATTLE position multipliers, unknowns (z_i, delta_i): E_i = [[M_ii I, -x_i], "
            "[-2 xn_i^T, 0]] (row-major 4 x 4); H = [I; 0], K = [I, 0]",
            (_s(M_II), _a("x"), _a("xn")),
            (Output("e", _flat(rattle(-2, x))),),
        ),
        KernelDef(
            "rattle_vel_blocks",
            "RATTLE velocity multipliers, unknowns (z_i, kappa_i): E_i = [[M_ii I, -xn_i], "
            "[xn_i^T, 0]] (row-major 4 x 4); H = [I; 0], K = [I, 0]",
            (_s(M_II), _a("xn")),
            (Output("e", _flat(rattle(1, xn))),),
        ),
    ]
    if chain:
        pq, pv = vector("pq"), vector("pv")
        ks += [
            KernelDef(
                "kin_sweep",
                "kinetic energy of body j in a max-index sweep: 1/2 M_jj |v_j|^2 + a_j c_j "
                "v_j . pv, pv = sum_{i<j} a_i v_i",
                (_s(M_II), _s(AC), _a("q"), _a("w"), _a("pv")),
                (Output("t", (M_II * dot(v, v) / 2 + AC * dot(v, pv),), scalar=True),),
            ),
            KernelDef(
                "mom_sweep",
                "angular momentum of body j in a max-index sweep: M_jj q_j x v_j + a_j c_j "
                "(pq x v_j + q_j x pv), pq = sum_{i<j} a_i q_i",
                (_s(M_II), _s(AC), _a("q"), _a("w"), _a("pq"), _a("pv")),
                (_o("j", M_II * q.cross(v) + AC * (pq.cross(v) + q.cross(pv))),),
            ),
        ]
    return ks
