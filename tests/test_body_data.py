"""Per-body data ([data]): a term reads a body's entry as c (body terms) or ci and cj (pair
terms) for every selection. The same system written with per-pair data (one value per listed
pair, computed here from the per-body arrays) runs the same trajectory in C, NumPy and the
reference; a cutoff mixture of two species agrees between the three backends; the inertia reads
[data] as it reads [inertia.data]; a million values load without SymPy per number."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import pytest

from s2gen.passes import lower_system
from s2gen.runtime import get_backend, simulate
from s2gen.spec import define_system, load_spec_text
from s2gen.symbols import q_symbol

N = 6
RNG = np.random.default_rng(7)
CHARGE = [1.0, -0.5, 0.8, -1.2, 0.6, -0.9]
OFFSET = RNG.normal(scale=0.1, size=(N, 3)).round(6).tolist()
Q0 = RNG.normal(size=(N, 3))
Q0 /= np.linalg.norm(Q0, axis=1)[:, None]
W0 = np.cross(Q0, RNG.normal(scale=0.5, size=(N, 3)))
PAIR_V = "k*ci*cj/norm(qi - qj + e1/10) + dot(qi, oi - oj)"
PER_PAIR_V = "k*cc/norm(qi - qj + e1/10) + dot(qi, d)"
BODY_V = "-c*g*q[2] + dot(o, q)"


def _system(pairs: Any, per_body: bool, name: str) -> Any:
    """The test system over `pairs` ("chain", "all" or a list), its data per body or, for a
    listed selection, per pair (the pair products and offset differences written out)."""
    common: dict[str, Any] = {
        "bodies": N,
        "parameters": {"k": 0.3, "g": 1.0},
        "diagonal": "1 + i/10",
        "initial_q": Q0,
        "initial_omega": W0,
        "data": {"c": CHARGE, "o": OFFSET},
    }
    if per_body:
        terms = [{"V": PAIR_V, "pairs": pairs}]
        return define_system(name=name, body_terms=[{"V": BODY_V}], pair_terms=terms, **common)
    members = pairs if isinstance(pairs, list) else [[i, i + 1] for i in range(1, N)]
    if pairs == "all":
        members = [[i, j] for i in range(1, N + 1) for j in range(i + 1, N + 1)]
    data = {
        "cc": [CHARGE[i - 1] * CHARGE[j - 1] for i, j in members],
        "d": [np.subtract(OFFSET[i - 1], OFFSET[j - 1]).tolist() for i, j in members],
    }
    term = {"V": PER_PAIR_V, "pairs": members, "data": data}
    return define_system(name=name, body_terms=[{"V": BODY_V}], pair_terms=[term], **common)


@pytest.mark.parametrize(
    "pairs", [[[1, 3], [2, 5], [6, 4], [3, 2]], "chain", "all"], ids=["list", "chain", "all"]
)
def test_per_body_data_match_per_pair_data(pairs: Any) -> None:
    tag = pairs if isinstance(pairs, str) else "list"
    body = _system(pairs, True, f"bd_{tag}")
    pair = _system(pairs, False, f"pd_{tag}")
    if pairs == "all":  # the rows layout, reading a number and a 3-vector per body
        assert [t.rows for t in lower_system(body).terms] == [False, True]
    truth = simulate(pair, "vi", "reference", h=0.01, T=0.5, energy=False)
    for backend in ("c", "numpy", "reference"):
        run = simulate(body, "vi", backend, h=0.01, T=0.5, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
        assert np.max(np.abs(run.omega - truth.omega)) < 1e-12, backend


def _mixture(cutoff: float) -> Any:
    """Two species of a soft-sphere mixture on the sphere: sizes and strengths per body."""
    n = 120
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5**0.5) * k
    q0 = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    species = np.arange(n) % 2
    size = np.where(species == 0, 0.12, 0.18).tolist()
    strength = np.where(species == 0, 1.0, 2.0).tolist()
    return define_system(
        name="mixture",
        bodies=n,
        parameters={"m": 1.0},
        diagonal="m",
        data={"s": size, "a": strength},
        pair_terms=[
            {
                "V": "sqrt(ai*aj)*((si + sj)**2/(4*dot(qi - qj, qi - qj)))**3",
                "pairs": "all",
                "cutoff": cutoff,
            }
        ],
        initial_q=q0,
        initial_omega=0.2 * np.cross(q0, [0.0, 0.0, 1.0]),
    )


def test_cutoff_mixture_of_two_species_agrees_between_backends() -> None:
    s = _mixture(0.4)
    p = np.array(s.parameter_values)
    q = s.q0
    g_ref = get_backend(s, "reference")._problem(p).grad(q)
    c = get_backend(s, "c")
    _, dw = c.rhs(q, np.zeros_like(q), p)  # with workspace: the cell list
    scale = np.max(np.abs(g_ref))
    assert np.max(np.abs(c.gradient(q, p) - g_ref)) < 1e-12 * scale
    assert np.max(np.abs(dw + np.cross(q, g_ref))) < 1e-12 * scale
    assert np.max(np.abs(get_backend(s, "numpy").gradient(q, p) - g_ref)) < 1e-12 * scale
    truth = simulate(s, "vi", "reference", h=0.002, T=0.1, energy=False)
    for backend in ("c", "numpy"):
        run = simulate(s, "vi", backend, h=0.002, T=0.1, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-11, backend
    # the reference's potential against the mixture written out here pair by pair
    read = {d.name: np.array(d.values) for d in s.terms[0].body_data}
    size, strength = read["s"], read["a"]
    i, j = np.triu_indices(s.n, 1)
    r2 = np.sum((q[i] - q[j]) ** 2, axis=1)
    near = r2 < 0.4**2
    pair = np.sqrt(strength[i] * strength[j]) * ((size[i] + size[j]) ** 2 / (4 * r2)) ** 3
    by_hand = float(np.sum(pair[near]))
    assert np.sum(near) > s.n  # the cutoff keeps neighbours of both species
    assert abs(get_backend(s, "reference")._problem(p).potential(q) - by_hand) < 1e-12 * by_hand


def test_inertia_reads_data_as_inertia_data() -> None:
    head = 'name = "rod"\nbodies = 3\n[parameters]\nm = 2.0\n[potential]\nV = "q1[2]"\n'
    alias = load_spec_text(head + '[inertia]\ndiagonal = "m*l"\n[inertia.data]\nl = [1, 2, 3]\n')
    top = load_spec_text(head + '[inertia]\ndiagonal = "m*l"\n[data]\nl = [1, 2, 3]\n')
    assert np.allclose(np.diag(top.inertia_numeric()), [2.0, 4.0, 6.0])
    assert np.array_equal(top.inertia_numeric(), alias.inertia_numeric())


@pytest.mark.timeout(20)
def test_a_million_data_values_load_quickly() -> None:
    n = 1000
    values = np.random.default_rng(1).normal(size=(n, 1000))
    data = {f"d{k}": values[:, k].tolist() for k in range(1000)}
    start = time.perf_counter()
    s = define_system(
        name="big",
        bodies=n,
        parameters={"m": 1.0},
        diagonal="m",
        data=data,
        body_terms=[{"V": "d7*q[2] + d999*q[0]"}],
    )
    print(f"loaded {values.size} data values in {time.perf_counter() - start:.3f} s")
    read = {d.name: d.values for d in s.terms[0].body_data}
    assert sorted(read) == ["d7", "d999"]
    assert read["d999"] == tuple(values[:, 999])


def _charges(per_body: bool, name: str) -> Any:
    """Screened charges over all pairs: per body, or as an explicit list of every pair with
    the products of the charges per pair."""
    pairs: Any = "all"
    data: dict[str, Any] = {}
    v = "k*ci*cj*exp(-norm(qi - qj))/norm(qi - qj)"
    if not per_body:
        pairs = [[i, j] for i in range(1, N + 1) for j in range(i + 1, N + 1)]
        data = {"cc": [CHARGE[i - 1] * CHARGE[j - 1] for i, j in pairs]}
        v = "k*cc*exp(-norm(qi - qj))/norm(qi - qj)"
    term = {"V": v, "pairs": pairs, **({"data": data} if data else {})}
    return define_system(
        name=name,
        bodies=N,
        parameters={"k": 0.3},
        diagonal="1 + i/10",
        initial_q=Q0,
        initial_omega=W0,
        data={"c": CHARGE},
        pair_terms=[term],
    )


def test_all_pairs_rows_read_per_body_data() -> None:
    body, pair = _charges(True, "rows_body"), _charges(False, "rows_pair")
    assert [t.rows for t in lower_system(body).terms] == [True]
    truth = simulate(pair, "vi", "reference", h=0.01, T=0.5, energy=False)
    for backend in ("c", "numpy", "reference"):
        run = simulate(body, "vi", backend, h=0.01, T=0.5, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend
    for method, other in (("rk4", "reference"), ("rattle", "numpy")):
        truth = simulate(pair, method, other, h=0.01, T=0.3, energy=False)
        run = simulate(body, method, "c", h=0.01, T=0.3, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, method


def test_bilinear_per_body_terms_enter_the_quadratic_form() -> None:
    """k ci cj qi.qj + k ci qi_x qj_y over a list of all pairs is quadratic in q (gathered from a
    list, its loop costs more than K): its coefficients read per-body data."""
    v = "k*ci*cj*dot(qi, qj) + k*ci*qi[0]*qj[1] + c2i*q2j"
    extra = {"c2": [0.1 * k for k in range(N)]}
    common: dict[str, Any] = {
        "bodies": N,
        "parameters": {"k": 0.3},
        "diagonal": "1",
        "initial_q": Q0,
        "initial_omega": W0,
    }
    members = [[i, j] for i in range(1, N + 1) for j in range(i + 1, N + 1)]
    body = define_system(
        name="quad_body",
        data={"c": CHARGE, **extra},
        pair_terms=[{"V": v.replace("q2j", "qj[2]"), "pairs": members}],
        **common,
    )
    pair = define_system(
        name="quad_pair",
        pair_terms=[
            {
                "V": "k*cc*dot(qi, qj) + k*ai*qi[0]*qj[1] + di*qj[2]",
                "pairs": members,
                "data": {
                    "cc": [CHARGE[i - 1] * CHARGE[j - 1] for i, j in members],
                    "ai": [CHARGE[i - 1] for i, _ in members],
                    "di": [extra["c2"][i - 1] for i, _ in members],
                },
            }
        ],
        **common,
    )
    assert lower_system(body).terms[0].quadratic
    truth = simulate(pair, "vi", "reference", h=0.01, T=0.5, energy=False)
    for backend in ("c", "numpy", "reference"):
        run = simulate(body, "vi", backend, h=0.01, T=0.5, energy=False)
        assert np.max(np.abs(run.q - truth.q)) < 1e-12, backend


def test_expanded_potential_reads_each_members_bodies() -> None:
    """The System's potential written out member by member (SymPy, per-body values substituted
    at each member's bodies) equals the reference's vectorized evaluation and the C module's."""
    s = _system([[1, 3], [2, 5], [6, 4]], True, "expanded")
    values = dict(zip(s.parameter_symbols, s.parameter_values))
    subs = {q_symbol(b + 1, c): Q0[b, c] for b in range(N) for c in range(3)}
    expanded = float(s.full_potential().xreplace(values).xreplace(subs))
    p = np.array(s.parameter_values)
    assert abs(get_backend(s, "reference")._problem(p).potential(Q0) - expanded) < 1e-12
    assert abs(float(get_backend(s, "c").potential(Q0, p)) - expanded) < 1e-12


def test_toml_data_table_is_the_python_data_argument() -> None:
    text = f"""
name = "tomlions"
bodies = {N}
[parameters]
k = 0.3
g = 1.0
[inertia]
diagonal = "1 + i/10"
[data]
c = {CHARGE}
o = {OFFSET}
[potential]
[[potential.body]]
V = "{BODY_V}"
[[potential.pair]]
V = "{PAIR_V}"
pairs = "chain"
"""
    toml = load_spec_text(text)
    api = _system("chain", True, "tomlions")
    assert [t.body_data for t in toml.terms] == [t.body_data for t in api.terms]
    assert [t.expr for t in toml.terms] == [t.expr for t in api.terms]
    assert toml.inertia_numeric().tolist() == api.inertia_numeric().tolist()
