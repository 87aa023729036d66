"""A general potential that is a long sum of pair or one-body terms gets a one-line hint, before
its (long) derivation starts, naming the structured term that would derive it once."""

from __future__ import annotations

import itertools

import pytest

import s2gen.emit
from s2gen.spec import load_spec_text
from s2gen.spec.hints import LEAST_TERMS, structure_hint, terms_by_bodies
from s2gen.symbols import q_vector
from s2gen.system import SpecWarning
from s2gen.systems import builtin, builtin_names


def _coulomb_text(n: int) -> str:
    """n charges of alternating sign, their Coulomb sum written out pair by pair in V."""
    sign = [1 if i % 2 else -1 for i in range(n)]
    pairs = itertools.combinations(range(n), 2)
    V = " + ".join(f"{sign[i] * sign[j]}/norm(q{i + 1} - q{j + 1})" for i, j in pairs)
    return f"""
name = "charges"
bodies = {n}
[parameters]
m = 1.0
[inertia]
diagonal = "m"
[potential]
V = "{V}"
"""


class _Derived(Exception):
    """Raised where the derivation would start."""


def test_a_written_out_pair_sum_is_hinted_before_the_derivation(monkeypatch) -> None:
    system = load_spec_text(_coulomb_text(11), origin="charges.toml")

    def derive(_: object) -> None:
        raise _Derived

    monkeypatch.setattr(s2gen.emit, "printed", derive)
    with pytest.warns(SpecWarning) as caught, pytest.raises(_Derived):
        s2gen.emit.emit(system, "c", cache=False)
    (warning,) = [w for w in caught if "[[potential.pair]]" in str(w.message)]
    message = str(warning.message)
    assert message.startswith("charges.toml: [potential] V is a sum of 55 terms")
    assert "55 pairs" in message and "\n" not in message


def test_counts_follow_the_bodies_each_term_reads() -> None:
    """A closed-form count: n one-body terms, n(n-1)/2 pair terms and one three-body term."""
    n = 9
    q = [q_vector(i) for i in range(1, n + 1)]
    V = sum(qi[2] for qi in q)
    V += sum(1 / (q[i] - q[j]).norm() for i, j in itertools.combinations(range(n), 2))
    V += q[0].dot(q[1].cross(q[2]))  # q1_c times a cross component: 3 terms, 3 bodies each
    counts = terms_by_bodies(V)
    assert sum(k for b, k in counts.items() if len(b) == 1) == n
    assert sum(k for b, k in counts.items() if len(b) == 2) == n * (n - 1) // 2
    assert counts[frozenset({1, 2, 3})] == 3
    assert structure_hint(V, n) is None  # 36 pair terms: below the threshold
    assert "36 terms that each couple two bodies" in str(structure_hint(V, n, least=30))
    assert "9 terms that each read one body" in str(structure_hint(sum(qi[2] for qi in q), n, 9))


def test_a_constant_factor_is_looked_through() -> None:
    q = [q_vector(i) for i in range(1, 12)]
    pairs = itertools.combinations(range(11), 2)
    V = -3 * sum((1 / (q[i] - q[j]).norm() for i, j in pairs), start=0)
    assert "55 terms" in str(structure_hint(V, 11))
    assert LEAST_TERMS == 50


@pytest.mark.parametrize("name", builtin_names())
def test_no_built_in_is_hinted(name: str) -> None:
    """The built-ins write their sums as structured terms already: no false hint."""
    system = builtin(name)
    assert structure_hint(system.potential, system.n) is None
