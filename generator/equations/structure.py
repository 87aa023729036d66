"""What a system's code needs: its coupling pairs and its system-specific kernels.

Input: a `System`. Output: the coupling structure of M (which off-diagonal entries are not
identically zero) and the `KernelDef`s that depend on the system itself: the potential V, its
gradient dV/dq_i (taken by SymPy), and the entries of M that exist, as functions of the
parameters. Everything generic (the flow itself) comes from `continuous.py` and `discrete.py`.

Example:
    >>> import sympy as sp
    >>> from s2gen.system import System
from s2gen.symbols import q_symbol
    >>> m = sp.Symbol("m", real=True)
    >>> s = System.create(name="two", n=2, parameters={"m": 1.0},
    ...                   inertia=sp.diag(m, m), potential=q_symbol(1, 0) * q_symbol(2, 0))
    >>> coupling_pairs(s)
    ()
"""

from __future__ import annotations

import sympy as sp

from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import local_vector, q_symbols
from s2gen.system import System, Term

__all__ = ["coupling_pairs", "has_general_potential", "system_kernels", "term_kernels"]


def coupling_pairs(system: System) -> tuple[tuple[int, int], ...]:
    """0-based pairs (i, j), i < j, whose M_ij is not identically zero, in row order."""
    entries = system.inertia.todok()
    return tuple(sorted((i, j) for (i, j), v in entries.items() if i < j and sp.simplify(v) != 0))


def has_general_potential(system: System) -> bool:
    """True when V has an unstructured part (anything outside the terms)."""
    return system.potential != 0 or not system.terms


def system_kernels(system: System) -> list[KernelDef]:
    """Inertia-entry kernel and, when V has a general part, its potential and gradient."""
    p = Argument("p", system.parameter_symbols)
    pairs = coupling_pairs(system)
    M = system.inertia
    diag = [M[i, i] for i in range(system.n)]
    # a uniform diagonal is one value, filled in by a loop (code size independent of n)
    uniform = all(d == diag[0] for d in diag)
    outputs = [Output("mdiag", (diag[0],) if uniform else tuple(diag))]
    if pairs:
        outputs.append(Output("mpair", tuple(M[i, j] for i, j in pairs)))
    kernels = [
        KernelDef(
            "inertia",
            "diagonal of M and its coupled off-diagonal entries (pair order of the header)",
            (p,),
            tuple(outputs),
            system=True,
        )
    ]
    if has_general_potential(system):
        q = Argument("q", tuple(q_symbols(system.n)))
        V = system.potential
        grad = tuple(sp.diff(V, s) for s in q.symbols)
        kernels += [
            KernelDef(
                "potential",
                "potential energy V(q) (general part)",
                (p, q),
                (Output("v", (V,), scalar=True),),
                system=True,
                stages=(("p", 0),),
            ),
            KernelDef(
                "gradient",
                "dV/dq, body-major (3 per body)",
                (p, q),
                (Output("g", grad),),
                system=True,
                stages=(("p", 0),),
            ),
        ]
    return kernels


def term_kernels(system: System, index: int, term: Term) -> tuple[KernelDef, KernelDef]:
    """Value and gradient kernels of one term, in its local positions, data and parameters."""
    p = Argument("p", system.parameter_symbols)
    positions = [Argument(role, local_vector(role)) for role in term.roles()]
    # data arguments are prefixed so that no datum name can clash with p, q, v, g, ...
    data = [Argument(f"d_{d.name}", d.symbols(), scalar=d.width == 1) for d in term.data]
    inputs = (p, *positions, *data)
    stages = (("p", 0), *((a.name, 1) for a in data))
    where = f"{term.label}: {'sum over bodies' if term.kind == 'body' else 'sum over pairs'}"
    grads = tuple(
        Output(f"g{role[1:]}" if role != "q" else "g", tuple(sp.diff(term.expr, s) for s in pos))
        for role, pos in zip(term.roles(), (a.symbols for a in positions))
    )
    return (
        KernelDef(
            f"t{index}_value",
            f"{where} ({term.select}), value",
            inputs,
            (Output("v", (term.expr,), scalar=True),),
            stages=stages,
        ),
        KernelDef(
            f"t{index}_gradient", f"{where} ({term.select}), gradient", inputs, grads, stages=stages
        ),
    )
