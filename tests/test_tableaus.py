"""The Runge-Kutta tableaus of s2gen.tableaus, against Butcher's order conditions.

Every fixed-step tableau satisfies, in exact rational arithmetic, every order condition up to
its stated order and fails one of the next order; Dormand-Prince 5(4)'s solution has order 5,
its embedded solution (solution minus the error weights) order 4, and its continuous extension
gives the solution's weights at sigma = 1. The rooted trees are those of tests/test_dop853.py.
"""

from __future__ import annotations

from fractions import Fraction

import pytest
from test_dop853 import Tree, _density, trees

from s2gen.ir import ModuleKind
from s2gen.methods import KINDS, METHODS
from s2gen.tableaus import DOPRI5, EXPLICIT, Explicit


def _weights(t: Tree, a: tuple[tuple[Fraction, ...], ...]) -> list[Fraction]:
    """Per stage, the elementary weight of t, exactly."""
    out = [Fraction(1)] * len(a)
    for c in t:
        inner = _weights(c, a)
        out = [
            o * sum((x * inner[j] for j, x in enumerate(row)), Fraction(0))
            for o, row in zip(out, a)
        ]
    return out


def _orders_met(
    b: tuple[Fraction, ...], a: tuple[tuple[Fraction, ...], ...], upto: int
) -> list[int]:
    """The orders p <= upto whose every condition b . Phi(t) = 1 / gamma(t) holds exactly."""
    return [
        p
        for p in range(1, upto + 1)
        if all(
            sum((bi * w for bi, w in zip(b, _weights(t, a))), Fraction(0))
            == Fraction(1, _density(t))
            for t in trees(p)
        )
    ]


@pytest.mark.parametrize("tableau", EXPLICIT, ids=lambda t: t.name)
def test_explicit_tableau_has_its_order_and_not_one_more(tableau: Explicit) -> None:
    met = _orders_met(tableau.b, tableau.a, tableau.order + 1)
    assert met == list(range(1, tableau.order + 1)), met


def test_every_fixed_step_method_has_a_listed_tableau_of_its_order() -> None:
    fixed = [m for m in METHODS if m.tableau is not None]
    assert fixed and all(m.tableau in EXPLICIT for m in fixed)
    assert all(
        m.order == m.tableau.order and m.evals == m.tableau.stages for m in fixed if m.tableau
    )


def test_dormand_prince_orders_and_continuous_extension() -> None:
    a = DOPRI5.a
    b = (*a[-1], Fraction(0))  # the FSAL stage has weight 0
    embedded = tuple(bi - ei for bi, ei in zip(b, DOPRI5.e))
    assert _orders_met(b, a, 6) == [1, 2, 3, 4, 5]
    assert _orders_met(embedded, a, 5) == [1, 2, 3, 4]
    assert tuple(sum(row, Fraction(0)) for row in DOPRI5.dense) == b


def test_the_methods_module_kinds_are_the_ir_module_kinds() -> None:
    assert KINDS == tuple(k.value for k in ModuleKind)
    assert {k for m in METHODS for k in m.kinds} == set(KINDS)


def test_a_tableau_whose_nodes_are_not_its_row_sums_is_refused() -> None:
    with pytest.raises(ValueError, match="row sums"):
        Explicit(
            "bad",
            2,
            "bad",
            ((), (Fraction(1, 2),)),
            (Fraction(0), Fraction(1)),
            (Fraction(0), Fraction(1)),
        )
