"""Call sites carry typed bindings, and the printers render them consistently.

(a) The IR holds no C or NumPy text: every field of every binding of every call site of every
    module kind is an identifier, a number, a flag, a loop position or another binding.
(b) Every kind of binding occurs in some module, so every branch of both printers is used.
(c) C and NumPy address the same doubles: a C slot (`x + 3 * i0`, pointer arithmetic from
    the array's start) and the NumPy expression for the same binding (`x[PAIR_I]`, rows of
    the (n, 3) array) are evaluated on concrete index values and must agree, member by member.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import typing
from pathlib import Path

import numpy as np
import pytest

from s2gen.bindings import Binding, BodyDatum, Index, MemberSlot, Slot
from s2gen.equations.angles import derive_angles
from s2gen.ir import Module
from s2gen.passes import lower_angles, lower_system
from s2gen.printing.c_calls import c_binding
from s2gen.printing.numpy import py_binding
from s2gen.spec import load_spec_text
from s2gen.systems import builtin

#: Module kinds: dense, max-index (one kernel, from the matrix, per body with data),
#: quadratic, cutoff, rows, per-body data ([data]) in a member loop and a cutoff
CASES = (
    "double_pendulum",
    "elastic_rod",
    "chain4",
    "rope",
    "dipoles",
    "lj_cutoff",
    "pendulum_chain",
    "species",
)
SPECIES = """\
name = "species"
bodies = 5
[parameters]
k = 1.0
[inertia]
diagonal = ["1", "1", "1", "1", "1"]
[data]
c = [1, 2, 1, 2, 1]
r = [[0, 0, 1], [0, 1, 0], [1, 0, 0], [0, 0, 1], [0, 1, 0]]
[potential]
[[potential.body]]
V = "c*dot(r, q)"
[[potential.pair]]
V = "k*ci*cj/norm(qi - qj) + dot(ri, qj)"
pairs = [[1, 2], [3, 4], [2, 5], [4, 5]]
[[potential.pair]]
V = "ci*cj/dot(qi - qj, qi - qj)"
pairs = "all"
cutoff = 0.5
"""
STRUCTURED = '[inertia]\nsolver = "structured"\n'

KINDS = typing.get_args(Binding)


@functools.cache
def module(name: str) -> Module:
    if name == "angles":
        return lower_angles(derive_angles(builtin("double_pendulum"), False))
    if name == "chain4":  # a max-index M's generators from one system kernel
        text = (Path(__file__).parent / "specs" / "chain4.toml").read_text()
        return lower_system(load_spec_text(text.replace("[inertia]\n", STRUCTURED)))
    if name == "species":
        return lower_system(load_spec_text(SPECIES))
    return lower_system(builtin(name))


def _bindings(m: Module) -> list[Binding]:
    return [b for call in m.calls for b in (*call.inputs, *call.outputs)]


def _plain(value: object) -> bool:
    """An identifier, a number, a flag, a loop position, nothing, or a binding of those."""
    if isinstance(value, str):
        return value.isidentifier()
    if isinstance(value, (bool, int, enum.Enum)) or value is None:
        return True
    if isinstance(value, tuple):
        return all(_plain(v) for v in value)
    if isinstance(value, KINDS):
        return all(_plain(getattr(value, f.name)) for f in dataclasses.fields(value))
    return False


@pytest.mark.parametrize("name", [*CASES, "angles"])
def test_bindings_carry_no_language_text(name: str) -> None:
    m = module(name)
    assert m.calls
    for call in m.calls:
        for b in (*call.inputs, *call.outputs):
            assert isinstance(b, KINDS), (call.site, b)
            assert _plain(b), (call.site, b)


def test_every_kind_of_binding_is_used() -> None:
    used = {type(b) for name in (*CASES, "angles") for b in _bindings(module(name))}
    assert used == set(KINDS), set(KINDS) - used


#: Concrete loop positions: member k of a pair loop is (PAIR_I[k], PAIR_J[k]); a term's
#: member k is (T<t>_I[k], T<t>_J[k]).
FIRST, SECOND = np.array([0, 2, 1, 3]), np.array([1, 3, 4, 4])
N = 5


def _agree(c_text: str, py_text: str, array: str, stride: int) -> None:
    """The C pointer offset and the first double of the NumPy row are the same entry."""
    whole = np.arange(N * stride).reshape(N, stride)
    names = {"PAIR_I": FIRST, "PAIR_J": SECOND}
    names |= {f"T{t}_{x}": a for t in range(4) for x, a in (("I", FIRST), ("J", SECOND))}
    rows = eval(py_text, {array: whole, **names})
    for k in range(len(FIRST)):
        position = {v: int(a[k]) for v, a in (("i0", FIRST), ("j0", SECOND))}
        position |= {"i": int(FIRST[k]), "j": int(SECOND[k])}
        offset = eval(c_text, {array: 0, **position})
        assert offset == rows[k][0], (c_text, py_text, k)


@pytest.mark.parametrize("name", CASES)
def test_c_and_numpy_address_the_same_slot(name: str) -> None:
    checked = 0
    for b in _bindings(module(name)):
        if isinstance(b, Slot) and b.index in (Index.FIRST, Index.SECOND):
            _agree(c_binding("x", b), py_binding(b), b.array, b.stride)
            checked += 1
        elif isinstance(b, MemberSlot):
            _agree(c_binding("x", b), py_binding(b), "q", 3)
            checked += 1
        elif isinstance(b, BodyDatum) and b.width == 3:  # a pointer to the body's 3-vector
            _agree(
                c_binding("x", b).removeprefix("x_data_"),
                py_binding(b).removeprefix("DATA_"),
                b.name,
                3,
            )
            checked += 1
        elif isinstance(b, BodyDatum):  # one double: C's index is NumPy's row
            c_text, py_text = c_binding("x", b), py_binding(b)
            _agree(
                c_text.replace(f"x_data_{b.name}[", "(").replace("]", ")"),
                py_text.removeprefix("DATA_"),
                b.name,
                1,
            )
            checked += 1
    assert checked or name in ("elastic_rod", "chain4", "rope"), name
