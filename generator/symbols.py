"""The one symbol scheme: every 3-vector `name` has the real components `name_0, name_1, name_2`.

Input: names. Output: SymPy symbols and 3x1 matrices. Used by every stage that builds or reads
expressions, so a vector written by the spec, differentiated by the equations and printed by
the printers is always the same three symbols:

- body i (1-based, as in the paper) is the vector ``q{i}``: ``q1_0, q1_1, q1_2``, and its
  angular velocity (in forces) is ``w{i}``: ``w1_0, w1_1, w1_2``; time is the real symbol
  ``t`` (`TIME`);
- a term's own vectors are ``q`` (one-body terms), ``qi`` and ``qj`` (pair terms), and a vector
  datum ``r`` of a term is ``r_0, r_1, r_2``;
- the generic kernels of the equations use the same rule (``qi``, ``wi``, ``f``, ``gn``, ...).

Example:
    >>> vector("qi").T
    Matrix([[qi_0, qi_1, qi_2]])
    >>> q_symbol(2, 1), q_symbols(1)
    (q2_1, [q1_0, q1_1, q1_2])
"""

from __future__ import annotations

import sympy as sp

__all__ = [
    "TIME",
    "component",
    "components",
    "local_vector",
    "q_symbol",
    "q_symbols",
    "q_vector",
    "vector",
    "w_symbol",
    "w_vector",
]

#: Time, the one symbol of a time-dependent potential or force (the name `t` in the spec).
TIME = sp.Symbol("t", real=True)


def component(name: str, c: int) -> sp.Symbol:
    """Component c (0, 1, 2) of the vector `name`: the real symbol ``name_c``."""
    return sp.Symbol(f"{name}_{c}", real=True)


def components(name: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """The three component symbols of the vector `name`."""
    return component(name, 0), component(name, 1), component(name, 2)


def vector(name: str) -> sp.Matrix:
    """The vector `name` as a 3x1 SymPy column."""
    return sp.Matrix(components(name))


def local_vector(role: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """A term's own vector ("q", "qi", "qj") or vector datum: its component symbols."""
    return components(role)


def q_symbol(i: int, c: int) -> sp.Symbol:
    """Component c (0, 1, 2) of body i's unit vector (i is 1-based)."""
    return component(f"q{i}", c)


def q_vector(i: int) -> sp.Matrix:
    """Body i's unit vector as a 3x1 SymPy column (i is 1-based)."""
    return vector(f"q{i}")


def q_symbols(n: int) -> list[sp.Symbol]:
    """All 3n position symbols in storage order (body-major, then component)."""
    return [q_symbol(i, c) for i in range(1, n + 1) for c in range(3)]


def w_symbol(i: int, c: int) -> sp.Symbol:
    """Component c (0, 1, 2) of body i's angular velocity omega_i (i is 1-based)."""
    return component(f"w{i}", c)


def w_vector(i: int) -> sp.Matrix:
    """Body i's angular velocity as a 3x1 SymPy column (i is 1-based).

    Example:
        >>> w_vector(2).T
        Matrix([[w2_0, w2_1, w2_2]])
    """
    return vector(f"w{i}")
