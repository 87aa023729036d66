"""Validation of the driven part of a system: inputs and forces.

Input: the inputs (name -> default value), the `Force`s, the number of bodies, the parameter
symbols and the location for messages. Output: the `Inputs` record, or a `SpecError`: an
input is an identifier that is not reserved and not a parameter, with a finite default; a
force is a 3-vector in the positions and angular velocities of its bodies (q1..qn and w1..wn
for a general force, the body's own q and w, its data and the per-body data it reads for a
term), time t, the inputs and the parameters, acting on bodies 1..n.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np
import sympy as sp

from s2gen.errors import SpecError, shown
from s2gen.forces import Force, Inputs
from s2gen.symbols import TIME, local_vector, q_symbol, w_symbol
from s2gen.terms import Selection
from s2gen.validate.names import _C_IDENTIFIER, _TEMPORARY, _TEMPORARY_CLASH

__all__: list[str] = []

_BODY_NAME = re.compile(r"[qw][0-9]+(_[0-9]+)?")
_RESERVED = frozenset({"t", "pi", "e1", "e2", "e3", "q", "w", "qi", "qj"})


def _check_inputs(inputs: Mapping[str, float], parameters: set[str], where: str) -> Inputs:
    """The inputs' names (identifiers, not reserved, not parameters) and finite defaults."""
    if not isinstance(inputs, Mapping):
        raise SpecError(f"{where}: [inputs]: expected a table of name = default value")
    names = tuple(inputs.keys())
    values: list[float] = []
    for name in names:
        _check_input_name(name, parameters, where)
        at = f"{where}: [inputs] {name}"
        value = inputs[name]
        if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
            raise SpecError(f"{at}: expected a number, got {shown(value)}")
        if not np.isfinite(float(value)):
            raise SpecError(f"{at}: value {float(value)} is not finite")
        values.append(float(value))
    return Inputs(names, tuple(values))


def _check_input_name(name: object, parameters: set[str], where: str) -> None:
    """An input's name: an identifier, not a parameter, not reserved (t, pi, the axes, the
    body vectors and a term's own vectors) and not a temporary's name."""
    if not isinstance(name, str) or not _C_IDENTIFIER.fullmatch(name):
        raise SpecError(f"{where}: [inputs]: {shown(name)} is not an identifier")
    at = f"{where}: [inputs] {name}"
    if name in parameters:
        raise SpecError(f"{at}: the input {shown(name)} clashes with the parameter {name}")
    from s2gen.spec.names import RESERVED_NAMES  # the spec package imports this module

    if name in _RESERVED or name in RESERVED_NAMES or _BODY_NAME.fullmatch(name):
        raise SpecError(f"{at}: the name {shown(name)} is reserved")
    if _TEMPORARY.fullmatch(name):
        raise SpecError(f"{at}: the name {shown(name)} {_TEMPORARY_CLASH}")


def _validate_force(force: Force, n: int, allowed: set[sp.Symbol], where: str) -> None:
    """A force: a 3-vector in the symbols its kind may use, on bodies 1..n (`allowed` holds
    the parameters, the inputs and time)."""
    at = f"{where}: {force.label}"
    expr = force.expr
    if not isinstance(expr, sp.MatrixBase) or expr.shape != (3, 1):
        shape = expr.shape if isinstance(expr, sp.MatrixBase) else "a scalar"
        raise SpecError(f"{at}: a force is a 3-vector (3x1), got {shape}")
    if force.expr_j is not None:
        expr = sp.ImmutableMatrix.vstack(expr, force.expr_j)
        if force.expr_j.shape != (3, 1):
            raise SpecError(f"{at}: a force is a 3-vector (3x1), got {force.expr_j.shape}")
    if any(e.has(sp.Derivative, sp.Integral) for e in expr):
        raise SpecError(f"{at}: must not contain derivatives or integrals")
    selection = Selection.of(force.kind, force.select)
    if selection is None or not selection.fixed:
        raise SpecError(f"{at}: unknown {force.kind.value} selection {shown(force.select)}")
    arity = force.kind.arity
    for k, member in enumerate(force.members):
        if len(member) != arity or not all(0 <= b < n for b in member):
            raise SpecError(f"{at}: member {k + 1} {shown(member)} is not of bodies 1..{n}")
    if force.global_ and (force.select != "list" or len(force.members) != 1):
        raise SpecError(f"{at}: a general force acts on exactly one listed body")
    if force.global_:
        own = {
            s for i in range(1, n + 1) for c in range(3) for s in (q_symbol(i, c), w_symbol(i, c))
        }
        kinds = f"q1..q{n}, w1..w{n}"
    else:
        roles = ("q", "w") if force.expr_j is None else ("qi", "qj", "wi", "wj")
        own = {s for role in roles for s in local_vector(role)} | set(force.data_symbols())
        own |= {s for _, _, symbols in force.body_symbols() for s in symbols}
        kinds = (
            "the body's q and w, its data"
            if force.expr_j is None
            else "the pair's qi, qj, wi, wj, its data"
        )
        for d in force.data:
            count = len(force.member_list(n))
            if len(d.values) != d.width * count or not np.all(np.isfinite(d.values)):
                raise SpecError(
                    f"{at}: data '{d.name}' needs {count} finite value(s) per {force.kind.value}"
                )
        for d in force.body_data:
            if len(d.values) != d.width * n or not np.all(np.isfinite(d.values)):
                raise SpecError(f"{at}: the [data] array '{d.name}' needs {n} finite entries")
    extra = set().union(*(e.free_symbols for e in expr)) - own - allowed
    if extra:
        bad = ", ".join(sorted(str(s) for s in extra))
        raise SpecError(
            f"{at}: depends on {bad}, which is not one of {kinds}, t, an input or a parameter"
        )


def _driven_symbols(psyms: set[sp.Symbol], inputs: Inputs) -> set[sp.Symbol]:
    """What a potential or force may hold besides positions: parameters, inputs and time."""
    return {*psyms, *inputs.symbols, TIME}
