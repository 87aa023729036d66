"""The cost model of the `quadratic` pass: one gradient evaluation through the constant matrix
K against the same evaluation through the terms' own member loops.

Input: the sizes the pass knows (the order 3n of K; per term its member count, arity, the
coefficients of its member's quadratic form and whether its loop is contiguous). Output: a
`Cost` per choice (floating-point operations, bytes streamed, vector lanes) and its estimated
cycles on one core, the larger of

- compute: operations / (`PIPES` x lanes): two floating-point pipes, each taking `LANES`
  doubles per operation in a contiguous loop and one in a loop that gathers its operands;
- memory: bytes streamed / the bandwidth of the cache level the streamed bytes fit in
  (`TIERS`: 32 bytes per cycle within a 32 KiB L1, 16 within a 1 MiB L2, 12 within a 32 MiB
  L3, 4 from memory beyond). On a 2-core AMD EPYC with a 32 MiB L3 (gcc 12, -O3
  -march=native), a full 3 x 3 coupling of every listed pair took per VI step 124 ns through
  K and 755 ns through the gathered loop at 16 bodies, 25 and 36 us at 130, 145 and 220 us at
  400 (K of 11.5 MB streamed at about 80 GB/s): the model picks K in all three.

K costs (3n)^2 multiply-adds (plus 3n additions of its linear part b) on contiguous rows and
streams its 8 (3n)^2 bytes once per evaluation, whatever the terms in it. A member loop costs,
per member, the operations of the member's gradient written from its coefficients (B_m x_m +
b_m, counted by `opcount.profile`: the `hoist` pass makes what depends only on parameters and
data a member table, so the term's own kernel costs about this; the dipoles' takes 30
operations a pair where this counts 36),
plus 3 additions per body to scatter it into the gradient, and streams the coefficient slots
and the member's body indices. Positions and gradient (48 n bytes) stay in cache either way.

Example:
    >>> matrix_cost(48).ops, matrix_cost(48).cycles
    (4656, 612.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from s2gen.passes.opcount import profile

__all__ = ["LANES", "PIPES", "TIERS", "Cost", "loop_cost", "matrix_cost"]

#: Doubles per vector operation in a contiguous loop (256-bit vectors).
LANES = 4
#: Floating-point operations issued per cycle.
PIPES = 2
#: (bytes a cache level holds, bytes per cycle it delivers), nearest first; beyond the last,
#: the bandwidth of `_FAR`.
TIERS: tuple[tuple[int, float], ...] = (
    (32 * 1024, 32.0),
    (1024 * 1024, 16.0),
    (32 * 1024 * 1024, 12.0),
)
_FAR = 4.0
_DOUBLE, _INDEX = 8, 4  # bytes of a coefficient, of a member's body index


@dataclass(frozen=True)
class Cost:
    """One gradient evaluation: operations, bytes streamed and the lanes the loop runs with."""

    ops: int
    bytes: int
    lanes: int

    @property
    def cycles(self) -> float:
        """Estimated cycles: the larger of compute and memory time.

        Example:
            >>> Cost(800, 320, 1).cycles, Cost(800, 64 * 1024, 4).cycles
            (400.0, 4096.0)
        """
        return max(self.ops / (PIPES * self.lanes), self.bytes / bandwidth(self.bytes))


def bandwidth(nbytes: int) -> float:
    """Bytes per cycle when `nbytes` are streamed from the nearest cache level holding them.

    Example:
        >>> bandwidth(18 * 1024), bandwidth(4 * 1024 * 1024), bandwidth(64 * 1024 * 1024)
        (32.0, 12.0, 4.0)
    """
    for size, rate in TIERS:
        if nbytes <= size:
            return rate
    return _FAR


def matrix_cost(order: int) -> Cost:
    """The product Kx + b with K of `order` x `order` (K's rows contiguous).

    Example:
        >>> matrix_cost(3).ops, matrix_cost(3).bytes
        (21, 144)
    """
    return Cost(2 * order * order + order, _DOUBLE * (order * order + 3 * order), LANES)


def loop_cost(
    count: int, entries: Sequence[tuple[int, int]], arity: int, contiguous: bool = False
) -> Cost:
    """A loop over `count` members of `arity` bodies whose member potential has the quadratic
    form with coefficients at (row, column) `entries` (Hessian upper triangle; column -1:
    linear, row and column -1: constant), each coefficient a slot of its member table;
    `contiguous` when the loop runs over contiguous rows (vectorised), not through gathers.

    Example:
        >>> chain = [(0, 3), (1, 4), (2, 5), (-1, -1)]  # k (1 - qi.qj)
        >>> c = loop_cost(19, chain, 2)
        >>> c.ops, c.cycles
        (228, 114.0)
    """
    x = sp.symbols(f"x:{3 * arity}")
    grad: list[sp.Expr] = [sp.Integer(0)] * (3 * arity)
    for k, (r, c) in enumerate(entries):
        b = sp.Symbol(f"b{k}")
        if r < 0:
            continue
        if c < 0:
            grad[r] += b
        elif r == c:
            grad[r] += b * x[r]
        else:
            grad[r] += b * x[c]
            grad[c] += b * x[r]
    member_ops = profile(grad).total + 3 * arity
    member_bytes = _DOUBLE * len(entries) + _INDEX * arity
    return Cost(count * member_ops, count * member_bytes, LANES if contiguous else 1)
