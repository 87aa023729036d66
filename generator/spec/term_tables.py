"""Spec term tables: [[potential.body]] and [[potential.pair]], checked one by one.

Input: the list of term tables of one kind (TOML arrays of tables or `define_system`'s
`body_terms` / `pair_terms`), the body count, the parameters, the spec's origin and the
per-body arrays of its [data] (`s2gen.spec.data`).
Output: `Term`s labelled "[[potential.pair]] #k" (k from 1), with their expression in the
term's own vectors, data and per-body data (c, or ci and cj), their selection (a word of
`s2gen.terms.spellings`, or a list of members, 1-based in the spec and 0-based in the Term),
per-member `TermData`, the per-body arrays they read and cutoff; or a `SpecError` naming the
table, the key and the offending item.
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.spec.names import _Q_RESERVED
from s2gen.spec.parser import parse_expression
from s2gen.spec.tables import _check_data_name, _check_keys, _key, _number, _rows, _scalar
from s2gen.symbols import local_vector
from s2gen.terms import Selection, Term, TermData, TermKind, body_names, spellings

__all__: list[str] = []


def _terms(
    entries: Any,
    kind: TermKind,
    n: int,
    params: Mapping[str, float],
    origin: str,
    inputs: Sequence[str] = (),
    shared: Sequence[TermData] = (),
) -> list[Term]:
    """The terms of one kind (None: none), labelled "[[potential.body]] #k" (k from 1);
    `shared` are the per-body arrays of the spec's [data]."""
    if entries is None:
        return []
    if isinstance(entries, (Mapping, str, bytes)) or not isinstance(entries, Sequence):
        raise SpecError(
            f"{origin}: {kind.table}: expected a list of term tables (in TOML an array of "
            f"tables, written {kind.table}), got {shown(entries)}"
        )
    return [
        _term(entry, kind, k + 1, n, params, origin, inputs, shared)
        for k, entry in enumerate(entries)
    ]


def _term(
    entry: Any,
    kind: TermKind,
    k: int,
    n: int,
    params: Mapping[str, float],
    origin: str,
    inputs: Sequence[str] = (),
    shared: Sequence[TermData] = (),
) -> Term:
    """One term table: its key V, its selection, its per-member data and the per-body data
    of [data] it reads."""
    label = f"{kind.table} #{k}"
    where = f"{origin}: {label}"
    if not isinstance(entry, Mapping):
        raise SpecError(
            f"{where}: expected a table (V, {kind.select_key}, data), got {shown(entry)}"
        )
    cutoff_allowed = Selection.of(kind, "all", cutoff=True) is not None
    allowed = ("V", kind.select_key, "data") + (("cutoff",) if cutoff_allowed else ())
    _check_keys(entry, allowed, where)
    for key in ("V", kind.select_key):
        if key not in entry and not (key == kind.select_key and kind.default):
            raise SpecError(f"{where}: missing required key {shown(key)}")
    for role in kind.roles:
        if role in params:
            raise SpecError(
                f"{where}: the parameter {shown(role)} clashes with the term's own vector {role} "
                "(rename the parameter)"
            )
    select, members = _selection(entry.get(kind.select_key, kind.default), kind, n, where)
    count = Term(kind, sp.Integer(0), select, members).count(n)
    data = _term_data(entry.get("data"), kind, select, count, params, where)
    for d in data:
        if any(d.name == s.name for s in shared):
            raise SpecError(
                f"{where} data.{d.name}: {shown(d.name)} is also a per-body datum of [data] "
                "(rename one of them)"
            )
    _check_symbols(kind, data, params, where, shared)
    local = {**{role: 3 for role in kind.roles}, **{d.name: d.width for d in data}}
    body = {name: d.width for d in shared for name in body_names(d.name, kind)}
    for name in (*(d.name for d in data), *body):
        if name in inputs:
            raise SpecError(f"{where}: the datum name {shown(name)} is also an input")
    expr = _term_expression(entry["V"], kind, n, {**local, **body}, params, f"{where} V", inputs)
    named = {s.name for s in expr.free_symbols}
    used = tuple(d for d in shared if _reads(d, kind, named))
    cutoff = None
    if entry.get("cutoff") is not None:
        cutoff = _number(entry["cutoff"], f"{where} cutoff", params)
        if not cutoff > 0.0 or Selection.of(kind, select, cutoff=True) is None:
            raise SpecError(
                f"{where} cutoff: must be a positive distance, on a term over all pairs "
                f"(got {shown(entry['cutoff'])} with pairs = {shown(select)})"
            )
    return Term(kind, expr, select, members, data, label, cutoff, used)


def _reads(d: TermData, kind: TermKind, named: set[str]) -> bool:
    """True when the expression (symbol names `named`) reads the per-body datum `d`."""
    return any(
        s.name in named
        for local in body_names(d.name, kind)
        for s in _local_symbols(local, d.width)
    )


def _options(kind: TermKind) -> str:
    """What a selection key may be, for messages: its named selections or a list."""
    named = [f'"{s}"' for s in spellings(kind, named=True)]
    words = ", ".join(named)
    return f"{words} or a list of {kind.listing}"


def _selection(
    value: Any, kind: TermKind, n: int, where: str
) -> tuple[str, tuple[tuple[int, ...], ...]]:
    """The selection key: a named selection, or a list of members (1-based -> 0-based)."""
    where = f"{where} {kind.select_key}"
    if isinstance(value, str) and value in spellings(kind, named=True):
        return value, ()
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not isinstance(value, Sequence) or not value:
        raise SpecError(f"{where}: expected {_options(kind)} 1..{n}, got {shown(value)}")
    listed = next(s for s in spellings(kind) if s not in spellings(kind, named=True))
    return listed, tuple(
        _member(item, kind, n, f"{where}[{m + 1}]") for m, item in enumerate(value)
    )


def _member(item: Any, kind: TermKind, n: int, where: str) -> tuple[int, ...]:
    """One listed body (i,) or pair (i, j), 0-based."""
    if kind.arity == 1:
        return (_body_index(item, n, where) - 1,)
    if isinstance(item, np.ndarray):
        item = item.tolist()
    if isinstance(item, (str, bytes)) or not isinstance(item, Sequence) or len(item) != 2:
        raise SpecError(
            f"{where}: expected a pair [i, j] of body indices 1..{n}, got {shown(item)}"
        )
    i, j = (_body_index(b, n, where) for b in item)
    if i == j:
        raise SpecError(f"{where}: the pair [{i}, {j}] joins body {i} with itself")
    return (i - 1, j - 1)


def _body_index(value: Any, n: int, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise SpecError(f"{where}: expected a body index 1..{n}, got {shown(value)}")
    value = int(value)
    if not 1 <= value <= n:
        hint = " (indices are 1-based)" if value == 0 else ""
        raise SpecError(f"{where}: body {value} is not one of 1..{n}{hint}")
    return value


def _term_data(
    data: Any,
    kind: TermKind,
    select: str,
    count: int,
    params: Mapping[str, float],
    where: str,
) -> tuple[TermData, ...]:
    """The data table: name = one number or 3-vector per member."""
    if data is None:
        return ()
    if not isinstance(data, Mapping):
        raise SpecError(
            f"{where} data: expected a table of name = list of values, got {shown(data)}"
        )
    return tuple(
        _datum(name, values, kind, select, count, params, f"{where} data.{_key(name)}")
        for name, values in data.items()
    )


def _datum(
    name: Any,
    values: Any,
    kind: TermKind,
    select: str,
    count: int,
    params: Mapping[str, float],
    where: str,
) -> TermData:
    """One datum: its name checked, one value per member, all numbers or all 3-vectors."""
    _check_data_name(name, params, where)
    selection = Selection.of(kind, select)
    assert selection is not None, "the selection was read by _selection"
    if not selection.rule.data:
        named = [f'"{w}"' for w in spellings(kind, named=True) if _carries_data(kind, w)]
        raise SpecError(
            f"{where}: per-pair data need an explicit list of pairs or {' or '.join(named)} "
            f'(with {kind.select_key} = "{select}", a value common to all pairs is a parameter)'
        )
    member = selection.rule.member
    entries = _rows(values, count, where, f"values (one per {member})")
    widths = [_entry_width(entry, f"{where}[{m + 1}]") for m, entry in enumerate(entries)]
    for m, width in enumerate(widths):
        if width != widths[0]:
            kinds = {1: "a number", 3: "a 3-vector"}
            raise SpecError(
                f"{where}[{m + 1}]: {kinds[width]}, but entry 1 is {kinds[widths[0]]} "
                "(a datum is all numbers or all 3-vectors)"
            )
    flat = [
        _number(value, f"{where}[{m + 1}]" + (f"[{c + 1}]" if width == 3 else ""), params)
        for m, (entry, width) in enumerate(zip(entries, widths))
        for c, value in enumerate(_vector_items(entry) or [entry])
    ]
    return TermData(name, widths[0] if widths else 1, tuple(flat))


def _carries_data(kind: TermKind, spelling: str) -> bool:
    """True when the named selection `spelling` of `kind` allows per-member data."""
    selection = Selection.of(kind, spelling)
    return selection is not None and selection.rule.data


def _entry_width(entry: Any, where: str) -> int:
    """1 for a scalar entry, 3 for a 3-vector; anything else is an error."""
    if isinstance(entry, (str, sp.Expr)) or (
        isinstance(entry, numbers.Real) and not isinstance(entry, bool)
    ):
        return 1
    items = _vector_items(entry)
    if items is not None and len(items) == 3:
        return 3
    got = repr(entry) if items is None else f"a list of {len(items)}"
    raise SpecError(f"{where}: expected a number or a 3-vector, got {got}")


def _vector_items(entry: Any) -> list[Any] | None:
    """The components of a list-like entry (None if it is not one)."""
    if isinstance(entry, (np.ndarray, sp.MatrixBase)):
        return list(np.asarray(entry, dtype=object).ravel())
    if isinstance(entry, Sequence) and not isinstance(entry, (str, bytes)):
        return list(entry)
    return None


def _check_symbols(
    kind: TermKind,
    data: Sequence[TermData],
    params: Mapping[str, float],
    where: str,
    shared: Sequence[TermData] = (),
) -> None:
    """No two of the parameters, the term's own vectors, its data and the names it reads the
    per-body data of [data] under may share a SymPy symbol (a vector datum r owns r_0, r_1,
    r_2; the vector q owns q_0, q_1, q_2; a per-body datum c is ci and cj in a pair term)."""
    owners = {p: f"the parameter {shown(p)}" for p in params}
    claims = [(s.name, f"the term's vector {r}") for r in kind.roles for s in local_vector(r)]
    claims += [(s.name, f"the datum {shown(d.name)}") for d in data for s in d.symbols()]
    claims += [
        (s.name, f"the [data] array {shown(d.name)} (read as {local})")
        for d in shared
        for local in body_names(d.name, kind)
        for s in _local_symbols(local, d.width)
    ]
    for symbol, owner in claims:
        if symbol in owners:
            raise SpecError(
                f"{where}: {owner} uses the symbol {symbol}, which is also {owners[symbol]} "
                "(rename one of them)"
            )
        owners[symbol] = owner


def _term_expression(
    value: Any,
    kind: TermKind,
    n: int,
    local: Mapping[str, int],
    params: Mapping[str, float],
    where: str,
    inputs: Sequence[str] = (),
) -> sp.Expr:
    """A term's V: a string in its local names, or a SymPy scalar in their symbols (and in
    time t and the inputs)."""
    names = [*params, *inputs]
    if isinstance(value, str):
        return parse_expression(value, n=n, parameters=names, where=where, local=local)
    if isinstance(value, sp.MatrixBase):
        raise SpecError(f"{where}: the term is a {value.shape} matrix, not a scalar")
    if not isinstance(value, sp.Expr) and (
        isinstance(value, bool) or not isinstance(value, numbers.Real)
    ):
        raise SpecError(
            f"{where}: expected an expression string or a SymPy scalar, got {shown(value)}"
        )
    expr = _scalar(value, where, names)
    own = " and ".join(kind.roles)
    symbols = {s.name for s in expr.free_symbols}
    global_q = sorted(name for name in symbols if _Q_RESERVED.fullmatch(name))
    if global_q:
        raise SpecError(
            f"{where}: the global positions {', '.join(global_q)} are not allowed in a term "
            f"expression (a term sees only its own vectors, here {own})"
        )
    allowed = {s.name for name, width in local.items() for s in _local_symbols(name, width)}
    extra = sorted(symbols - allowed - set(params) - set(inputs) - {"t"})
    if extra:
        raise SpecError(
            f"{where}: depends on {', '.join(extra)}, which is not one of the term's vectors "
            f"({own}), its data, t, an input or a parameter"
        )
    return expr


def _local_symbols(name: str, width: int) -> tuple[sp.Symbol, ...]:
    return local_vector(name) if width == 3 else (sp.Symbol(name, real=True),)
