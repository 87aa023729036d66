"""Properties of the integrators, checked against conservation laws and convergence rates.

- the VI keeps unit length at round-off with no renormalization;
- its energy and state errors fall as h^2; RK4's state error as h^4;
- RK45 at tight tolerance and the VI at small h agree at a fixed time;
- the VI conserves angular momentum about the axes the potential is symmetric about.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SYSTEMS

from s2gen import metrics
from s2gen.runtime import Options, get_backend, simulate
from s2gen.systems import builtin


@pytest.mark.parametrize("name", ["double_pendulum", "three", "chain4"])
def test_vi_unit_length_1e4_steps(name: str) -> None:
    s = SYSTEMS[name]()
    h = 0.01 if name == "double_pendulum" else 0.001
    tr = simulate(s, "vi", "c", h=h, T=10_000 * h)
    assert metrics.unit_length_error(tr.q)["max_norm"] < 1e-13


def test_vi_unit_length_1e5_steps() -> None:
    tr = simulate(builtin("double_pendulum"), "vi", "c", h=0.01, T=1000.0)
    assert metrics.unit_length_error(tr.q)["max_norm"] < 1e-12


def _final_state(tr) -> np.ndarray:
    return np.concatenate([tr.q[-1].ravel(), tr.omega[-1].ravel()])


@pytest.mark.parametrize(
    "name", ["double_pendulum", "three", "chain4", "springs4", "springs4_terms", "lj_ring"]
)
def test_vi_second_order(name: str) -> None:
    """Energy error and state error at T fall as h^2 (order 2 +- 0.1)."""
    s = SYSTEMS[name]()
    T = 0.2 if name.startswith("springs4") else 1.0
    h0 = {
        "double_pendulum": 0.02,
        "three": 0.004,
        "chain4": 0.004,
        "springs4": 0.0004,
        "springs4_terms": 0.0004,
        "lj_ring": 0.02,
    }[name]
    hs = h0 / 2.0 ** np.arange(4)
    exact = simulate(s, "rk4", "c", h=hs[-1] / 16, T=T)
    e_state, e_energy = [], []
    for h in hs:
        tr = simulate(s, "vi", "c", h=h, T=T)
        e_state.append(np.max(np.abs(_final_state(tr) - _final_state(exact))))
        e_energy.append(metrics.energy_variation(tr.energy)[1])
    assert abs(metrics.observed_order(hs, e_state) - 2.0) < 0.1, e_state
    assert abs(metrics.observed_order(hs, e_energy) - 2.0) < 0.1, e_energy


def test_rk4_fourth_order() -> None:
    s = builtin("double_pendulum")
    hs = 0.04 / 2.0 ** np.arange(4)
    exact = simulate(s, "rk45", "c", h=0.01, T=2.0, options=Options(rtol=1e-13, atol=1e-13))
    errs = [
        np.max(np.abs(_final_state(simulate(s, "rk4", "c", h=h, T=2.0)) - _final_state(exact)))
        for h in hs
    ]
    assert abs(metrics.observed_order(hs, errs) - 4.0) < 0.2, errs


@pytest.mark.parametrize("name", ["double_pendulum", "three", "chain4"])
def test_vi_small_h_agrees_with_tight_rk45(name: str) -> None:
    s = SYSTEMS[name]()
    T = 1.0
    vi = simulate(s, "vi", "c", h=1e-4, T=T)
    rk = simulate(s, "rk45", "c", h=0.01, T=T, options=Options(rtol=1e-12, atol=1e-12))
    diff = np.max(np.abs(_final_state(vi) - _final_state(rk)))
    scale = np.max(np.abs(_final_state(rk)))
    # VI global error ~ C h^2 with h = 1e-4
    assert diff < 1e-5 * scale, diff


@pytest.mark.parametrize(
    ("name", "axes"),
    [("double_pendulum", [2]), ("chain4", [2]), ("three", [0, 1, 2]), ("lj_ring", [0, 1, 2])],
)
def test_vi_conserves_angular_momentum(name: str, axes: list[int]) -> None:
    """Components of J about symmetry axes stay constant to round-off over 5000 steps.

    Round-off is measured against the size of the momentum terms, sum|M_ij| max|omega|: the VI
    stays within 5e-13 of it, while RK4 at the same step drifts by more than 5e-12 (so the
    check can fail).
    """
    s = SYSTEMS[name]()
    h = {"double_pendulum": 0.01, "chain4": 0.002, "three": 0.001, "lj_ring": 0.01}[name]
    be = get_backend(s, "c")
    p = np.array(s.parameter_values)
    drift = {}
    for method in ("vi", "rk4"):
        tr = simulate(s, method, "c", h=h, T=5000 * h)
        J = np.array([be.angular_momentum(q, w, p) for q, w in zip(tr.q, tr.omega)])
        scale = np.sum(np.abs(s.inertia_numeric())) * np.max(np.abs(tr.omega))
        drift[method] = max(np.max(np.abs(J[:, a] - J[0, a])) for a in axes) / scale
    assert drift["vi"] < 5e-13, drift
    assert drift["rk4"] > 5e-12, drift


@pytest.mark.parametrize("name", ["double_pendulum", "three", "chain4", "lj_ring"])
def test_composition_fourth_order_and_rattle_second_order(name: str) -> None:
    """Yoshida's composition of the VI has order 4 +- 0.2; RATTLE order 2 +- 0.1."""
    s = SYSTEMS[name]()
    T = 1.0
    h0 = {"double_pendulum": 0.04, "three": 0.008, "chain4": 0.008, "lj_ring": 0.04}[name]
    hs = h0 / 2.0 ** np.arange(4)
    exact = simulate(s, "rk45", "c", h=hs[-1], T=T, options=Options(rtol=1e-13, atol=1e-13))
    for method, order, tol in (("vi4", 4.0, 0.2), ("rattle", 2.0, 0.1)):
        errs = [
            np.max(np.abs(_final_state(simulate(s, method, "c", h=h, T=T)) - _final_state(exact)))
            for h in hs
        ]
        assert abs(metrics.observed_order(hs, errs) - order) < tol, (method, errs)


@pytest.mark.parametrize("name", ["double_pendulum", "three", "lj_ring"])
def test_rattle_keeps_constraints(name: str) -> None:
    """|q_i| = 1 to round-off at every step. The position step solves |y - s q| = 1 for
    y = q + h v - h^2/2 (M^-1 dV/dq), so the round-off of |q+| scales with |y|^2: each step's
    error must stay below 16 eps (1 + h|v| + h^2 |dV/dq| / (2 lambda_min(M)))^2 (close
    encounters of the three bodies make |y| large), and below 1e-13 wherever |y| stays near 1."""
    s = SYSTEMS[name]()
    h = 0.002
    tr = simulate(s, "rattle", "c", h=h, T=20.0)
    be = get_backend(s, "c")
    params = be.default_params()
    # |M^-1 dV/dq| <= |dV/dq| / lambda_min(M) bounds the gradient's part of y for every body
    md = float(np.min(np.linalg.eigvalsh(s.inertia_numeric())))
    g = np.array([be.gradient(q, params) for q in tr.q[:-1]])
    v = np.cross(tr.omega[:-1], tr.q[:-1])
    y = 1.0 + h * np.linalg.norm(v, axis=2) + h * h * np.linalg.norm(g, axis=2) / (2 * md)
    err = np.abs(np.linalg.norm(tr.q[1:], axis=2) - 1.0)
    eps = np.finfo(float).eps
    assert np.all(err <= 16 * eps * y**2), float(np.max(err / (eps * y**2)))
    assert np.max(err[np.max(y, axis=1) < 1.5]) < 1e-13
    tangency = np.abs(np.einsum("kic,kic->ki", tr.q, tr.omega))
    assert np.max(tangency) < 1e-12 * max(1.0, float(np.max(np.abs(tr.omega))))


@pytest.mark.parametrize("name", ["double_pendulum", "three", "chain4"])
@pytest.mark.parametrize("method", ["vi", "vi4", "rattle"])
def test_time_reversibility(name: str, method: str) -> None:
    """N steps forward, reverse the velocities, N steps forward: back to the start."""
    s = SYSTEMS[name]()
    h = 0.01
    fwd = simulate(s, method, "c", h=h, T=500 * h)
    back = simulate(s, method, "c", h=h, T=500 * h, q0=fwd.q[-1], omega0=-fwd.omega[-1])
    wscale = max(1.0, float(np.max(np.abs(fwd.omega))))
    assert np.max(np.abs(back.q[-1] - s.q0)) < 1e-11
    assert np.max(np.abs(back.omega[-1] + s.omega0)) < 1e-11 * wscale
    # the check can fail: RK4 is not time-reversible (its final q_i are off unit length by
    # ~1e-10, so the continuation opts out of the unit-length check on q0)
    rk = simulate(s, "rk4", "c", h=h, T=500 * h)
    off = Options(unit_tol=0.0)
    rk_back = simulate(
        s, "rk4", "c", h=h, T=500 * h, options=off, q0=rk.q[-1], omega0=-rk.omega[-1]
    )
    assert np.max(np.abs(rk_back.q[-1] - s.q0)) > 1e-10


@pytest.mark.parametrize("name", ["double_pendulum", "three", "chain4", "lj_ring"])
def test_vi_and_rattle_are_the_same_discrete_flow(name: str) -> None:
    """The paper's discrete Lagrangian on the sphere generates RATTLE: two independently
    written solvers (Cayley/explicit rotation vs Cartesian multipliers) must agree to round-off."""
    s = SYSTEMS[name]()
    h = {"double_pendulum": 0.01, "three": 0.001, "chain4": 0.002, "lj_ring": 0.01}[name]
    vi = simulate(s, "vi", "c", h=h, T=200 * h)
    ra = simulate(s, "rattle", "c", h=h, T=200 * h)
    wscale = max(1.0, float(np.max(np.abs(vi.omega))))
    assert np.max(np.abs(vi.q[1] - ra.q[1])) < 2e-15
    assert np.max(np.abs(vi.omega[1] - ra.omega[1])) < 4e-15 * wscale
    assert np.max(np.abs(vi.q - ra.q)) < 1e-12
