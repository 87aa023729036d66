"""The exact Jacobian of the continuous field on (S^2)^n, for the step Jacobians.

Input: a `System` of at most `JACOBIAN_MAX_BODIES` bodies without cutoff terms
(`has_jacobian`; the kernel is whole-system and dense). Output: the whole-system kernel ``field_jacobian`` that the ``jacobian`` part calls at
every Runge-Kutta stage to propagate the derivative of a step through it (the chain rule of
the tableau, in `templates/c/_jacobian.jinja`).

Derivation. The emitted field is qdot_i = w_i x q_i and the solution a = wdot of
A(q) a = b(q, w, t, u), with the blocks the field's solvers use: A_ii = M_ii I (the completed
diagonal block, `s2gen.equations.continuous`), A_ij = -M_ij hat(q_i) hat(q_j), and
    b_i = sum_{j != i} M_ij |w_j|^2 q_i x q_j - q_i x g_i + q_i x F_i,
g = dV/dq, F the forces (`s2gen.equations.driven`). Differentiating A a = b at the field's own
a gives
    da/dx = A^-1 d(b - A a)/dx |_a   (x = q or w),      da/du = A^-1 db/du,
so the kernel returns A, jq = d(w x q)/d(q, w), jr = d(b - A a)/d(q, w) and ju = db/du; SymPy
takes every derivative (the Hessian of V enters through dg/dq), nothing is differenced.

Example:
    >>> from s2gen.systems import builtin
    >>> k = jacobian_kernels(builtin("double_pendulum").with_jacobians())[0]
    >>> k.name, [o.name for o in k.outputs], [o.size for o in k.outputs]
    ('field_jacobian', ['jq', 'jr', 'am'], [72, 72, 36])
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.driven import _force_total, tu_argument, tu_symbols
from s2gen.equations.geometry import hat
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import q_symbols, w_symbol
from s2gen.system import System

__all__ = [
    "JACOBIAN_MAX_BODIES",
    "field_jacobian",
    "has_jacobian",
    "jacobian_kernels",
    "jacobian_refusal",
]

#: The step Jacobians are emitted for systems of at most this many bodies: their kernel is
#: whole-system and dense ((3n)^2 derivatives of the field), as are the products the chain rule
#: takes.
JACOBIAN_MAX_BODIES = 8


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
        >>> jacobian_refusal(builtin("rope", n=20))
        'step Jacobians are emitted for systems of at most 8 bodies, not n = 20'
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


def field_jacobian(system: System) -> dict[str, sp.Matrix]:
    """The field's pieces for the whole system, in the symbols q (3n), w (3n), a (3n), the
    parameters, time and the inputs: ``A`` (3n x 3n), ``b`` (3n), ``jq``, ``jr`` (3n x 6n)
    and ``ju`` (3n x inputs), as in the module docstring.

    Example:
        >>> from s2gen.systems import builtin
        >>> parts = field_jacobian(builtin("double_pendulum"))
        >>> parts["A"].shape, parts["jr"].shape, parts["ju"].shape
        ((6, 6), (6, 12), (6, 0))
    """
    n = system.n
    qs = q_symbols(n)
    ws = [w_symbol(i, c) for i in range(1, n + 1) for c in range(3)]
    a_s = list(sp.symbols(f"a_0:{3 * n}", real=True))
    q, w = _blocks(qs, n), _blocks(ws, n)
    V = system.full_potential()
    g = [sp.Matrix([sp.diff(V, s) for s in q[i]]) for i in range(n)]
    F = _force_total(system) if system.forces else sp.zeros(3 * n, 1)
    M = system.inertia
    A = sp.zeros(3 * n, 3 * n)
    b = sp.zeros(3 * n, 1)
    for i in range(n):
        A[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = M[i, i] * sp.eye(3)
        bi = q[i].cross(F[3 * i : 3 * i + 3, 0]) - q[i].cross(g[i])
        for j in range(n):
            if j == i or M[i, j] == 0:
                continue
            A[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = -M[i, j] * hat(q[i]) * hat(q[j])
            bi += M[i, j] * w[j].dot(w[j]) * q[i].cross(q[j])
        b[3 * i : 3 * i + 3, 0] = bi
    x = qs + ws
    qdot = sp.Matrix([e for i in range(n) for e in w[i].cross(q[i])])
    residual = b - A * sp.Matrix(a_s)
    inputs = list(tu_symbols(system)[1:]) if system.driven else []
    return {
        "A": A,
        "b": b,
        "jq": qdot.jacobian(x),
        "jr": residual.jacobian(x),
        "ju": b.jacobian(inputs) if inputs else sp.zeros(3 * n, 0),
    }


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def jacobian_kernels(system: System) -> list[KernelDef]:
    """The ``field_jacobian`` kernel (row-major outputs jq, jr, am = A and, with inputs, ju),
    or none when the system is too large (`has_jacobian`)."""
    if not has_jacobian(system):
        return []
    n = system.n
    parts = field_jacobian(system)
    outputs = [
        Output("jq", _flat(parts["jq"])),
        Output("jr", _flat(parts["jr"])),
        Output("am", _flat(parts["A"])),
    ]
    if parts["ju"].cols:
        outputs.append(Output("ju", _flat(parts["ju"])))
    exprs = [e for o in outputs for e in o.exprs]
    return [
        KernelDef(
            "field_jacobian",
            "the field's derivatives: jq = d(w x q)/d(q, w), jr = d(b - A a)/d(q, w) at a, "
            "am = A(q), ju = db/du (row-major)",
            (
                Argument("p", system.parameter_symbols),
                Argument("q", tuple(q_symbols(n))),
                Argument("w", tuple(w_symbol(i, c) for i in range(1, n + 1) for c in range(3))),
                Argument("a", tuple(sp.symbols(f"a_0:{3 * n}", real=True))),
                *tu_argument(system, *exprs),
            ),
            tuple(outputs),
            system=True,
            stages=(("p", 0),),
        )
    ]
