"""Generalized forces and inputs: the driven part of a system, as frozen records.

Input: nothing (this module is data). Output: `Force` (a 3-vector F_i conjugate to q_i, on
one body in the global symbols; a term over bodies in a body's own q and w with per-body
data; or a term over pairs, the forces Fi and Fj on a pair's two bodies in their qi, qj, wi,
wj and per-pair data; both terms may read the per-body arrays of the spec's [data]) and
`Inputs` (the names and default values of the caller's inputs). `System` holds them;
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
from s2gen.terms import Selection, TermData, TermKind, body_names

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
    #: A pair term's force on its second body (`expr` is then the first body's, Fi): both in
    #: the pair's qi, qj, wi, wj and data ("[[forces.pair]] #1"); None for a body's force.
    expr_j: sp.ImmutableMatrix | None = None
    #: The per-body arrays of the spec's [data] the expressions read (n entries of `width`
    #: values, body-major), under the names `body_names` gives: c in a body's force, ci and cj
    #: (the values of the pair's bodies) in a pair term.
    body_data: tuple[TermData, ...] = ()

    @property
    def kind(self) -> TermKind:
        """BODY, or PAIR for a pair term."""
        return TermKind.BODY if self.expr_j is None else TermKind.PAIR

    @property
    def selection(self) -> Selection:
        """The selection of the bodies (or pairs) the force acts on."""
        found = Selection.of(self.kind, self.select)
        if found is None:
            raise ValueError(f"{self.label}: no {self.kind.value} selection {self.select!r}")
        return found

    def member_list(self, n: int) -> list[tuple[int, ...]]:
        """The bodies or pairs (0-based, one per member) for n bodies, in loop order."""
        return self.selection.members(n, self.members)

    def data_symbols(self) -> tuple[sp.Symbol, ...]:
        return tuple(s for d in self.data for s in d.symbols())

    def body_symbols(self) -> tuple[tuple[TermData, int, tuple[sp.Symbol, ...]], ...]:
        """(per-body datum, body of the member (0 or 1), its symbols) for each name under
        which the expressions read a per-body datum.

        Example:
            >>> c = TermData("c", 1, (0.5, 2.0))
            >>> f = Force(sp.ImmutableMatrix([0, 0, 0]), "chain", expr_j=sp.ImmutableMatrix(
            ...     [0, 0, 0]), body_data=(c,))
            >>> [(r, s) for _, r, s in f.body_symbols()]
            [(0, (ci,)), (1, (cj,))]
        """
        return tuple(
            (d, r, TermData(local, d.width, ()).symbols())
            for d in self.body_data
            for r, local in enumerate(body_names(d.name, self.kind))
        )

    def instance(self, member: tuple[int, ...], index: int) -> sp.ImmutableMatrix:
        """The force on one member's body in the global symbols q{i}_{c}, w{i}_{c} (a body's
        force; a pair term's is `contributions`)."""
        return self.contributions(member, index)[0][1]

    def contributions(
        self, member: tuple[int, ...], index: int
    ) -> list[tuple[int, sp.ImmutableMatrix]]:
        """(body, force) of member number `index`: its body's force, or a pair's forces on its
        two bodies, in the global symbols (bodies 0-based).

        Example:
            >>> from s2gen.symbols import vector
            >>> c = sp.Symbol("c", real=True)
            >>> wi, wj, qi, qj = (vector(s) for s in ("wi", "wj", "qi", "qj"))
            >>> joint = Force(sp.ImmutableMatrix(c * (wj - wi).cross(qi)), "chain",
            ...               expr_j=sp.ImmutableMatrix(-c * (wj - wi).cross(qj)))
            >>> [b for b, _ in joint.contributions((0, 1), 0)]
            [0, 1]
        """
        if self.global_:
            return [(member[0], self.expr)]
        subs: dict[sp.Symbol, sp.Expr] = {}
        roles = ("q", "w") if self.expr_j is None else ("qi", "wi", "qj", "wj")
        for role in roles:
            body = member[0 if role[-1] != "j" else 1] + 1
            symbol = q_symbol if role[0] == "q" else w_symbol
            subs.update(zip(local_vector(role), (symbol(body, c) for c in range(3))))
        for d in self.data:
            vals = d.values[index * d.width : (index + 1) * d.width]
            subs.update({s: sp.Float(v) for s, v in zip(d.symbols(), vals)})
        for d, r, symbols in self.body_symbols():
            vals = d.values[member[r] * d.width : (member[r] + 1) * d.width]
            subs.update({s: sp.Float(v) for s, v in zip(symbols, vals)})
        out = [(member[0], sp.ImmutableMatrix(self.expr.xreplace(subs)))]
        if self.expr_j is not None:
            out.append((member[1], sp.ImmutableMatrix(self.expr_j.xreplace(subs))))
        return out

    def total(self, n: int) -> list[tuple[int, sp.ImmutableMatrix]]:
        """(body, force) of every member, in loop order."""
        return [c for k, m in enumerate(self.member_list(n)) for c in self.contributions(m, k)]


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
