"""Pair terms with a cutoff: the emitted cell list, its all-pairs fallback, NumPy's k-d tree
and the reference's plain distance test find the same pairs and give the same gradient."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from s2gen.passes import lower_system
from s2gen.runtime import get_backend, simulate
from s2gen.spec import define_system
from s2gen.symbols import local_vector
from s2gen.system import SpecError, System, Term


def fibonacci_sphere(n: int) -> np.ndarray:
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5**0.5) * k
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def lj_system(n: int, cutoff: float | None, name: str = "ljcut") -> System:
    qi, qj = sp.Matrix(local_vector("qi")), sp.Matrix(local_vector("qj"))
    eps, sig, m = sp.symbols("eps sigma m", real=True)
    r2 = (qi - qj).dot(qi - qj)
    V = 4 * eps * ((sig**2 / r2) ** 6 - (sig**2 / r2) ** 3)
    q0 = fibonacci_sphere(n)
    sigma = np.sqrt(4 * np.pi / n) * 1.07 / 2 ** (1 / 6)
    w0 = 0.3 * (np.array([0.0, 0.0, 1.0]) - q0[:, 2:3] * q0)
    return System.create(
        name=name,
        n=n,
        parameters={"m": 1.0, "eps": 0.01, "sigma": sigma},
        inertia=sp.ImmutableSparseMatrix(n, n, {(i, i): m for i in range(n)}),
        potential=sp.Integer(0),
        terms=[Term("pair", V, "all", label="LJ", cutoff=cutoff)],
        q0=q0,
        omega0=w0,
    )


def test_cell_list_matches_all_pairs_test_and_peers() -> None:
    n = 300
    sigma = np.sqrt(4 * np.pi / n) * 1.07 / 2 ** (1 / 6)
    s = lj_system(n, 2.5 * sigma)
    p = np.array(s.parameter_values)
    rng = np.random.default_rng(2)
    q = s.q0 + 0.02 * rng.normal(size=s.q0.shape)
    q /= np.linalg.norm(q, axis=1)[:, None]
    c = get_backend(s, "c")
    g_fallback = c.gradient(q, p)  # public gradient: all pairs with the distance test
    _, dw = c.rhs(q, np.zeros_like(q), p)  # rhs runs with workspace: the cell list
    g_numpy = get_backend(s, "numpy").gradient(q, p)  # scipy's k-d tree
    g_ref = get_backend(s, "reference")._problem(p).grad(q)  # plain distance test
    scale = np.max(np.abs(g_ref))
    assert np.max(np.abs(g_numpy - g_ref)) < 1e-12 * scale
    assert np.max(np.abs(g_fallback - g_ref)) < 1e-12 * scale
    # diagonal M = 1: omegadot = -q x g
    assert np.max(np.abs(dw + np.cross(q, g_ref))) < 1e-12 * scale


def test_cutoff_beyond_the_sphere_equals_all_pairs() -> None:
    a = simulate(lj_system(80, None, "ljall"), "vi", "c", h=0.005, T=0.5)
    b = simulate(lj_system(80, 2.5, "ljwide"), "vi", "c", h=0.005, T=0.5)
    assert np.max(np.abs(a.q - b.q)) < 1e-12
    assert np.max(np.abs(a.energy - b.energy)) < 1e-12 * abs(a.energy[0])


@pytest.mark.parametrize("method", ["vi", "rk4"])
def test_cutoff_system_backends_agree(method: str) -> None:
    n = 200
    sigma = np.sqrt(4 * np.pi / n) * 1.07 / 2 ** (1 / 6)
    s = lj_system(n, 2.5 * sigma)
    runs = {b: simulate(s, method, b, h=0.005, T=0.5) for b in ("c", "numpy", "reference")}
    for b in ("c", "numpy"):
        assert np.max(np.abs(runs[b].q - runs["reference"].q)) < 1e-10, b


def _two_species(V: str, n: int = 150) -> System:
    """n bodies on a Fibonacci sphere, two species (size s, strength c) per body, one pair
    term `V` over the pairs closer than 0.45 (a grid of 4 cells per axis)."""
    q0 = fibonacci_sphere(n)
    species = np.arange(n) % 3 == 0
    return define_system(
        name="species",
        bodies=n,
        parameters={"m": 1.0},
        diagonal="m",
        data={
            "s": np.where(species, 0.16, 0.11).tolist(),
            "c": np.where(species, 2.0, 0.5).tolist(),
        },
        pair_terms=[{"V": V, "pairs": "all", "cutoff": 0.45}],
        initial_q=q0,
        initial_omega=0.4 * np.cross(q0, [0.3, 0.0, 1.0]),
    )


@pytest.mark.parametrize(
    "V, symmetric",
    [
        ("sqrt(ci*cj)*((si + sj)**2/(4*dot(qi - qj, qi - qj)))**3", True),
        ("ci*(si**2/dot(qi - qj, qi - qj))**3 + cj*dot(qi, e3)*sj", False),
    ],
    ids=["symmetric", "lopsided"],
)
def test_sorted_cells_only_for_symmetric_terms_and_both_agree(V: str, symmetric: bool) -> None:
    """A term symmetric in its two bodies gets the sorted cells (each pair met in whichever
    order the cells meet it); one that is not keeps the linked list (pairs as i < j). Both
    give the reference's gradient and trajectory."""
    s = _two_species(V)
    assert [t.sorted_cells for t in lower_system(s).terms] == [symmetric]
    p = np.array(s.parameter_values)
    rng = np.random.default_rng(4)
    q = s.q0 + 0.03 * rng.normal(size=s.q0.shape)
    q /= np.linalg.norm(q, axis=1)[:, None]
    g_ref = get_backend(s, "reference")._problem(p).grad(q)
    _, dw = get_backend(s, "c").rhs(q, np.zeros_like(q), p)  # with workspace: the cells
    scale = np.max(np.abs(g_ref))
    assert np.max(np.abs(dw + np.cross(q, g_ref))) < 1e-12 * scale
    truth = simulate(s, "vi", "reference", h=0.002, T=0.2, energy=False)
    run = simulate(s, "vi", "c", h=0.002, T=0.2, energy=False)
    assert np.max(np.abs(truth.q[-1] - s.q0)) > 1e-2
    assert np.max(np.abs(run.q - truth.q)) < 1e-11


@pytest.mark.parametrize(
    "V, symmetric",
    [
        ("exp(-dot(qi - qj, qi - qj))*(ci + cj)*cos(si*sj)", True),
        ("(si*cj + sj*ci)/norm(qi - qj)", True),
        ("(1 + 1e-12*qi[2])*ci*cj/dot(qi - qj, qi - qj)", False),
        ("si/norm(qi - qj) + sj/dot(qi - qj, qi - qj)", False),
    ],
)
def test_symmetry_is_told_apart(V: str, symmetric: bool) -> None:
    """Only a term that is symmetric in its two bodies is laid out on sorted cells, however
    small its asymmetric part."""
    assert [t.sorted_cells for t in lower_system(_two_species(V, n=20)).terms] == [symmetric]


def test_cutoff_only_on_all_pairs() -> None:
    qi = sp.Matrix(local_vector("qi"))
    with pytest.raises(SpecError, match="cutoff applies only"):
        System.create(
            name="bad",
            n=3,
            parameters={},
            inertia=sp.eye(3),
            potential=sp.Integer(0),
            terms=[Term("pair", qi[0], "chain", cutoff=0.1)],
        )


def test_cutoff_from_toml(tmp_path) -> None:
    from s2gen.spec import load_spec_text

    base = """
name = "c3"
bodies = 3
[parameters]
m = 1.0
[inertia]
diagonal = ["m", "m", "m"]
[[potential.pair]]
V = "dot(qi, qj)"
pairs = "{pairs}"
cutoff = {cutoff}
"""
    s = load_spec_text(base.format(pairs="all", cutoff="0.5"), origin="c3.toml")
    assert s.terms[0].cutoff == 0.5
    with pytest.raises(SpecError, match="cutoff"):
        load_spec_text(base.format(pairs="chain", cutoff="0.5"), origin="c3.toml")
    with pytest.raises(SpecError, match="cutoff"):
        load_spec_text(base.format(pairs="all", cutoff="-1"), origin="c3.toml")
