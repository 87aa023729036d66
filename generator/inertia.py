"""The inertia matrix M: its structure, found or given, and the per-body way to give it.

Input: M as a SymPy matrix (any spec), or per-body expressions (`ChainInertia`, the
structured spec of a chain: three expressions and per-body data, never n^2 entries).
Output: an `InertiaStructure`, the typed record every later stage reads to choose its solvers:

- DIAGONAL: no off-diagonal entry (explicit updates, no solves);
- BANDED: M_ij = 0 for |i - j| > b, with b < n - 1 (neighbours only, a few coupled pairs);
- MAX_INDEX: M = diag(d) + (a_i a_j c_max(i,j))_{i != j}, every off-diagonal entry nonzero
  and c_k != c_k+1 (c_n+1 = 0): chains, rods, ropes. With C_ij = c_max(i,j) = sum_{k >= max}
  delta_k (delta_k = c_k - c_k+1), C = P diag(delta) P^T with P the upper triangle of ones,
  so C^-1 = P^-T diag(1/delta) P^-1 is tridiagonal:
      (C^-1)_kk = 1/delta_k-1 + 1/delta_k,   (C^-1)_k,k+1 = -1/delta_k    (1/delta_0 = 0);
- DENSE: anything else (the fallback).

Detection (`detect`) is symbolic, so that a structure holds for every parameter value the
emitted code may be called with: a pair is coupled unless its entry is identically zero, and
MAX_INDEX requires the 2 x 2 minors M_ij M_n1 - M_nj M_i1 (1 < j < i < n) to vanish
identically (SymPy `expand`, then `simplify`; a minor without parameters is a number and must
vanish to 1e-12 relative). Only the generators' nonzero conditions (M_n1, M_nj and the
differences delta_k away from 0) are checked at the spec's parameter values; the emitted code
reports ERR_SINGULAR if other values break them. Anything not proven falls back to DENSE.

Example:
    >>> import sympy as sp
    >>> m = sp.Symbol("m", real=True)
    >>> M = sp.ImmutableSparseMatrix(sp.Matrix(3, 3, lambda i, j: m * (3 - max(i, j))))
    >>> detect(M, {m: 1.0}).kind
    <InertiaKind.MAX_INDEX: 'max-index'>
    >>> tridiagonal = sp.ImmutableSparseMatrix(3, 3, {(0, 0): m, (1, 1): m, (2, 2): m,
    ...                                            (0, 1): 1, (1, 0): 1})
    >>> detect(tridiagonal, {m: 3.0}).kind
    <InertiaKind.BANDED: 'banded'>
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

if TYPE_CHECKING:
    from s2gen.system import TermData

__all__ = [
    "INDEX",
    "ChainInertia",
    "Generators",
    "InertiaKind",
    "InertiaStructure",
    "chain_cholesky_pivots",
    "chain_structure",
    "coupled_pairs",
    "detect",
]

#: The body index (1-based) in the expressions of a `ChainInertia`.
INDEX = sp.Symbol("i", real=True)

_ONE = sp.Integer(1)

#: Differences c_k - c_k+1 smaller than this times max |c| are treated as zero (C singular).
DELTA_TOL = 1e-9

#: A numeric 2 x 2 minor (no parameters) is zero when below this relative size.
MINOR_TOL = 1e-12


class InertiaKind(enum.Enum):
    """The structure of M (see the module docstring); also names the solver chosen for it."""

    DIAGONAL = "diagonal"
    BANDED = "banded"
    MAX_INDEX = "max-index"
    DENSE = "dense"


@dataclass(frozen=True)
class Generators:
    """M_ii = diagonal[i], M_ij = scale[i] scale[j] max_index[max(i, j)] (i != j), 0-based:
    one expression in the parameters per body each (found by `detect` in a given matrix)."""

    diagonal: tuple[sp.Expr, ...]
    scale: tuple[sp.Expr, ...]
    max_index: tuple[sp.Expr, ...]


@dataclass(frozen=True)
class ChainInertia:
    """M given per body: M_ii = diagonal(i), M_ij = scale(i) scale(j) max_index(max(i, j)).

    Each is one expression in the parameters, the per-body data (`data`: one number per body,
    symbol = the datum's name) and the body index `INDEX` (1-based). Nothing here grows like
    n^2; `matrix` builds the n^2 entries only when asked (small n: the dense fallback, the
    angle form, tests).

    Example:
        >>> u = sp.Symbol("u", real=True)
        >>> rod = ChainInertia(u * (sp.Rational(1, 3) + 3 - INDEX), u * (3 - INDEX + 1) / 2)
        >>> rod.matrix(3).subs(u, 1).tolist()
        [[7/3, 1, 1/2], [1, 4/3, 1/2], [1/2, 1/2, 1/3]]
    """

    diagonal: sp.Expr
    max_index: sp.Expr
    scale: sp.Expr = _ONE
    data: tuple[TermData, ...] = ()

    def data_symbols(self) -> tuple[sp.Symbol, ...]:
        """The per-body data symbols, in data order."""
        return tuple(sp.Symbol(d.name, real=True) for d in self.data)

    def at_body(self, expr: sp.Expr, body: int) -> sp.Expr:
        """`expr` (one of the three) at body `body` (0-based): data and index substituted."""
        subs: dict[sp.Symbol, sp.Expr] = {INDEX: sp.Integer(body + 1)}
        for d, s in zip(self.data, self.data_symbols()):
            subs[s] = sp.Float(d.values[body])
        return sp.sympify(expr.xreplace(subs))

    def generators(self, n: int) -> Generators:
        """The per-body expressions in the parameters (n SymPy expressions each).

        Example:
            >>> ChainInertia(2 * INDEX, INDEX).generators(2).max_index
            (1, 2)
        """
        return Generators(
            tuple(self.at_body(self.diagonal, b) for b in range(n)),
            tuple(self.at_body(self.scale, b) for b in range(n)),
            tuple(self.at_body(self.max_index, b) for b in range(n)),
        )

    def numeric(self, n: int, subs: Mapping[sp.Symbol, float]) -> tuple[np.ndarray, ...]:
        """(d, a, c): the three generators at every body, as float arrays (vectorized).

        Example:
            >>> [v.tolist() for v in ChainInertia(2 * INDEX, INDEX).numeric(2, {})]
            [[2.0, 4.0], [1.0, 1.0], [1.0, 2.0]]
        """
        args = (INDEX, *self.data_symbols())
        values = (np.arange(1, n + 1, dtype=float), *(np.array(d.values) for d in self.data))
        out = []
        for expr in (self.diagonal, self.scale, self.max_index):
            e = sp.sympify(expr).xreplace(dict(subs))
            f = sp.lambdify(args, e, modules="numpy")
            out.append(np.broadcast_to(np.asarray(f(*values), dtype=float), (n,)).copy())
        return tuple(out)

    def matrix(self, n: int) -> sp.ImmutableSparseMatrix:
        """The n x n SymPy matrix (n^2 entries: small n only)."""
        g = self.generators(n)
        entries = {(i, i): g.diagonal[i] for i in range(n)}
        coupled = self.max_index != 0 and self.scale != 0
        for i in range(n if coupled else 0):
            for j in range(n):
                if j != i:
                    entries[(i, j)] = g.scale[i] * g.scale[j] * g.max_index[max(i, j)]
        return sp.ImmutableSparseMatrix(n, n, {k: v for k, v in entries.items() if v != 0})

    def dense(self, n: int, subs: Mapping[sp.Symbol, float]) -> np.ndarray:
        """M as a float array at the parameter values `subs`."""
        d, a, c = self.numeric(n, subs)
        idx = np.arange(n)
        big = np.maximum(idx[:, None], idx[None, :])
        out = a[:, None] * a[None, :] * c[big]
        out[idx, idx] = d
        return out


@dataclass(frozen=True)
class InertiaStructure:
    """What M is: its kind, its bandwidth (largest |i - j| of a coupled pair; 0 if diagonal)
    and, for MAX_INDEX, its generators (found in a matrix, or the given `ChainInertia`).

    `pairs` lists the coupled pairs (0-based, i < j) of a matrix; it stays empty for a
    `ChainInertia` (all pairs are coupled; listing n^2/2 of them is what the structure avoids).
    """

    kind: InertiaKind
    bandwidth: int
    pairs: tuple[tuple[int, int], ...] = ()
    generators: Generators | ChainInertia | None = None

    @property
    def coupled(self) -> bool:
        """True when some off-diagonal entry is not identically zero."""
        return self.kind is not InertiaKind.DIAGONAL


# --------------------------------------------------------------------------- numbers
def chain_cholesky_pivots(d: np.ndarray, a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The squared pivots l_j^2 of the Cholesky factor of M = diag(d) + (a_i a_j c_max)_{i!=j},
    in O(n): M is positive definite iff all are positive.

    Below the diagonal M_ij = u_i v_j (u = a c, v = a), and so is the factor: L_ij = u_i w_j,
    with s_j = sum_{k<j} w_k^2, l_j^2 = d_j - u_j^2 s_j-1 and w_j = (v_j - u_j s_j-1) / l_j,
    the same sums as the dense Cholesky factorization, factored.

    Example:
        >>> M = np.array([[3.0, 2, 1], [2, 2.5, 1], [1, 1, 1.5]])
        >>> p = chain_cholesky_pivots(np.diag(M), np.ones(3), np.array([9.0, 2, 1]))
        >>> np.allclose(p, np.diag(np.linalg.cholesky(M)) ** 2)
        True
    """
    u, v = a * c, a
    out = np.empty(len(d))
    s = 0.0
    for j in range(len(d)):
        l2 = d[j] - u[j] * u[j] * s
        out[j] = l2
        if not l2 > 0.0:
            out[j + 1 :] = math.nan
            break
        w = (v[j] - u[j] * s) / math.sqrt(l2)
        s += w * w
    return out


# --------------------------------------------------------------------------- detection
def _evaluate(expr: sp.Expr, subs: Mapping[sp.Symbol, float]) -> float:
    try:
        return float(sp.sympify(sp.sympify(expr).xreplace(dict(subs))).evalf())
    except (TypeError, ValueError):
        return math.nan


def coupled_pairs(
    M: sp.ImmutableSparseMatrix, subs: Mapping[sp.Symbol, float]
) -> tuple[tuple[int, int], ...]:
    """0-based pairs (i, j), i < j, whose M_ij is not identically zero, in row order.

    An entry that is nonzero at the parameter values is not identically zero; only entries
    that vanish there are simplified (most coupled entries cost one evaluation, not a
    `simplify`).

    Example:
        >>> m = sp.Symbol("m", real=True)
        >>> coupled_pairs(sp.ImmutableSparseMatrix([[m, m - m], [0, m]]), {m: 1.0})
        ()
    """
    pairs = []
    for (i, j), v in sorted(M.todok().items()):
        if i >= j or v == 0:
            continue
        value = _evaluate(v, subs)
        if (math.isfinite(value) and value != 0.0) or sp.simplify(v) != 0:
            pairs.append((i, j))
    return tuple(pairs)


def _vanishes(minor: sp.Expr, scale: sp.Expr) -> bool:
    """True when `minor` is identically zero (a number: zero relative to `scale`)."""
    if minor == 0:
        return True
    if not minor.free_symbols:
        size = abs(float(scale))
        return abs(float(minor)) <= MINOR_TOL * size
    expanded = sp.expand(minor)
    if expanded == 0:
        return True
    return bool(sp.simplify(minor) == 0)


def _perturbed(subs: Mapping[sp.Symbol, float], k: int) -> dict[sp.Symbol, float]:
    """Parameter values moved by a few percent (deterministic), for a quick numeric screen."""
    rng = np.random.default_rng(1234 + k)
    return {s: v * (1.0 + 0.1 * rng.uniform(0.1, 1.0)) + 0.01 * k for s, v in subs.items()}


def _max_index(
    M: sp.ImmutableSparseMatrix, n: int, subs: Mapping[sp.Symbol, float]
) -> Generators | None:
    """The generators of a MAX_INDEX matrix (every off-diagonal entry coupled), or None.

    a_j = M_nj / M_n1 (j < n), a_n = 1; c_i = M_i1 / a_i (1 < i < n), c_n = M_n1, and the
    free c_1 = 2 c_2 - c_3 (c_1 = 2 c_2 for n = 2) continues the differences. Then
    M_ij = a_i a_j c_i (j < i) holds for j = 1 and for i = n by construction, and for the other
    entries iff the minors M_ij M_n1 - M_nj M_i1 vanish.
    """
    last = n - 1
    e = {key: sp.sympify(v) for key, v in M.todok().items()}

    def entry(i: int, j: int) -> sp.Expr:
        return e.get((max(i, j), min(i, j)), e.get((min(i, j), max(i, j)), sp.Integer(0)))

    # quick numeric screen at the parameter values and two perturbations of them
    points = [dict(subs), _perturbed(subs, 1), _perturbed(subs, 2)]
    for point in points:
        num = np.zeros((n, n))
        for (i, j), v in e.items():
            num[i, j] = _evaluate(v, point)
        if not np.all(np.isfinite(num)):
            continue
        lower = np.tril(num, -1)
        minors = lower[1:last, 1:last] * num[last, 0] - np.outer(num[1:last, 0], num[last, 1:last])
        size = np.abs(lower[1:last, 1:last] * num[last, 0]) + np.abs(
            np.outer(num[1:last, 0], num[last, 1:last])
        )
        mask = np.tril(np.ones_like(minors, dtype=bool), -1)
        if np.any(np.abs(minors[mask]) > 1e-9 * (size[mask] + 1e-300)):
            return None
    n1 = entry(last, 0)
    scale = [entry(last, j) / n1 for j in range(last)] + [sp.Integer(1)]
    gen = [sp.Integer(0)] * n
    for i in range(1, last):
        gen[i] = entry(i, 0) * n1 / entry(last, i)
    gen[last] = n1
    if n == 2:
        gen[0] = 2 * gen[1]
    else:
        gen[0] = 2 * gen[1] - gen[2]
    # nonzero conditions at the parameter values
    a_num = np.array([_evaluate(s, subs) for s in scale])
    c_num = np.array([_evaluate(g, subs) for g in gen])
    if not (np.all(np.isfinite(a_num)) and np.all(np.isfinite(c_num)) and np.all(a_num != 0)):
        return None
    delta = c_num - np.append(c_num[1:], 0.0)
    if not np.all(np.abs(delta) > DELTA_TOL * np.max(np.abs(c_num))):
        return None
    # symbolic proof: every minor vanishes identically
    for i in range(2, last):
        for j in range(1, i):
            left, right = entry(i, j) * n1, entry(last, j) * entry(i, 0)
            if not _vanishes(
                left - right, abs(_evaluate(left, subs)) + abs(_evaluate(right, subs))
            ):
                return None
    diagonal = tuple(entry(i, i) for i in range(n))
    return Generators(diagonal, tuple(sp.sympify(s) for s in scale), tuple(gen))


def detect(M: sp.ImmutableSparseMatrix, subs: Mapping[sp.Symbol, float]) -> InertiaStructure:
    """The structure of a symbolic M (see the module docstring); `subs` are the spec's
    parameter values (used to screen and for the generators' nonzero conditions).

    Example:
        >>> detect(sp.ImmutableSparseMatrix(sp.eye(2)), {}).kind
        <InertiaKind.DIAGONAL: 'diagonal'>
    """
    n = M.shape[0]
    pairs = coupled_pairs(M, subs)
    if not pairs:
        return InertiaStructure(InertiaKind.DIAGONAL, 0)
    width = max(j - i for i, j in pairs)
    if len(pairs) == n * (n - 1) // 2:
        gens = _max_index(M, n, subs)
        if gens is not None:
            return InertiaStructure(InertiaKind.MAX_INDEX, width, pairs, gens)
    kind = InertiaKind.BANDED if width < n - 1 else InertiaKind.DENSE
    return InertiaStructure(kind, width, pairs)


def chain_structure(chain: ChainInertia, n: int, subs: Mapping[sp.Symbol, float]) -> bool:
    """True when a `ChainInertia` meets the MAX_INDEX conditions at the parameter values:
    scale nonzero at every body and c_k != c_k+1 (c_n != 0).

    Example:
        >>> chain_structure(ChainInertia(sp.Integer(5), 3 - INDEX), 2, {})
        True
    """
    _, a, c = chain.numeric(n, subs)
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(c)) and np.all(a != 0)):
        return False
    delta = c - np.append(c[1:], 0.0)
    top = float(np.max(np.abs(c))) if n else 0.0
    return bool(top > 0 and np.all(np.abs(delta) > DELTA_TOL * top))
