"""C call sites: a `Call`'s typed bindings (`s2gen.bindings`) and the call itself as C text.

Input: `Call` records and the module's prefix (static tables are named after the module).
Output: the argument expressions and the call expression the templates insert.

Example:
    >>> from s2gen.bindings import Index, Slot
    >>> c_binding("pend", Slot("hb", 9, Index.BODY))
    'hb + 9 * i'
"""

from __future__ import annotations

from typing import assert_never

from s2gen.bindings import (
    Binding,
    BodyDatum,
    BodyNumber,
    ContextArray,
    Element,
    Index,
    InertiaDatum,
    Local,
    MemberSlot,
    Product,
    Shifted,
    Slot,
    TermDatum,
    TermTable,
)
from s2gen.ir import Call

__all__ = ["c_binding", "c_call"]

#: The C loop variable of each loop position (a pair's bodies are i0, j0; a member is m)
_INDEX = {
    Index.BODY: "i",
    Index.PAIR: "k",
    Index.FIRST: "i0",
    Index.SECOND: "j0",
    Index.MEMBER: "m",
    Index.ELEMENT: "e",
}


def c_binding(prefix: str, b: Binding) -> str:
    """A bound argument as C: slots are pointers into their array, context arrays are read
    through `cx`, static tables carry the module's `prefix`.

    Example:
        >>> c_binding("pend", Element("mp", Index.BODY, offset=2, address=True))
        '&mp[2 + i]'
        >>> c_binding("pend", TermDatum(0, "k", 3))
        'pend_t0_k + 3 * m'
    """
    if isinstance(b, Local):
        return f"&{b.name}" if b.address else b.name
    if isinstance(b, ContextArray):
        return f"cx->{b.name}"
    if isinstance(b, Slot):
        return f"{b.array} + {b.stride} * {_INDEX[b.index]}"
    if isinstance(b, MemberSlot):
        return f"q + 3 * {b.body}"
    if isinstance(b, Element):
        at = f"{b.offset} + {_INDEX[b.index]}" if b.offset else _INDEX[b.index]
        return f"{'&' if b.address else ''}{'cx->' if b.context else ''}{b.array}[{at}]"
    if isinstance(b, Product):
        return " * ".join(c_binding(prefix, f) for f in b.factors)
    if isinstance(b, Shifted):
        return f"{b.array} + {b.offset}"
    if isinstance(b, BodyNumber):
        return "(double)(i + 1)"
    if isinstance(b, TermDatum):
        table = f"{prefix}_t{b.term}_{b.name}"
        return f"{table}[m]" if b.width == 1 else f"{table} + {b.width} * m"
    if isinstance(b, BodyDatum):
        table = f"{prefix}_data_{b.name}"
        return f"{table}[{b.body}]" if b.width == 1 else f"{table} + {b.width} * {b.body}"
    if isinstance(b, InertiaDatum):
        return f"{prefix}_inertia_{b.name}[i]"
    if isinstance(b, TermTable):
        return "row" if b.row else "tab"
    assert_never(b)


def c_call(prefix: str, call: Call) -> str:
    """The C call expression of a call site (no semicolon): inputs, then outputs.

    Example:
        >>> from s2gen.ir import Call
        >>> c_call("pend", Call("e", "energy", (Local("q"),), (Local("e", address=True),)))
        'pend_k_energy(q, &e)'
    """
    args = ", ".join(c_binding(prefix, b) for b in (*call.inputs, *call.outputs))
    return f"{prefix}_k_{call.kernel}({args})"
