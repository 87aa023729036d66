"""The paper's example systems (`s2gen.systems.paper`) against facts derived independently of them.

Each check recomputes a quantity from the paper's formulas (or from first principles) with
plain NumPy and compares it with what the built-in system gives through the reference backend:
potentials, gradients, the rod's inertia, the icosphere, the Lennard-Jones sigma, the initial
states, and energy conservation of the variational integrator over short runs.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.experiments.reproduce.paper import EXAMPLES
from s2gen.metrics import summary
from s2gen.reference import ReferenceProblem, problem_from_system
from s2gen.runtime import METHODS, simulate
from s2gen.symbols import local_vector
from s2gen.system import System
from s2gen.systems import builtin, builtin_names, resolve
from s2gen.systems import paper as ps

SPECS = Path(__file__).parent / "specs"
NAMES = ("three_bodies", "four_pendula", "elastic_rod", "dipoles", "molecular")


@functools.cache
def system(name: str) -> System:
    return builtin(name)


@functools.cache
def problem(name: str) -> ReferenceProblem:
    return problem_from_system(system(name))


def random_sphere(n: int, seed: int = 0) -> np.ndarray:
    q = np.random.default_rng(seed).standard_normal((n, 3))
    return q / np.linalg.norm(q, axis=1)[:, None]


def random_tangent(q: np.ndarray, seed: int = 1) -> np.ndarray:
    v = np.random.default_rng(seed).standard_normal(q.shape)
    return v - np.einsum("ij,ij->i", v, q)[:, None] * q


def numeric_gradient(f: Callable[[np.ndarray], float], q: np.ndarray) -> np.ndarray:
    """Central differences of f in each of the 3n coordinates."""
    g = np.zeros_like(q)
    step = 1e-6
    for idx in np.ndindex(q.shape):
        e = np.zeros_like(q)
        e[idx] = step
        g[idx] = (f(q + e) - f(q - e)) / (2 * step)
    return g


# ----------------------------------------------------------------------------- every system
@pytest.mark.parametrize("name", NAMES)
def test_builtin_builds_with_unit_q_and_tangent_omega(name: str) -> None:
    s = system(name)
    assert name in builtin_names() and s.name == name
    assert s.q0 is not None and s.omega0 is not None
    assert np.allclose(np.linalg.norm(s.q0, axis=1), 1.0, atol=1e-15, rtol=0)
    assert np.max(np.abs(np.einsum("ij,ij->i", s.q0, s.omega0))) < 1e-14
    assert s.potential == 0 and s.terms  # everything is structured


@pytest.mark.parametrize("name", NAMES)
def test_gradient_matches_finite_differences(name: str) -> None:
    """The reference gradient of the structured terms is the derivative of their sum."""
    p = problem(name)
    n = system(name).n
    q = random_sphere(n, seed=3)
    if name == "molecular":  # keep particles apart; check a few coordinates only
        q = system(name).q0 + 0.01 * random_tangent(system(name).q0, seed=4)
        g = p.grad(q)
        for idx in [(0, 0), (100, 2), (641, 1)]:
            e = np.zeros_like(q)
            e[idx] = 1e-6
            fd = (p.potential(q + e) - p.potential(q - e)) / 2e-6
            assert fd == pytest.approx(g[idx], rel=1e-5, abs=1e-8)
        return
    assert np.allclose(p.grad(q), numeric_gradient(p.potential, q), rtol=1e-5, atol=1e-7)


# ----------------------------------------------------------------------------- three bodies
def test_three_bodies_potential_and_force_as_printed() -> None:
    """V = -gamma/2 sum_{i!=j} c/sqrt(1-c^2); dV/dq_i = -gamma sum_j q_j (1 - c_ij^2)^(-3/2)."""
    p = problem("three_bodies")
    q = random_sphere(3, seed=5)
    c = q @ q.T
    np.fill_diagonal(c, 0.0)
    off = ~np.eye(3, dtype=bool)
    V = -0.5 * np.sum((c / np.sqrt(1 - c**2))[off])
    assert p.potential(q) == pytest.approx(V, rel=1e-13)
    weights = np.where(off, (1 - c**2) ** -1.5, 0.0)
    assert np.allclose(p.grad(q), -weights @ q, rtol=1e-12)


def test_three_bodies_reproduces_the_printed_energy_errors() -> None:
    """The printed 1.1717e-4 and 1.1986e-6 are mean |E - E0| at h = 5e-3 and 5e-4."""
    s = system("three_bodies")
    tr = simulate(s, "vi", "reference", h=5e-3, T=10.0)
    m = summary(tr.q, tr.energy)
    assert m["mean_dE"] == pytest.approx(1.1717e-4, rel=5e-4)
    assert m["max_dE"] > 30 * m["mean_dE"]  # the max is not what the paper prints


# ----------------------------------------------------------------------------- pendula
def test_four_pendula_equals_the_written_out_spec() -> None:
    """The terms sum to the single-expression potential of tests/specs/springs4.toml."""
    ours = system("four_pendula").full_potential()
    theirs = resolve(str(SPECS / "springs4.toml"))
    subs = dict(zip(theirs.parameter_symbols, theirs.parameter_values))
    subs |= dict(zip(system("four_pendula").parameter_symbols, (0.1, 0.1, 9.81)))
    f = sp.lambdify(sorted(ours.free_symbols - set(subs), key=str), ours.xreplace(subs))
    g = sp.lambdify(sorted(ours.free_symbols - set(subs), key=str), theirs.potential.xreplace(subs))
    for seed in range(3):
        q = random_sphere(4, seed).ravel()
        assert f(*q) == pytest.approx(g(*q), rel=1e-13)


def test_four_pendula_hanging_state_is_an_equilibrium() -> None:
    """At q_i = e3 the springs are unstretched: the gradient is gravity's -m g l e3, radial,
    so the torque q_i x dV/dq_i vanishes (the gradient itself does not)."""
    p = problem("four_pendula")
    q = np.tile([0.0, 0.0, 1.0], (4, 1))
    g = p.grad(q)
    assert np.allclose(g, np.tile([0.0, 0.0, -0.1 * 9.81 * 0.1], (4, 1)), atol=1e-15)
    assert np.max(np.abs(np.cross(q, g))) == 0.0
    tr = simulate(system("four_pendula"), "vi", "reference", h=0.01, T=0.2, q0=q, omega0=0 * q)
    assert np.max(np.abs(tr.q - q)) < 1e-15


def test_four_pendula_reproduces_the_printed_energy_error() -> None:
    tr = simulate(system("four_pendula"), "vi", "reference", h=0.005, T=30.0)
    assert summary(tr.q, tr.energy)["mean_dE"] == pytest.approx(3.6171e-5, rel=5e-4)


# ----------------------------------------------------------------------------- elastic rod
def chain_kinetic_energy(qdot: np.ndarray, m_e: float, l_e: float) -> float:
    """Translational energy of each rod's centre plus its rotation (1/12 m l^2) about it."""
    n = len(qdot)
    total = 0.0
    for k in range(n):
        v = l_e * qdot[:k].sum(axis=0) + 0.5 * l_e * qdot[k]
        total += 0.5 * m_e * v @ v + 0.5 * m_e * l_e**2 / 12 * qdot[k] @ qdot[k]
    return total


@pytest.mark.parametrize("n", [1, 4, 10])
def test_rod_physical_inertia_is_the_chain_kinetic_energy(n: int) -> None:
    s = ps.elastic_rod(n, inertia="physical")
    m_e, l_e = 0.055 / (n + 1), 1.1 / (n + 1)
    q = random_sphere(n, seed=n)
    qdot = np.cross(random_tangent(q, seed=n + 1), q)
    M = s.inertia_numeric()
    direct = 0.5 * np.einsum("ij,ic,jc->", M, qdot, qdot)
    assert direct == pytest.approx(chain_kinetic_energy(qdot, m_e, l_e), rel=1e-13)


def test_rod_printed_inertia_matches_the_ELrod_matrix() -> None:
    """Entries of the paper's matrix (ELrod), in units of m l^2/(n+1)^3, and its general
    formula M_ii = 1/3 m_i l_i^2 + sum_{k>i} m_k l_i^2, M_ij = sum_{k>=max} 1/2 m_k l_k^2."""
    n, m, l = 10, 0.055, 1.1
    M = system("elastic_rod").inertia_numeric()
    unit = m * l**2 / (n + 1) ** 3
    assert M[0, 0] == pytest.approx((n - 2 / 3) * unit, rel=1e-14)
    assert M[1, 1] == pytest.approx((n - 5 / 3) * unit, rel=1e-14)
    assert M[-1, -1] == pytest.approx(unit / 3, rel=1e-14)
    assert M[0, 1] == pytest.approx((n - 1) / 2 * unit, rel=1e-14)
    assert M[0, -1] == M[1, -1] == M[-1, 0] == pytest.approx(unit / 2, rel=1e-14)
    me, le = np.full(n + 1, m / (n + 1)), np.full(n + 1, l / (n + 1))  # index 0: the wall
    for i in range(1, n + 1):
        for j in range(1, n + 1):
            k0 = max(i, j)
            want = (
                me[i] * le[i] ** 2 / 3 + me[i + 1 :].sum() * le[i] ** 2
                if i == j
                else 0.5 * np.sum(me[k0:] * le[k0:] ** 2)
            )
            assert M[i - 1, j - 1] == pytest.approx(want, rel=1e-13)


def test_rod_potential_as_printed() -> None:
    """V = -sum_i m_i g (sum_{j<i} l_j q_j + l_i q_i/2).e3 + sum_i kappa/2 (1 - q_{i-1}.q_i)^2."""
    n, m_e, l_e, g, kappa = 10, 0.005, 0.1, 9.81, 1000.0
    q = random_sphere(n, seed=11)
    chain = np.vstack([[1.0, 0.0, 0.0], q])
    centres = np.cumsum(l_e * q, axis=0) - 0.5 * l_e * q
    V = -m_e * g * centres[:, 2].sum()
    V += 0.5 * kappa * np.sum((1 - np.einsum("ij,ij->i", chain[:-1], chain[1:])) ** 2)
    assert problem("elastic_rod").potential(q) == pytest.approx(V, rel=1e-12)
    assert problem("elastic_rod").potential(np.tile([1.0, 0, 0], (n, 1))) == 0.0


def test_rod_kick_and_short_vi_run() -> None:
    s = system("elastic_rod")
    assert s.omega0 is not None and np.flatnonzero(np.abs(s.omega0).sum(axis=1)).tolist() == [4]
    tr = simulate(s, "vi", "reference", h=1e-4, T=0.03)
    m = summary(tr.q, tr.energy)
    assert m["max_dE"] < 1e-4 * abs(tr.energy[0]) and m["max_dot"] < 1e-13


# ----------------------------------------------------------------------------- dipoles
def dipole_energy(q: np.ndarray, pos: np.ndarray) -> float:
    """mu nu^2/(4 pi) / 2 sum_{i!=j} [qi.qj - 3 (qi.r)(qj.r)/r^2] / r^3, straight from the paper."""
    coef = 4e-7 * math.pi * 0.1**2 / (4 * math.pi)
    total = 0.0
    for i in range(len(q)):
        for j in range(len(q)):
            if i != j:
                r = pos[j] - pos[i]
                d = np.linalg.norm(r)
                total += coef / d**3 * (q[i] @ q[j] - 3 * (q[i] @ r) * (q[j] @ r) / d**2)
    return 0.5 * total


@pytest.mark.parametrize(("plane", "numbering"), [("xy", "row"), ("xz", "snake")])
def test_dipole_potential_as_printed(plane: str, numbering: str) -> None:
    s = system("dipoles") if plane == "xy" else ps.dipoles(plane, numbering)
    pos = 1.2 * 0.02 * ps.dipole_grid(plane, numbering)
    q = random_sphere(16, seed=7)
    want = dipole_energy(q, pos)
    assert problem_from_system(s).potential(q) == pytest.approx(want, rel=1e-12)


def test_dipole_grid_layouts() -> None:
    for plane in ps.DIPOLE_PLANES:
        for numbering in ps.DIPOLE_NUMBERINGS:
            pos = ps.dipole_grid(plane, numbering)
            assert len({tuple(p) for p in pos}) == 16
            assert sorted(np.ptp(pos, axis=0).tolist()) == [0.0, 3.0, 3.0]
    row, snake = ps.dipole_grid("xy", "row"), ps.dipole_grid("xy", "snake")
    assert row[15].tolist() == [3.0, 3.0, 0.0] and snake[15].tolist() == [0.0, 3.0, 0.0]


def test_dipoles_short_vi_run() -> None:
    tr = simulate(system("dipoles"), "vi", "reference", h=1e-3, T=0.5)
    m = summary(tr.q, tr.energy)
    assert m["max_dE"] < 1e-7 and m["max_dot"] < 1e-13


# ----------------------------------------------------------------------------- molecular
@pytest.mark.parametrize("s", [0, 1, 2, 3, 4])
def test_icosphere_counts_and_topology(s: int) -> None:
    v, f = ps.icosphere(s)
    assert len(v) == 10 * 4**s + 2 and len(f) == 20 * 4**s
    assert np.allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-15, rtol=0)
    edges: dict[tuple[int, int], int] = {}
    for tri in f.tolist():
        for a, b in zip(tri, tri[1:] + tri[:1]):
            edges[(a, b)] = edges.get((a, b), 0) + 1
    undirected = {tuple(sorted(e)) for e in edges}
    assert len(v) - len(undirected) + len(f) == 2  # Euler characteristic of the sphere
    assert all(c == 1 and (b, a) in edges for (a, b), c in edges.items())  # closed, oriented
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert np.all(np.einsum("ij,ij->i", normals, v[f].sum(axis=1)) > 0)  # outward


def test_molecular_sigma_puts_zero_force_at_the_neighbour_distance() -> None:
    s = system("molecular")
    v, _ = ps.icosphere(3)
    d_nn = ps.nearest_neighbour_distance(v)
    assert s.n == 642 and np.allclose(s.q0, v, atol=1e-15, rtol=0)
    eps, sigma = s.parameters["eps"], s.parameters["sigma"]
    assert sigma == pytest.approx(d_nn / 2 ** (1 / 6), rel=1e-15)
    qi, qj = local_vector("qi"), local_vector("qj")
    params = sp.symbols("eps sigma", real=True)
    force = sp.lambdify([*qi, *qj, *params], sp.diff(s.terms[0].expr, qj[0]))

    def at(d: float) -> float:  # d/dx of the pair energy, particles d apart along x
        return float(force(0.0, 0.0, 1.0, d, 0.0, 1.0, eps, sigma))

    scale = 24 * eps / sigma  # the LJ force scale
    assert abs(at(d_nn)) < 1e-12 * scale
    assert abs(at(0.9 * d_nn)) > 0.5 * scale


def test_vortex_field_is_rigid_rotation_with_gaussian_weight() -> None:
    q = random_sphere(50, seed=9)
    axis = np.array([[0.0, 0.0, 1.0]])
    w = ps.vortex_velocities(q, axis, (3.0,), 0.4)
    theta = np.arccos(q[:, 2])
    velocity = np.cross(w, q)
    want = 3.0 * np.exp(-(theta**2) / (2 * 0.4**2))[:, None] * np.cross(axis, q)
    assert np.allclose(velocity, want, atol=1e-14)
    assert np.max(np.abs(np.einsum("ij,ij->i", w, q))) < 1e-15
    a = ps.vortex_axes(30.0)
    assert math.degrees(math.acos(a[0] @ a[1])) == pytest.approx(30.0, abs=1e-12)


def test_molecular_short_vi_run() -> None:
    tr = simulate(system("molecular"), "vi", "reference", h=0.005, T=0.01)
    m = summary(tr.q, tr.energy)
    assert m["max_dE"] < 2e-4 and m["max_dot"] < 1e-14


# ----------------------------------------------------------------------------- paper.py
@pytest.mark.parametrize("name", NAMES)
def test_examples_entries(name: str) -> None:
    e = EXAMPLES[name]
    assert e.system == name and e.runs and e.quick
    for run in e.runs + e.quick:
        assert run.method in METHODS
        assert abs(round(run.T / run.h) * run.h - run.T) < 1e-9 * run.T
        assert set(run.paper) <= {"mean_dE", "max_dE", "mean_norm", "mean_dot", "max_norm"}
    assert any(run.paper for run in e.runs)


def test_nearest_neighbour_distance_is_the_k_d_trees(monkeypatch: pytest.MonkeyPatch) -> None:
    """Small point sets compare all pairs instead of importing scipy's k-d tree: the same
    doubles as the tree gives (the molecular system's sigma, hence its emitted code, depends
    on them), on an icosphere and on random points."""
    from s2gen.systems import meshes

    rng = np.random.default_rng(7)
    random = rng.normal(size=(900, 3))
    sets = [meshes.icosphere(3)[0], random / np.linalg.norm(random, axis=1)[:, None]]
    direct = [meshes.nearest_neighbour_distance(p) for p in sets]
    monkeypatch.setattr(meshes, "BRUTE_FORCE_POINTS", 0)
    assert direct == [meshes.nearest_neighbour_distance(p) for p in sets]
