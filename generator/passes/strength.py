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

    def __init__(self, uses: dict[sp.Expr, int] | None = None) -> None:
        #: reducible powers of each base in the kernel (see `_uses`): a lone 1/b or sqrt(b)
        #: is left as written, one a base shares with other powers joins its chain
        self.uses = uses or {}
        self.raw: dict[sp.Symbol, sp.Expr] = {}  # a base's symbol -> the base as written
        self.halves: set[sp.Expr] = set()  # bases with a half-integer negative power
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
        """1/b ("inv"), sqrt(b) ("sqrt") or 1/sqrt(b) ("isqrt"), once per base; with a
        half-integer negative power as well, 1/b is (1/sqrt(b))^2 (one division per base)."""
        key = (base, kind, 1)
        if key not in self.made:
            if kind == "inv" and self.raw.get(base, base) in self.halves:
                unit = self.root(base, "isqrt")
                expr: sp.Expr = sp.Mul(unit, unit, evaluate=False)
            elif kind == "inv":
                expr = sp.Pow(base, -1, evaluate=False)
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
            lone = e in _SIMPLE and self.uses.get(expr.base, 0) < 2
            if twice.is_Integer and 0 < abs(twice) <= 2 * LIMIT and e != 1 and not lone:
                raw = expr.base
                base = raw if raw.is_Symbol else self.named(self.replace(raw))
                self.raw[base] = raw
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


#: Powers that cost one operation alone (1/b, sqrt(b), 1/sqrt(b)): reduced only when their base
#: has other reducible powers in the kernel, whose chain they then share.
_SIMPLE = (sp.Integer(-1), sp.Rational(1, 2), sp.Rational(-1, 2))


def _uses(kernel: Kernel) -> tuple[dict[sp.Expr, int], set[sp.Expr]]:
    """Per base: how many reducible powers of it the kernel has; and the bases with a
    half-integer negative power (whose 1/b is then the square of 1/sqrt(b))."""
    uses: dict[sp.Expr, int] = {}
    halves: set[sp.Expr] = set()
    for a in kernel.assignments:
        for e in sp.preorder_traversal(a.expr):
            reducible = isinstance(e, sp.Pow) and e.exp.is_Rational and (2 * e.exp).is_Integer
            if reducible and e.exp != 1 and abs(e.exp) <= LIMIT:
                uses[e.base] = uses.get(e.base, 0) + 1
                if e.exp.is_negative and not e.exp.is_Integer:
                    halves.add(e.base)
    return uses, halves


@functools.lru_cache(maxsize=1024)
def reduce_kernel(kernel: Kernel) -> Kernel:
    """The kernel with its powers of symbols sharing roots and squares."""
    uses, halves = _uses(kernel)
    powers = _Powers(uses)
    powers.halves = halves
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
