"""Which numbers the spec's expressions may hold: finite, real and within a double.

Input: a SymPy expression (a value met while parsing). Output: why it cannot be computed in
doubles as C, NumPy and the reference do (or None), and short renderings of huge numbers for
messages; the limit on exact digits that also bounds the size of numeric powers.
"""

from __future__ import annotations

import math
import sys

import sympy as sp

__all__ = ["DOUBLE_MAX"]

_MAX_DIGITS = 1000  # decimal digits of an exact number (numerator and denominator together)
#: The largest finite double: every number, as written or computed, must stay within it.
DOUBLE_MAX = sys.float_info.max
_NON_FINITE = (sp.zoo, sp.oo, sp.S.NegativeInfinity, sp.nan)


def _number_problem(expr: sp.Expr) -> str | None:
    """Why `expr` cannot be computed in doubles as C, NumPy and the reference do (None if it
    can): a non-finite number, an exact number too long to handle, a number beyond the range
    of a double, or a constant that is not real."""
    symbolic = False
    for atom in expr.atoms(sp.Number, sp.Symbol, type(sp.zoo)):
        if isinstance(atom, sp.Symbol):
            symbolic = True
        elif atom in _NON_FINITE:
            return "is not finite (division by zero?)"
        elif isinstance(atom, sp.Rational) and _digits(atom) > _MAX_DIGITS:
            return f"holds an exact number of more than the limit of {_MAX_DIGITS} digits"
        elif abs(atom) > DOUBLE_MAX:
            return f"holds the number {_short(atom)}, beyond the range of a double ({_RANGE})"
    if symbolic or isinstance(expr, sp.Number):
        return None
    value = expr.evalf(17)
    if value.has(sp.I):
        return f"is not real (it is {_short(value)})"
    if isinstance(value, sp.Float) and abs(value) > DOUBLE_MAX:
        return f"is about {_short(value)}, beyond the range of a double ({_RANGE})"
    return None


_RANGE = "magnitude at most about 1.8e308"
_LOG10_2 = math.log10(2.0)


def _short(value: sp.Expr) -> str:
    """A number for a message: a few significant digits, never thousands (an exponent of
    more than 12 digits is given by its length: 5.957e+<233 digits>).

    Example:
        >>> _short(sp.Integer(10) ** 400), _short(sp.Float("1e300") ** (10**200))
        ('1.000e+400', '1.000e+<203 digits>')
    """
    if isinstance(value, (sp.Integer, sp.Float)):
        text = str(sp.Float(value, 4)) if abs(value) >= 1e6 else str(value)
    else:
        text = str(sp.N(value, 4))
    mantissa, e, exponent = text.partition("e")
    if e and len(exponent.lstrip("+-")) > 12:
        return f"{mantissa}e{exponent[0]}<{len(exponent.lstrip('+-'))} digits>"
    return text if len(text) <= 60 else text[:57] + "..."


def _digits(value: sp.Expr) -> float:
    """About how many decimal digits SymPy computes exactly when it raises `value` to the
    power 1 (an upper bound of the work of `value**e` is |e| times this): the digits of exact
    numbers, including those SymPy distributes a power over (products and powers of powers);
    0 for floats (mpmath powers are cheap) and for what SymPy leaves unevaluated."""
    if isinstance(value, sp.Rational):
        return (_log10(abs(int(value.p))) + _log10(int(value.q))) or 0.0
    if isinstance(value, sp.Mul):
        return sum(_digits(arg) for arg in value.args)
    if isinstance(value, sp.Pow) and isinstance(value.exp, sp.Number):
        return abs(float(value.exp)) * _digits(value.base)
    return 0.0


def _log10(n: int) -> float:
    """A lower bound of log10(n) for n >= 1 (0 for 0 and 1), without converting n to float."""
    return max(n.bit_length() - 1, 0) * _LOG10_2
