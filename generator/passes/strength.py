"""Pass `strength`: powers by products of shared bases, one division and one square root per base.

Input: a `Module` of lowered kernels. Output: the same module in which, for every base `b`
raised to rational powers in a kernel (a symbol, or an expression first named as a
temporary so that its powers do not recompute it), the powers share their work:
one division `1/b` for all negative exponents, one `sqrt(b)` for all half-integer exponents, and
integer powers built by repeated squaring from a chain of squares shared by every exponent of
that base (b^7 and b^4 cost four multiplications together, not nine). New temporaries are named
pw0, pw1, ... and placed right after the base is defined. Powers the pass leaves alone (bases
with exponents other than integers and halves, or beyond `LIMIT`) are left to `powers`.

Example:
    >>> import sympy as sp
    >>> from s2gen.ir import Argument, KernelDef, Output
    >>> from s2gen.passes.cse import lower_kernel
    >>> x = sp.Symbol("x", real=True)
    >>> k = lower_kernel(KernelDef("k", "", (Argument("x", (x,), True),),
    ...                            (Output("y", (x**-7 + x**-4 + x**sp.Rational(3, 2),)),)))
    >>> [str(a.expr) for a in reduce_kernel(k).assignments]
    ['1/x', 'pw0*pw0', 'pw1*pw1', 'sqrt(x)', 'pw0*pw1*pw2 + pw2 + pw3*x']
"""

from __future__ import annotations

import functools
from dataclasses import replace

import sympy as sp

from s2gen.ir import Assignment, Kernel, Module

__all__ = ["reduce_kernel", "strength_pass"]

#: Exponents beyond this are left to pow() (repeated squaring would not pay).
LIMIT = 64


class _Powers:
    """The shared power chains of one kernel's bases, as new temporaries."""

    def __init__(self) -> None:
        self.count = 0
        self.new: dict[sp.Symbol, list[Assignment]] = {}  # base -> its chain, in order
        self.made: dict[tuple[sp.Symbol, str, int], sp.Expr] = {}
        self.bases: dict[sp.Expr, sp.Symbol] = {}  # a base that is an expression -> its temp
        self.pending: list[Assignment] = []  # base temporaries to place before the assignment

    def fresh(self) -> sp.Symbol:
        sym = sp.Symbol(f"pw{self.count}", real=True)
        self.count += 1
        return sym

    def temp(self, base: sp.Symbol, expr: sp.Expr) -> sp.Symbol:
        sym = self.fresh()
        self.new.setdefault(base, []).append(Assignment(sym, None, expr))
        return sym

    def named(self, base: sp.Expr) -> sp.Symbol:
        """A base that is an expression, named once (so its powers do not recompute it)."""
        if base not in self.bases:
            sym = self.fresh()
            self.bases[base] = sym
            self.pending.append(Assignment(sym, None, base))
        return self.bases[base]

    def root(self, base: sp.Symbol, kind: str) -> sp.Expr:
        """1/b ("inv"), sqrt(b) ("sqrt") or 1/sqrt(b) ("isqrt"), once per base."""
        key = (base, kind, 1)
        if key not in self.made:
            if kind == "inv":
                expr: sp.Expr = sp.Pow(base, -1, evaluate=False)
            elif kind == "sqrt":
                expr = sp.sqrt(base)
            else:
                expr = sp.Pow(self.root(base, "sqrt"), -1, evaluate=False)
            self.made[key] = self.temp(base, expr)
        return self.made[key]

    def power(self, base: sp.Symbol, start: sp.Expr, kind: str, k: int) -> sp.Expr:
        """start**k by the shared chain of squares of `start` (k >= 1)."""
        squares = [start]
        while 2 ** len(squares) <= k:
            key = (base, kind, 2 ** len(squares))
            if key not in self.made:
                self.made[key] = self.temp(base, sp.Mul(squares[-1], squares[-1], evaluate=False))
            squares.append(self.made[key])
        factors = [squares[j] for j in range(len(squares)) if k >> j & 1]
        return factors[0] if len(factors) == 1 else sp.Mul(*factors, evaluate=False)

    def replace(self, expr: sp.Expr) -> sp.Expr:
        """`expr` with its reducible powers written from the chains."""
        if expr.is_Pow and expr.exp.is_Rational:
            e = expr.exp
            twice = 2 * e
            if twice.is_Integer and 1 < abs(twice) <= 2 * LIMIT and e not in (1, -1):
                base = expr.base
                if not base.is_Symbol:
                    base = self.named(self.replace(base))
                whole, half = divmod(int(abs(twice)), 2)
                negative = e < 0
                if half:
                    unit = self.root(base, "isqrt" if negative else "sqrt")
                    if not whole:
                        return unit
                    start = self.root(base, "inv") if negative else base
                    rest = self.power(base, start, "inv" if negative else "pos", whole)
                    return sp.Mul(rest, unit, evaluate=False)
                start = self.root(base, "inv") if negative else base
                return self.power(base, start, "inv" if negative else "pos", whole)
        if not expr.args:
            return expr
        return expr.func(*(self.replace(a) for a in expr.args))


@functools.lru_cache(maxsize=1024)
def reduce_kernel(kernel: Kernel) -> Kernel:
    """The kernel with its powers of symbols sharing roots and squares."""
    powers = _Powers()
    staged: list[tuple[list[Assignment], Assignment]] = []  # (base temps before it, assignment)
    for a in kernel.assignments:
        expr = powers.replace(a.expr)
        staged.append((powers.pending, Assignment(a.temp, a.output, expr)))
        powers.pending = []
    if not powers.new and not powers.bases:
        return kernel
    defined = {a.temp for _, a in staged if a.temp is not None} | set(powers.bases.values())
    out: list[Assignment] = []
    for base, chain in powers.new.items():  # bases that are inputs: their chains first
        if base not in defined:
            out += chain
    for before, a in staged:
        for b in before:
            out.append(b)
            out += powers.new.get(b.temp, [])  # type: ignore[arg-type]
        out.append(a)
        if a.temp is not None and a.temp in powers.new:
            out += powers.new[a.temp]
    return replace(kernel, assignments=tuple(out))


def clear_cache() -> None:
    """Forget the kernels reduced in this process."""
    reduce_kernel.cache_clear()


def strength_pass(module: Module) -> Module:
    """Reduce the powers of every lowered kernel of the module."""
    kernels = tuple(reduce_kernel(k) if isinstance(k, Kernel) else k for k in module.kernels)
    return replace(module, kernels=kernels)
