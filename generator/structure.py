"""What a system's code needs: its coupling pairs and its system-specific kernels.

Input: a `System`. Output: the coupling structure of M (which off-diagonal entries are not
identically zero) and the `KernelDef`s that depend on the system itself: the potential V, its
gradient dV/dq_i (taken by SymPy), and the entries of M that exist, as functions of the
parameters. Everything generic (the flow itself) comes from `continuous.py` and `discrete.py`.

Example:
    >>> import sympy as sp
    >>> from s2gen.system import System, q_symbol
    >>> m = sp.Symbol("m", real=True)
    >>> s = System.create(name="two", n=2, parameters={"m": 1.0},
    ...                   inertia=sp.diag(m, m), potential=q_symbol(1, 0) * q_symbol(2, 0))
    >>> coupling_pairs(s)
    ()
"""

from __future__ import annotations

import sympy as sp

from .ir import Argument, KernelDef, Output
from .system import System, q_symbols

__all__ = ["coupling_pairs", "system_kernels"]


def coupling_pairs(system: System) -> tuple[tuple[int, int], ...]:
    """0-based pairs (i, j), i < j, whose M_ij is not identically zero, in row order."""
    M = system.inertia
    return tuple(
        (i, j) for i in range(system.n) for j in range(i + 1, system.n) if sp.simplify(M[i, j]) != 0
    )


def system_kernels(system: System) -> list[KernelDef]:
    """Potential, gradient and inertia-entry kernels of one system."""
    p = Argument("p", system.parameter_symbols)
    q = Argument("q", tuple(q_symbols(system.n)))
    V = system.potential
    grad = tuple(sp.diff(V, s) for s in q.symbols)
    pairs = coupling_pairs(system)
    M = system.inertia
    outputs = [Output("mdiag", tuple(M[i, i] for i in range(system.n)))]
    if pairs:
        outputs.append(Output("mpair", tuple(M[i, j] for i, j in pairs)))
    return [
        KernelDef("potential", "potential energy V(q)", (p, q), (Output("v", (V,), scalar=True),)),
        KernelDef("gradient", "g = dV/dq, body-major (3 per body)", (p, q), (Output("g", grad),)),
        KernelDef(
            "inertia",
            "diagonal of M and its coupled off-diagonal entries (pair order of the header)",
            (p,),
            tuple(outputs),
        ),
    ]
