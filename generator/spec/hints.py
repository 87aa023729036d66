"""Advice on a general potential that is really a sum of one-body or pair terms.

Input: a general potential V(q1..qn) (a SymPy expression) and the number of bodies. Output: a
one-line hint, or None. A general potential is derived as one expression: its gradient, the
common subexpressions and the printed kernel all grow with the number of its terms, so a
Coulomb sum over 780 pairs written in `[potential] V` takes minutes to derive where the same
sum as a structured pair term is derived once for a generic pair. The hint says so before the
derivation starts (`s2gen.emit` warns with it), and how to write the terms instead.

Example:
    >>> import sympy as sp
    >>> from s2gen.symbols import q_vector
    >>> V = sum(1 / (q_vector(i) - q_vector(j)).norm() for i in range(1, 8) for j in range(i + 1, 8))
    >>> print(structure_hint(V, 7, least=20))  # doctest: +NORMALIZE_WHITESPACE
    [potential] V is a sum of 21 terms that each couple two bodies (21 pairs): write them as one
    [[potential.pair]] term (pairs = "all" or a list; per-pair data for what differs), which is
    derived once for a generic pair instead of 21 times
"""

from __future__ import annotations

import re
from collections import Counter

import sympy as sp

__all__ = ["LEAST_TERMS", "structure_hint", "terms_by_bodies"]

#: The fewest one-body or pair-shaped terms of a general potential that earn a hint.
LEAST_TERMS = 50

_BODY = re.compile(r"q([0-9]+)_[0-2]")


def _bodies(term: sp.Expr) -> frozenset[int]:
    """The bodies whose positions a term reads."""
    found = (_BODY.fullmatch(s.name) for s in term.free_symbols if isinstance(s, sp.Symbol))
    return frozenset(int(m.group(1)) for m in found if m)


def _summands(potential: sp.Expr) -> tuple[sp.Expr, ...]:
    """The terms of V's sum, looking through one constant factor (-gamma*(a + b + ...))."""
    if isinstance(potential, sp.Mul):
        sums = [a for a in potential.args if isinstance(a, sp.Add)]
        if len(sums) == 1 and all(not _bodies(a) for a in potential.args if a is not sums[0]):
            return sums[0].args
    if isinstance(potential, sp.Add):
        return potential.args
    return (potential,)


def terms_by_bodies(potential: sp.Expr) -> Counter[frozenset[int]]:
    """How many of V's terms read each set of bodies.

    Example:
        >>> from s2gen.symbols import q_vector
        >>> V = q_vector(1)[2] + q_vector(2)[2] + 1 / (q_vector(1) - q_vector(2)).norm()
        >>> sorted((sorted(b), k) for b, k in terms_by_bodies(V).items())
        [([1], 1), ([1, 2], 1), ([2], 1)]
    """
    return Counter(_bodies(t) for t in _summands(potential))


def structure_hint(potential: sp.Expr, n: int, least: int = LEAST_TERMS) -> str | None:
    """One line advising structured terms when at least `least` of V's terms each read one
    body (body terms) or two bodies (pair terms); None otherwise (or for n < 2 pairs)."""
    counts = terms_by_bodies(potential)
    pairs = {b: k for b, k in counts.items() if len(b) == 2}
    bodies = {b: k for b, k in counts.items() if len(b) == 1}
    npair, nbody = sum(pairs.values()), sum(bodies.values())
    if npair >= least and npair >= nbody:
        return (
            f"[potential] V is a sum of {npair} terms that each couple two bodies "
            f"({len(pairs)} pairs): write them as one [[potential.pair]] term "
            '(pairs = "all" or a list; per-pair data for what differs), which is derived once '
            f"for a generic pair instead of {npair} times"
        )
    if nbody >= least:
        return (
            f"[potential] V is a sum of {nbody} terms that each read one body "
            f"({len(bodies)} of {n} bodies): write them as one [[potential.body]] term "
            '(bodies = "all" or a list; per-body data for what differs), which is derived once '
            f"for a generic body instead of {nbody} times"
        )
    return None
