"""Validation of names and expressions: the system name, the parameters, the general potential.

Input: a system name, the parameters (name -> value), SymPy expressions and the location for
messages. Output: the parameter names and values, the potential as a SymPy scalar, or a
`SpecError`: the name must be a C identifier that is not reserved and not too long; a
parameter must be an identifier that no position symbol or temporary takes, with a finite
value; the potential a real scalar in q1..qn and the parameters.
"""

from __future__ import annotations

import keyword
import re
from collections.abc import Mapping

import numpy as np
import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.symbols import q_symbol

__all__ = ["MAX_NAME_LENGTH"]

#: The longest system name: it prefixes every emitted symbol and names the emitted files.
MAX_NAME_LENGTH = 64
_C_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_C_RESERVED = frozenset(
    [
        "auto",
        "break",
        "case",
        "char",
        "const",
        "continue",
        "default",
        "do",
        "double",
        "else",
        "enum",
        "extern",
        "float",
        "for",
        "goto",
        "if",
        "inline",
        "int",
        "long",
        "register",
        "restrict",
        "return",
        "short",
        "signed",
        "sizeof",
        "static",
        "struct",
        "switch",
        "typedef",
        "union",
        "unsigned",
        "void",
        "volatile",
        "while",
        "main",
    ]
)


def _check_name(name: object, where: str) -> None:
    """The system name prefixes every emitted symbol and macro and names the files."""
    if not isinstance(name, str) or not _C_IDENTIFIER.fullmatch(name):
        raise SpecError(f"{where}: key 'name': {shown(name)} is not a C identifier")
    if len(name) > MAX_NAME_LENGTH:
        raise SpecError(
            f"{where}: key 'name': {shown(name[:16])}... has {len(name)} characters, more than the "
            f"limit of {MAX_NAME_LENGTH}"
        )
    if name.startswith("_"):
        raise SpecError(
            f"{where}: key 'name': {shown(name)} starts with '_' (C reserves such names, and the "
            f"header guard {name.upper()}_H could clash with a system header's)"
        )
    if name in _C_RESERVED or keyword.iskeyword(name):
        raise SpecError(f"{where}: key 'name': {shown(name)} is a reserved word in C or Python")


def _is_position(symbol: sp.Symbol, n: int) -> bool:
    """True for the position symbols q{i}_{c} of bodies 1..n (without building all 3n)."""
    match = _POSITION.fullmatch(symbol.name)
    return (
        match is not None
        and 1 <= int(match.group(1)) <= n
        and symbol == q_symbol(int(match.group(1)), int(match.group(2)))
    )


_POSITION = re.compile(r"q([1-9][0-9]*)_([0-2])")
#: The names of the emitted kernels' common-subexpression temporaries (`passes.cse`): real
#: symbols x0, x1, ... that a parameter or scalar datum of the same name would be taken for.
_TEMPORARY = re.compile(r"x[0-9]+")
_TEMPORARY_CLASH = "is reserved (the emitted code names its temporaries x0, x1, ...)"


def _check_real(expr: sp.Expr, where: str) -> None:
    """Refuse an expression that holds a complex number (sqrt(-1), log(-2), (-8)**(1/3)) or
    that SymPy knows is not real: the emitted code computes in real doubles."""
    bad: sp.Expr | None = sp.I if expr.has(sp.I) else None
    if bad is None:
        for atom in expr.atoms(sp.Pow, sp.Function):
            if not atom.free_symbols and atom.evalf(15).has(sp.I):
                bad = atom
                break
    if bad is None and expr.is_extended_real is False:
        bad = expr
    if bad is not None:
        text = str(bad) if len(str(bad)) <= 40 else str(bad)[:37] + "..."
        raise SpecError(f"{where}: is not real ({text} is complex); the potential must be real")


def _check_parameters(
    parameters: Mapping[str, float], where: str
) -> tuple[tuple[str, ...], list[float]]:
    """Parameter names (identifiers, no position symbol or temporary) and finite values."""
    names = tuple(parameters.keys())
    values: list[float] = []
    for pname in names:
        if not isinstance(pname, str) or not _C_IDENTIFIER.fullmatch(pname):
            raise SpecError(f"{where}: [parameters]: {shown(pname)} is not an identifier")
        if re.fullmatch(r"q[0-9]+_[0-9]+", pname):
            raise SpecError(f"{where}: [parameters]: {shown(pname)} clashes with a position symbol")
        if _TEMPORARY.fullmatch(pname):
            raise SpecError(f"{where}: [parameters]: {shown(pname)} {_TEMPORARY_CLASH}")
        try:
            v = float(parameters[pname])
        except (TypeError, ValueError):
            got = shown(parameters[pname])
            raise SpecError(
                f"{where}: [parameters] {pname}: expected a number, got {got}"
            ) from None
        if not np.isfinite(v):
            raise SpecError(f"{where}: [parameters] {pname}: value {v} is not finite")
        values.append(v)
    return names, values


def _check_potential(potential: sp.Expr, n: int, psyms: set[sp.Symbol], where: str) -> sp.Expr:
    """The general potential: a real scalar in q1..qn and the parameters, without
    derivatives or integrals."""
    V = sp.sympify(potential)
    if not isinstance(V, sp.Expr):
        raise SpecError(f"{where}: [potential] V: must be a scalar expression, got {shown(V)}")
    extra = {s for s in V.free_symbols - psyms if not _is_position(s, n)}
    if extra:
        bad = ", ".join(sorted(str(s) for s in extra))
        raise SpecError(
            f"{where}: [potential] V: depends on {bad}; only q1..q{n}, time t, the inputs and "
            "the declared parameters may appear"
        )
    if V.has(sp.Derivative, sp.Integral):
        raise SpecError(f"{where}: [potential] V: must not contain derivatives or integrals")
    _check_real(V, f"{where}: [potential] V")
    return V
