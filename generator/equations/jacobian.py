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
A, jq = d(w x q)/d(q, w) and jr = d(b - A a)/d(q, w) with G held fixed are assembled at run
time from one generic body's and one generic pair's blocks (`field_blocks`, derived once,
called for each body and each pair with M_ij != 0, M's entries from ``jac_mass``); the C adds
-hat(q_i) dG_i/d(q, w, u), dG/dq = H - dF/dq assembled from the terms' Hessian blocks. SymPy
takes every derivative, nothing is differenced.

Example:
    >>> from s2gen.systems import builtin
    >>> [k.name for k in jacobian_kernels(builtin("double_pendulum").with_jacobians())]
    ['jac_body', 'jac_pair', 'jac_mass', 'hessian']
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.geometry import hat
from s2gen.equations.hessian import force_jacobian_kernel, hessian_kernels, sparse_jacobian
from s2gen.ir import Argument, KernelDef, Output
from s2gen.system import System

__all__ = [
    "JACOBIAN_MAX_BODIES",
    "field_blocks",
    "has_jacobian",
    "jacobian_kernels",
    "jacobian_refusal",
]

#: The step Jacobians are emitted for systems of at most this many bodies: their derivation no
#: longer grows with n (blocks derived once, placed at run time), but the derivatives are
#: dense ((6n)^2 for A, (9n)^2 for a coupled VI's equations), as are the products and solves
#: of the chain rule (O(n^3) per step: 12 to 26 ms at n = 32, `benchmarks/jacobian_cost.py`).
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


def _vector(name: str) -> sp.Matrix:
    return sp.Matrix(sp.symbols(f"{name}_0:3", real=True))


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def field_blocks() -> tuple[KernelDef, KernelDef]:
    """The field's derivative blocks, derived once for a generic body and a generic pair:
    ``jac_body`` (q, w, G -> jqq = d(w x q)/dq, jqw = d(w x q)/dw, jrq = d(-q x G)/dq) and
    ``jac_pair`` (mij, qi, qj, wj, aj -> aij = A_ij, and the derivatives of the pair's part
    of row i of b - A a, c_ij = M_ij (|w_j|^2 q_i x q_j + hat(q_i) hat(q_j) a_j), in q_i, q_j
    and w_j: dqi, dqj, dwj, all 3 x 3 row-major; and ct = c_ij / M_ij, its derivative in
    M_ij).

    Example:
        >>> body, pair = field_blocks()
        >>> [o.name for o in pair.outputs], pair.inputs[0].name
        (['aij', 'dqi', 'dqj', 'dwj', 'ct'], 'mij')
    """
    q, w, G = _vector("q"), _vector("w"), _vector("G")
    qi, qj, wj, aj = _vector("qi"), _vector("qj"), _vector("wj"), _vector("aj")
    mij = sp.Symbol("mij", real=True)
    qdot = w.cross(q)
    c = mij * (wj.dot(wj) * qi.cross(qj) + hat(qi) * (hat(qj) * aj))

    def arg(name: str, v: sp.Matrix) -> Argument:
        return Argument(name, tuple(v))

    body = KernelDef(
        "jac_body",
        "a body's blocks of the field's derivatives: d(w x q)/dq, d(w x q)/dw, d(-q x G)/dq",
        (arg("q", q), arg("w", w), arg("G", G)),
        (
            Output("jqq", _flat(qdot.jacobian(q))),
            Output("jqw", _flat(qdot.jacobian(w))),
            Output("jrq", _flat((-q.cross(G)).jacobian(q))),
        ),
    )
    pair = KernelDef(
        "jac_pair",
        "a coupled pair's blocks: A_ij and d(c_ij)/d(q_i, q_j, w_j) of row i of b - A a",
        (Argument("mij", (mij,), scalar=True), arg("qi", qi), arg("qj", qj), arg("wj", wj)),
        (
            Output("aij", _flat(-mij * hat(qi) * hat(qj))),
            Output("dqi", _flat(c.jacobian(qi))),
            Output("dqj", _flat(c.jacobian(qj))),
            Output("dwj", _flat(c.jacobian(wj))),
            Output("ct", tuple(c / mij)),
        ),
    )
    pair = KernelDef(pair.name, pair.doc, (*pair.inputs, arg("aj", aj)), pair.outputs)
    return body, pair


def jacobian_kernels(system: System) -> list[KernelDef]:
    """The field's blocks (`field_blocks`), ``jac_mass`` (M's n x n entries, row-major, from
    the parameters, and their derivatives in the parameters, mp, (i n + j) x parameters) and
    the second derivatives of V and the forces
    (`s2gen.equations.hessian`), or none when the system has no step Jacobians
    (`has_jacobian`)."""
    if not has_jacobian(system):
        return []
    M = system.inertia
    params = list(system.parameter_symbols)
    outputs = [Output("mm", _flat(M))]
    if params:
        outputs.append(Output("mp", _flat(sparse_jacobian(list(M), params))))
    mass = KernelDef(
        "jac_mass",
        "M's entries (mm: n x n, row-major) and their derivatives in the parameters (mp)",
        (Argument("p", system.parameter_symbols),),
        tuple(outputs),
        system=True,
        stages=(("p", 0),),
    )
    return [
        *field_blocks(),
        mass,
        *hessian_kernels(system),
        *force_jacobian_kernel(system),
    ]
