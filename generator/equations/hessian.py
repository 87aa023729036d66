"""The second derivatives the step Jacobians need, derived per term and evaluated per member.

Input: a `System` with step Jacobians (`s2gen.equations.jacobian.has_jacobian`). Output: the
kernels that the ``jacobian`` part calls to assemble, at run time, the Hessian of V and the
derivatives of the forces (3n x 3n each, dense):

- ``t<k>_hessian`` for structured term k: the Hessian of the term's expression in its local
  positions (3 x 3 for a body term, 6 x 6 for a pair term, rows and columns (qi, qj)) and the
  derivative of its gradient in the inputs and the parameters (``gpb``), derived once for the term and called
  for each member in the term's own loop, in its local positions, data and parameters (like
  ``t<k>_gradient``), its blocks added into H (and dg/dp) at the member's bodies;
- ``hessian``: the Hessian of V's general part (the part written as one expression of all
  positions, `s2gen.equations.structure.has_general_potential`) and the derivative of its
  gradient in the inputs and the parameters, whole-system;
- ``force_jacobian`` (driven systems with forces): F and its derivatives in q, w, the inputs
  and the parameters, whole-system (the forces of a spec are written per body, with few
  bodies).

So the derivation grows with the number of term kinds, not with the number of members, and no
whole-system expression of a structured V is differentiated twice.

Example:
    >>> from s2gen.systems import builtin
    >>> [k.name for k in hessian_kernels(builtin("four_pendula"))]
    ['t0_hessian', 't1_hessian']
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from s2gen.equations.driven import _force_total, tu_argument, tu_symbols
from s2gen.equations.structure import has_general_potential, term_kernels
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import q_symbols, w_symbol
from s2gen.system import System

__all__ = ["force_jacobian_kernel", "hessian_kernels", "sparse_jacobian"]


def sparse_jacobian(exprs: Sequence[sp.Expr], by: Sequence[sp.Symbol]) -> sp.Matrix:
    """d`exprs`/d`by`, differentiating each expression only in the symbols it contains (the
    rows of a structured system touch few of them).

    Example:
        >>> x, y = sp.symbols("x y")
        >>> sparse_jacobian([x * y, x**2], [x, y]).tolist()
        [[y, x], [2*x, 0]]
    """
    column = {s: c for c, s in enumerate(by)}
    out = sp.zeros(len(exprs), len(by))
    for r, e in enumerate(exprs):
        e = sp.sympify(e)
        for s in e.free_symbols & column.keys():
            out[r, column[s]] = sp.diff(e, s)
    return out


def _flat(mat: sp.Matrix) -> tuple[sp.Expr, ...]:
    return tuple(mat[r, c] for r in range(mat.rows) for c in range(mat.cols))


def hessian_kernels(system: System) -> list[KernelDef]:
    """The ``t<k>_hessian`` kernels of the structured terms with members (outputs ``hb``, the
    (3 a) x (3 a) Hessian row-major, a the term's arity, and ``gpb``, (3 a) x (inputs +
    parameters)) and, when V has a general part that depends on the positions, ``hessian``
    (outputs ``hv``, 3n x 3n, and ``gpv``, 3n x (inputs + parameters)); ``gpb`` and ``gpv``
    only when there are inputs or parameters."""
    kernels = []
    # the columns of dg/d(u, p): the inputs (V may read them), then the parameters
    params = [*(tu_symbols(system)[1:] if system.driven else ()), *system.parameter_symbols]
    for k, term in enumerate(system.terms):
        if term.count(system.n) == 0:
            continue
        value = term_kernels(system, k, term)[0]
        positions = term.position_symbols()
        grad = [sp.diff(term.expr, s) for s in positions]
        outputs = [Output("hb", _flat(sparse_jacobian(grad, positions)))]
        if params:
            outputs.append(Output("gpb", _flat(sparse_jacobian(grad, params))))
        kernels.append(
            KernelDef(
                f"t{k}_hessian",
                f"{term.label}: one member's term's Hessian in its positions (hb) and its "
                "gradient's derivative in the inputs and parameters (gpb), row-major",
                value.inputs,
                tuple(outputs),
                stages=value.stages,
            )
        )
    qs = q_symbols(system.n)
    if has_general_potential(system) and system.potential.free_symbols & set(qs):
        V = system.potential
        grad = [sp.diff(V, s) for s in qs]
        hv = sparse_jacobian(grad, qs)
        outputs = [Output("hv", _flat(hv))]
        if params:
            outputs.append(Output("gpv", _flat(sparse_jacobian(grad, params))))
        kernels.append(
            KernelDef(
                "hessian",
                "V's general part: its Hessian (hv) and its gradient's derivative in the "
                "inputs and parameters (gpv), row-major",
                (
                    Argument("p", system.parameter_symbols),
                    Argument("q", tuple(qs)),
                    *tu_argument(system, *[e for o in outputs for e in o.exprs]),
                ),
                tuple(outputs),
                system=True,
                stages=(("p", 0),),
            )
        )
    return kernels


def force_jacobian_kernel(system: System) -> list[KernelDef]:
    """``force_jacobian`` for a driven system with forces: outputs F (3n), fq = dF/dq,
    fw = dF/dw (3n x 3n), fu = dF/du (3n x inputs) and fp = dF/dp (3n x parameters),
    row-major (fu, fp only when there are inputs, parameters); else none."""
    if not system.forces:
        return []
    n = system.n
    qs = q_symbols(n)
    ws = [w_symbol(i, c) for i in range(1, n + 1) for c in range(3)]
    inputs = list(tu_symbols(system)[1:])
    F = list(_force_total(system))
    outputs = [
        Output("F", tuple(F)),
        Output("fq", _flat(sparse_jacobian(F, qs))),
        Output("fw", _flat(sparse_jacobian(F, ws))),
    ]
    if inputs:
        outputs.append(Output("fu", _flat(sparse_jacobian(F, inputs))))
    if system.parameter_symbols:
        outputs.append(Output("fp", _flat(sparse_jacobian(F, list(system.parameter_symbols)))))
    return [
        KernelDef(
            "force_jacobian",
            "the forces F and their derivatives dF/dq, dF/dw, dF/du (row-major)",
            (
                Argument("p", system.parameter_symbols),
                Argument("q", tuple(qs)),
                Argument("w", tuple(ws)),
                *tu_argument(system, *F),
            ),
            tuple(outputs),
            system=True,
            stages=(("p", 0),),
        )
    ]
