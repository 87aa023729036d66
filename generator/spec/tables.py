"""Spec tables and API values, checked one by one and turned into the pieces of a `System`.

Input: the values of one TOML table or `define_system` argument (parameters, bodies, the
inertia M or its diagonal, the general potential V, [initial] q and omega, [run]) plus the
`origin` that names the spec in messages; the term tables are `s2gen.spec.term_tables`'.
Output: parameter values (dict), the body count, the SymPy inertia matrix and potential,
initial vectors as lists of floats and `RunSettings` (a [run]
method is one of `s2gen.methods.NAMES`); or a `SpecError` naming the file, the table and key
(list indices 1-based) and the offending item.
Semantic checks on the whole system (e.g. M positive definite) are `System.create`'s.
"""

from __future__ import annotations

import keyword
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from typing import Any

import numpy as np
import sympy as sp

from s2gen.methods import NAMES
from s2gen.spec.names import _Q_RESERVED, _ROLES, RESERVED_NAMES
from s2gen.spec.parser import parse_expression
from s2gen.symbols import TIME
from s2gen.system import MAX_BODIES, RunSettings, SpecError, shown


def _bodies(bodies: Any, origin: str) -> int:
    if isinstance(bodies, bool) or not isinstance(bodies, numbers.Integral) or bodies < 1:
        raise SpecError(f"{origin}: key 'bodies': expected a positive integer, got {shown(bodies)}")
    if bodies > MAX_BODIES:  # before anything sized by it is read
        raise SpecError(
            f"{origin}: key 'bodies': {bodies} bodies is more than the limit of {MAX_BODIES}"
        )
    return int(bodies)


def _parameters(parameters: Any, origin: str) -> dict[str, float]:
    if not isinstance(parameters, Mapping):
        raise SpecError(f"{origin}: [parameters]: expected a table of name = number")
    values: dict[str, float] = {}
    for pname, value in parameters.items():
        where = f"{origin}: [parameters] {_key(pname)}"
        _check_parameter_name(pname, where)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise SpecError(f"{where}: expected a number, got {shown(value)}")
        if not math.isfinite(float(value)):
            raise SpecError(f"{where}: value {shown(value)} is not finite")
        values[pname] = float(value)
    return values


def _key(name: Any) -> str:
    """A user's key as it appears in a location: as written if it is an identifier, else its
    repr (a name with a line break or other oddities must not break the one-line message)."""
    return name if isinstance(name, str) and name.isidentifier() and name.isascii() else repr(name)


def _check_parameter_name(pname: Any, where: str) -> None:
    if not isinstance(pname, str) or not pname.isidentifier() or not pname.isascii():
        raise SpecError(f"{where}: {shown(pname)} is not an identifier")
    if keyword.iskeyword(pname):
        raise SpecError(f"{where}: {shown(pname)} is a reserved word")
    if pname in RESERVED_NAMES or _Q_RESERVED.fullmatch(pname):
        raise SpecError(
            f"{where}: {shown(pname)} is a reserved name (q1.., w1.., e1..e3, pi and the "
            "function names have fixed meanings)"
        )


def _scalar(value: Any, where: str, names: Sequence[str]) -> sp.Expr:
    """A number, an expression string in numbers and parameters, or a SymPy scalar."""
    if isinstance(value, bool):
        raise SpecError(f"{where}: expected a number or an expression string, got {shown(value)}")
    if isinstance(value, numbers.Integral):
        return sp.Integer(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, sp.Basic):
        if not math.isfinite(float(value)):
            raise SpecError(f"{where}: value {shown(value)} is not finite")
        return sp.Float(float(value))
    if isinstance(value, str):
        return parse_expression(value, n=0, parameters=names, where=where, allow_vectors=False)
    if isinstance(value, sp.Expr):
        return value
    raise SpecError(f"{where}: expected a number or an expression string, got {shown(value)}")


def _rows(value: Any, length: int, where: str, what: str) -> list[Any]:
    """`value` as a list of exactly `length` items (a precise error otherwise)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence):
        raise SpecError(f"{where}: expected a list of {length} {what}, got {shown(value)}")
    if len(value) != length:
        raise SpecError(f"{where}: expected {length} {what}, got {len(value)}")
    return list(value)


def _inertia(
    inertia: Any, diagonal: Any, n: int, names: Sequence[str], origin: str
) -> sp.MatrixBase:
    where = f"{origin}: [inertia]"
    if (inertia is None) == (diagonal is None):
        given = "both" if inertia is not None else "neither"
        raise SpecError(f"{where}: give exactly one of 'M' and 'diagonal' (got {given})")
    if isinstance(inertia, sp.MatrixBase):
        return inertia
    if diagonal is not None:
        entries = _rows(diagonal, n, f"{where} diagonal", "entries (one per body)")
        return sp.diag(
            *[_scalar(v, f"{where} diagonal[{i + 1}]", names) for i, v in enumerate(entries)]
        )
    rows = _rows(inertia, n, f"{where} M", "rows")
    matrix = [_rows(row, n, f"{where} M[{r + 1}]", "entries") for r, row in enumerate(rows)]
    return sp.Matrix(
        [
            [_scalar(v, f"{where} M[{r + 1}][{c + 1}]", names) for c, v in enumerate(row)]
            for r, row in enumerate(matrix)
        ]
    )


def _potential(potential: Any, n: int, names: Sequence[str], origin: str) -> sp.Expr:
    where = f"{origin}: [potential] V"
    if isinstance(potential, str):
        return parse_expression(potential, n=n, parameters=names, where=where)
    if isinstance(potential, sp.MatrixBase):
        raise SpecError(f"{where}: the potential is a {potential.shape} matrix, not a scalar")
    if isinstance(potential, sp.Expr) or (
        isinstance(potential, numbers.Real) and not isinstance(potential, bool)
    ):
        return _scalar(potential, where, names)
    raise SpecError(
        f"{where}: expected an expression string or a SymPy scalar, got {shown(potential)}"
    )


def _check_data_name(name: Any, params: Mapping[str, float], where: str) -> None:
    if not isinstance(name, str) or not name.isidentifier() or not name.isascii():
        raise SpecError(f"{where}: data name {shown(name)} is not an identifier")
    if keyword.iskeyword(name):
        raise SpecError(f"{where}: data name {shown(name)} is a reserved word")
    if name in params:
        raise SpecError(
            f"{where}: data name {shown(name)} clashes with the parameter {shown(name)}"
        )
    if name in _ROLES:
        raise SpecError(
            f"{where}: data name {shown(name)} is reserved for a term's own vector (q, qi, qj)"
        )
    if name in RESERVED_NAMES or _Q_RESERVED.fullmatch(name):
        raise SpecError(
            f"{where}: data name {shown(name)} is a reserved name (q1.., w1.., e1..e3, pi and the "
            "function names have fixed meanings)"
        )


def _initial(
    value: Any, key: str, n: int, params: Mapping[str, float], origin: str
) -> list[list[float]] | None:
    """[initial] q or omega as n lists of 3 floats (shape and numbers checked here)."""
    if value is None:
        return None
    where = f"{origin}: [initial] {key}"
    rows = _rows(value, n, where, "vectors (one per body)")
    vectors = [_rows(row, 3, f"{where}[{i + 1}]", "components") for i, row in enumerate(rows)]
    return [
        [_number(v, f"{where}[{i + 1}][{c + 1}]", params) for c, v in enumerate(vector)]
        for i, vector in enumerate(vectors)
    ]


def _number(value: Any, where: str, params: Mapping[str, float]) -> float:
    """Evaluate a number or parameter expression to a finite float."""
    expr = _scalar(value, where, list(params))
    subs = {sp.Symbol(p, real=True): v for p, v in params.items()}
    extra = expr.free_symbols - set(subs)
    if extra:
        bad = ", ".join(sorted(str(s) for s in extra))
        raise SpecError(f"{where}: depends on {bad} (only numbers and parameters allowed)")
    try:
        result = float(expr.subs(subs).evalf())
    except (TypeError, ValueError):
        raise SpecError(f"{where}: {shown(value)} is not a real number") from None
    if not math.isfinite(result):
        raise SpecError(f"{where}: {shown(value)} is not finite")
    return result


def _run_settings(run: Any, origin: str, n: int = 0, parameters: Sequence[str] = ()) -> RunSettings:
    if run is None:
        return RunSettings()
    if isinstance(run, RunSettings):
        run = {k: v for k, v in asdict(run).items() if v is not None}
    if not isinstance(run, Mapping):
        raise SpecError(f"{origin}: [run]: expected a table, got {shown(run)}")
    _check_keys(run, ("h", "T", "method", "rtol", "atol", "g"), f"{origin}: [run]")
    settings: dict[str, Any] = {}
    for key, value in run.items():
        where = f"{origin}: [run] {key}"
        if key == "g":
            settings[key] = _monitor_text(value, n, parameters, where)
        elif key != "method":
            settings[key] = _positive(value, where)
        elif value in NAMES:
            settings[key] = value
        else:
            raise SpecError(f"{where}: unknown method {shown(value)} (one of {', '.join(NAMES)})")
    return RunSettings(**settings)


def _monitor_text(value: Any, n: int, parameters: Sequence[str], where: str) -> str:
    """[run] g: an expression in q1..qn and the parameters (the time-transformed methods'
    monitor R(q), positive where the bodies move fast), kept as its text once it parses."""
    if not isinstance(value, str):
        raise SpecError(
            f"{where}: expected an expression in q1..q{n} (a string), got {shown(value)}"
        )
    expr = parse_expression(value, n=n, parameters=parameters, where=where)
    if TIME in expr.free_symbols:
        raise SpecError(f"{where}: the monitor depends on q only, not on time t")
    return value


def _positive(value: Any, where: str) -> float:
    number = float(value) if isinstance(value, numbers.Real) else math.nan
    if isinstance(value, bool) or not (math.isfinite(number) and number > 0):
        raise SpecError(f"{where}: expected a positive number, got {shown(value)}")
    return number


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise SpecError(f"{where}: unknown key {shown(key)} (allowed: {', '.join(allowed)})")
