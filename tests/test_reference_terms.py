"""Structured potential terms in the reference (s2gen.reference.problem_from_system).

Each term is differentiated once in its local symbols and evaluated vectorized over its
members. Here that path is checked against independent ones: the fully expanded potential
(`System.full_potential`, differentiated by SymPy in the global symbols), plain Python loops
over pairs with the Lennard-Jones force of paper eq. ELmd written by hand, the symmetries of
pair potentials, and a VI run of the same system written as a general potential.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pytest
import sympy as sp

from s2gen.reference import integrate, problem_from_system
from s2gen.symbols import local_vector, q_symbol, q_symbols
from s2gen.system import SpecError, System, Term, TermData

QV = sp.Matrix(local_vector("q"))
QI = sp.Matrix(local_vector("qi"))
QJ = sp.Matrix(local_vector("qj"))
EPS, SIGMA = sp.symbols("epsilon sigma", real=True)
R_IJ = sp.sqrt((QI - QJ).dot(QI - QJ))
LJ_EXPR = 4 * EPS * ((SIGMA / R_IJ) ** 12 - (SIGMA / R_IJ) ** 6)
LJ_EPS, LJ_SIGMA = 0.01, 0.1


# ---------------------------------------------------------------------------------- helpers
def random_unit(n: int, seed: int) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=(n, 3))
    return q / np.linalg.norm(q, axis=1)[:, None]


def make(
    n: int,
    terms: Sequence[Term],
    parameters: Mapping[str, float] | None = None,
    potential: sp.Expr | None = None,
) -> System:
    """A system with unit masses and the given terms (general part 0 unless given)."""
    return System.create(
        name="terms",
        n=n,
        parameters=dict(parameters or {}),
        inertia=sp.eye(n),
        potential=sp.Integer(0) if potential is None else potential,
        terms=list(terms),
    )


def expanded(
    system: System, values: Mapping[str, float] | None = None
) -> tuple[Callable[[np.ndarray], float], Callable[[np.ndarray], np.ndarray]]:
    """V and dV/dq from the fully expanded potential, differentiated in the global symbols."""
    params = {**system.parameters, **(values or {})}
    subs = {sp.Symbol(k, real=True): v for k, v in params.items()}
    V = system.full_potential().xreplace(subs)
    qs = q_symbols(system.n)
    v_fn = sp.lambdify([qs], V, modules="numpy")
    g_fn = sp.lambdify([qs], [sp.diff(V, s) for s in qs], modules="numpy")
    return (
        lambda q: float(v_fn(list(q.ravel()))),
        lambda q: np.array(g_fn(list(q.ravel())), dtype=float).reshape(system.n, 3),
    )


def assert_matches_expansion(
    system: System, q: np.ndarray, values: Mapping[str, float] | None = None
) -> None:
    problem = problem_from_system(system, values)
    v_ref, g_ref = expanded(system, values)
    g, gr = problem.grad(q), g_ref(q)
    assert g.shape == (system.n, 3)
    assert np.max(np.abs(g - gr)) <= 1e-12 * max(1.0, float(np.max(np.abs(gr))))
    v, vr = problem.potential(q), v_ref(q)
    assert isinstance(v, float)
    assert abs(v - vr) <= 1e-12 * max(1.0, abs(vr))


def lj_system(n: int) -> System:
    return make(n, [Term("pair", LJ_EXPR, label="lj")], {"epsilon": LJ_EPS, "sigma": LJ_SIGMA})


def lj_pair_grad(qi: np.ndarray, qj: np.ndarray) -> np.ndarray:
    """dV_ij/dq_i of the Lennard-Jones pair potential (paper eq. ELmd, by hand)."""
    d = qi - qj
    r = float(np.sqrt(d @ d))
    return 4 * LJ_EPS * (d / r) * (-12 * LJ_SIGMA**12 / r**13 + 6 * LJ_SIGMA**6 / r**7)


def lj_pair_value(qi: np.ndarray, qj: np.ndarray) -> float:
    r = float(np.linalg.norm(qi - qj))
    return 4 * LJ_EPS * ((LJ_SIGMA / r) ** 12 - (LJ_SIGMA / r) ** 6)


# ---------------------------------------------------------------------------------- small systems
def body_terms(n: int) -> list[Term]:
    """One-body terms: per-body scalar and 3-vector data ("all") and a listed term with a
    repeated body."""
    rng = np.random.default_rng(5)
    k, c = sp.symbols("k c", real=True)
    a = sp.Matrix(local_vector("a"))
    anchor = Term(
        "body",
        k / 2 * (QV - a).dot(QV - a) + c * sp.exp(a.dot(QV)) * QV[2],
        data=(
            TermData("k", 1, tuple(rng.uniform(0.5, 2.0, n))),
            TermData("a", 3, tuple(rng.normal(size=3 * n))),
        ),
        label="anchor",
    )
    w = sp.Symbol("w", real=True)
    listed = Term(
        "body",
        w * sp.sin(QV[0] * QV[1]) + c * QV[2] ** 3,
        select="list",
        members=((1,), (0,), (1,)),
        data=(TermData("w", 1, (0.3, -1.2, 0.7)),),
        label="listed",
    )
    return [anchor, listed]


def pair_terms(n: int) -> list[Term]:
    """Pair terms over all pairs (parameters only), a chain with scalar and vector data, and a
    list with a repeated pair and vector data."""
    rng = np.random.default_rng(6)
    gamma = sp.Symbol("gamma", real=True)
    dot = QI.dot(QJ)
    everything = Term("pair", -gamma * dot / sp.sqrt(2 - dot**2), label="all pairs")
    kappa, theta = sp.symbols("kappa theta", real=True)
    b = sp.Matrix(local_vector("b"))
    chain = Term(
        "pair",
        kappa * (dot - sp.cos(theta)) ** 2 + b.dot(QI - QJ),
        select="chain",
        data=(
            TermData("kappa", 1, tuple(rng.uniform(1.0, 3.0, n - 1))),
            TermData("theta", 1, tuple(rng.uniform(0.1, 1.0, n - 1))),
            TermData("b", 3, tuple(rng.normal(size=3 * (n - 1)))),
        ),
        label="chain",
    )
    d = sp.Matrix(local_vector("d"))
    s = sp.Symbol("s", real=True)
    members = ((0, 2), (2, 1), (0, 2), (3, 1))
    listed = Term(
        "pair",
        d.dot(QI.cross(QJ)) + s * dot**3 + gamma * QI[2] * QJ[0],
        select="list",
        members=members,
        data=(
            TermData("d", 3, tuple(rng.normal(size=3 * len(members)))),
            TermData("s", 1, tuple(rng.normal(size=len(members)))),
        ),
        label="listed pairs",
    )
    return [everything, chain, listed]


def test_body_terms_match_expanded_potential() -> None:
    system = make(4, body_terms(4), {"c": 0.8})
    for seed in range(3):
        assert_matches_expansion(system, random_unit(4, seed))


@pytest.mark.parametrize("which", [0, 1, 2])
def test_each_pair_selection_matches_expanded_potential(which: int) -> None:
    system = make(5, [pair_terms(5)[which]], {"gamma": 1.3})
    for seed in range(3):
        assert_matches_expansion(system, random_unit(5, seed))


def test_terms_general_part_and_parameter_overrides() -> None:
    m, c = sp.symbols("m c", real=True)
    general = -m * q_symbol(1, 2) + c * q_symbol(2, 0) * q_symbol(4, 1) ** 2
    system = make(
        4, body_terms(4) + pair_terms(4), {"m": 2.0, "c": 0.8, "gamma": 1.3}, potential=general
    )
    q = random_unit(4, 11)
    assert_matches_expansion(system, q)
    assert_matches_expansion(system, q, {"c": -0.4, "gamma": 0.2})
    by_sequence = problem_from_system(system, [2.0, -0.4, 0.2])
    by_mapping = problem_from_system(system, {"c": -0.4, "gamma": 0.2})
    assert np.array_equal(by_sequence.grad(q), by_mapping.grad(q))
    assert by_sequence.potential(q) == by_mapping.potential(q)


def test_term_gradient_matches_central_differences() -> None:
    system = make(4, body_terms(4) + pair_terms(4), {"c": 0.8, "gamma": 1.3})
    problem = problem_from_system(system)
    q = random_unit(4, 3)
    step = 1e-6
    fd = np.zeros_like(q)
    for i in range(4):
        for c in range(3):
            e = np.zeros_like(q)
            e[i, c] = step
            fd[i, c] = (problem.potential(q + e) - problem.potential(q - e)) / (2 * step)
    assert np.max(np.abs(fd - problem.grad(q))) < 1e-7 * max(1.0, float(np.max(np.abs(fd))))


def test_datum_named_like_a_parameter_is_rejected() -> None:
    """A datum may not shadow a parameter (the System refuses it, as the TOML front door does)."""
    k = sp.Symbol("k", real=True)
    term = Term("body", k * QV[2], data=(TermData("k", 1, (2.0, 3.0)),))
    with pytest.raises(SpecError, match="'k' is both a parameter"):
        make(2, [term], {"k": 100.0})


def test_degenerate_terms() -> None:
    # No potential at all; a pair term with no pairs (n = 1); a term free of positions.
    free = problem_from_system(make(2, []))
    q = random_unit(2, 0)
    assert free.potential(q) == 0.0 and np.array_equal(free.grad(q), np.zeros((2, 3)))
    lonely = problem_from_system(make(1, [Term("pair", QI.dot(QJ))]))
    assert lonely.potential(q[:1]) == 0.0 and not lonely.grad(q[:1]).any()
    constant = Term("body", sp.Symbol("e", real=True), data=(TermData("e", 1, (1.5, 2.0)),))
    flat = problem_from_system(make(2, [constant]))
    assert flat.potential(q) == 3.5 and np.array_equal(flat.grad(q), np.zeros((2, 3)))


def test_terms_are_not_expanded_per_member(monkeypatch: pytest.MonkeyPatch) -> None:
    def forbidden(*args: object) -> None:
        raise AssertionError("per-member expansion used")

    system = make(6, pair_terms(6), {"gamma": 1.3})
    for name in ("full_potential",):
        monkeypatch.setattr(System, name, forbidden)
    for name in ("instance", "member_list"):
        monkeypatch.setattr(Term, name, forbidden)
    problem = problem_from_system(system)
    assert np.all(np.isfinite(problem.grad(random_unit(6, 2))))


# ---------------------------------------------------------------------------------- Lennard-Jones
@pytest.fixture(scope="module")
def md642() -> tuple[System, np.ndarray]:
    """The paper's molecular-dynamics size: 642 bodies, Lennard-Jones over all 205,761 pairs."""
    return lj_system(642), random_unit(642, 642)


def test_lennard_jones_small_n_matches_double_loop() -> None:
    n = 30
    system, q = lj_system(n), random_unit(n, 30)
    problem = problem_from_system(system)
    g = np.zeros((n, 3))
    scale = np.zeros(n)
    v = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            gij = lj_pair_grad(q[i], q[j])
            g[i] += gij
            g[j] -= gij
            scale[i] += np.max(np.abs(gij))
            scale[j] += np.max(np.abs(gij))
            v += lj_pair_value(q[i], q[j])
    assert np.all(np.abs(problem.grad(q) - g) <= 1e-12 * scale[:, None])
    assert problem.potential(q) == pytest.approx(v, rel=1e-12)


def test_lennard_jones_matches_expanded_potential() -> None:
    assert_matches_expansion(lj_system(7), random_unit(7, 7))


def test_lennard_jones_642_matches_loop_and_symmetries(md642: tuple[System, np.ndarray]) -> None:
    system, q = md642
    n = system.n
    problem = problem_from_system(system)
    g = problem.grad(q)
    assert g.shape == (n, 3) and np.all(np.isfinite(g))
    # Loop over every partner j of a subset of bodies i (both orders of each pair occur).
    for i in (0, 1, 200, 457, 641):
        gi, scale = np.zeros(3), 0.0
        for j in range(n):
            if j != i:
                gij = lj_pair_grad(q[i], q[j])
                gi += gij
                scale += float(np.max(np.abs(gij)))
        assert np.all(np.abs(g[i] - gi) <= 1e-12 * scale)
    # The potential, summed independently over the full distance matrix.
    r = np.linalg.norm(q[:, None, :] - q[None, :, :], axis=2)[np.triu_indices(n, k=1)]
    v = float(np.sum(4 * LJ_EPS * ((LJ_SIGMA / r) ** 12 - (LJ_SIGMA / r) ** 6)))
    assert problem.potential(q) == pytest.approx(v, rel=1e-12)
    # V depends on q_i - q_j only and is rotation invariant: sum g_i = 0, sum q_i x g_i = 0.
    size = float(np.sum(np.abs(g)))
    assert np.max(np.abs(g.sum(axis=0))) <= 1e-13 * size
    assert np.max(np.abs(np.cross(q, g).sum(axis=0))) <= 1e-13 * size


@pytest.mark.timeout(60)  # typically ~10 ms a gradient; the expanded path would take minutes
def test_lennard_jones_642_gradient_is_fast(md642: tuple[System, np.ndarray]) -> None:
    system, q = md642
    problem = problem_from_system(system)
    for _ in range(5):
        g = problem.grad(q)
    assert g.shape == q.shape and np.all(np.isfinite(g))


# ---------------------------------------------------------------------------------- integration
def test_vi_all_pairs_term_equals_general_potential() -> None:
    """Three bodies with the cotangent potential (as in tests/conftest.py), written once as a
    general potential and once as an "all"-pairs term: explicit VI runs agree to 1e-13."""
    m, gamma = sp.symbols("m gamma", real=True)

    def cot(a: sp.Matrix, b: sp.Matrix) -> sp.Expr:
        return a.dot(b) / sp.sqrt(1 - a.dot(b) ** 2)

    qv = [sp.Matrix([q_symbol(i, c) for c in range(3)]) for i in (1, 2, 3)]
    pairs = ((0, 1), (0, 2), (1, 2))
    general = -gamma * sum((cot(qv[i], qv[j]) for i, j in pairs), sp.Integer(0))
    common: dict[str, Any] = {
        "n": 3,
        "parameters": {"m": 1.0, "gamma": 1.0},
        "inertia": sp.diag(m, m, m),
        "q0": [[0, -1, 0], [0, 0, 1], [-1, 0, 0]],
        "omega0": [[0, 0, -1.1], [1, 0, 0], [0, 1, 0]],
    }
    as_general = System.create(name="general", potential=general, **common)
    as_term = System.create(
        name="term",
        potential=sp.Integer(0),
        terms=[Term("pair", -gamma * cot(QI, QJ), label="cot")],
        **common,
    )
    runs = [
        integrate(problem_from_system(s), "vi", s.q0, s.omega0, h=0.001, nsteps=2000)
        for s in (as_general, as_term)
    ]
    assert runs[0].stats["newton_iterations_total"] == 0  # diagonal M: explicit VI
    assert np.max(np.abs(runs[0].q - runs[1].q)) <= 1e-13
    assert np.max(np.abs(runs[0].omega - runs[1].omega)) <= 1e-13
    assert np.max(np.abs(runs[0].energy - runs[1].energy)) <= 1e-13
