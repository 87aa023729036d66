"""Pass `cse`: common-subexpression elimination of each kernel, with deterministic names.

Input: a `Module` whose kernels are `KernelDef`s. Output: the same module with `Kernel`s: all
outputs of one kernel share one elimination, temporaries are named x0, x1, ... in the order
SymPy's canonical cse produces them (the same input always gives the same names), and
`ops_before` holds the operations of the expressions as derived. Kernels are lowered once per
process and kept on disk (the generic ones are shared by every system).

Example:
    >>> import sympy as sp
    >>> from s2gen.ir import Argument, KernelDef, Output
    >>> x = sp.Symbol("x", real=True)
    >>> k = lower_kernel(KernelDef("k", "doc", (Argument("x", (x,), scalar=True),),
    ...                            (Output("y", (sp.sin(x) ** 2 + sp.sin(x),), scalar=True),)))
    >>> [str(a.temp) for a in k.assignments if a.temp is not None]
    ['x0']
"""

from __future__ import annotations

import functools
from dataclasses import replace

import sympy as sp

from s2gen.ir import Assignment, Kernel, KernelDef, Module

__all__ = ["count_ops", "cse_pass", "lower_kernel"]


def count_ops(exprs: list[sp.Expr] | tuple[sp.Expr, ...]) -> int:
    """Operations of a list of expressions as printed (see `passes.opcount.profile`)."""
    from s2gen.passes.opcount import profile

    return profile(exprs).total


@functools.lru_cache(maxsize=1024)
def lower_kernel(kdef: KernelDef) -> Kernel:
    """Eliminate common subexpressions of all outputs of one kernel together (read from the
    disk cache of derivations, `s2gen.derivations`, when it holds this kernel)."""
    from s2gen.build import cache_dir
    from s2gen.derivations import cached, kernel_key

    return cached(cache_dir(), "cse", kernel_key(kdef), lambda: _eliminate(kdef))


def _eliminate(kdef: KernelDef) -> Kernel:
    flat = [sp.sympify(e) for out in kdef.outputs for e in out.exprs]
    slots = [(out.name, k) for out in kdef.outputs for k in range(out.size)]
    temps, reduced = sp.cse(flat, symbols=sp.numbered_symbols("x", real=True), order="canonical")
    assignments = [Assignment(t, None, e) for t, e in temps]
    assignments += [Assignment(None, slot, e) for slot, e in zip(slots, reduced)]
    return Kernel(
        name=kdef.name,
        doc=kdef.doc,
        inputs=kdef.inputs,
        outputs=kdef.outputs,
        assignments=tuple(assignments),
        ops_before=count_ops(flat),
        ops_after=-1,
        system=kdef.system,
        stages=kdef.stages,
    )


def cse_pass(module: Module) -> Module:
    """Lower every kernel definition of the module (kernels already lowered stay)."""
    kernels = tuple(lower_kernel(k) if isinstance(k, KernelDef) else k for k in module.kernels)
    return replace(module, kernels=kernels)
