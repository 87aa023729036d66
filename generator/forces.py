"""Generalized forces and inputs: the driven part of a system, as frozen records.

Input: nothing (this module is data). Output: `Force` (a 3-vector F_i conjugate to q_i, on
one body in the global symbols, or a term over bodies in a body's own q and w with per-body
data) and `Inputs` (the names and default values of the caller's inputs). `System` holds them;
the spec (`s2gen.spec.forces`) builds them; `System.force_vectors` sums them per body.

A force F_i acts through its virtual work F_i . delta q_i (only its part orthogonal to q_i
acts); it may depend on the positions q, the angular velocities w, time t, the inputs and the
parameters. Inputs are scalars held over each step (zero-order hold) whose values the caller
gives; their defaults are the values used when none are given.

Example:
    >>> import sympy as sp
    >>> from s2gen.symbols import vector
    >>> c = sp.Symbol("c", real=True)
    >>> damping = Force(sp.ImmutableMatrix(-c * vector("w").cross(vector("q"))), "all")
    >>> damping.member_list(2), damping.instance((1,), 1)[2]
    ([(0,), (1,)], -c*(-q2_0*w2_1 + q2_1*w2_0))
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from s2gen.symbols import local_vector, q_symbol, w_symbol
from s2gen.terms import Selection, TermData, TermKind

__all__ = ["Force", "Inputs"]


@dataclass(frozen=True)
class Force:
    """One force of the spec: a general force on one body or a term over bodies.

    `global_` True: `expr` is the 3-vector F of the single listed body, in the global symbols
    q1..qn, w1..wn ("[forces] F2"). False: `expr` is in the body's own q and w (symbols
    `local_vector("q")`, `local_vector("w")`) and per-body `data`, applied to each member of
    the selection ("all", or "list" with `members`, 0-based) ("[[forces.body]] #1").
    """

    expr: sp.ImmutableMatrix
    select: str = "all"
    members: tuple[tuple[int, ...], ...] = ()
    data: tuple[TermData, ...] = ()
    label: str = "force"
    global_: bool = False

    @property
    def selection(self) -> Selection:
        """The selection of the bodies the force acts on."""
        found = Selection.of(TermKind.BODY, self.select)
        if found is None:
            raise ValueError(f"{self.label}: no body selection {self.select!r}")
        return found

    def member_list(self, n: int) -> list[tuple[int, ...]]:
        """The bodies (0-based, one per member) for n bodies, in loop order."""
        return self.selection.members(n, self.members)

    def data_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(s for d in self.data for s in d.symbols())

    def instance(self, member: tuple[int, ...], index: int) -> sp.ImmutableMatrix:
        """The force on one member's body in the global symbols q{i}_{c}, w{i}_{c}."""
        if self.global_:
            return self.expr
        body = member[0] + 1
        subs: dict[sp.Symbol, sp.Expr] = {}
        subs.update(zip(local_vector("q"), (q_symbol(body, c) for c in range(3))))
        subs.update(zip(local_vector("w"), (w_symbol(body, c) for c in range(3))))
        for d in self.data:
            vals = d.values[index * d.width : (index + 1) * d.width]
            subs.update({s: sp.Float(v) for s, v in zip(d.symbols(), vals)})
        return sp.ImmutableMatrix(self.expr.xreplace(subs))


@dataclass(frozen=True)
class Inputs:
    """The caller's inputs: names (in the order of the emitted `u[]` array) and defaults.

    Example:
        >>> Inputs(("a", "b"), (0.0, 1.5)).defaults
        {'a': 0.0, 'b': 1.5}
    """

    names: tuple[str, ...] = ()
    values: tuple[float, ...] = ()

    @property
    def symbols(self) -> tuple[sp.Symbol, ...]:
        """The inputs' real symbols, in order."""
        return tuple(sp.Symbol(u, real=True) for u in self.names)

    @property
    def defaults(self) -> dict[str, float]:
        """Default values by name."""
        return dict(zip(self.names, self.values))
