"""Variational-integrator equations on (S^2)^n in (q, omega) form: explicit and Cayley/Newton.

Input: nothing system-specific (as in `continuous.py`, the discrete flow depends on the system
only through g_i = dV/dq_i and the entries of M). Output: `KernelDef`s for one body and one
coupled pair, which the templates apply in loops.

Derivation. The discrete Lagrangian over one step is
    L_d = 1/(2h) sum_ij M_ij (q_i+ - q_i).(q_j+ - q_j) - h/2 V(q) - h/2 V(q+),
and SymPy differentiates it for a generic pair (V enters through its gradient g, g+). The
discrete Legendre transforms, projected on the tangent planes by a cross product, read
    k:   q_i  x sum_j M_ij (omega_j  x q_j ) = q_i  x (-D_{q_i}  L_d)
    k+1: q_i+ x sum_j M_ij (omega_j+ x q_j+) = q_i+ x ( D_{q_i+} L_d).
With q_j+ = F_j q_j the first gives, multiplied by h,
    M_ii q_i x F_i q_i + sum_{j!=i} M_ij q_i x (F_j q_j - q_j) = d_i,
    d_i = h sum_j M_ij q_i x (omega_j x q_j) - h^2/2 q_i x g_i.
With Cayley parameters f_i orthogonal to q_i, q_i x F_i q_i = 2 (q_i.q_i) f_i / (1 + f_i.f_i)
(= 2 f_i/(1 + f_i.f_i) on the sphere; the factor is kept so that round-off in |q_i| does not
leak into the momentum), which closes the system: the
component of the residual along q_i is what forces f_i . q_i = 0. The Jacobian in f is taken
by SymPy. For diagonal M the system decouples and is solved in closed form:
    a_i = d_i / M_ii,  q_i+ = a_i x q_i + sqrt(1 - a_i.a_i) q_i   (feasible iff a_i.a_i <= 1),
and, using q_i+ x q_i = -a_i, the second transform gives
    omega_i+ = a_i / h - h/(2 M_ii) q_i+ x g_i+ = omega_i - h/(2M_ii)(q_i x g_i + q_i+ x g_i+).
For coupled M the second transform is the SPD system A(q+) omega+ = c with the same blocks as
the continuous equations and c_i = q_i+ x D_{q_i+} L_d.

Example:
    >>> sorted(k.name for k in explicit_kernels())
    ['vi_pos', 'vi_vel']
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.geometry import cayley_apply, cayley_displacement, dot, hat
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import vector

__all__ = ["explicit_kernels", "legendre_pair", "newton_kernels"]

H = sp.Symbol("h", positive=True)
M_II = sp.Symbol("m", positive=True)
M_JJ = sp.Symbol("mjj", positive=True)
M_IJ = sp.Symbol("mij", real=True)


def _a(name: str, v: sp.Matrix) -> Argument:
    return Argument(name, tuple(v))


def _s(sym: sp.Symbol) -> Argument:
    return Argument(sym.name, (sym,), scalar=True)


def _o(name: str, v: sp.Matrix) -> Output:
    return Output(name, tuple(v))


def _tidy(v: sp.Matrix) -> sp.Matrix:
    return v.applyfunc(lambda e: sp.factor(sp.expand(e)))


def legendre_pair() -> dict[str, sp.Matrix]:
    """Projected discrete Legendre transforms for a generic coupled pair (i, j).

    Returns the tangent (cross-product) forms of -D_{q_i} L_d and D_{q_i+} L_d, and the
    momenta q_i x sum_j M_ij qdot_j at both ends, in symbols qi, qj, qni, qnj, wi, wj, gi, gni...
    """
    qni = vector("qni")
    Ld = _discrete_lagrangian()
    minus_d1 = _minus_d1(Ld)
    d2 = sp.Matrix([sp.diff(Ld, c) for c in qni])  # D_{q_i+} L_d
    return {"minus_D1": minus_d1, "D2": qni.cross(d2)}


def _discrete_lagrangian() -> sp.Expr:
    """L_d of a generic coupled pair (i, j) over one step."""
    qi, qj, qni, qnj = vector("qi"), vector("qj"), vector("qni"), vector("qnj")
    gi, gj, gni, gnj = vector("gi"), vector("gj"), vector("gni"), vector("gnj")
    di, dj = qni - qi, qnj - qj
    kinetic = (M_II * dot(di, di) + 2 * M_IJ * dot(di, dj) + M_JJ * dot(dj, dj)) / (2 * H)
    # V enters through its gradient: V(q) ~ g.q to first order is all D L_d ever sees.
    return kinetic - H / 2 * (dot(gi, qi) + dot(gj, qj)) - H / 2 * (dot(gni, qni) + dot(gnj, qnj))


def _minus_d1(Ld: sp.Expr) -> sp.Matrix:
    """The projected first transform q_i x (-D_{q_i} L_d)."""
    qi = vector("qi")
    d1 = sp.Matrix([sp.diff(Ld, c) for c in qi])  # D_{q_i} L_d
    return qi.cross(-d1)


def explicit_kernels() -> list[KernelDef]:
    """Closed-form VI step for a body whose row of M is diagonal (paper's qikpexp/wikpexp)."""
    q, w, g, qn, gn = vector("q"), vector("w"), vector("g"), vector("qn"), vector("gn")
    minus_d1 = _minus_d1(_discrete_lagrangian())  # the transform at k+1 is not needed here
    qi, gi = vector("qi"), vector("gi")
    # d_i = h q_i x p_i - h (q_i x -D_{q_i} L_d)|_{q+ = q}; the second term (M_ij = 0) is the
    # gradient part, h^2/2 q_i x g_i.
    d_grad = -(H * minus_d1).subs({M_IJ: 0}).subs({**{c: c2 for c, c2 in zip(vector("qni"), qi)}})
    d_grad = _tidy(d_grad.subs(dict(zip(list(qi) + list(gi), list(q) + list(g)))))
    a = H * w + d_grad / M_II
    s = 1 - dot(a, a)
    qnew = a.cross(q) + sp.sqrt(s) * q
    # the half-step velocity a/h = omega - h/(2M_ii) q x g: omega+ = a/h - h/(2M_ii) q+ x g+
    wh = vector("wh")
    return [
        KernelDef(
            "vi_pos",
            "explicit VI position update: a = h omega - h^2/(2M_ii) q x g, "
            "q+ = a x q + sqrt(1 - a.a) q (s = 1 - a.a must be >= 0), wh = a/h",
            (_s(H), _s(M_II), _a("q", q), _a("w", w), _a("g", g)),
            (_o("qn", qnew), _o("wh", a / H), Output("s", (s,), scalar=True)),
        ),
        KernelDef(
            "vi_vel",
            "explicit VI velocity update: omega+ = wh - h/(2M_ii) q+ x g+",
            (_s(H), _s(M_II), _a("wh", wh), _a("qn", qn), _a("gn", gn)),
            (_o("wn", wh - H / (2 * M_II) * qn.cross(gn)),),
        ),
    ]


def newton_kernels() -> list[KernelDef]:
    """Kernels of the implicit VI step for coupled M (paper's DELw1 with impf, DELw2m)."""
    lp = legendre_pair()
    qi, qj, qni, qnj = vector("qi"), vector("qj"), vector("qni"), vector("qnj")
    wi, wj, gi = vector("wi"), vector("wj"), vector("gi")
    fi, fj = vector("fi"), vector("fj")
    q, w, g, f, qn, gn = (
        vector("q"),
        vector("w"),
        vector("g"),
        vector("f"),
        vector("qn"),
        vector("gn"),
    )
    to_body = {**dict(zip(qi, q)), **dict(zip(gi, g)), **dict(zip(qni, qn)), **dict(zip(wi, w))}
    to_body.update({gc: gnc for gc, gnc in zip(vector("gni"), gn)})

    # Known side d_i = h q_i x p_i - h (q_i x -D_{q_i} L_d)|_{q+ = q}: momentum part
    # h q_i x sum_j M_ij (omega_j x q_j), gradient part -h^2/2 q_i x g_i.
    at_rest = {**dict(zip(qni, qi)), **dict(zip(qnj, qj))}
    grad_part = (H * lp["minus_D1"]).subs(at_rest)
    # momentum part of the self term kept exact, h M_ii q x (omega x q), so d_i is tangent
    d_body = H * M_II * q.cross(w.cross(q)) - _tidy(
        grad_part.subs({M_IJ: 0}).subs(to_body, simultaneous=True)
    )
    d_pair_i = _tidy(H * M_IJ * qi.cross(wj.cross(qj)))
    d_pair_j = _tidy(H * M_IJ * qj.cross(wi.cross(qi)))

    # f-dependent side: q_i x sum_j M_ij (F_j q_j - q_j); self term reduced on f_i . q_i = 0.
    # Displacements F_j q_j - q_j are written from f_j directly (`cayley_displacement`).
    # q x F q = 2 (q.q) f / (1 + f.f) holds for f orthogonal to q at any |q|; keeping the factor
    # (q.q) stops the round-off in |q| from leaking into the momentum step after step.
    r_body = 2 * M_II * dot(q, q) * f / (1 + dot(f, f)) - vector("d")
    r_pair_i = M_IJ * qi.cross(cayley_displacement(fj, qj))
    r_pair_j = M_IJ * qj.cross(cayley_displacement(fi, qi))

    # Velocity side c_i = q_i+ x D_{q_i+} L_d, split into the one-body and the pair part.
    # D2 is linear in the displacements q_j+ - q_j; they are replaced by their Cayley form, and
    # in the self term q_i+ x (q_i+ - q_i) = q_i x F_i q_i = 2 f_i/(1 + f_i.f_i), so that the
    # 1/h in front multiplies quantities of size h, never a difference of unit vectors.
    c_all = lp["D2"]
    disp = {**dict(zip(qni, qi + vector("ui"))), **dict(zip(qnj, qj + vector("uj")))}
    c_disp = c_all.subs(disp, simultaneous=True)
    self_part = c_disp.subs({M_IJ: 0}).subs({gc: 0 for gc in vector("gni")})
    check = (self_part - M_II / H * (qi + vector("ui")).cross(vector("ui"))).applyfunc(sp.expand)
    assert check == sp.zeros(3, 1), "self term of D2 must be M_ii/h q_i+ x (q_i+ - q_i)"
    c_body = M_II / H * 2 * dot(q, q) * f / (1 + dot(f, f)) + _tidy(
        c_all.subs({M_II: 0, M_IJ: 0}).subs(to_body, simultaneous=True)
    )
    pair_part = c_all.subs({M_II: 0}).subs({gc: 0 for gc in vector("gni")})
    # pair part is M_ij/h q_i+ x (q_j+ - q_j): keep q_i+, substitute the displacement of j
    c_pair_i = pair_part.subs(dict(zip(qnj, qj + cayley_displacement(fj, qj))), simultaneous=True)
    c_pair_j = c_pair_i.subs(
        {**dict(zip(qi, qj)), **dict(zip(qj, qi)), **dict(zip(qni, qnj)), **dict(zip(fj, fi))},
        simultaneous=True,
    )

    # Completed diagonal block of the velocity system: -M_ii hat(q)^2 + M_ii q q^T.
    completed = (-M_II * hat(q) * hat(q) + M_II * q * q.T).applyfunc(sp.expand)
    a_diag = sp.factor(completed[0, 0])
    assert completed == (a_diag * sp.eye(3)).applyfunc(sp.expand)

    def flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
        return tuple(mat[r, c] for r in range(3) for c in range(3))

    return [
        KernelDef(
            "d_body",
            "known side d_i, one-body part: h M_ii omega_i - h^2/2 q_i x g_i",
            (_s(H), _s(M_II), _a("q", q), _a("w", w), _a("g", g)),
            (_o("d", d_body),),
        ),
        KernelDef(
            "d_pair",
            "known side, pair part: h M_ij q_i x (omega_j x q_j) (and i <-> j)",
            (_s(H), _s(M_IJ), _a("qi", qi), _a("wi", wi), _a("qj", qj), _a("wj", wj)),
            (_o("di", d_pair_i), _o("dj", d_pair_j)),
        ),
        KernelDef(
            "res_body",
            "residual 2 M_ii (q.q) f/(1+f.f) - d and its Jacobian block in f (row-major)",
            (_s(M_II), _a("q", q), _a("f", f), _a("d", vector("d"))),
            (_o("r", r_body), Output("jac", flat(r_body.jacobian(f)))),
        ),
        KernelDef(
            "res_pair",
            "pair residual M_ij q_i x (F_j q_j - q_j) (and i <-> j), Jacobian blocks d/df_j, d/df_i",
            (_s(M_IJ), _a("qi", qi), _a("fi", fi), _a("qj", qj), _a("fj", fj)),
            (
                _o("ri", r_pair_i),
                _o("rj", r_pair_j),
                Output("jij", flat(r_pair_i.jacobian(fj))),
                Output("jji", flat(r_pair_j.jacobian(fi))),
            ),
        ),
        KernelDef(
            "a_body",
            "diagonal block of A(q+) for the VI velocity solve: M_ii (q.q) I, the exact completion"
            " of -M_ii hat(q)^2 (equal to M_ii I on the sphere)",
            (_s(M_II), _a("q", q)),
            (Output("a", (a_diag,), scalar=True),),
        ),
        KernelDef(
            "cayley",
            "q+ = F q with F the Cayley rotation of f (exactly orthogonal for any f)",
            (_a("q", q), _a("f", f)),
            (_o("qn", cayley_apply(f, q)),),
        ),
        KernelDef(
            "c_body",
            "velocity right side, one-body part: 2 M_ii/h (q.q) f/(1 + f.f) - h/2 q+ x g+",
            (_s(H), _s(M_II), _a("q", q), _a("f", f), _a("qn", qn), _a("gn", gn)),
            (_o("c", c_body),),
        ),
        KernelDef(
            "c_pair",
            "velocity right side, pair part: M_ij/h q_i+ x (F_j q_j - q_j) (and i <-> j)",
            (
                _s(H),
                _s(M_IJ),
                _a("qi", qi),
                _a("fi", fi),
                _a("qni", qni),
                _a("qj", qj),
                _a("fj", fj),
                _a("qnj", qnj),
            ),
            (_o("ci", c_pair_i), _o("cj", c_pair_j)),
        ),
    ]
