"""Pass `powers`: small integer powers become products.

Input: a `Module` of lowered kernels. Output: the same module with every integer power up to
`POW_EXPANSION_LIMIT` written as repeated multiplication (any base, not only symbols): pow()
is a library call, x*x*x a few cycles, and cse has already named repeated bases.

Example:
    >>> import sympy as sp
    >>> x = sp.Symbol("x")
    >>> expand_pow(x**3 + 1)
    1 + x*x*x
"""

from __future__ import annotations

import functools
from dataclasses import replace

import sympy as sp
from sympy.codegen.rewriting import create_expand_pow_optimization

from s2gen.ir import Assignment, Kernel, Module

__all__ = ["POW_EXPANSION_LIMIT", "clear_cache", "expand_pow", "powers_pass"]

#: Integer powers up to this exponent become products.
POW_EXPANSION_LIMIT = 16
_expand = create_expand_pow_optimization(POW_EXPANSION_LIMIT, base_req=lambda b: True)


def expand_pow(expr: sp.Expr) -> sp.Expr:
    """`expr` with its integer powers up to the limit written as products."""
    return _expand(expr)  # type: ignore[no-any-return]


@functools.lru_cache(maxsize=1024)
def _expanded(kernel: Kernel) -> Kernel:
    assignments = tuple(
        Assignment(a.temp, a.output, expand_pow(a.expr)) for a in kernel.assignments
    )
    return replace(kernel, assignments=assignments)


def clear_cache() -> None:
    """Forget the kernels expanded in this process."""
    _expanded.cache_clear()


def powers_pass(module: Module) -> Module:
    """Expand small integer powers in every kernel of the module."""
    kernels = tuple(_expanded(k) if isinstance(k, Kernel) else k for k in module.kernels)
    return replace(module, kernels=kernels)
