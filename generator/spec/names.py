"""The names of the spec's expression language: what each name means in one parse.

Input: the number of bodies, the declared parameter names, whether vectors are allowed, a
term's local names (with their widths) and whether angular velocities may appear (forces).
Output: a `_Names` table (pi, the parameters, time t, the axes e1..e3, the global body vectors
q1..qn (and w1..wn in a force) or a term's own vectors and data) that looks a name up or
explains why it means nothing there; the fixed tables `RESERVED_NAMES` (pi, the functions,
e1..e3), the patterns of q1.. and w1.. names and the term roles q, qi, qj (from
`s2gen.terms`). Time t exists wherever vectors do (potentials and forces), never in the
inertia or the initial values; a parameter or datum named t (older specs) hides it.

Example:
    >>> sorted(RESERVED_NAMES)[:4]
    ['Abs', 'cos', 'cross', 'dot']
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TypeAlias

import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.symbols import TIME, local_vector, q_vector, w_vector
from s2gen.terms import TermKind

__all__ = ["RESERVED_NAMES", "Value"]

_SCALAR_FUNCTIONS: dict[str, Callable[[sp.Expr], sp.Expr]] = {
    "sqrt": sp.sqrt,
    "exp": sp.exp,
    "log": sp.log,
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "Abs": sp.Abs,
}
_VECTOR_FUNCTIONS = {"dot": 2, "cross": 2, "norm": 1}
_AXES = {f"e{k + 1}": sp.ImmutableMatrix([int(k == c) for c in range(3)]) for k in range(3)}
#: Names the expression language gives a meaning; parameters may not use them.
RESERVED_NAMES = frozenset({"pi", *_SCALAR_FUNCTIONS, *_VECTOR_FUNCTIONS, *_AXES})
_Q_NAME = re.compile(r"q([0-9]+)")
_W_NAME = re.compile(r"w([0-9]+)")
#: Names of body vectors and their components (q1, q2_0, w1, w3_2): never a parameter or datum.
_Q_RESERVED = re.compile(r"[qw][0-9]+(_[0-9]+)?")
#: The own vectors of term expressions: q (one-body terms), qi and qj (pair terms).
_ROLES = tuple(role for kind in TermKind for role in kind.roles)

#: A parsed value: a scalar SymPy expression or a 3x1 vector.
Value: TypeAlias = "sp.Expr | sp.ImmutableMatrix"


@dataclass(frozen=True)
class _Names:
    """The name table of one parse: what each name means, and why a missing one is missing.

    `fixed` holds pi, the parameters, the axes and a term's local names; the global body
    vectors q1..q{bodies} are resolved on demand (a long chain need not build n matrices).
    """

    fixed: Mapping[str, Value]
    bodies: int  # q1..q{bodies} are the global body vectors (0 inside a term or without vectors)
    n: int  # the number of bodies, for messages
    roles: tuple[str, ...]  # a term's own vectors (q, or qi and qj); empty outside a term
    term: bool
    allow_vectors: bool
    velocities: bool = False  # w1..w{bodies} (a general force) or a force term's own w

    def lookup(self, name: str) -> Value | None:
        """The value of `name`, or None when it means nothing here."""
        if name in self.fixed:
            return self.fixed[name]
        match = _Q_NAME.fullmatch(name)
        if match and not name.startswith("q0") and 1 <= int(match.group(1)) <= self.bodies:
            return sp.ImmutableMatrix(q_vector(int(match.group(1))))
        match = _W_NAME.fullmatch(name)
        velocity = match and self.velocities and not name.startswith("w0")
        if velocity and match and 1 <= int(match.group(1)) <= self.bodies:
            return sp.ImmutableMatrix(w_vector(int(match.group(1))))
        return None

    def explain(self, name: str) -> str:
        """Why `name` means nothing here (the message of the error)."""
        global_q = _Q_NAME.fullmatch(name) is not None
        global_w = _W_NAME.fullmatch(name) is not None
        if not self.allow_vectors and (global_q or global_w or name in (*_AXES, *_ROLES, "t")):
            return f"{shown(name)} is not allowed here (only numbers and parameters)"
        if (global_w or name == "w") and not self.velocities:
            return (
                f"the angular velocity {shown(name)} is not allowed here (velocities may appear "
                "only in forces: [forces] F1.., and w in [[forces.body]])"
            )
        own = " and ".join(self.roles)
        if (global_q or global_w) and self.term:
            what = "position" if global_q else "angular velocity"
            return (
                f"the global {what} {shown(name)} is not allowed in a term expression "
                f"(a term sees only its own vectors, here {own})"
            )
        if global_q or global_w:
            first = name[0]
            return f"no body {shown(name)}: the bodies are {first}1..{first}{self.n}"
        if name in _ROLES and self.term:
            return f"unknown name {shown(name)} (this term's own vectors are {own})"
        if name in _ROLES:
            return (
                f"unknown name {shown(name)} (q, qi and qj exist only in term expressions: "
                "[[potential.body]] has q, [[potential.pair]] has qi and qj)"
            )
        return f"unknown name {shown(name)}"


def _name_table(
    n: int,
    parameters: Sequence[str],
    allow_vectors: bool,
    local: Mapping[str, int] | None,
    where: str,
    velocities: bool = False,
) -> _Names:
    """The names a parse may use: pi, parameters, time and axes, then q1..qn (and w1..wn with
    `velocities`) or a term's local names."""
    fixed: dict[str, Value] = {"pi": sp.pi}
    fixed.update({p: sp.Symbol(p, real=True) for p in parameters})
    if allow_vectors:
        fixed.update(_AXES)
    for name, width in (local or {}).items():
        if name in fixed or name in RESERVED_NAMES or _Q_RESERVED.fullmatch(name):
            what = "a parameter" if name in parameters else "reserved"
            raise SpecError(
                f"{where}: local name {shown(name)} clashes with {what} name {shown(name)}"
            )
        if width not in (1, 3):
            raise SpecError(f"{where}: local name {shown(name)} has width {width}, not 1 or 3")
        if width == 1:
            fixed[name] = sp.Symbol(name, real=True)
        elif allow_vectors:
            fixed[name] = sp.ImmutableMatrix(local_vector(name))
    roles = tuple(r for r in _ROLES if local and local.get(r) == 3)
    bodies = n if allow_vectors and local is None else 0
    if allow_vectors:
        fixed.setdefault("t", TIME)  # a parameter or datum named t hides time
    own_w = bool(local) and local is not None and local.get("w") == 3
    roles = roles + (("w",) if own_w else ())
    return _Names(fixed, bodies, n, roles, local is not None, allow_vectors, velocities or own_w)
