"""Spec tables of driven systems: [inputs] and [forces] (with [[forces.body]] terms).

Input: the tables (TOML or `define_system`'s `inputs`, `forces` and `force_terms`), the body
count, the parameters, the input names and the spec's origin.
Output: the inputs (name -> default value) and `Force`s labelled "[forces] F2" or
"[[forces.body]] #k" (k from 1), or a `SpecError` naming the table, the key and the token::

    [inputs]                 # the caller's inputs and their defaults (zero-order hold)
    a = 0.0

    [forces]                 # F_i in R^3 conjugate to q_i: virtual work F_i . delta q_i
    F1 = "a*cross(e3, q1)"   # in q1..qn, w1..wn (angular velocities), t, inputs, parameters

    [[forces.body]]          # one force per body of the selection, in its own q and w
    F = "-c*cross(w, q)"     # viscous damping
    bodies = "all"           # or a list of 1-based body indices; default "all"
    [forces.body.data]       # optional per-body data, as for [[potential.body]]
    c = [0.1, 0.2]

    [[forces.pair]]          # forces on both bodies of each pair, in qi, qj, wi, wj
    Fi = "cross(c*(wj - wi), qi)"    # joint damping: torque -c (wj - wi) on j, its reaction
    Fj = "cross(-c*(wj - wi), qj)"   # on i (F = tau x q)
    pairs = "chain"          # "chain", "ring", "all" or a list of [i, j]; default "chain"
    [forces.pair.data]       # optional per-pair data, as for [[potential.pair]]

The per-body arrays of the top-level [data] table (`s2gen.spec.data`) are read as in the
potential terms: by name (c) in a [[forces.body]] term, as ci and cj (the pair's bodies'
values) in a [[forces.pair]] term, whatever the selection.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.forces import Force
from s2gen.spec.parser import parse_vector
from s2gen.spec.tables import _check_keys, _key, _number
from s2gen.spec.term_tables import (
    _check_symbols,
    _local_symbols,
    _reads,
    _selection,
    _term_data,
)
from s2gen.symbols import local_vector as vector
from s2gen.terms import Term, TermData, TermKind, body_names
from s2gen.validate.forces import _check_input_name

__all__: list[str] = []

_GENERAL = re.compile(r"F([1-9][0-9]*)")
_FORCE_TERM = "[[forces.body]]"
_PAIR_TERM = "[[forces.pair]]"


def _inputs(value: Any, params: Mapping[str, float], origin: str) -> dict[str, float]:
    """[inputs]: name = default value (a number or an expression in the parameters)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SpecError(f"{origin}: [inputs]: expected a table of name = default value")
    out: dict[str, float] = {}
    for name, default in value.items():
        _check_input_name(name, set(params), origin)
        out[name] = _number(default, f"{origin}: [inputs] {_key(name)}", params)
    return out


def _forces(
    general: Any,
    terms: Any,
    n: int,
    params: Mapping[str, float],
    inputs: Sequence[str],
    origin: str,
    pairs: Any = None,
    shared: Sequence[TermData] = (),
) -> list[Force]:
    """The general forces F1..Fn (a mapping), the [[forces.body]] terms and the
    [[forces.pair]] terms (lists); `shared` are the per-body arrays of the spec's [data]."""
    out: list[Force] = []
    if general is not None:
        if not isinstance(general, Mapping):
            raise SpecError(
                f"{origin}: [forces]: expected a table of F1 = ..., got {shown(general)}"
            )
        for key, value in general.items():
            match = _GENERAL.fullmatch(key) if isinstance(key, str) else None
            if match is None:
                raise SpecError(
                    f"{origin}: [forces]: unknown key {shown(key)} (allowed: F1..F{n}, body, pair)"
                )
            body = int(match.group(1))
            if body > n:
                raise SpecError(f"{origin}: [forces] {key}: no body {body}: the bodies are 1..{n}")
            label = f"[forces] {key}"
            expr = _vector(value, n, [*params, *inputs], None, f"{origin}: {label}")
            out.append(Force(expr, "list", ((body - 1,),), (), label, global_=True))
    for table, entries in ((_FORCE_TERM, terms), (_PAIR_TERM, pairs)):
        if entries is None:
            continue
        if isinstance(entries, (Mapping, str, bytes)) or not isinstance(entries, Sequence):
            raise SpecError(
                f"{origin}: {table}: expected a list of force tables (in TOML an array of "
                f"tables, written {table}), got {shown(entries)}"
            )
        for k, entry in enumerate(entries):
            term = _force_term if table == _FORCE_TERM else _pair_term
            out.append(term(entry, k + 1, n, params, inputs, origin, shared))
    return out


def _force_term(
    entry: Any,
    k: int,
    n: int,
    params: Mapping[str, float],
    inputs: Sequence[str],
    origin: str,
    shared: Sequence[TermData] = (),
) -> Force:
    """One [[forces.body]] table: F in the body's q and w, its bodies and per-body data."""
    label = f"{_FORCE_TERM} #{k}"
    where = f"{origin}: {label}"
    if not isinstance(entry, Mapping):
        raise SpecError(f"{where}: expected a table (F, bodies, data), got {shown(entry)}")
    _check_keys(entry, ("F", "bodies", "data"), where)
    if "F" not in entry:
        raise SpecError(f"{where}: missing required key 'F'")
    _check_roles(("q", "w"), params, inputs, where, "the body's")
    kind = TermKind.BODY
    select, members = _selection(entry.get("bodies", "all"), kind, n, where)
    data, local = _names(entry, kind, select, members, n, params, inputs, where, shared)
    expr = _vector(entry["F"], n, [*params, *inputs], local, f"{where} F")
    return Force(expr, select, members, data, label, body_data=_used(kind, shared, expr))


def _pair_term(
    entry: Any,
    k: int,
    n: int,
    params: Mapping[str, float],
    inputs: Sequence[str],
    origin: str,
    shared: Sequence[TermData] = (),
) -> Force:
    """One [[forces.pair]] table: Fi and Fj in the pair's qi, qj, wi, wj, its pairs and
    per-pair data."""
    label = f"{_PAIR_TERM} #{k}"
    where = f"{origin}: {label}"
    if not isinstance(entry, Mapping):
        raise SpecError(f"{where}: expected a table (Fi, Fj, pairs, data), got {shown(entry)}")
    _check_keys(entry, ("Fi", "Fj", "pairs", "data"), where)
    for key in ("Fi", "Fj"):
        if key not in entry:
            raise SpecError(f"{where}: missing required key {key!r}")
    _check_roles(("qi", "qj", "wi", "wj"), params, inputs, where, "the pair's")
    kind = TermKind.PAIR
    select, members = _selection(entry.get("pairs", "chain"), kind, n, where)
    if select not in ("chain", "ring", "all", "list"):
        raise SpecError(f"{where} pairs: a force term takes 'chain', 'ring', 'all' or a list")
    data, local = _names(entry, kind, select, members, n, params, inputs, where, shared)
    names = [*params, *inputs]
    fi = _vector(entry["Fi"], n, names, local, f"{where} Fi")
    fj = _vector(entry["Fj"], n, names, local, f"{where} Fj")
    used = _used(kind, shared, sp.ImmutableMatrix.vstack(fi, fj))
    return Force(fi, select, members, data, label, expr_j=fj, body_data=used)


def _check_roles(
    roles: Sequence[str], params: Mapping[str, float], inputs: Sequence[str], where: str, whose: str
) -> None:
    """No parameter or input may be named like one of the term's own vectors."""
    for role in roles:
        if role in params or role in inputs:
            raise SpecError(
                f"{where}: the name {shown(role)} clashes with {whose} own vector {role} "
                "(rename the parameter or input)"
            )


def _names(
    entry: Mapping[str, Any],
    kind: TermKind,
    select: Any,
    members: Any,
    n: int,
    params: Mapping[str, float],
    inputs: Sequence[str],
    where: str,
    shared: Sequence[TermData],
) -> tuple[tuple[TermData, ...], dict[str, int]]:
    """A force term's per-member data and every local name its expressions read with its
    width: its own vectors (q, w or qi, qj, wi, wj), its data and the names of the per-body
    arrays of [data] (`_body_names`); clashes between them are one-line errors."""
    velocities = tuple(r.replace("q", "w") for r in kind.roles)
    count = Term(kind, sp.Integer(0), select, members).count(n)
    data = _term_data(entry.get("data"), kind, select, count, params, where)
    body = _body_names(kind, data, shared, velocities, inputs, where)
    _check_symbols(kind, data, params, where, shared)
    _check_taken(data, velocities, inputs, where)
    own = dict.fromkeys((*kind.roles, *velocities), 3)
    return data, {**own, **{d.name: d.width for d in data}, **body}


def _check_taken(
    data: Sequence[TermData], velocities: Sequence[str], inputs: Sequence[str], where: str
) -> None:
    """A term datum may be named neither like one of the term's angular velocities nor like
    one of their components (w_0 is the first component of w: a datum w_0 would replace it)
    nor like an input."""
    components = {s.name: v for v in velocities for s in vector(v)}
    for d in data:
        if d.name in (*velocities, *inputs):
            raise SpecError(f"{where} data.{d.name}: the name {shown(d.name)} is taken")
        for s in d.symbols():
            if s.name in components:
                raise SpecError(
                    f"{where} data.{d.name}: the datum uses the symbol {s.name}, a component "
                    f"of the term's angular velocity {components[s.name]} (rename the datum)"
                )


def _body_names(
    kind: TermKind,
    data: Sequence[TermData],
    shared: Sequence[TermData],
    velocities: Sequence[str],
    inputs: Sequence[str],
    where: str,
) -> dict[str, int]:
    """The names a force term reads the per-body arrays of [data] under (c, or ci and cj) and
    their widths; a name that is also a datum of the term, one of its velocities or an input
    is an error, as in the potential terms."""
    out: dict[str, int] = {}
    for d in shared:
        if any(d.name == own.name for own in data):
            raise SpecError(
                f"{where} data.{d.name}: {shown(d.name)} is also a per-body datum of [data] "
                "(rename one of them)"
            )
        for name in body_names(d.name, kind):
            symbols = {s.name for s in _local_symbols(name, d.width)}
            if name in velocities or symbols & {s.name for v in velocities for s in vector(v)}:
                raise SpecError(
                    f"{where}: the [data] array {shown(d.name)} is read as {name}, the "
                    f"angular velocity {name} of the term (rename the datum)"
                )
            if name in inputs:
                raise SpecError(f"{where}: the datum name {shown(name)} is also an input")
            out[name] = d.width
    return out


def _used(kind: TermKind, shared: Sequence[TermData], expr: sp.MatrixBase) -> tuple[TermData, ...]:
    """The per-body arrays of [data] that the force expression reads."""
    named = {s.name for s in expr.free_symbols}
    return tuple(d for d in shared if _reads(d, kind, named))


def _vector(
    value: Any, n: int, names: Sequence[str], local: Mapping[str, int] | None, where: str
) -> sp.ImmutableMatrix:
    """A force: an expression string, or a 3-vector of SymPy expressions (checked later)."""
    if isinstance(value, str):
        return parse_vector(value, n=n, parameters=names, where=where, local=local)
    if isinstance(value, sp.MatrixBase):
        if value.shape not in ((3, 1), (1, 3)):
            raise SpecError(f"{where}: a force is a 3-vector, got a {value.shape} matrix")
        return sp.ImmutableMatrix(value.reshape(3, 1))
    if isinstance(value, Sequence) and not isinstance(value, bytes) and len(value) == 3:
        try:
            return sp.ImmutableMatrix([sp.sympify(v, strict=True) for v in value])
        except (sp.SympifyError, TypeError):
            raise SpecError(
                f"{where}: expected numbers or SymPy expressions, got {shown(value)}"
            ) from None
    raise SpecError(
        f"{where}: a force is a 3-vector (an expression string or 3 SymPy entries), "
        f"got {shown(value)}"
    )
