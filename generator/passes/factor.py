"""Pass `factor`: common factors pulled out of sums, before common subexpressions are sought.

Input: a `Module` whose kernels are `KernelDef`s. Output: the same kernels with every output
expression passed through `sympy.factor_terms` (which pulls common numeric and symbolic factors
out of sums without expanding anything), so that, e.g., the two components 12*qi_0 - 12*qj_0 and
6*qi_0 - 6*qj_0 of a gradient become 12*(qi_0 - qj_0) and 6*(qi_0 - qj_0) and `cse` finds the
shared difference. Factoring can also hide a subexpression two outputs share, so a kernel keeps
its factored form only when `cse` then leaves fewer operations. Factored once per kernel
definition, kept in the process and on disk (`s2gen.derivations`).

Example:
    >>> import sympy as sp
    >>> a, b = sp.symbols("a b")
    >>> factored(12 * a - 12 * b)
    12*(a - b)
"""

from __future__ import annotations

import functools
from dataclasses import replace

import sympy as sp

from s2gen.ir import KernelDef, Module, Output

__all__ = ["factor_pass", "factored"]


def factored(expr: sp.Expr) -> sp.Expr:
    """`expr` with common factors pulled out of its sums (nothing expanded)."""
    return sp.factor_terms(expr)


@functools.lru_cache(maxsize=1024)
def _factor_kernel(kdef: KernelDef) -> KernelDef:
    """`_factored_kernel`, read from the disk cache of derivations when it holds this kernel."""
    from s2gen.build import cache_dir
    from s2gen.derivations import cached, kernel_key

    return cached(cache_dir(), "factor", kernel_key(kdef), lambda: _factored_kernel(kdef))


def _factored_kernel(kdef: KernelDef) -> KernelDef:
    """The factored kernel, when common subexpressions then cost fewer operations; else the
    kernel as it is (factoring can hide a subexpression two outputs share)."""
    from s2gen.passes.cse import lower_kernel
    from s2gen.passes.opcount import kernel_ops

    outputs = tuple(
        Output(o.name, tuple(factored(sp.sympify(e)) for e in o.exprs), o.scalar)
        for o in kdef.outputs
    )
    candidate = replace(kdef, outputs=outputs)
    if kernel_ops(lower_kernel(candidate)) < kernel_ops(lower_kernel(kdef)):
        return candidate
    return kdef


def clear_cache() -> None:
    """Forget the kernels factored in this process."""
    _factor_kernel.cache_clear()


def factor_pass(module: Module) -> Module:
    """Factor the outputs of every kernel definition of the module."""
    kernels = tuple(_factor_kernel(k) if isinstance(k, KernelDef) else k for k in module.kernels)
    return replace(module, kernels=kernels)
