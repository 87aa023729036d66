"""Continuous Euler-Lagrange equations on (S^2)^n in (q, omega) form, energy and momenta.

Input: nothing system-specific. The equations of a Lagrangian
L = 1/2 sum_ij M_ij qdot_i . qdot_j - V(q) are the same for every system once the gradient
g_i = dV/dq_i and the entries of M are known, so they are derived here once, for a generic body
i and a generic coupled pair (i, j), and emitted as kernels that loops apply to every body and
every coupling pair the system actually has.
Output: `KernelDef`s (see `ir.py`).

Derivation (Hamilton's principle with variations delta q_i = xi_i x q_i, xi_i . q_i = 0):
    R_i = q_i x sum_j M_ij qddot_j + q_i x g_i = 0,   qddot_j = omegadot_j x q_j - |omega_j|^2 q_j.
R is linear in omegadot; its coefficient blocks dR_i/d omegadot_j are taken by SymPy. The
diagonal block -M_ii hat(q_i)^2 is singular along q_i; adding M_ii q_i q_i^T (legitimate because
q_i . omegadot_i = 0 on solutions) gives M_ii I and the symmetric positive definite matrix A of
the paper's eq. (ELwm). The right-hand side is b = -R(omegadot = 0).

Example:
    >>> [k.name for k in continuous_kernels(coupled=True)][:3]
    ['kin_body', 'kin_pair', 'mom_body']
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.geometry import dot
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import vector

__all__ = ["continuous_kernels", "el_residual", "system_matrix_blocks"]

H = sp.Symbol("h", positive=True)
M_II = sp.Symbol("m", positive=True)
M_IJ = sp.Symbol("mij", real=True)


def _arg(name: str, v: sp.Matrix) -> Argument:
    return Argument(name, tuple(v))


def _out(name: str, v: sp.Matrix) -> Output:
    return Output(name, tuple(v))


def _scalar_in(sym: sp.Symbol) -> Argument:
    return Argument(sym.name, (sym,), scalar=True)


def el_residual(
    mii: sp.Expr,
    mij: sp.Expr,
    qi: sp.Matrix,
    qj: sp.Matrix,
    wi: sp.Matrix,
    wj: sp.Matrix,
    ai: sp.Matrix,
    aj: sp.Matrix,
    gi: sp.Matrix,
) -> sp.Matrix:
    """R_i for a body i coupled to one body j (a = omegadot): the Euler-Lagrange residual."""
    qdd_i = ai.cross(qi) - dot(wi, wi) * qi
    qdd_j = aj.cross(qj) - dot(wj, wj) * qj
    return qi.cross(mii * qdd_i + mij * qdd_j) + qi.cross(gi)


def _residual() -> tuple[sp.Matrix, tuple[sp.Matrix, ...]]:
    """R_i of a generic pair and its vectors (qi, qj, wi, wj, ai, aj, gi)."""
    vectors = tuple(vector(s) for s in ("qi", "qj", "wi", "wj", "ai", "aj", "gi"))
    return el_residual(M_II, M_IJ, *vectors), vectors


def _known_side(R: sp.Matrix, ai: sp.Matrix, aj: sp.Matrix) -> sp.Matrix:
    """b_i = -R_i(omegadot = 0), each entry factored."""
    return (-R.subs({a: 0 for a in list(ai) + list(aj)})).applyfunc(
        lambda e: sp.factor(sp.expand(e))
    )


def system_matrix_blocks() -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
    """(A_ii, A_ij, b_i pieces) derived from `el_residual` for a generic pair.

    Returns the completed diagonal block (M_ii I after the identity -hat(q)^2 + q q^T = I on
    |q| = 1), the off-diagonal block dR_i/d omegadot_j, and b_i = -R_i(omegadot = 0).
    """
    R, (qi, _, _, _, ai, aj, _) = _residual()
    Aii_raw = R.jacobian(ai)
    Aij = R.jacobian(aj)
    completed = (Aii_raw + M_II * qi * qi.T).applyfunc(sp.expand)
    unit = {qi[2] ** 2: 1 - qi[0] ** 2 - qi[1] ** 2}
    Aii = completed.applyfunc(lambda e: sp.expand(e.subs(unit)))
    assert Aii == M_II * sp.eye(3), "the completed diagonal block must be M_ii I on |q| = 1"
    return Aii, Aij.applyfunc(sp.expand), _known_side(R, ai, aj)


def continuous_kernels(coupled: bool) -> list[KernelDef]:
    """Per-body (and, if `coupled`, per-pair) kernels of energy, momenta and the vector field."""
    q, w, g = vector("q"), vector("w"), vector("g")
    qi, wi, qj, wj = vector("qi"), vector("wi"), vector("qj"), vector("wj")
    vi, vj = wi.cross(qi), wj.cross(qj)
    v = w.cross(q)
    if coupled:
        _, Aij, b = system_matrix_blocks()
    else:  # only the one-body part of b is used: the blocks and the pair part are not derived
        R, (_, _, _, _, ai, aj, _) = _residual()
        b = _known_side(R, ai, aj)
    gi = vector("gi")
    # b splits into a one-body part (M_ij = 0) and a pair part (g_i = 0); M_ii drops out.
    b_body = b.subs({M_IJ: 0}).subs(dict(zip(list(qi) + list(gi), list(q) + list(g))))
    kin_body = KernelDef(
        "kin_body",
        "kinetic energy of one body: 1/2 M_ii |omega x q|^2",
        (_scalar_in(M_II), _arg("q", q), _arg("w", w)),
        (Output("t", (M_II * dot(v, v) / 2,), scalar=True),),
    )
    mom_body = KernelDef(
        "mom_body",
        "angular momentum of one body: M_ii q x (omega x q)",
        (_scalar_in(M_II), _arg("q", q), _arg("w", w)),
        (_out("j", M_II * q.cross(v)),),
    )
    if not coupled:
        rhs_diag = KernelDef(
            "rhs_diag",
            "vector field, uncoupled body: qdot = omega x q, omegadot = -q x g / M_ii",
            (_scalar_in(M_II), _arg("q", q), _arg("w", w), _arg("g", g)),
            (_out("dq", v), _out("dw", b_body / M_II)),
        )
        return [kin_body, mom_body, rhs_diag]
    b_pair_i = b.subs({gc: 0 for gc in gi}).applyfunc(lambda e: sp.factor(e))
    swap = dict(
        zip(list(qi) + list(wi) + list(qj) + list(wj), list(qj) + list(wj) + list(qi) + list(wi))
    )
    b_pair_j = b_pair_i.subs(swap, simultaneous=True)
    return [
        kin_body,
        KernelDef(
            "kin_pair",
            "kinetic energy of a coupled pair: M_ij (omega_i x q_i).(omega_j x q_j)",
            (_scalar_in(M_IJ), _arg("qi", qi), _arg("wi", wi), _arg("qj", qj), _arg("wj", wj)),
            (Output("t", (M_IJ * dot(vi, vj),), scalar=True),),
        ),
        mom_body,
        KernelDef(
            "mom_pair",
            "angular momentum of a pair: M_ij (q_i x qdot_j + q_j x qdot_i)",
            (_scalar_in(M_IJ), _arg("qi", qi), _arg("wi", wi), _arg("qj", qj), _arg("wj", wj)),
            (_out("j", M_IJ * (qi.cross(vj) + qj.cross(vi))),),
        ),
        KernelDef(
            "rhs_body",
            "vector field, coupled body: qdot = omega x q and b_i = -q x g",
            (_arg("q", q), _arg("w", w), _arg("g", g)),
            (_out("dq", v), _out("b", b_body)),
        ),
        KernelDef(
            "rhs_pair",
            "pair terms of b: M_ij |omega_j|^2 q_i x q_j (and i <-> j)",
            (_scalar_in(M_IJ), _arg("qi", qi), _arg("wi", wi), _arg("qj", qj), _arg("wj", wj)),
            (_out("bi", b_pair_i), _out("bj", b_pair_j)),
        ),
        KernelDef(
            "a_pair",
            "block A_ij = -M_ij hat(q_i) hat(q_j) (row-major); A_ji is its transpose",
            (_scalar_in(M_IJ), _arg("qi", qi), _arg("qj", qj)),
            (Output("a", tuple(Aij[r, c] for r in range(3) for c in range(3))),),
        ),
    ]
