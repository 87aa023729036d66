"""Shared fixtures: the systems the verification tests run on."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from s2gen import load
from s2gen.runtime.model import Model
from s2gen.system import System
from s2gen.systems import builtin, resolve

SPECS = Path(__file__).parent / "specs"

#: The per-test limit of the slow suites (the default suite's is `timeout` in pyproject.toml).
SLOW_TIMEOUT = 3600


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Give every slow test without a timeout of its own the slow suites' limit."""
    for item in items:
        if item.get_closest_marker("slow") and not item.get_closest_marker("timeout"):
            item.add_marker(pytest.mark.timeout(SLOW_TIMEOUT))


def three_bodies() -> System:
    """Three bodies on a sphere with the cotangent potential (diagonal M), from a TOML text."""
    from s2gen.spec import load_spec_text

    pairs = [(1, 2), (1, 3), (2, 3)]
    terms = " + ".join(f"dot(q{i}, q{j})/sqrt(1 - dot(q{i}, q{j})**2)" for i, j in pairs)
    text = f"""
name = "three"
bodies = 3
[parameters]
m = 1.0
gamma = 1.0
[inertia]
diagonal = ["m", "m", "m"]
[potential]
V = "-gamma*({terms})"
[initial]
q = [[0, -1, 0], [0, 0, 1], [-1, 0, 0]]
omega = [[0, 0, -1.1], [1, 0, 0], [0, 1, 0]]
[run]
h = 0.001
T = 10.0
"""
    return load_spec_text(text, origin="tests/conftest.py three_bodies")


SYSTEMS = {
    "double_pendulum": lambda: builtin("double_pendulum"),
    "three": three_bodies,
    "chain4": lambda: resolve(str(SPECS / "chain4.toml")),
    "springs4": lambda: resolve(str(SPECS / "springs4.toml")),
    "springs4_terms": lambda: resolve(str(SPECS / "springs4_terms.toml")),
    "lj_ring": lambda: lennard_jones_ring(),
    # the paper's rod with its max-index inertia given per body: the structured O(n) solvers
    "rod12": lambda: builtin("elastic_rod", n=12),
}


def lennard_jones_ring(n: int = 12) -> System:
    """n particles near a great circle with an all-pairs Lennard-Jones term (diagonal M)."""
    import numpy as np

    from s2gen.spec import define_system

    ang = 2 * np.pi * np.arange(n) / n
    q = np.stack([np.cos(ang), np.sin(ang), 0.05 * np.sin(3 * ang)], axis=1)
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = 0.3 * np.stack([np.zeros(n), np.zeros(n), np.ones(n)], axis=1)
    w += 0.2 * np.cross(q, np.array([1.0, 0.0, 0.0]))
    w -= np.einsum("ij,ij->i", w, q)[:, None] * q
    d = 2 * np.sin(np.pi / n)
    return define_system(
        name="lj_ring",
        bodies=n,
        parameters={"m": 1.0, "eps": 0.01, "sigma": d / 2 ** (1 / 6)},
        diagonal=["m"] * n,
        pair_terms=[
            {
                "V": "4*eps*((sigma**2/dot(qi-qj, qi-qj))**6 - (sigma**2/dot(qi-qj, qi-qj))**3)",
                "pairs": "all",
            }
        ],
        initial_q=q.tolist(),
        initial_omega=w.tolist(),
        run={"h": 0.01, "T": 1.0},
    )


def final_state(tr) -> np.ndarray:
    """(q, omega) at the last sample of a trajectory, flat."""
    return np.concatenate([tr.q[-1].ravel(), tr.omega[-1].ravel()])


def reference_path(system: System, T: float, times, tol: float = 3e-14) -> np.ndarray:
    """(q, omega) at `times` (rows) by scipy's DOP853 at rtol = atol = tol on the reference
    backend's field (s2gen.reference, written independently of the emitted code)."""
    from scipy.integrate import solve_ivp

    from s2gen.reference import continuous_rhs, problem_from_system

    problem, n = problem_from_system(system), system.n

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        dq, dw = continuous_rhs(problem, y[: 3 * n].reshape(n, 3), y[3 * n :].reshape(n, 3))
        return np.concatenate([dq.ravel(), dw.ravel()])

    assert system.q0 is not None and system.omega0 is not None
    y0 = np.concatenate([system.q0.ravel(), system.omega0.ravel()])
    sol = solve_ivp(fun, (0.0, T), y0, method="DOP853", t_eval=times, rtol=tol, atol=tol)
    assert sol.success
    return sol.y.T


def reference_final(system: System, T: float, tol: float = 3e-14) -> np.ndarray:
    """(q, omega)(T), flat, as `reference_path`."""
    return reference_path(system, T, [T], tol)[-1]


@pytest.fixture(scope="session", params=sorted(SYSTEMS))
def system(request: pytest.FixtureRequest) -> System:
    return SYSTEMS[request.param]()


# The Models the Jacobian and Lyapunov tests share (built once per run, their modules with the
# step Jacobians on first use): a dense M, a diagonal M, a driven system with an input.
@pytest.fixture(scope="session")
def double() -> Model:
    return Model(load("double_pendulum"))


@pytest.fixture(scope="session")
def four() -> Model:
    return Model(load("four_pendula"))


@pytest.fixture(scope="session")
def driven() -> Model:
    return Model(load(str(Path(__file__).parent / "specs" / "driven_double.toml")))
