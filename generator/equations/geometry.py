"""S^2 and SO(3) algebra on SymPy 3-vectors: hat map, cross products, Cayley update.

Input: 3x1 SymPy matrices. Output: SymPy matrices/expressions. No state.

Example:
    >>> import sympy as sp
    >>> a = sp.Matrix(sp.symbols("a0:3")); b = sp.Matrix(sp.symbols("b0:3"))
    >>> (hat(a) * b - a.cross(b)).applyfunc(sp.expand) == sp.zeros(3, 1)
    True
"""

from __future__ import annotations

import sympy as sp

__all__ = ["cayley_apply", "cayley_apply_tangent", "cayley_displacement", "dot", "hat"]


def hat(a: sp.Matrix) -> sp.Matrix:
    """The hat map: hat(a) b = a x b."""
    return sp.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def dot(a: sp.Matrix, b: sp.Matrix) -> sp.Expr:
    """Euclidean inner product of two 3x1 columns."""
    return sum((a[c] * b[c] for c in range(3)), sp.Integer(0))


def cayley_apply(f: sp.Matrix, q: sp.Matrix) -> sp.Matrix:
    """F q for the Cayley rotation F = (I + hat f)(I - hat f)^(-1), any f (closed form)."""
    ff = dot(f, f)
    return ((1 - ff) * q + 2 * f * dot(f, q) + 2 * f.cross(q)) / (1 + ff)


def cayley_apply_tangent(f: sp.Matrix, q: sp.Matrix) -> sp.Matrix:
    """F q when f is orthogonal to q (the paper's reduced form, eq. Fiqi)."""
    ff = dot(f, f)
    return ((1 - ff) * q + 2 * f.cross(q)) / (1 + ff)


def cayley_displacement(f: sp.Matrix, q: sp.Matrix) -> sp.Matrix:
    """F q - q for f orthogonal to q, written without the cancellation of q - q.

    (2 f x q - 2 (f.f) q) / (1 + f.f): of the size of f, so dividing it by h amplifies no
    round-off (the difference of two computed unit vectors would carry an error of 1 ulp of 1).
    """
    ff = dot(f, f)
    return (2 * f.cross(q) - 2 * ff * q) / (1 + ff)
