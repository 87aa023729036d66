"""Typed bindings: what a kernel argument is at a call site, never how a language writes it.

A `Call` (`s2gen.ir`) binds each argument of its kernel to one of these records: a variable of
the calling function (`Local`), an array of the per-call context (`ContextArray`), the slot of
a body, a pair's body or a member in an array (`Slot`, `MemberSlot`), one entry of a per-body
or per-pair array (`Element`, `Product`), a run of an array from an offset (`Shifted`), the
body's number (`BodyNumber`), a term's or the inertia's data (`TermDatum`, `InertiaDatum`), a
per-body array of [data] at a member's body (`BodyDatum`) or a
term's member table (`TermTable`). The C printer (`s2gen.printing.c_calls.c_binding`) and
the NumPy printer (`s2gen.printing.numpy.py_binding`) render them; NumPy calls vectorize over
the loop, so a slot there is the whole array (or the array indexed by the pairs' or the
members' bodies).

Example:
    >>> from s2gen.printing.c_calls import c_binding
    >>> from s2gen.printing.numpy import py_binding
    >>> b = Slot("q", 3, Index.FIRST)
    >>> c_binding("m", b), py_binding(b)
    ('q + 3 * i0', 'q[PAIR_I]')
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = [
    "Binding",
    "BodyDatum",
    "BodyNumber",
    "ContextArray",
    "Element",
    "Index",
    "InertiaDatum",
    "Local",
    "MemberSlot",
    "Product",
    "Shifted",
    "Slot",
    "TermDatum",
    "TermTable",
]


class Index(enum.Enum):
    """The loop position a slot or an entry is taken at.

    Example:
        >>> [i.name for i in Index]
        ['BODY', 'PAIR', 'FIRST', 'SECOND', 'MEMBER', 'ELEMENT']
    """

    BODY = "body"  # body i of a loop over bodies
    PAIR = "pair"  # coupled pair k of a loop over pairs
    FIRST = "first"  # the first body of pair k
    SECOND = "second"  # the second body of pair k
    MEMBER = "member"  # member m of a term's loop
    ELEMENT = "element"  # body e of the angle form's conversion loop


@dataclass(frozen=True)
class Local:
    """A variable of the calling function: a scalar or a whole array by value, or a scalar
    output by `address`. `vector`: the name NumPy's code keeps it under, when not `name`.

    Example:
        >>> Local("total", address=True).address
        True
    """

    name: str
    address: bool = False
    vector: str | None = None


@dataclass(frozen=True)
class ContextArray:
    """A whole array of the per-call context (e.g. the constants `cc`).

    Example:
        >>> ContextArray("cc").name
        'cc'
    """

    name: str


@dataclass(frozen=True)
class Slot:
    """The `stride` doubles of `array` at `index` (a body's 3-vector, a body's 3 x 3 block, a
    pair's body). `vector`: NumPy's name of the whole array, when not `array`.

    Example:
        >>> Slot("e", 9, Index.BODY).stride
        9
    """

    array: str
    stride: int
    index: Index
    vector: str | None = None


@dataclass(frozen=True)
class MemberSlot:
    """The position vector of one body of member m of term `term`; `body` is the term kind's
    loop index of that body (`TermKind.indices`: "i" or "j").

    Example:
        >>> MemberSlot(0, "j").body
        'j'
    """

    term: int
    body: str


@dataclass(frozen=True)
class Element:
    """One entry of a per-body or per-pair array at `index`, `offset` entries in; read from the
    per-call context when `context`, passed by `address` when the kernel writes it.

    Example:
        >>> Element("mp", Index.BODY, offset=4, address=True).offset
        4
    """

    array: str
    index: Index
    offset: int = 0
    address: bool = False
    context: bool = False


@dataclass(frozen=True)
class Product:
    """The product of entries (e.g. a generator pair a_i c_i of a max-index M).

    Example:
        >>> len(Product((Element("sa", Index.BODY), Element("sc", Index.BODY))).factors)
        2
    """

    factors: tuple[Element, ...]


@dataclass(frozen=True)
class Shifted:
    """`array` from entry `offset` on (a second block of outputs in the same array).
    `vector`: the name NumPy's code keeps that block under, when not a slice of `array`.

    Example:
        >>> Shifted("mp", 5).offset
        5
    """

    array: str
    offset: int
    vector: str | None = None


@dataclass(frozen=True)
class BodyNumber:
    """The number (from 1) of the body of a loop over bodies, as a double.

    Example:
        >>> BodyNumber() == BodyNumber()
        True
    """


@dataclass(frozen=True)
class TermDatum:
    """Per-member datum `name` (`width` doubles per member) of term `term`, at member m.

    Example:
        >>> TermDatum(1, "k", 1).width
        1
    """

    term: int
    name: str
    width: int


@dataclass(frozen=True)
class BodyDatum:
    """Per-body array `name` of the spec's [data] (`width` doubles per body), at body `body`
    ("i" or "j", `TermKind.indices`) of member m of term `term`.

    Example:
        >>> BodyDatum(0, "c", 1, "j").body
        'j'
    """

    term: int
    name: str
    width: int
    body: str


@dataclass(frozen=True)
class InertiaDatum:
    """Per-body datum `name` of the inertia, at body i.

    Example:
        >>> InertiaDatum("r").name
        'r'
    """

    name: str


@dataclass(frozen=True)
class TermTable:
    """The member table of term `term`: its whole table, or (`row`) the row being computed.

    Example:
        >>> TermTable(0, row=True).row
        True
    """

    term: int
    row: bool = False


#: Every kind of binding a call site's argument can have.
Binding = (
    Local
    | ContextArray
    | Slot
    | MemberSlot
    | Element
    | Product
    | Shifted
    | BodyNumber
    | TermDatum
    | BodyDatum
    | InertiaDatum
    | TermTable
)
