"""Term kinds and selections (s2gen.terms) against the reference's own member enumerator.

The reference (`s2gen.reference.problem`) enumerates a term's members with NumPy from the
definition of each selection; `Selection.members` is what the spec, the IR and both printers
use. They must agree on every selection, for every n, on random member lists, and (for the
cutoff) on which pairs lie within the distance at random positions. Every selection a spec can
name must also come out of a spec with that name, and the loops the C and NumPy printers write
for it must give the reference's gradient.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
import sympy as sp

from s2gen.reference.problem import _compile_term, _term_indices
from s2gen.runtime import get_backend
from s2gen.spec import define_system
from s2gen.symbols import local_vector
from s2gen.system import System, Term, TermData
from s2gen.terms import Selection, TermKind, spellings

QV = sp.Matrix(local_vector("q"))
QI, QJ = sp.Matrix(local_vector("qi")), sp.Matrix(local_vector("qj"))
EXPR = {TermKind.BODY: QV[2], TermKind.PAIR: QI.dot(QJ)}
TERM_SELECTIONS = [s for s in Selection if s.rule.spelling is not None]


def random_listed(kind: TermKind, n: int, rng: np.random.Generator) -> tuple[tuple[int, ...], ...]:
    """A random member list (repeats allowed, pairs of distinct bodies in either order)."""
    count = int(rng.integers(1, 2 * n + 2))
    if kind is TermKind.BODY:
        return tuple((int(b),) for b in rng.integers(0, n, size=count))
    return tuple(tuple(int(b) for b in rng.choice(n, size=2, replace=False)) for _ in range(count))


def term_of(selection: Selection, n: int, rng: np.random.Generator) -> Term:
    rule = selection.rule
    assert rule.spelling is not None
    members = random_listed(rule.kind, n, rng) if selection.listed else ()
    cutoff = float(rng.uniform(0.2, 1.5)) if rule.cutoff else None
    return Term(rule.kind, EXPR[rule.kind], rule.spelling, members, cutoff=cutoff)


def reference_members(term: Term, n: int) -> list[tuple[int, ...]]:
    return list(zip(*(idx.tolist() for idx in _term_indices(term, n))))


def test_every_term_selection_is_reachable_by_its_spelling() -> None:
    for selection in TERM_SELECTIONS:
        rule = selection.rule
        found = Selection.of(rule.kind, rule.spelling, cutoff=rule.cutoff)
        assert found is selection
        assert rule.spelling in spellings(rule.kind)


@pytest.mark.parametrize("selection", TERM_SELECTIONS, ids=lambda s: s.name)
def test_reference_enumerates_the_members_of_every_selection(selection: Selection) -> None:
    rng = np.random.default_rng(TERM_SELECTIONS.index(selection))
    for n in range(max(selection.rule.minimum, selection.kind.arity), 12):
        for _ in range(3 if selection.listed else 1):
            term = term_of(selection, n, rng)
            members = selection.members(n, term.members)
            assert reference_members(term, n) == members, (selection, n)
            assert len(members) == selection.count(n, term.members) == term.count(n)
            for member in members:
                assert len(member) == selection.kind.arity
                assert all(0 <= b < n for b in member)
                assert len(set(member)) == len(member), "a pair joins two different bodies"


@pytest.mark.parametrize("selection", TERM_SELECTIONS, ids=lambda s: s.name)
def test_named_selections_visit_each_member_once(selection: Selection) -> None:
    """No named selection visits a body or an unordered pair twice (a listed one may)."""
    if selection.listed:
        return
    for n in range(max(selection.rule.minimum, 1), 12):
        members = selection.members(n)
        assert len({frozenset(m) for m in members}) == len(members)


def test_all_pairs_and_chain_closed_forms() -> None:
    for n in range(1, 10):
        assert Selection.ALL_PAIRS.members(n) == list(itertools.combinations(range(n), 2))
        assert Selection.CHAIN.members(n) == [(i, i + 1) for i in range(n - 1)]
        assert Selection.BODIES.members(n) == [(i,) for i in range(n)]


@pytest.mark.parametrize("seed", range(6))
def test_reference_keeps_the_pairs_within_the_cutoff(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    term = term_of(Selection.CUTOFF_PAIRS, n, rng)
    assert term.cutoff is not None
    kernel = _compile_term(term, n, [], [])
    active = list(zip(*(idx.tolist() for idx in kernel._active(q.T.copy()))))
    close = [
        (i, j)
        for i, j in Selection.CUTOFF_PAIRS.members(n)
        if np.linalg.norm(q[i] - q[j]) < term.cutoff
    ]
    assert active == close


@pytest.mark.parametrize("selection", TERM_SELECTIONS, ids=lambda s: s.name)
def test_a_spec_names_every_selection(selection: Selection) -> None:
    rule = selection.rule
    assert rule.spelling is not None
    n = max(rule.minimum, 4)
    rng = np.random.default_rng(7)
    value: object = rule.spelling
    if selection.listed:
        members = random_listed(rule.kind, n, rng)
        value = [[b + 1 for b in m] if len(m) == 2 else m[0] + 1 for m in members]
    table: dict[str, object] = {"V": "qi[0] * qj[1]" if selection.pairs else "q[2]"}
    table[rule.kind.select_key] = value
    if rule.cutoff:
        table["cutoff"] = 0.5
    system = define_system(
        name="pick",
        bodies=n,
        parameters={},
        diagonal=[1.0] * n,
        **{f"{rule.kind.value}_terms": [table]},
    )
    assert isinstance(system, System)
    (term,) = system.terms
    assert term.selection is selection
    assert term.member_list(n) == reference_members(term, n)


def loop_system(selection: Selection, n: int, rng: np.random.Generator) -> System:
    """A system whose only potential is one term over `selection`: not polynomial (no K),
    asymmetric in i and j, with a datum that differs per member where the selection allows
    data, so a member visited twice, missed, swapped or paired with another's datum shows."""
    rule = selection.rule
    term = term_of(selection, n, rng)
    count = term.count(n)
    c = sp.Symbol("c", real=True)
    if selection.pairs:
        expr = sp.exp(QI[0] * QJ[1] + QI[2] / 2)
    else:
        expr = sp.exp(QV[2] * QV[0])
    data: tuple[TermData, ...] = ()
    if rule.data:
        expr = c * expr
        data = (TermData("c", 1, tuple(1.0 + 0.5 * k for k in range(count))),)
    name = f"sel_{selection.name.lower()}"
    return System.create(
        name=name,
        n=n,
        parameters={},
        inertia=sp.eye(n),
        potential=sp.Integer(0),
        terms=[dataclasses.replace(term, expr=expr, data=data, label=name)],
    )


@pytest.mark.parametrize("selection", TERM_SELECTIONS, ids=lambda s: s.name)
def test_c_and_numpy_loops_visit_the_reference_s_members(selection: Selection) -> None:
    n = max(selection.rule.minimum, 6)
    rng = np.random.default_rng(100 + TERM_SELECTIONS.index(selection))
    system = loop_system(selection, n, rng)
    q = rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    p = np.zeros(0)
    g_ref = get_backend(system, "reference")._problem(p).grad(q)
    scale = np.max(np.abs(g_ref))
    assert scale > 0.1
    c = get_backend(system, "c")
    _, dw = c.rhs(q, np.zeros_like(q), p)  # with workspace: member tables, rows, cell lists
    for g in (c.gradient(q, p), get_backend(system, "numpy").gradient(q, p)):
        assert np.max(np.abs(g - g_ref)) < 1e-12 * scale
    assert np.max(np.abs(dw + np.cross(q, g_ref))) < 1e-12 * scale  # M = 1: dw = -q x g
