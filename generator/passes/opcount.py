"""Pass `opcount`: operation counts of each lowered kernel, shown in the emitted files.

Input: a `Module` of lowered kernels. Output: the same module with each kernel's `ops_after`
set to the operations its assignments cost as printed (`Ops`): additions and subtractions,
multiplications, divisions, square roots and calls of other functions (pow, exp, ...). A
numeric coefficient is one multiplication, a negation is free, x**k for a small integer k is
k - 1 multiplications (as the `powers` pass writes it), x**-1 a division, x**(1/2) a square
root. These are the operations the C compiler cannot remove; the counts before and after the
passes show what each pass saved.

Example:
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> str(profile([3 * x / y + sp.sqrt(x) - x**3]))
    '7 ops (2 +, 3 *, 1 /, 1 sqrt, 0 calls)'
"""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass, replace

import sympy as sp

from s2gen.ir import Kernel, KernelDef, Module

__all__ = [
    "Ops",
    "definition_profile",
    "kernel_ops",
    "kernel_profile",
    "module_ops",
    "opcount_pass",
    "profile",
]

#: Integer powers up to this are counted as products (the `powers` pass writes them so).
_PRODUCT_POWERS = 16


@dataclass(frozen=True)
class Ops:
    """Operations by kind."""

    add: int = 0
    mul: int = 0
    div: int = 0
    sqrt: int = 0
    call: int = 0

    def __add__(self, other: Ops) -> Ops:
        return Ops(
            self.add + other.add,
            self.mul + other.mul,
            self.div + other.div,
            self.sqrt + other.sqrt,
            self.call + other.call,
        )

    @property
    def total(self) -> int:
        return self.add + self.mul + self.div + self.sqrt + self.call

    def __str__(self) -> str:
        return (
            f"{self.total} ops ({self.add} +, {self.mul} *, {self.div} /, {self.sqrt} sqrt, "
            f"{self.call} calls)"
        )


def _power(exp: sp.Basic) -> Ops:
    """The cost of base**exp beyond the base's own."""
    if exp.is_Integer:
        k = abs(int(exp))
        if k <= _PRODUCT_POWERS:
            return Ops(mul=max(k - 1, 0), div=1 if exp.is_negative else 0)
        return Ops(call=1)
    if exp == sp.Rational(1, 2):
        return Ops(sqrt=1)
    if exp == sp.Rational(-1, 2):
        return Ops(sqrt=1, div=1)
    return Ops(call=1)


def _count(e: sp.Basic) -> Ops:
    if e.is_Atom:
        return Ops()
    inner = Ops()
    for a in e.args:
        inner = inner + _count(a)
    if isinstance(e, sp.UnevaluatedExpr):  # the `powers` pass's products
        return inner
    if isinstance(e, sp.Add):
        return inner + Ops(add=len(e.args) - 1)
    if isinstance(e, sp.Mul):
        coeff, factors = e.as_coeff_mul()
        numerator = [f for f in factors if not (f.is_Pow and f.exp == -1)]
        mul = max(len(numerator) - 1, 0) + (0 if coeff in (1, -1) or not numerator else 1)
        # a reciprocal factor is a division (its Pow already counted it; a/b is one operation)
        return inner + Ops(mul=mul)
    if isinstance(e, sp.Pow):
        return inner + _power(e.exp)
    return inner + Ops(call=1)


def profile(exprs: Iterable[sp.Basic]) -> Ops:
    """The operations of a list of expressions, printed as C."""
    total = Ops()
    for e in exprs:
        total = total + _count(sp.sympify(e))
    return total


@functools.lru_cache(maxsize=2048)
def kernel_profile(kernel: Kernel) -> Ops:
    """Operations of a lowered kernel's assignments, by kind."""
    return profile(a.expr for a in kernel.assignments)


def kernel_ops(kernel: Kernel) -> int:
    """Operations of a lowered kernel's assignments."""
    return kernel_profile(kernel).total


@functools.lru_cache(maxsize=2048)
def definition_profile(kdef: KernelDef) -> Ops:
    """Operations of a kernel definition's outputs as derived (no common subexpressions)."""
    return profile(e for o in kdef.outputs for e in o.exprs)


def module_ops(module: Module) -> Ops:
    """Operations of all kernels of a module: lowered kernels as printed, kernels not yet
    lowered as derived."""
    total = Ops()
    for k in module.kernels:
        total = total + (kernel_profile(k) if isinstance(k, Kernel) else definition_profile(k))
    return total


def opcount_pass(module: Module) -> Module:
    """Attach `ops_after` to every lowered kernel."""
    kernels = tuple(
        replace(k, ops_after=kernel_ops(k)) if isinstance(k, Kernel) else k for k in module.kernels
    )
    return replace(module, kernels=kernels)
