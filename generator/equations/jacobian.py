"""The exact Jacobian of the continuous field on (S^2)^n, for the step Jacobians.

Input: a `System` of at most `JACOBIAN_MAX_BODIES` bodies without cutoff terms
(`has_jacobian`). Output: the kernel ``field_jacobian`` that the ``jacobian`` part calls at
every Runge-Kutta stage to propagate the derivative of a step through it (the chain rule of
the tableau, in `templates/c/_jacobian.jinja`), and the second derivatives of V and the forces
(`s2gen.equations.hessian`: per term, evaluated member by member at run time).

Derivation. The emitted field is qdot_i = w_i x q_i and the solution a = wdot of
A(q) a = b(q, w, t, u), with the blocks the field's solvers use: A_ii = M_ii I (the completed
diagonal block, `s2gen.equations.continuous`), A_ij = -M_ij hat(q_i) hat(q_j), and
    b_i = sum_{j != i} M_ij |w_j|^2 q_i x q_j - q_i x G_i,   G = g - F,
g = dV/dq, F the forces (`s2gen.equations.driven`). Differentiating A a = b at the field's own
a gives
    da/dx = A^-1 d(b - A a)/dx |_a   (x = q, w or u).
The kernel returns A, jq = d(w x q)/d(q, w) and jr = d(b - A a)/d(q, w) with G held fixed (its
rows touch only M's coupled pairs, each differentiated alone); the C adds
-hat(q_i) dG_i/d(q, w, u), dG/dq = H - dF/dq assembled from the terms' Hessian blocks. SymPy
takes every derivative, nothing is differenced.

Example:
    >>> from s2gen.systems import builtin
    >>> k = jacobian_kernels(builtin("double_pendulum").with_jacobians())[0]
    >>> k.name, [o.name for o in k.outputs], [o.size for o in k.outputs]
    ('field_jacobian', ['jq', 'jr', 'am'], [72, 72, 36])
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.geometry import hat
from s2gen.equations.hessian import force_jacobian_kernel, hessian_kernels
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import q_symbols, w_symbol
from s2gen.system import System

__all__ = [
    "JACOBIAN_MAX_BODIES",
    "field_jacobian",
    "g_symbols",
    "has_jacobian",
    "jacobian_kernels",
    "jacobian_refusal",
]

#: The step Jacobians are emitted for systems of at most this many bodies: the derivatives are
#: dense ((6n)^2 for A, (9n)^2 for the VI's equations), as are the products and solves of the
#: chain rule (O(n^3) per step) and the kernels of the field's geometry (one block per coupled
#: pair of M).
JACOBIAN_MAX_BODIES = 32


def has_jacobian(system: System) -> bool:
    """Whether the emitted C of `system` carries step_jacobian(): asked for
    (`System.with_jacobians`), at most `JACOBIAN_MAX_BODIES` bodies and no pair terms within a
    cutoff (whose members are found per call, and whose second derivatives jump there).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> has_jacobian(s), has_jacobian(s.with_jacobians())
        (False, True)
    """
    return system.jacobians and jacobian_refusal(system) is None


def jacobian_refusal(system: System) -> str | None:
    """Why `system`'s C cannot carry step_jacobian(), or None.

    Example:
        >>> from s2gen.systems import builtin
        >>> jacobian_refusal(builtin("rope", n=40))
        'step Jacobians are emitted for systems of at most 32 bodies, not n = 40'
    """
    if system.n > JACOBIAN_MAX_BODIES:
        return (
            f"step Jacobians are emitted for systems of at most {JACOBIAN_MAX_BODIES} bodies, "
            f"not n = {system.n}"
        )
    cutoff = [t.label for t in system.terms if not t.selection.fixed]
    if cutoff:
        return f"{cutoff[0]}: step Jacobians are not emitted for terms within a cutoff"
    return None


def _blocks(vec: list[sp.Symbol], n: int) -> list[sp.Matrix]:
    return [sp.Matrix(vec[3 * i : 3 * i + 3]) for i in range(n)]


def _generic_blocks() -> tuple[dict[str, sp.Matrix], dict[str, tuple[sp.Symbol, ...]]]:
    """The blocks of jr and jq derived once for a generic body and pair, and their symbols:
    the body's -q x G in q (``body_q``), a pair's c_ij = M_ij (|w_j|^2 q_i x q_j +
    hat(q_i) hat(q_j) a_j) in q_i, q_j and w_j (``pair_qi``, ``pair_qj``, ``pair_wj``), and
    d(w x q)/dq, d(w x q)/dw (``jq_q``, ``jq_w``)."""
    sym = {
        name: tuple(sp.symbols(f"{name}_0:3", real=True)) for name in ("qi", "qj", "wi", "wj", "aj")
    }
    sym["G"] = tuple(sp.symbols("Gb_0:3", real=True))
    sym["mij"] = (sp.Symbol("mij", real=True),)
    qi, qj, wi, wj, aj, G = (sp.Matrix(sym[k]) for k in ("qi", "qj", "wi", "wj", "aj", "G"))
    c = sym["mij"][0] * (wj.dot(wj) * qi.cross(qj) + hat(qi) * (hat(qj) * aj))
    body = -qi.cross(G)
    qdot = wi.cross(qi)
    blocks = {
        "body_q": body.jacobian(qi),
        "pair_qi": c.jacobian(qi),
        "pair_qj": c.jacobian(qj),
        "pair_wj": c.jacobian(wj),
        "jq_q": qdot.jacobian(qi),
        "jq_w": qdot.jacobian(wi),
    }
    return blocks, sym


def field_jacobian(system: System) -> dict[str, sp.Matrix]:
    """The field's pieces for the whole system, in the symbols q (3n), w (3n), a (3n), G (3n:
    g - F, held fixed) and the parameters: ``A`` (3n x 3n), ``jq``, ``jr`` (3n x 6n), as in
    the module docstring; each block is a generic body's or pair's (`_generic_blocks`) at the
    body or coupled pair of M.

    Example:
        >>> from s2gen.systems import builtin
        >>> parts = field_jacobian(builtin("double_pendulum"))
        >>> parts["A"].shape, parts["jr"].shape
        ((6, 6), (6, 12))
    """
    n = system.n
    qs = q_symbols(n)
    ws = [w_symbol(i, c) for i in range(1, n + 1) for c in range(3)]
    a_s = list(sp.symbols(f"a_0:{3 * n}", real=True))
    q, w, a = _blocks(qs, n), _blocks(ws, n), _blocks(a_s, n)
    G = _blocks(list(g_symbols(n)), n)
    blocks, sym = _generic_blocks()
    M = system.inertia
    A = sp.zeros(3 * n, 3 * n)
    jq = sp.zeros(3 * n, 6 * n)
    jr = sp.zeros(3 * n, 6 * n)

    def at(name: str, subs: dict[sp.Symbol, sp.Expr]) -> sp.Matrix:
        return blocks[name].xreplace(subs)

    for i in range(n):
        r, qc, wc = (
            slice(3 * i, 3 * i + 3),
            slice(3 * i, 3 * i + 3),
            slice(3 * n + 3 * i, 3 * n + 3 * i + 3),
        )
        own = {**dict(zip(sym["qi"], q[i])), **dict(zip(sym["wi"], w[i]))}
        own.update(zip(sym["G"], G[i]))
        A[r, qc] = M[i, i] * sp.eye(3)
        jq[r, qc] = at("jq_q", own)
        jq[r, wc] = at("jq_w", own)
        jr[r, qc] = at("body_q", own)
        for j in range(n):
            if j == i or M[i, j] == 0:
                continue
            qj, wj = slice(3 * j, 3 * j + 3), slice(3 * n + 3 * j, 3 * n + 3 * j + 3)
            pair = {**own, **dict(zip(sym["qj"], q[j])), **dict(zip(sym["wj"], w[j]))}
            pair.update({**dict(zip(sym["aj"], a[j])), sym["mij"][0]: M[i, j]})
            A[r, qj] = -M[i, j] * hat(q[i]) * hat(q[j])
            jr[r, qc] += at("pair_qi", pair)
            jr[r, qj] += at("pair_qj", pair)
            jr[r, wj] += at("pair_wj", pair)
    return {"A": A, "jq": jq, "jr": jr}


def g_symbols(n: int) -> tuple[sp.Symbol, ...]:
    """The symbols of G = g - F (3n, body-major) in the field's and the VI's kernels.

    Example:
        >>> g_symbols(1)
        (G_0, G_1, G_2)
    """
    return tuple(sp.symbols(f"G_0:{3 * n}", real=True))


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def jacobian_kernels(system: System) -> list[KernelDef]:
    """The ``field_jacobian`` kernel (row-major outputs jq, jr, am = A) and the second
    derivatives of V and the forces (`s2gen.equations.hessian`), or none when the system has
    no step Jacobians (`has_jacobian`)."""
    if not has_jacobian(system):
        return []
    n = system.n
    parts = field_jacobian(system)
    outputs = (
        Output("jq", _flat(parts["jq"])),
        Output("jr", _flat(parts["jr"])),
        Output("am", _flat(parts["A"])),
    )
    return [
        KernelDef(
            "field_jacobian",
            "the field's derivatives with G = g - F held: jq = d(w x q)/d(q, w), "
            "jr = d(b - A a)/d(q, w) at a, am = A(q) (row-major)",
            (
                Argument("p", system.parameter_symbols),
                Argument("q", tuple(q_symbols(n))),
                Argument("w", tuple(w_symbol(i, c) for i in range(1, n + 1) for c in range(3))),
                Argument("a", tuple(sp.symbols(f"a_0:{3 * n}", real=True))),
                Argument("G", g_symbols(n)),
            ),
            outputs,
            system=True,
            stages=(("p", 0),),
        ),
        *hessian_kernels(system),
        *force_jacobian_kernel(system),
    ]
