"""Equations to IR: common-subexpression elimination, power expansion, op counts.

Input: `KernelDef`s (SymPy expressions) and a `System`. Output: frozen `Kernel`s and the
`Module` that gathers them with the system's structure. Temporaries are named x0, x1, ... in
the order SymPy's canonical cse produces them, so the same input always gives the same names.

Example:
    >>> import sympy as sp
    >>> from s2gen.ir import Argument, KernelDef, Output
    >>> x = sp.Symbol("x", real=True)
    >>> k = lower(KernelDef("k", "doc", (Argument("x", (x,), scalar=True),),
    ...                     (Output("y", (sp.sin(x) ** 2 + sp.sin(x),), scalar=True),)))
    >>> [str(a.temp) for a in k.assignments if a.temp is not None]
    ['x0']
"""

from __future__ import annotations

import functools

import sympy as sp
from sympy.codegen.rewriting import create_expand_pow_optimization

from s2gen.equations.continuous import continuous_kernels
from s2gen.equations.discrete import explicit_kernels, newton_kernels
from s2gen.equations.rattle import rattle_kernels
from s2gen.equations.structure import coupling_pairs, system_kernels, term_kernels
from s2gen.ir import Assignment, Kernel, KernelDef, Module, TermLoop
from s2gen.system import System, Term

__all__ = ["lower", "lower_system", "workspace_size"]

#: Integer powers up to this exponent become products (any base, not only symbols): pow() is a
#: library call, x*x*x a few cycles; cse has already named repeated bases.
POW_EXPANSION_LIMIT = 16
_expand_pow = create_expand_pow_optimization(POW_EXPANSION_LIMIT, base_req=lambda b: True)


def _ops(exprs: list[sp.Expr]) -> int:
    return int(sum(sp.count_ops(e) for e in exprs))


def lower(kdef: KernelDef) -> Kernel:
    """Eliminate common subexpressions of all outputs of one kernel together."""
    flat = [e for out in kdef.outputs for e in out.exprs]
    slots = [(out.name, k) for out in kdef.outputs for k in range(out.size)]
    temps, reduced = sp.cse(
        [sp.sympify(e) for e in flat],
        symbols=sp.numbered_symbols("x", real=True),
        order="canonical",
    )
    assignments = [Assignment(t, None, _expand_pow(e)) for t, e in temps]
    assignments += [Assignment(None, slot, _expand_pow(e)) for slot, e in zip(slots, reduced)]
    return Kernel(
        name=kdef.name,
        doc=kdef.doc,
        inputs=kdef.inputs,
        outputs=kdef.outputs,
        assignments=tuple(assignments),
        ops_before=_ops(flat),
        ops_after=_ops([a.expr for a in assignments]),
    )


def workspace_size(n: int, coupled: bool) -> int:
    """Doubles of caller-provided workspace the emitted driver needs (see the C header)."""
    m = 3 * n
    flow = 12 * m  # q, w, g, gn, qn, wn, f, d, r, ... one vector of 3n each
    rk = 10 * 2 * m  # RK45: 7 stages, y, ynew, err (state is 6n)
    dense = (m * m + 2 * m) if coupled else 0  # one 3n x 3n matrix, rhs and scratch
    return flow + rk + dense


def _term_loop(system: System, index: int, term: Term) -> TermLoop:
    value, gradient = term_kernels(system, index, term)
    return TermLoop(
        index=index,
        kind=term.kind,
        select=term.select,
        count=term.count(system.n),
        members=term.members,
        data=tuple((d.name, d.width, d.values) for d in term.data),
        value=lower(value),
        gradient=lower(gradient),
        cutoff=term.cutoff,
        cells=cell_grid(term.cutoff) if term.cutoff is not None else 0,
    )


#: Most neighbour-list cells per axis (bounds the list's memory when the cutoff is tiny).
MAX_CELLS = 160


def cell_grid(cutoff: float) -> int:
    """Cells per axis of a grid over [-1, 1]^3 whose cells are at least `cutoff` wide."""
    return max(1, min(int(2.0 / cutoff), MAX_CELLS))


@functools.lru_cache(maxsize=2)
def generic_kernels(coupled: bool) -> tuple[Kernel, ...]:
    """The system-independent kernels (derived and lowered once per process)."""
    defs = continuous_kernels(coupled) + (
        newton_kernels() if coupled else explicit_kernels() + rattle_kernels()
    )
    return tuple(lower(k) for k in defs)


def lower_system(system: System) -> Module:
    """All kernels of one system, lowered, with the structure the templates need."""
    pairs = coupling_pairs(system)
    coupled = bool(pairs)
    terms = tuple(_term_loop(system, k, t) for k, t in enumerate(system.terms))
    neighbour = max((t.cells**3 + system.n for t in terms if t.cells), default=0)
    return Module(
        name=system.name,
        spec_hash=system.spec_hash(),
        origin=system.origin,
        n=system.n,
        parameter_names=system.parameter_names,
        parameter_values=system.parameter_values,
        coupled=coupled,
        pairs=pairs,
        system_kernels=tuple(lower(k) for k in system_kernels(system)),
        terms=terms,
        body_kernels=generic_kernels(coupled),
        work_base=workspace_size(system.n, coupled),
        work_size=workspace_size(system.n, coupled)
        + system.n
        + len(pairs)
        + (system.n if coupled else 0)
        + neighbour,
    )
