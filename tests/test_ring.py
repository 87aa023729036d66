"""The pair selection "ring": the chain closed by the pair (n, 1).

A ring of coupled pendula written with pairs = "ring" must be the same system as the one
written with the explicit list of its pairs: the emitted C, the emitted NumPy and the reference
agree on both, and the VI conserves the energy. The ring carries per-pair data, and one of its
terms is quadratic (assembled into the matrix K: with four bodies, K costs less than the
term's gathered loop) while the other keeps its member loop, so both ways of visiting the
ring's members run.
"""

from __future__ import annotations

import numpy as np
import pytest

from s2gen.passes import lower_system
from s2gen.runtime import simulate
from s2gen.spec import load_spec_text
from s2gen.system import SpecError, System

N = 4
SPRINGS = [1.0, 1.5, 2.0, 2.5]  # one per pair, in the order (1,2), (2,3), (3,4), (4,1)


def ring_spec(name: str, pairs: str, n: int = N, springs: list[float] | None = None) -> str:
    springs = SPRINGS if springs is None else springs
    rng = np.random.default_rng(11)
    q = np.array([0.0, 0.0, -1.0]) + 0.3 * rng.normal(size=(n, 3))
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = rng.normal(size=(n, 3))
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    rows = ", ".join(f"[{', '.join(repr(float(x)) for x in v)}]" for v in q)
    omegas = ", ".join(f"[{', '.join(repr(float(x)) for x in v)}]" for v in w)
    return f"""
name = "{name}"
bodies = {n}
[parameters]
m = 1.0
g = 9.81
kappa = 0.7
[inertia]
diagonal = "m"
[[potential.body]]
V = "m*g*dot(e3, q)"
[[potential.pair]]
V = "k/2*dot(qi - qj, qi - qj)"
pairs = {pairs}
[potential.pair.data]
k = {springs}
[[potential.pair]]
V = "kappa*(1 - dot(qi, qj))**2"
pairs = {pairs}
[initial]
q = [{rows}]
omega = [{omegas}]
"""


LISTED = "[" + ", ".join(f"[{i + 1}, {(i + 1) % N + 1}]" for i in range(N)) + "]"


@pytest.fixture(scope="module")
def systems() -> tuple[System, System]:
    return load_spec_text(ring_spec("ring4", '"ring"')), load_spec_text(
        ring_spec("ringlist4", LISTED)
    )


def test_the_ring_is_the_chain_closed_by_the_pair_n_1(systems: tuple[System, System]) -> None:
    ring, listed = systems
    expected = [(i, (i + 1) % N) for i in range(N)]
    assert [t.member_list(N) for t in ring.terms[1:]] == [expected, expected]
    assert [t.member_list(N) for t in listed.terms[1:]] == [expected, expected]
    module = lower_system(ring)
    assert [bool(t.quadratic) for t in module.terms] == [False, True, False]


@pytest.mark.parametrize("method", ["vi", "rk4"])
def test_ring_and_listed_pairs_agree_on_every_backend(
    systems: tuple[System, System], method: str
) -> None:
    ring, listed = systems
    truth = simulate(listed, method, "reference", h=0.002, T=1.0)
    for system in (ring, listed):
        for backend in ("c", "numpy", "reference"):
            run = simulate(system, method, backend, h=0.002, T=1.0)
            assert np.max(np.abs(run.q - truth.q)) < 1e-10, (system.name, backend)
            assert np.max(np.abs(run.energy - truth.energy)) < 1e-9, (system.name, backend)
    # the closing pair (4, 1) matters: the chain alone moves differently
    chain = load_spec_text(ring_spec("chain4", '"chain"', springs=SPRINGS[:-1]))
    other = simulate(chain, method, "reference", h=0.002, T=1.0)
    assert np.max(np.abs(other.q - truth.q)) > 1e-3


def test_the_vi_conserves_the_ring_s_energy(systems: tuple[System, System]) -> None:
    ring, _ = systems
    drifts = []
    for h in (0.004, 0.002):
        run = simulate(ring, "vi", "c", h=h, T=4.0)
        drifts.append(np.max(np.abs(run.energy - run.energy[0])) / abs(run.energy[0]))
    assert drifts[1] < 1e-3
    assert 3.0 < drifts[0] / drifts[1] < 5.0  # second order: the error falls as h^2


def test_a_ring_needs_three_bodies_and_one_datum_per_pair() -> None:
    with pytest.raises(SpecError, match="needs at least 3 bodies"):
        load_spec_text(ring_spec("ring2", '"ring"', n=2, springs=[1.0, 2.0]))
    with pytest.raises(SpecError, match="one per pair of the ring"):
        load_spec_text(ring_spec("ring4bad", '"ring"', springs=SPRINGS[:-1]))
