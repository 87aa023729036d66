"""Pass `quadratic`: terms whose potential is quadratic in the positions become one constant
matrix, built once per call, and the gradient a matrix-vector product.

Input: a `Module` whose kernels are `KernelDef`s. Output: the same module in which every term
whose member potential is a polynomial of degree <= 2 in the member's positions, with
coefficients in the parameters and the member's data (V_m = 1/2 x^T B_m x + b_m . x + c_m,
x the member's 3 or 6 coordinates), is marked `quadratic`: the new kernel `t<k>_quad` computes
the entries of B_m, b_m and c_m that are not identically zero (the zero pattern is found here,
once), and the emitted code adds them into one 3n x 3n matrix K, a vector b and a constant c
once per call, so that V = 1/2 q.Kq + b.q + c and dV/dq = Kq + b. The term's own kernels stay
for the functions that run without workspace.

Whether K pays is decided by a cost model (`passes/cost.py`) of one gradient evaluation, the
larger of its operations over the vector lanes and its bytes streamed over the bandwidth of
the cache level they fit in. K costs (3n)^2 multiply-adds on contiguous rows and streams its
8 (3n)^2 bytes, once for all the terms in it; each term's own loop costs, per member, the
operations of its gradient from its coefficients (B_m x_m + b_m: the `hoist` pass makes them a
member table; the dipoles' hoisted kernel takes 30 operations per pair, this counts 36) plus the scatter into the gradient, gathered (one lane) unless the term runs as
contiguous rows (`layout.contiguous`), and streams the member's coefficients and indices. The
quadratic terms go into K when K costs fewer cycles than their loops together, else all keep
their loops. So a bilinear term coupling every pair of a few bodies through a full 3 x 3 block
(the 16 dipoles: about 600 cycles through K, 2,200 through the gathered pair loop) takes K;
a chain or a single body (far fewer members than K has entries) keeps its loop; and once K
no longer fits a last-level cache (beyond about 680 such bodies, 3n = 2,040) the matrix
streamed from memory costs more than the loop's operations, and the loop is kept.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.equations.assemble import sphere_module
    >>> m = quadratic_pass(sphere_module(builtin("dipoles")))
    >>> m.quadratic, len(m.terms[0].quadratic)
    (48, 9)
"""

from __future__ import annotations

from dataclasses import replace

import sympy as sp

from s2gen.ir import KernelDef, Module, Output, TermLoop
from s2gen.passes.cost import Cost, loop_cost, matrix_cost
from s2gen.passes.layout import contiguous

__all__ = ["CONSTANT_ENTRY", "LINEAR", "MAX_BODIES", "costs", "quadratic_pass"]

#: Column index of a linear coefficient, and (row, column) of the constant, in an entry.
LINEAR = -1
CONSTANT_ENTRY = (-1, -1)
#: Largest system given a dense K (9 n^2 doubles of workspace), whatever the cost model says.
MAX_BODIES = 1024


def _degree_bound(expr: sp.Basic, coords: frozenset[sp.Symbol]) -> int | None:
    """An upper bound of the degree of `expr` as a polynomial in `coords`, read off its tree
    (sums: the largest, products: the sum, powers: times a non-negative integer exponent);
    None when the tree is not a polynomial in them (a coordinate under a root, a division or a
    function). Cheap, so that a term that is not quadratic is turned down without expanding it.

    Example:
        >>> x, y, a = sp.symbols("x y a")
        >>> _degree_bound(a * x * y + x, frozenset({x, y})), _degree_bound(1 / x, frozenset({x}))
        (2, None)
    """
    if not expr.has(*coords):
        return 0
    if expr.is_Symbol:
        return 1
    if isinstance(expr, sp.Add):
        parts = [_degree_bound(a, coords) for a in expr.args]
        return None if None in parts else max(p for p in parts if p is not None)
    if isinstance(expr, sp.Mul):
        parts = [_degree_bound(a, coords) for a in expr.args]
        return None if None in parts else sum(p for p in parts if p is not None)
    if isinstance(expr, sp.Pow) and expr.exp.is_Integer and expr.exp >= 0:
        base = _degree_bound(expr.base, coords)
        return None if base is None else base * int(expr.exp)
    return None


def _coefficients(expr: sp.Expr, coords: list[sp.Symbol]) -> list[tuple[int, int, sp.Expr]] | None:
    """(row, column, coefficient) of the Hessian's upper triangle, the linear part (column
    LINEAR) and the constant (row and column -1), not identically zero; None when `expr` is
    not a polynomial of degree <= 2 in `coords`."""
    expr = sp.sympify(expr)
    bound = _degree_bound(expr, frozenset(coords))
    if bound is None:
        return None
    if bound > 2:  # a polynomial whose terms of degree > 2 might cancel
        poly = expr.as_poly(*coords)
        if poly is None or poly.total_degree() > 2:
            return None
    at_zero = {c: 0 for c in coords}
    out: list[tuple[int, int, sp.Expr]] = []
    for r, x in enumerate(coords):
        for c in range(r, len(coords)):
            entry = sp.diff(expr, x, coords[c])
            if entry != 0:
                out.append((r, c, entry))
    for r, x in enumerate(coords):
        entry = sp.diff(expr, x).xreplace(at_zero)
        if entry != 0:
            out.append((r, LINEAR, entry))
    constant = expr.xreplace(at_zero)
    if constant != 0:
        out.append((*CONSTANT_ENTRY, constant))
    return out


Candidate = tuple[TermLoop, KernelDef, list[tuple[int, int, sp.Expr]]]


def _candidates(module: Module) -> list[Candidate]:
    """The terms over fixed members whose member potential is quadratic (not merely linear)
    in the positions, with their value kernel and coefficients."""
    found: list[Candidate] = []
    for t in module.terms:
        if not t.loop.kind.fixed:  # members found per call: no constant matrix
            continue
        value = module.kernel(t.value)
        assert isinstance(value, KernelDef)
        stages = dict(value.stages or ())
        positions = [a for a in value.inputs if a.name not in stages]
        coords = [s for a in positions for s in a.symbols]
        entries = _coefficients(value.outputs[0].exprs[0], coords)
        if entries is not None and any(c >= 0 for _, c, _ in entries):
            found.append((t, value, entries))
    return found


def _loop_cost(t: TermLoop, value: KernelDef, entries: list[tuple[int, int, sp.Expr]]) -> Cost:
    stages = dict(value.stages or ())
    arity = sum(1 for a in value.inputs if a.name not in stages)
    return loop_cost(t.loop.count, [(r, c) for r, c, _ in entries], arity, contiguous(t))


def costs(module: Module) -> tuple[Cost, tuple[tuple[int, Cost], ...]]:
    """The cost of one gradient evaluation through K, and (term index, cost) of each quadratic
    term's own loop, in the unlowered `module` (see the module's docstring).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.equations.assemble import sphere_module
        >>> k, loops = costs(sphere_module(builtin("dipoles")))
        >>> k.cycles, [(i, c.cycles) for i, c in loops]
        (612.0, [(0, 2160.0)])
    """
    loops = tuple((t.index, _loop_cost(t, v, e)) for t, v, e in _candidates(module))
    return matrix_cost(3 * module.n), loops


def quadratic_pass(module: Module) -> Module:
    """Put the quadratic terms into K when the cost model says K is cheaper than their loops;
    add their kernels."""
    if module.n > MAX_BODIES:
        return module
    found = _candidates(module)
    matrix = matrix_cost(3 * module.n)
    if not found or matrix.cycles >= sum(_loop_cost(*f).cycles for f in found):
        return module
    kernels = list(module.kernels)
    terms = list(module.terms)
    for t, value, entries in found:
        stages = dict(value.stages or ())
        inputs = tuple(a for a in value.inputs if a.name in stages)
        kernels.append(
            KernelDef(
                f"t{t.index}_quad",
                f"term {t.index}: its member's coefficients of 1/2 x^T B x + b.x + c "
                "(B's upper triangle, b, c; the entries not identically zero)",
                inputs,
                (Output("coef", tuple(e for _, _, e in entries)),),
            )
        )
        pattern = tuple((k, r, c) for k, (r, c, _) in enumerate(entries))
        terms[terms.index(t)] = replace(t, quadratic=pattern)
    parts = list(module.parts)
    parts.insert(parts.index("potential"), "quadratic")
    return replace(
        module,
        kernels=tuple(kernels),
        terms=tuple(terms),
        quadratic=3 * module.n,
        parts=tuple(parts),
    )
