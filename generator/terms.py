"""Term kinds and member selections: the one table every stage reads.

Input: nothing (this module is data). Output: `TermKind` (a term over one body or over a pair of
bodies: its arity, its own vectors and loop indices, how a spec writes it) and `Selection` (which
members a term or loop visits: every body, listed bodies, the chain, the ring (the chain closed
by the pair (n, 1)), listed pairs, every pair, the pairs within a cutoff, the coupled pairs of
M), each with the record `Rule` saying how its members are enumerated and described; and the
`Term` record itself, with its per-member `TermData`. Spec parsing, `System` validation, the IR
(`ir.LoopKind` is `Selection`), assembly, the passes and both printers read these records; the
printers turn a rule's `Enumeration` into a C loop and NumPy index arrays. A new selection whose
members follow one of the existing enumerations is one entry here, plus its branch in the
reference's own enumerator (`s2gen.reference.problem`), its words in the spec docs and a test.

Example:
    >>> Selection.of(TermKind.PAIR, "chain").members(4)
    [(0, 1), (1, 2), (2, 3)]
    >>> Selection.CHAIN.doc, Selection.CHAIN.kind.roles
    ('sum over pairs (chain)', ('qi', 'qj'))
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

from s2gen.symbols import local_vector, q_symbol

__all__ = [
    "Enumeration",
    "Rule",
    "Selection",
    "Term",
    "TermData",
    "TermKind",
    "body_names",
    "spellings",
]


class TermKind(enum.StrEnum):
    """What one member of a term is: a body (`q`) or a pair of bodies (`qi`, `qj`).

    Example:
        >>> TermKind("pair").arity, TermKind.PAIR.indices, TermKind.BODY.table
        (2, ('i', 'j'), '[[potential.body]]')
    """

    BODY = "body"
    PAIR = "pair"

    @property
    def arity(self) -> int:
        """Bodies per member."""
        return len(self.roles)

    @property
    def roles(self) -> tuple[str, ...]:
        """The term expression's own vectors, one per body of a member."""
        return ("q",) if self is TermKind.BODY else ("qi", "qj")

    @property
    def indices(self) -> tuple[str, ...]:
        """The loop's name for each body of a member (C loop variables, table suffixes)."""
        return ("i", "j")[: self.arity]

    @property
    def plural(self) -> str:
        """The members in words ("bodies", "pairs")."""
        return "bodies" if self is TermKind.BODY else "pairs"

    @property
    def table(self) -> str:
        """The spec's array of tables for terms of this kind (also their label prefix)."""
        return f"[[potential.{self.value}]]"

    @property
    def select_key(self) -> str:
        """The key of a term table that names its selection."""
        return self.plural

    @property
    def default(self) -> str | None:
        """The selection when a spec omits the key (None: the key is required)."""
        return "all" if self is TermKind.BODY else None

    @property
    def listing(self) -> str:
        """What a listed selection is a list of, in words."""
        return "body indices" if self is TermKind.BODY else "pairs [i, j] of body indices"


class Enumeration(enum.Enum):
    """How a loop finds its members (the printers write one loop shape per enumeration).

    SHIFTED: member m is the bodies m + s for each shift s (mod n when the rule wraps);
    TABLE: read from member tables; TRIANGLE: every pair i < j in row order; NEIGHBOURS: the
    pairs closer than a cutoff, found from cell lists at each call.
    """

    SHIFTED = "shifted"
    TABLE = "table"
    TRIANGLE = "triangle"
    NEIGHBOURS = "neighbours"


@dataclass(frozen=True)
class Rule:
    """One selection: its kind, how a spec spells it, how its members are enumerated.

    `spelling` is the spec's word (None: not a term selection); `member` names one member in
    messages; `data` says whether per-member data are allowed; `minimum` is the fewest bodies
    it accepts; `shifts` and `wrap` define SHIFTED members; `cutoff` marks the selection a term
    over all pairs gets from a cutoff distance.
    """

    kind: TermKind
    spelling: str | None
    enumeration: Enumeration
    doc: str
    member: str
    shifts: tuple[int, ...] = ()
    wrap: bool = False
    cutoff: bool = False
    data: bool = True
    minimum: int = 1


_B, _P = TermKind.BODY, TermKind.PAIR
_SHIFTED, _TABLE = Enumeration.SHIFTED, Enumeration.TABLE


@enum.unique  # two equal rules would silently make one selection an alias of the other
class Selection(enum.Enum):
    """The selections, in the order messages list them; each value is its `Rule`."""

    BODIES = Rule(_B, "all", _SHIFTED, "sum over bodies (all)", "body", shifts=(0,))
    BODY_LIST = Rule(_B, "list", _TABLE, "sum over bodies (list)", "listed body")
    ALL_PAIRS = Rule(_P, "all", Enumeration.TRIANGLE, "sum over pairs (all)", "pair", data=False)
    CUTOFF_PAIRS = Rule(
        _P,
        "all",
        Enumeration.NEIGHBOURS,
        "sum over pairs within the cutoff",
        "pair",
        cutoff=True,
        data=False,
    )
    CHAIN = Rule(_P, "chain", _SHIFTED, "sum over pairs (chain)", "pair of the chain", (0, 1))
    RING = Rule(
        _P,
        "ring",
        _SHIFTED,
        "sum over pairs (ring)",
        "pair of the ring",
        (0, 1),
        wrap=True,
        minimum=3,
    )
    PAIR_LIST = Rule(_P, "list", _TABLE, "sum over pairs (list)", "listed pair")
    COUPLING = Rule(_P, None, _TABLE, "sum over the coupled pairs of M", "coupled pair")

    @property
    def rule(self) -> Rule:
        """The record of this selection."""
        value: Rule = self.value
        return value

    @property
    def kind(self) -> TermKind:
        return self.rule.kind

    @property
    def doc(self) -> str:
        return self.rule.doc

    @property
    def pairs(self) -> bool:
        """True when a member is a pair of bodies."""
        return self.rule.kind is TermKind.PAIR

    @property
    def listed(self) -> bool:
        """True when members are read from index tables."""
        return self.rule.enumeration is Enumeration.TABLE

    @property
    def fixed(self) -> bool:
        """True when the members are known when the code is generated (not found per call)."""
        return self.rule.enumeration is not Enumeration.NEIGHBOURS

    @staticmethod
    def of(kind: TermKind, spelling: object, cutoff: bool = False) -> Selection | None:
        """The selection a term of `kind` spelled `spelling` (with or without a cutoff) has,
        or None when there is none.

        Example:
            >>> Selection.of(TermKind.PAIR, "all", cutoff=True), Selection.of(TermKind.BODY, "x")
            (<Selection.CUTOFF_PAIRS: ...>, None)
        """
        for s in Selection:
            r = s.rule
            if r.kind is kind and r.spelling == spelling and r.cutoff == cutoff:
                return s
        return None

    def count(self, n: int, listed: Sequence[tuple[int, ...]] = ()) -> int:
        """Number of members for n bodies (the candidates, for a cutoff).

        Example:
            >>> Selection.ALL_PAIRS.count(4), Selection.BODY_LIST.count(4, [(2,)])
            (6, 1)
        """
        r = self.rule
        if r.enumeration is Enumeration.TABLE:
            return len(listed)
        if r.enumeration is Enumeration.SHIFTED:
            return n if r.wrap else max(n - max(r.shifts), 0)
        return n * (n - 1) // 2

    def members(self, n: int, listed: Sequence[tuple[int, ...]] = ()) -> list[tuple[int, ...]]:
        """The members (0-based bodies) for n bodies, in loop order (the candidates, for a
        cutoff); a listed selection's are `listed`.

        Example:
            >>> Selection.BODIES.members(2), Selection.ALL_PAIRS.members(3)
            ([(0,), (1,)], [(0, 1), (0, 2), (1, 2)])
        """
        r = self.rule
        if r.enumeration is Enumeration.TABLE:
            return [tuple(m) for m in listed]
        if r.enumeration is Enumeration.SHIFTED:
            wrap = n if r.wrap else n + max(r.shifts) + 1
            return [tuple((m + s) % wrap for s in r.shifts) for m in range(self.count(n))]
        return [(i, j) for i in range(n) for j in range(i + 1, n)]


def spellings(kind: TermKind, named: bool = False) -> tuple[str, ...]:
    """The spec's words for the selections of `kind`, in order; `named` leaves out "list"
    (a listed selection is written as the list itself).

    Example:
        >>> spellings(TermKind.PAIR), spellings(TermKind.BODY, named=True)
        (('all', 'chain', 'ring', 'list'), ('all',))
    """
    out: list[str] = []
    for s in Selection:
        word = s.rule.spelling
        if s.kind is kind and word is not None and word not in out and not (named and s.listed):
            out.append(word)
    return tuple(out)


@dataclass(frozen=True)
class TermData:
    """Per-member data of a term: `width` 1 (a scalar symbol `name`) or 3 (a vector, symbols
    name_0..2), with `width` values per member, member-major.

    Example:
        >>> TermData("r", 3, (1.0, 0.0, 0.0)).symbols()
        (r_0, r_1, r_2)
    """

    name: str
    width: int
    values: tuple[float, ...]

    def symbols(self) -> tuple[sp.Symbol, ...]:
        if self.width == 1:
            return (sp.Symbol(self.name, real=True),)
        return local_vector(self.name)


def body_names(name: str, kind: TermKind) -> tuple[str, ...]:
    """The names a term of `kind` reads the per-body datum `name` under, one per body of a
    member: the name itself in a body term, name + i and name + j in a pair term.

    Example:
        >>> body_names("c", TermKind.PAIR), body_names("c", TermKind.BODY)
        (('ci', 'cj'), ('c',))
    """
    if kind.arity == 1:
        return (name,)
    return tuple(f"{name}{i}" for i in kind.indices)


@dataclass(frozen=True)
class Term:
    """A structured part of the potential: a sum of one expression over a list of members.

    `kind` (a `TermKind`, or its value "body" or "pair") says what a member is: the expression
    is in the body's vector q (symbols `local_vector("q")`) or in a pair's qi and qj. `select`
    is the spec's word for the members ("all", "chain", "list" with `members` 0-based; see
    `spellings`), and with a `cutoff` a term over all pairs visits only the pairs closer than
    it; `selection` is the resulting `Selection`. Per-member data (spring constants, offsets,
    ...) enter as extra symbols; parameters as usual. `body_data` are the per-body arrays of
    the spec's [data] that the expression reads (n entries of `width` values, body-major), under
    the names `body_names` gives (c in a body term, ci and cj in a pair term), for any selection.

    Example:
        >>> qi, qj = sp.Matrix(local_vector("qi")), sp.Matrix(local_vector("qj"))
        >>> t = Term("pair", qi.dot(qj), select="chain")
        >>> t.selection, t.count(3), t.member_list(3)
        (<Selection.CHAIN: ...>, 2, [(0, 1), (1, 2)])
    """

    kind: TermKind
    expr: sp.Expr
    select: str = "all"
    members: tuple[tuple[int, ...], ...] = ()
    data: tuple[TermData, ...] = ()
    label: str = "term"
    cutoff: float | None = None  # pair terms over all pairs: only pairs with |q_i - q_j| < cutoff
    body_data: tuple[TermData, ...] = ()

    def __post_init__(self) -> None:
        kind: object = self.kind
        if isinstance(kind, str) and kind in TermKind.__members__.values():
            object.__setattr__(self, "kind", TermKind(kind))  # frozen: normalized once

    @property
    def selection(self) -> Selection:
        """The selection of the members (ValueError when the kind and `select` have none)."""
        found = Selection.of(self.kind, self.select, self.cutoff is not None)
        if found is None:
            raise ValueError(f"{self.label}: no {self.kind} selection {self.select!r}")
        return found

    def count(self, n: int) -> int:
        """Number of members for n bodies."""
        return self.selection.count(n, self.members)

    def member_list(self, n: int) -> list[tuple[int, ...]]:
        """The members (0-based) for n bodies, in loop order."""
        return self.selection.members(n, self.members)

    def roles(self) -> tuple[str, ...]:
        return self.kind.roles

    def position_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(s for role in self.roles() for s in local_vector(role))

    def data_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(s for d in self.data for s in d.symbols())

    def body_symbols(self) -> tuple[tuple[TermData, int, tuple[sp.Symbol, ...]], ...]:
        """(per-body datum, body of the member (0 or 1), its symbols) for each name under
        which the expression reads a per-body datum."""
        return tuple(
            (d, r, TermData(local, d.width, ()).symbols())
            for d in self.body_data
            for r, local in enumerate(body_names(d.name, self.kind))
        )

    def instance(self, member: tuple[int, ...], index: int) -> sp.Expr:
        """The term of one member written in the global symbols q{i}_{c} (for checks)."""
        subs: dict[sp.Symbol, sp.Expr] = {}
        for role, body in zip(self.roles(), member):
            subs.update(dict(zip(local_vector(role), (q_symbol(body + 1, c) for c in range(3)))))
        for d in self.data:
            vals = d.values[index * d.width : (index + 1) * d.width]
            subs.update({s: sp.Float(v) for s, v in zip(d.symbols(), vals)})
        for d, r, symbols in self.body_symbols():
            vals = d.values[member[r] * d.width : (member[r] + 1) * d.width]
            subs.update({s: sp.Float(v) for s, v in zip(symbols, vals)})
        return self.expr.xreplace(subs)
