"""The structured [inertia] table: M per body, for chains of any length (never n^2 entries).

Input: the values of an [inertia] table written per body (`diagonal` as one expression,
`max_index`, `scale`, the per-body `[inertia.data]`), the number of bodies, the parameters,
the `origin` naming the spec in messages and the scalar per-body arrays of the spec's [data]
(`s2gen.spec.data`), which the expressions read by name as they read `[inertia.data]`.
Output: a `ChainInertia` (`s2gen.inertia`), or a `SpecError` naming the file, the key and the
offending item.

Syntax (TOML; the Python API takes the same keys as arguments of `define_system`)::

    [inertia]
    diagonal  = "u*(1/3 + n - i)"    # M_ii, per body
    max_index = "u*(n - i + 1)/2"    # c_i: M_ij = scale_i scale_j c_max(i,j) for i != j
    scale     = "l"                  # a_i (optional, default 1)
    solver    = "auto"               # optional: "auto", "dense" or "structured"
    [inertia.data]                   # optional per-body data: one number per body
    l = [0.5, 0.5, 0.4]

Each expression sees the parameters, the data, the body index `i` (1..n) and the number of
bodies `n`; nothing else (no positions: M is constant). A chain of point masses m_k on links
of length l_k has M_ij = l_i l_j sum_{k >= max(i,j)} m_k: `diagonal = "l**2*tail"`,
`max_index = "tail"`, `scale = "l"` with the tail sums as data.

Example:
    >>> c = chain_inertia("m*(n - i + 1)", "m*(n - i + 1)/2", None, None, 3, {"m": 2.0},
    ...                   "spec.toml")
    >>> c.matrix(3).tolist()
    [[3*m, m, m/2], [m, 2*m, m/2], [m/2, m/2, m]]
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping
from typing import Any

import sympy as sp

from s2gen.inertia import INDEX, ChainInertia
from s2gen.spec.parser import parse_expression
from s2gen.spec.tables import _check_data_name, _number, _rows
from s2gen.system import SpecError, TermData

__all__ = ["chain_inertia"]

_N = sp.Symbol("n", real=True)


def chain_inertia(
    diagonal: Any,
    max_index: Any,
    scale: Any,
    data: Any,
    n: int,
    params: Mapping[str, float],
    origin: str,
    shared: tuple[TermData, ...] = (),
) -> ChainInertia:
    """The per-body inertia of an [inertia] table (see the module docstring); `shared` are
    the scalar per-body arrays of the spec's [data], kept when an expression names them."""
    where = f"{origin}: [inertia]"
    values = _data(data, n, params, where)
    own = {d.name for d in values}
    for d in shared:
        if d.name in own:
            raise SpecError(
                f"{where} data.{d.name}: {d.name!r} is also a datum of [data] (give it once)"
            )
        if d.name in (INDEX.name, _N.name):
            raise SpecError(
                f"{where}: [data] {d.name}: {d.name!r} is the body index or count of [inertia] "
                "expressions"
            )
    local = {INDEX.name: 1, _N.name: 1, **{d.name: 1 for d in (*values, *shared)}}
    exprs = [
        _expression(value, key, n, params, local, where)
        for key, value in (("diagonal", diagonal), ("max_index", max_index), ("scale", scale))
    ]
    named = {s.name for e in exprs for s in e.free_symbols}
    used = tuple(d for d in shared if d.name in named)
    return ChainInertia(exprs[0], exprs[1], exprs[2], (*values, *used))


def _expression(
    value: Any, key: str, n: int, params: Mapping[str, float], local: dict[str, int], where: str
) -> sp.Expr:
    """One per-body expression: a string in the local names, a SymPy scalar or a number."""
    if value is None:
        return sp.Integer(1 if key == "scale" else 0)
    if isinstance(value, str):
        expr = parse_expression(
            value,
            n=n,
            parameters=list(params),
            where=f"{where} {key}",
            allow_vectors=False,
            local=local,
        )
        return sp.sympify(expr.xreplace({_N: sp.Integer(n)}))
    if isinstance(value, sp.Expr) or (
        isinstance(value, numbers.Real) and not isinstance(value, bool)
    ):
        return sp.sympify(value)
    raise SpecError(
        f"{where} {key}: expected an expression string (per body, in i, n, the parameters "
        f"and [inertia.data]), got {value!r}"
    )


def _data(data: Any, n: int, params: Mapping[str, float], where: str) -> tuple[TermData, ...]:
    """[inertia.data]: name = one number (or parameter expression) per body."""
    if data is None:
        return ()
    if not isinstance(data, Mapping):
        raise SpecError(f"{where} data: expected a table of name = list of values, got {data!r}")
    out = []
    for name, values in data.items():
        at = f"{where} data.{name}"
        _check_data_name(name, params, at)
        if name in (INDEX.name, _N.name):
            raise SpecError(f"{at}: {name!r} is the body index or count of [inertia] expressions")
        entries = _rows(values, n, at, "numbers (one per body)")
        out.append(
            TermData(
                name, 1, tuple(_number(v, f"{at}[{k + 1}]", params) for k, v in enumerate(entries))
            )
        )
    return tuple(out)
