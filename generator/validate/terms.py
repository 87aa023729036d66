"""Validation of structured potential terms: kind, selection, members, data and symbols.

Input: a `Term`, the number of bodies, the parameter symbols and the location for messages.
Output: nothing, or a `SpecError` naming the term and what is wrong with it. The kinds and
selections themselves are `s2gen.terms`'.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.terms import Selection, Term, TermKind, body_names, spellings
from s2gen.validate.names import _C_IDENTIFIER, _TEMPORARY, _TEMPORARY_CLASH, _check_real

__all__ = ["MAX_CUTOFF"]

#: The largest pair-term cutoff: every pair of unit vectors lies within 2, and the emitted
#: code squares the cutoff, which must stay a finite double.
MAX_CUTOFF = 1e100


def _validate_term(term: Term, n: int, psyms: set[sp.Symbol], where: str) -> None:
    """Check kind, selection, members, data sizes and the symbols of one term."""
    at = f"{where}: {term.label}"
    if not isinstance(term.kind, TermKind):
        kinds = " or ".join(repr(k.value) for k in TermKind)
        raise SpecError(f"{at}: kind must be {kinds}, got {shown(term.kind)}")
    allowed = spellings(term.kind)
    if term.select not in allowed:
        raise SpecError(f"{at}: selection must be one of {allowed}, got {shown(term.select)}")
    selection = Selection.of(term.kind, term.select, term.cutoff is not None)
    if selection is None:
        raise SpecError(f"{at}: a cutoff applies only to pair terms over all pairs")
    if selection.listed:
        width = term.kind.arity
        for k, mem in enumerate(term.members):
            if len(mem) != width or not all(0 <= b < n for b in mem):
                one_based = [b + 1 for b in mem]
                raise SpecError(
                    f"{at}: member {k + 1} {one_based} is not {width} body index(es) 1..{n}"
                )
            if width == 2 and mem[0] == mem[1]:
                raise SpecError(f"{at}: member {k + 1} pairs body {mem[0] + 1} with itself")
    elif term.members:
        raise SpecError(f"{at}: members are given but the selection is {shown(term.select)}")
    if n < selection.rule.minimum:
        raise SpecError(
            f"{at}: the selection {shown(term.select)} needs at least {selection.rule.minimum} "
            f"bodies, the system has {n}"
        )
    if term.cutoff is not None and not (
        np.isfinite(term.cutoff) and 0.0 < term.cutoff <= MAX_CUTOFF
    ):
        raise SpecError(
            f"{at}: cutoff must be a positive distance of at most {MAX_CUTOFF:g} (unit "
            f"vectors lie within 2 of each other), got {shown(term.cutoff)}"
        )
    count = term.count(n)
    _check_data_names(term, at)
    for d in term.data:
        if not selection.rule.data:
            raise SpecError(
                f"{at}: per-pair data '{d.name}' needs an explicit pair list or a chain "
                "(a value common to all pairs is a parameter)"
            )
        if d.width not in (1, 3) or len(d.values) != d.width * count:
            got = len(d.values) / max(d.width, 1)
            raise SpecError(
                f"{at}: data '{d.name}' has {got:g} entries of width {d.width}, expected {count} "
                f"{'numbers' if d.width == 1 else '3-vectors'} (one per member)"
            )
        if not all(np.isfinite(d.values)):
            raise SpecError(f"{at}: data '{d.name}' contains a non-finite value")
    for d in term.body_data:
        if d.width not in (1, 3) or len(d.values) != d.width * n:
            raise SpecError(
                f"{at}: the per-body datum '{d.name}' has {len(d.values)} values, expected "
                f"{n} {'numbers' if d.width == 1 else '3-vectors'} (one per body)"
            )
        for local in body_names(d.name, term.kind):
            if d.width == 1 and _TEMPORARY.fullmatch(local):
                raise SpecError(f"{at}: the name {shown(local)} {_TEMPORARY_CLASH}")
        if not bool(np.all(np.isfinite(np.asarray(d.values, dtype=float)))):
            raise SpecError(f"{at}: the per-body datum '{d.name}' contains a non-finite value")
    if not isinstance(term.expr, sp.Expr) or term.expr.has(sp.Derivative, sp.Integral):
        raise SpecError(f"{at}: must be a scalar expression without derivatives or integrals")
    body = [s for _, _, symbols in term.body_symbols() for s in symbols]
    names = [s.name for s in (*term.position_symbols(), *term.data_symbols(), *body)]
    clash = sorted(set(names) & {p.name for p in psyms}) or sorted(
        {x for x in names if names.count(x) > 1}
    )
    if clash:
        raise SpecError(f"{at}: symbol '{clash[0]}' is both a parameter/position and a datum")
    extra = term.expr.free_symbols - set(term.position_symbols()) - psyms
    extra -= {*term.data_symbols(), *body}
    if extra:
        bad = ", ".join(sorted(str(s) for s in extra))
        raise SpecError(f"{at}: depends on {bad}, which is not a position, datum or parameter")
    _check_real(term.expr, f"{at} V")


#: Names of a term's emitted member tables: C `NAME_t<k>_i`, `_j`; NumPy `T<k>_I`, `_J` (data
#: tables are `NAME_t<k>_<name>` and `T<k>_<NAME>`, upper-cased, in the same namespaces).
_MEMBER_TABLES = frozenset(i.upper() for k in TermKind for i in k.indices)


def _check_data_names(term: Term, at: str) -> None:
    """Data names must not clash with the emitted member tables of their term or the kernels'
    temporaries, nor with each other once upper-cased (the NumPy module's table names): k and
    K would share one table."""
    seen: dict[str, str] = {}
    for d in term.data:
        if not isinstance(d.name, str) or not _C_IDENTIFIER.fullmatch(d.name):
            raise SpecError(f"{at} data.{shown(d.name)}: {shown(d.name)} is not an identifier")
        if d.width == 1 and _TEMPORARY.fullmatch(d.name):  # a vector's symbols are x0_0..
            raise SpecError(f"{at} data.{d.name}: the name {shown(d.name)} {_TEMPORARY_CLASH}")
        upper = d.name.upper()
        if upper in _MEMBER_TABLES:
            raise SpecError(
                f"{at} data.{d.name}: the name {shown(d.name)} is taken by the term's table of "
                "member bodies in the emitted code (rename the datum)"
            )
        if upper in seen:
            raise SpecError(
                f"{at} data.{d.name}: the names {shown(seen[upper])} and {shown(d.name)} differ "
                "only in case, and the emitted NumPy module names its tables in upper case "
                "(rename one)"
            )
        seen[upper] = d.name
