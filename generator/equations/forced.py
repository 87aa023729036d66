"""Forced equations on (S^2)^n: the terms generalized forces add to the continuous field and to
the variational integrator, derived for a generic body and pair, as `KernelDef`s.

Input: nothing system-specific — forces enter, as the gradient g does, through their values F_i
(3-vectors conjugate to q_i) and, where an iteration needs it, their Jacobian Fw = dF_i/dw_i;
`force_kernel` turns one force expression into a kernel computing F and Fw.
Output: `KernelDef`s; `forced_el_residual` and `forced_legendre_pair` (the equations
themselves, for checks). Not yet used by the printers or the spec.

Continuous (Lagrange-d'Alembert): R_i = q_i x (sum_j M_ij qddot_j + g_i - F_i) = 0, so the
right side b of A(q) omegadot = b gains q_i x F_i (`frhs_body`).

Discrete (Marsden & West 2001, Acta Numerica 10, section 3.2): with the L_d of `discrete.py`
and trapezoidal discrete forces f_d^- = (h/2) F(q, omega, t, u), f_d^+ = (h/2) F(q+, omega+,
t + h, u), the forced discrete Legendre transforms p = -D_1 L_d - f_d^-, p+ = D_2 L_d + f_d^+,
projected by q_i x and q_i+ x, give
    known side  d_i  gains  (h^2/2) q_i x F_i                                      (`fd_body`)
    velocity    c_i  gains  (h/2) q_i+ x F_i+,  F_i+ = F(q+, omega+): implicit in omega+
                                                  (`fc_body`, with its Jacobian in omega_i+),
and for diagonal M, a_i = h omega_i - h^2/(2M_ii) q_i x (g_i - F_i), q_i+ = a_i x q_i +
sqrt(1 - a_i.a_i) q_i (`fvi_pos`), and omega_i+ solves
    r(omega+) = omega+ - a_i/h + h/(2M_ii) q_i+ x (g_i+ - F_i+(omega+)) = 0      (`fvi_vel`,
residual and Jacobian I - h/(2M_ii) hat(q_i+) Fw_i+; one Newton step from any start when F is
linear in omega, none when F does not depend on omega). Positions never need dF/dq: the
position equations use F at the known start of the step.

Example:
    >>> [k.name for k in forced_kernels()]
    ['frhs_body', 'fd_body', 'fvi_pos', 'fvi_vel', 'fc_body']
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.continuous import el_residual
from s2gen.equations.discrete import legendre_pair
from s2gen.equations.geometry import dot, hat
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import vector

__all__ = ["force_kernel", "forced_el_residual", "forced_kernels", "forced_legendre_pair"]

H = sp.Symbol("h", positive=True)
M_II = sp.Symbol("m", positive=True)
M_IJ = sp.Symbol("mij", real=True)


def _a(name: str, v: sp.Matrix) -> Argument:
    return Argument(name, tuple(v))


def _s(sym: sp.Symbol) -> Argument:
    return Argument(sym.name, (sym,), scalar=True)


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def _tidy(v: sp.Matrix) -> sp.Matrix:
    return v.applyfunc(lambda e: sp.factor(sp.expand(e)))


def forced_el_residual(
    mii: sp.Expr,
    mij: sp.Expr,
    qi: sp.Matrix,
    qj: sp.Matrix,
    wi: sp.Matrix,
    wj: sp.Matrix,
    ai: sp.Matrix,
    aj: sp.Matrix,
    gi: sp.Matrix,
    Fi: sp.Matrix,
) -> sp.Matrix:
    """R_i = q_i x (sum_j M_ij qddot_j + g_i - F_i) for a body i coupled to one body j.

    Example:
        >>> v = {s: vector(s) for s in ("qi", "qj", "wi", "wj", "ai", "aj", "gi", "Fi")}
        >>> R = forced_el_residual(M_II, M_IJ, *v.values())
        >>> R.subs({c: 0 for c in v["Fi"]}) == el_residual(M_II, M_IJ, *list(v.values())[:-1])
        True
    """
    return el_residual(mii, mij, qi, qj, wi, wj, ai, aj, gi - Fi)


def forced_legendre_pair() -> dict[str, sp.Matrix]:
    """The forced discrete Legendre transforms of a generic coupled pair, projected:

    ``minus_D1`` = q_i x (-D_{q_i} L_d - f_d^-_i) and ``D2`` = q_i+ x (D_{q_i+} L_d + f_d^+_i),
    f_d^- = h/2 F_i, f_d^+ = h/2 F_i+ (symbols Fi, Fni), in the symbols of `legendre_pair`.

    Example:
        >>> lp = forced_legendre_pair()
        >>> sorted(str(s) for s in lp["D2"].free_symbols if str(s).startswith("Fn"))
        ['Fni_0', 'Fni_1', 'Fni_2']
    """
    lp = legendre_pair()
    qi, qni, Fi, Fni = vector("qi"), vector("qni"), vector("Fi"), vector("Fni")
    return {
        "minus_D1": lp["minus_D1"] - H / 2 * qi.cross(Fi),
        "D2": lp["D2"] + H / 2 * qni.cross(Fni),
    }


def forced_kernels() -> list[KernelDef]:
    """The force terms of the continuous field and of the VI, for one body (see the module)."""
    q, w, g, F = vector("q"), vector("w"), vector("g"), vector("F")
    qn, gn, Fn, wh, wn = vector("qn"), vector("gn"), vector("Fn"), vector("wh"), vector("wn")
    Fw = sp.Matrix(3, 3, sp.symbols("Fw_0:9", real=True))
    qi, qj, wi, wj, ai, aj, gi, Fi = (
        vector(s) for s in ("qi", "qj", "wi", "wj", "ai", "aj", "gi", "Fi")
    )
    body = {**dict(zip(qi, q)), **dict(zip(wi, w)), **dict(zip(Fi, F))}
    # b_i = -R_i(omegadot = 0); its force part is what F adds to the conservative b.
    R = forced_el_residual(M_II, M_IJ, qi, qj, wi, wj, ai, aj, gi, Fi)
    b_force = _tidy(-(R - R.subs({c: 0 for c in Fi})).subs({c: 0 for c in list(ai) + list(aj)}))
    b_force = b_force.subs(body, simultaneous=True)
    lp = forced_legendre_pair()
    # d_i = h q_i x p_i - h minus_D1|_{q+ = q}: the force part is -h (minus_D1's F part).
    d_force = _tidy(-H * (lp["minus_D1"] - legendre_pair()["minus_D1"])).subs(body)
    c_force = _tidy(lp["D2"] - legendre_pair()["D2"]).subs(
        {**dict(zip(vector("qni"), qn)), **dict(zip(vector("Fni"), Fn))}, simultaneous=True
    )
    a = H * w - H**2 / (2 * M_II) * q.cross(g) + d_force / M_II
    s = 1 - dot(a, a)
    residual = wn - wh + H / (2 * M_II) * qn.cross(gn) - c_force / M_II
    jac = sp.eye(3) - H / (2 * M_II) * hat(qn) * Fw
    return [
        KernelDef(
            "frhs_body",
            "force part of the continuous right side b_i: q_i x F_i",
            (_a("q", q), _a("F", F)),
            (Output("b", tuple(b_force)),),
        ),
        KernelDef(
            "fd_body",
            "force part of the VI's known side d_i: h^2/2 q_i x F_i (f_d^- = h/2 F)",
            (_s(H), _a("q", q), _a("F", F)),
            (Output("d", tuple(d_force)),),
        ),
        KernelDef(
            "fvi_pos",
            "forced explicit VI position update: a = h omega - h^2/(2M_ii) q x (g - F), "
            "q+ = a x q + sqrt(1 - a.a) q (s = 1 - a.a must be >= 0), wh = a/h",
            (_s(H), _s(M_II), _a("q", q), _a("w", w), _a("g", g), _a("F", F)),
            (
                Output("qn", tuple(a.cross(q) + sp.sqrt(s) * q)),
                Output("wh", tuple(a / H)),
                Output("s", (s,), scalar=True),
            ),
        ),
        KernelDef(
            "fvi_vel",
            "forced explicit VI velocity equation in omega+: residual "
            "omega+ - wh + h/(2M_ii) q+ x (g+ - F+) and its Jacobian I - h/(2M_ii) hat(q+) Fw+",
            (
                _s(H),
                _s(M_II),
                _a("wh", wh),
                _a("wn", wn),
                _a("qn", qn),
                _a("gn", gn),
                _a("Fn", Fn),
                _a("Fw", Fw),
            ),
            (Output("r", tuple(residual)), Output("jac", _flat(jac))),
        ),
        KernelDef(
            "fc_body",
            "force part of the VI velocity right side c_i: h/2 q_i+ x F_i+, and its Jacobian "
            "in omega_i+ (h/2 hat(q_i+) Fw_i+)",
            (_s(H), _a("qn", qn), _a("Fn", Fn), _a("Fw", Fw)),
            (Output("c", tuple(c_force)), Output("jac", _flat(H / 2 * hat(qn) * Fw))),
        ),
    ]


def force_kernel(name: str, force: sp.Matrix, q: sp.Matrix, w: sp.Matrix) -> KernelDef:
    """A kernel computing one body's force F(q, w, ...) and its Jacobian Fw = dF/dw.

    `force` is a 3x1 expression in the body's `q` and `w` (and any other symbols: time,
    inputs, parameters, which become scalar inputs, sorted by name).

    Example:
        >>> q, w = vector("q"), vector("w")
        >>> c = sp.Symbol("c", positive=True)
        >>> k = force_kernel("damping", -c * w.cross(q), q, w)
        >>> [a.name for a in k.inputs], k.outputs[1].exprs[:3]
        (['c', 'q', 'w'], (0, -c*q_2, c*q_1))
    """
    force = sp.Matrix(force)
    if force.shape != (3, 1):
        raise ValueError(f"force_kernel {name!r}: a force is a 3-vector, got shape {force.shape}")
    others = sorted(force.free_symbols - set(q) - set(w), key=lambda s: s.name)
    return KernelDef(
        name,
        "a body's generalized force F and its Jacobian dF/domega (row-major)",
        (*(_s(s) for s in others), _a("q", q), _a("w", w)),
        (Output("F", tuple(force)), Output("Fw", _flat(force.jacobian(w)))),
    )
