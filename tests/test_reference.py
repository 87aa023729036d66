"""Tests of the independent reference integrators (s2gen.reference).

Everything is checked against independent facts: closed-form solutions (great circles, the
conical pendulum), conservation laws, measured convergence orders, finite differences, the
second-order form of the equations of motion (paper eq. ELm) and SciPy's solve_ivp.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from s2gen.methods import Status
from s2gen.reference import (
    InfeasibleStep,
    NewtonFailure,
    NonFiniteState,
    ReferenceIntegrationError,
    ReferenceProblem,
    SingularSystem,
    StepSizeUnderflow,
    angular_momentum,
    continuous_rhs,
    energy,
    integrate,
    problem_from_system,
    vi_d,
    vi_jacobian,
    vi_residual,
    vi_step,
)
from s2gen.runtime import IntegrationError, Options, simulate
from s2gen.symbols import q_symbol, q_vector
from s2gen.system import System
from s2gen.systems import builtin, resolve

E3 = np.array([0.0, 0.0, 1.0])


# ---------------------------------------------------------------------------------- helpers
def order(err_coarse: float, err_fine: float) -> float:
    """Measured order from errors at h and h/2."""
    return float(np.log2(err_coarse / err_fine))


def state(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    return np.concatenate([q.ravel(), w.ravel()])


def scipy_field(problem: ReferenceProblem):
    n = problem.n

    def fun(t: float, y: np.ndarray) -> np.ndarray:
        dq, dw = continuous_rhs(problem, y[: 3 * n].reshape(n, 3), y[3 * n :].reshape(n, 3))
        return state(dq, dw)

    return fun


def tangent(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Project each w_i onto the plane orthogonal to q_i."""
    return w - np.sum(w * q, axis=1)[:, None] * q


def unit_rows(a: np.ndarray) -> np.ndarray:
    return a / np.linalg.norm(a, axis=1)[:, None]


def free_problem(mass: float = 1.0) -> ReferenceProblem:
    return ReferenceProblem(np.array([[mass]]), lambda q: np.zeros_like(q), lambda q: 0.0)


def great_circle(q0: np.ndarray, w0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Free motion: q(t) = cos(|w| t) q0 + sin(|w| t) (w/|w| x q0)."""
    speed = np.linalg.norm(w0)
    return np.outer(np.cos(speed * t), q0) + np.outer(np.sin(speed * t), np.cross(w0 / speed, q0))


def double_pendulum(m1=1.0, m2=1.0, l1=9.81, l2=9.81, g=9.81) -> ReferenceProblem:
    """Paper example 1, built through System.create and problem_from_system."""
    s = {k: sp.Symbol(k, real=True) for k in ("m1", "m2", "l1", "l2", "g")}
    inertia = sp.Matrix(
        [
            [(s["m1"] + s["m2"]) * s["l1"] ** 2, s["m2"] * s["l1"] * s["l2"]],
            [s["m2"] * s["l1"] * s["l2"], s["m2"] * s["l2"] ** 2],
        ]
    )
    potential = -(s["m1"] + s["m2"]) * s["g"] * s["l1"] * q_symbol(1, 2) - s["m2"] * s["g"] * s[
        "l2"
    ] * q_symbol(2, 2)
    system = System.create(
        name="dsp",
        n=2,
        parameters={"m1": m1, "m2": m2, "l1": l1, "l2": l2, "g": g},
        inertia=inertia,
        potential=potential,
    )
    return problem_from_system(system)


def paper_dsp_state() -> tuple[np.ndarray, np.ndarray]:
    """The paper's double-pendulum initial state (q normalized, w made tangent)."""
    q0 = unit_rows(np.array([[0.8660, 0.0, 0.5], [0.0, 0.0, 1.0]]))
    return q0, tangent(q0, np.array([[-0.4330, 0.0, 0.75], [0.0, 1.0, 0.0]]))


def nbody_system(n: int = 3) -> System:
    """Paper example 2: V = -gamma/2 sum_{i!=j} q_i.q_j / sqrt(1 - (q_i.q_j)^2), M = m I."""
    gamma, m = sp.Symbol("gamma", real=True), sp.Symbol("m", real=True)
    V = sp.Integer(0)
    for i in range(1, n + 1):
        for j in range(1, n + 1):
            if i != j:
                c = q_vector(i).dot(q_vector(j))
                V += -gamma / 2 * c / sp.sqrt(1 - c**2)
    return System.create(
        name="nbody",
        n=n,
        parameters={"m": 1.0, "gamma": 1.0},
        inertia=m * sp.eye(n),
        potential=V,
    )


def pendulum(m: float, length: float, g: float) -> ReferenceProblem:
    """Spherical pendulum, V = -m g l q.e3 (e3 points along gravity), M = m l^2."""
    return ReferenceProblem(
        np.array([[m * length**2]]),
        lambda q: -m * g * length * E3[None, :] + 0.0 * q,
        lambda q: -m * g * length * float(q[0, 2]),
    )


# ---------------------------------------------------------------------------------- equations
def test_continuous_rhs_satisfies_the_second_order_equations() -> None:
    """(qdot, wdot) reproduce paper eq. EL (q form, derived separately) and conserve energy."""
    rng = np.random.default_rng(1)
    system = nbody_system(3)
    base = problem_from_system(system)
    B = rng.normal(size=(3, 3))
    problem = ReferenceProblem(B @ B.T + 3 * np.eye(3), base.grad, base.potential)
    q = unit_rows(rng.normal(size=(3, 3)))
    w = tangent(q, rng.normal(size=(3, 3)))
    dq, dw = continuous_rhs(problem, q, w)
    M, g = problem.M, problem.grad(q)
    qddot = np.cross(dw, q) + np.cross(w, dq)
    for i in range(3):
        others = sum(M[i, j] * qddot[j] for j in range(3) if j != i)
        lhs = M[i, i] * qddot[i]
        rhs = (
            np.cross(q[i], np.cross(q[i], others))
            - (dq[i] @ dq[i]) * M[i, i] * q[i]
            + np.cross(q[i], np.cross(q[i], g[i]))
        )
        np.testing.assert_allclose(lhs, rhs, atol=1e-12 * np.abs(lhs).max())
        assert abs(q[i] @ dw[i]) < 1e-13
    dE = np.sum(M * (qddot @ dq.T)) + np.sum(g * dq)
    assert abs(dE) < 1e-12 * np.abs(M).sum() * (1 + np.abs(qddot).max())


def test_continuous_rhs_diagonal_mass_reduces_to_torque_over_mass() -> None:
    rng = np.random.default_rng(2)
    problem = problem_from_system(nbody_system(3), {"m": 1.7})
    q = unit_rows(rng.normal(size=(3, 3)))
    w = tangent(q, rng.normal(size=(3, 3)))
    _, dw = continuous_rhs(problem, q, w)
    np.testing.assert_allclose(dw, -np.cross(q, problem.grad(q)) / 1.7, rtol=1e-14, atol=1e-14)


def test_problem_from_system_gradient_matches_finite_differences() -> None:
    rng = np.random.default_rng(3)
    problem = problem_from_system(nbody_system(3), [2.0, 0.5])  # m = 2, gamma = 0.5
    np.testing.assert_array_equal(problem.M, 2.0 * np.eye(3))
    q = unit_rows(rng.normal(size=(3, 3)))
    eps = 1e-6
    fd = np.zeros((3, 3))
    for i in range(3):
        for c in range(3):
            dq = np.zeros((3, 3))
            dq[i, c] = eps
            fd[i, c] = (problem.potential(q + dq) - problem.potential(q - dq)) / (2 * eps)
    np.testing.assert_allclose(problem.grad(q), fd, rtol=1e-7, atol=1e-8)


def test_cayley_jacobian_matches_finite_differences() -> None:
    rng = np.random.default_rng(4)
    B = rng.normal(size=(3, 3))
    M = B @ B.T + np.eye(3)
    q = unit_rows(rng.normal(size=(3, 3)))
    f = 0.3 * rng.normal(size=(3, 3))
    d = rng.normal(size=(3, 3))
    J = vi_jacobian(M, q, f)
    eps = 1e-6
    fd = np.zeros((9, 9))
    for k in range(9):
        df = np.zeros((3, 3))
        df[k // 3, k % 3] = eps
        fd[:, k] = (
            (vi_residual(M, q, f + df, d) - vi_residual(M, q, f - df, d)) / (2 * eps)
        ).ravel()
    np.testing.assert_allclose(J, fd, rtol=1e-8, atol=1e-9 * np.abs(J).max())


def test_newton_solution_satisfies_the_discrete_legendre_transform() -> None:
    """q+ solves q_i x sum_j M_ij (q+_j - q_j) = d_i, stays unit, and w+ is tangent."""
    problem = double_pendulum()
    q, w = paper_dsp_state()
    h = 0.05
    q1, w1, its = vi_step(problem, q, w, h)
    assert 1 <= its <= 10
    lhs = np.cross(q, problem.M @ (q1 - q))
    np.testing.assert_allclose(lhs, vi_d(problem, q, w, h), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(q1, axis=1), 1.0, atol=1e-15)
    assert np.abs(np.sum(q1 * w1, axis=1)).max() < 1e-13


# ---------------------------------------------------------------------------------- free motion
# Leading global phase errors for free motion at rate |w| over time T (per step, theta = h|w|):
# VI rotates by asin(theta) = theta + theta^3/6 + ..., explicit midpoint by
# atan(theta/(1 - theta^2/2)) = theta + theta^3/6 + ..., RK4 by theta - theta^5/120 + ...
LEADING_ERROR = {
    "vi": (2, lambda T, s, h: T * s**3 * h**2 / 6),
    "rk2": (2, lambda T, s, h: T * s**3 * h**2 / 6),
    "rk2-proj": (2, lambda T, s, h: T * s**3 * h**2 / 6),
    "rk4": (4, lambda T, s, h: T * s**5 * h**4 / 120),
}


@pytest.mark.parametrize("method", ["vi", "rk4", "rk2", "rk2-proj"])
def test_free_motion_follows_great_circle_with_expected_order(method: str) -> None:
    q0, w0 = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.6, 0.8]) * 1.3
    expected, leading = LEADING_ERROR[method]
    T, errors = 2.0, list[float]()
    for h in (0.02, 0.01):
        tr = integrate(free_problem(2.0), method, [q0], [w0], h, round(T / h))
        errors.append(float(np.linalg.norm(tr.q[-1, 0] - great_circle(q0, w0, tr.t)[-1])))
        np.testing.assert_allclose(tr.omega[:, 0], np.tile(w0, (tr.t.size, 1)), atol=1e-13)
        assert errors[-1] == pytest.approx(leading(T, 1.3, h), rel=0.02)
    assert abs(order(*errors) - expected) < (0.1 if expected == 2 else 0.2), errors


def test_rk2_proj_keeps_unit_length_and_vi_never_renormalizes() -> None:
    q0, w0 = np.array([[0.0, 0.6, 0.8]]), np.array([[3.0, 0.0, 0.0]])
    proj = integrate(free_problem(), "rk2-proj", q0, w0, 0.05, 100)
    plain = integrate(free_problem(), "rk2", q0, w0, 0.05, 100)
    assert np.abs(np.linalg.norm(proj.q, axis=2) - 1).max() < 4e-16
    assert np.abs(np.linalg.norm(plain.q, axis=2) - 1).max() > 1e-4
    vi = integrate(free_problem(), "vi", q0, w0, 0.05, 100)
    assert np.abs(np.linalg.norm(vi.q, axis=2) - 1).max() < 1e-14


@pytest.mark.parametrize("control", ["matlab", "hairer"])
def test_rk45_free_motion_matches_great_circle_on_the_grid(control: str) -> None:
    q0, w0 = np.array([0.0, 0.0, 1.0]), np.array([2.0, -1.0, 0.0])
    tr = integrate(
        free_problem(), "rk45", [q0], [w0], 0.1, 30, rtol=1e-10, atol=1e-12, control=control
    )
    np.testing.assert_array_equal(tr.t, np.arange(31) * 0.1)
    assert np.abs(tr.q[:, 0] - great_circle(q0, w0, tr.t)).max() < 1e-8
    assert tr.stats["steps"] > 0 and tr.stats["rhs_evaluations"] >= 6 * tr.stats["steps"]


# ---------------------------------------------------------------------------------- pendulum
def conical_orbit(m=1.3, length=0.7, g=9.81, theta=0.6):
    """q = (sin th cos Om t, sin th sin Om t, cos th), w = Om (e3 - cos th q).

    Then qdot = Om e3 x q and wdot = -Om^2 cos th (e3 x q); the equation
    m l^2 wdot = -q x (-m g l e3) = -m g l e3 x q gives Om^2 = g / (l cos th).
    """
    problem = pendulum(m, length, g)
    rate = np.sqrt(g / (length * np.cos(theta)))
    q0 = np.array([[np.sin(theta), 0.0, np.cos(theta)]])
    w0 = rate * (E3 - np.cos(theta) * q0)

    def exact(t: np.ndarray) -> np.ndarray:
        c = np.cos(theta) * np.ones_like(t)
        return np.stack([np.sin(theta) * np.cos(rate * t), np.sin(theta) * np.sin(rate * t), c], 1)

    return problem, q0, w0, exact, np.cos(theta), 2 * np.pi / rate


def test_conical_pendulum_rk_methods_keep_the_cone() -> None:
    problem, q0, w0, exact, cos_th, period = conical_orbit()
    errors = []
    for N in (100, 200):
        tr = integrate(problem, "rk4", q0, w0, 2 * period / N, N)
        assert np.abs(tr.q[:, 0, 2] - cos_th).max() < 1e-14
        errors.append(np.abs(tr.q[:, 0] - exact(tr.t)).max())
    assert abs(order(*errors) - 4) < 0.2
    for control in ("matlab", "hairer"):
        tr = integrate(
            problem, "rk45", q0, w0, period / 20, 40, rtol=1e-10, atol=1e-12, control=control
        )
        assert np.abs(tr.q[:, 0, 2] - cos_th).max() < 1e-14
        assert np.abs(tr.q[:, 0] - exact(tr.t)).max() < 1e-8


def test_conical_pendulum_vi_stays_near_cone_with_second_order_error() -> None:
    problem, q0, w0, exact, cos_th, period = conical_orbit()
    errors, cone = [], []
    for N in (200, 400):
        tr = integrate(problem, "vi", q0, w0, 2 * period / N, N)
        errors.append(np.abs(tr.q[:, 0] - exact(tr.t)).max())
        cone.append(np.abs(tr.q[:, 0, 2] - cos_th).max())
        assert tr.stats["newton_iterations_total"] == 0  # explicit update
        assert abs(angular_momentum(problem, tr.q[-1], tr.omega[-1])[2]) > 0
    assert abs(order(*errors) - 2) < 0.1
    assert abs(order(*cone) - 2) < 0.1


# ---------------------------------------------------------------------------------- coupled M
def test_double_pendulum_long_run_unit_length_and_momentum() -> None:
    """Paper example 1: 10^4 Newton-VI steps (h = 0.01, T = 100), nothing renormalized."""
    problem = double_pendulum()
    q0, w0 = paper_dsp_state()
    tr = integrate(problem, "vi", q0, w0, 0.01, 10_000)
    assert np.abs(np.linalg.norm(tr.q, axis=2) - 1).max() < 1e-13
    J = np.array([angular_momentum(problem, q, w) for q, w in zip(tr.q, tr.omega)])
    assert np.abs(J[:, 2] - J[0, 2]).max() < 1e-12 * np.linalg.norm(J[0])
    assert tr.stats["steps"] == 10_000
    assert 1 <= tr.stats["newton_iterations_max"] <= 6
    assert tr.stats["newton_iterations_total"] >= 10_000


def test_double_pendulum_energy_error_is_second_order() -> None:
    problem = double_pendulum()
    q0, w0 = paper_dsp_state()
    errors = []
    for h in (0.02, 0.01):
        tr = integrate(problem, "vi", q0, w0, h, round(5.0 / h))
        errors.append(np.abs(tr.energy - tr.energy[0]).max())
        np.testing.assert_allclose(tr.energy[0], energy(problem, q0, w0))
    assert abs(order(*errors) - 2) < 0.1


def test_double_pendulum_vi_converges_to_tight_rk45() -> None:
    """VI at h, h/2 approaches RK45 (rtol 1e-10) at T = 1 as h^2; Richardson removes it."""
    problem = double_pendulum()
    q0, w0 = paper_dsp_state()
    ref = integrate(problem, "rk45", q0, w0, 0.5, 2, rtol=1e-10, atol=1e-12)
    finals = []
    for h in (0.004, 0.002):
        tr = integrate(problem, "vi", q0, w0, h, round(1.0 / h))
        finals.append(state(tr.q[-1], tr.omega[-1]))
    exact = state(ref.q[-1], ref.omega[-1])
    diffs = [np.abs(y - exact).max() for y in finals]
    assert abs(order(*diffs) - 2) < 0.1
    richardson = (4 * finals[1] - finals[0]) / 3
    assert np.abs(richardson - exact).max() < diffs[1] / 20


# ---------------------------------------------------------------------------------- n-body
def test_three_body_explicit_vi_conserves_angular_momentum() -> None:
    """Paper example 2 (3 bodies, m = gamma = 1): J conserved to round-off, explicit steps."""
    problem = problem_from_system(nbody_system(3))
    q0 = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    w0 = np.array([[0.0, 0.0, -1.1], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    tr = integrate(problem, "vi", q0, w0, 1e-3, 10_000)
    J = np.array([angular_momentum(problem, q, w) for q, w in zip(tr.q, tr.omega)])
    assert np.abs(J - J[0]).max() < 1e-12 * np.linalg.norm(J[0])
    assert tr.stats["newton_iterations_total"] == 0
    assert np.abs(np.linalg.norm(tr.q, axis=2) - 1).max() < 1e-13


# ---------------------------------------------------------------------------------- rk45
@pytest.mark.parametrize("control", ["matlab", "hairer"])
def test_rk45_error_decreases_with_rtol(control: str) -> None:
    problem = double_pendulum(l1=1.0, l2=1.0)
    q0, w0 = paper_dsp_state()
    T = 3.0
    exact = solve_ivp(
        scipy_field(problem), (0, T), state(q0, w0), method="DOP853", rtol=1e-13, atol=1e-13
    ).y[:, -1]
    errors, steps = [], []
    for rtol in (1e-3, 1e-5, 1e-7, 1e-9):
        tr = integrate(
            problem, "rk45", q0, w0, T / 10, 10, rtol=rtol, atol=rtol * 1e-3, control=control
        )
        errors.append(np.abs(state(tr.q[-1], tr.omega[-1]) - exact).max())
        steps.append(tr.stats["steps"])
    assert all(a > b for a, b in itertools.pairwise(errors)), errors
    assert errors[-1] < 1e-4 * errors[0]
    assert all(a < b for a, b in itertools.pairwise(steps)), steps


@pytest.mark.parametrize("rtol", [1e-4, 1e-7])
def test_rk45_hairer_control_matches_scipy_solve_ivp(rtol: float) -> None:
    problem = double_pendulum(l1=1.0, l2=1.0)
    q0, w0 = paper_dsp_state()
    T, atol = 3.0, rtol * 1e-3
    sol = solve_ivp(
        scipy_field(problem), (0, T), state(q0, w0), method="RK45", rtol=rtol, atol=atol
    )
    tr = integrate(problem, "rk45", q0, w0, T / 6, 6, rtol=rtol, atol=atol, control="hairer")
    y = state(tr.q[-1], tr.omega[-1])
    scale = atol + rtol * np.abs(sol.y[:, -1])
    assert np.abs(y - sol.y[:, -1]).max() <= 3 * scale.max()
    accepted = sol.t.size - 1
    assert abs(tr.stats["steps"] - accepted) <= 0.1 * accepted


def test_rk45_matlab_control_respects_hmax() -> None:
    """ode45's default hmax = T/10 forces at least ten steps even for trivial motion."""
    tr = integrate(free_problem(), "rk45", [[1.0, 0, 0]], [[0, 0, 1e-3]], 1.0, 1)
    assert tr.stats["steps"] >= 10 and tr.stats["rejected"] == 0
    assert tr.stats["rhs_evaluations"] == 1 + 6 * tr.stats["steps"]


@pytest.mark.parametrize("control", ["matlab", "hairer"])
def test_the_reference_backend_honours_hmax(control: str) -> None:
    """Options.hmax reaches the reference backend: with steps capped at 0.003 (a tenth of what
    the tolerance allows) it takes the emitted C's and NumPy's steps, sample for sample."""
    s = resolve("double_pendulum")
    o = Options(hmax=0.003, control=control, rtol=1e-6, atol=1e-9)
    runs = {
        b: simulate(s, "rk45", b, h=0.01, T=1.0, options=o) for b in ("c", "numpy", "reference")
    }
    free = simulate(s, "rk45", "reference", h=0.01, T=1.0, options=Options(control=control))
    assert runs["reference"].stats["steps"] >= 1.0 / 0.003 > 3 * free.stats["steps"]
    for b in ("c", "numpy"):
        assert runs[b].stats["steps"] == runs["reference"].stats["steps"], b
        assert np.abs(runs[b].q - runs["reference"].q).max() < 1e-12, b


# ---------------------------------------------------------------------------------- failures
def test_infeasible_explicit_step_raises_with_partial_trajectory() -> None:
    problem = pendulum(1.0, 1.0, 9.81)  # released from the horizontal, speeds up to ~4.4 rad/s
    with pytest.raises(ReferenceIntegrationError) as info:
        integrate(problem, "vi", [[1.0, 0, 0]], [[0, 0, 0.0]], 0.25, 100)
    exc = info.value
    assert exc.step > 0 and f"step {exc.step}" in str(exc) and "body 1" in str(exc)
    assert exc.partial is not None and exc.partial.t.size == exc.step + 1
    assert np.all(np.isfinite(exc.partial.q)) and np.all(np.isfinite(exc.partial.energy))
    np.testing.assert_allclose(exc.partial.t, 0.25 * np.arange(exc.step + 1))


def test_newton_failure_names_the_step() -> None:
    problem = double_pendulum()
    q0, w0 = paper_dsp_state()
    with pytest.raises(ReferenceIntegrationError, match="step 0: Newton") as info:
        integrate(problem, "vi", q0, w0, 0.01, 5, newton_maxiter=1)
    assert info.value.partial is not None and info.value.partial.t.size == 1


def test_non_finite_state_raises() -> None:
    nan_below = ReferenceProblem(
        np.array([[1.0]]),
        lambda q: np.full_like(q, np.nan) if q[0, 2] < 0 else np.zeros_like(q),
        lambda q: 0.0,
    )
    with pytest.raises(ReferenceIntegrationError, match="non-finite") as info:
        integrate(nan_below, "rk4", [[0.0, 0, 1]], [[1.0, 0, 0]], 0.1, 40)
    assert info.value.partial is not None and 5 < info.value.partial.t.size < 40


# ---------------------------------------------------------------------------------- typed failures
def test_explicit_step_with_huge_h_is_infeasible() -> None:
    """Diagonal M, h = 10: |a|^2 = (h^2/2 |q x g| / M)^2 >> 1 at the very first step."""
    with pytest.raises(InfeasibleStep, match="step 0: explicit VI step infeasible") as info:
        integrate(pendulum(1.0, 1.0, 9.81), "vi", [[1.0, 0, 0]], [[0, 0, 0.0]], 10.0, 3)
    exc = info.value
    assert isinstance(exc, ReferenceIntegrationError) and exc.status is Status.INFEASIBLE
    assert exc.step == 0 and exc.partial is not None and exc.partial.t.size == 1


def test_newton_with_huge_h_on_the_double_pendulum_fails() -> None:
    """The coupled double pendulum from its built-in spec, h = 10: Newton cannot converge."""
    system = builtin("double_pendulum")
    problem = problem_from_system(system)
    with np.errstate(all="ignore"), pytest.raises(NewtonFailure, match="step 0: Newton") as info:
        integrate(problem, "vi", system.q0, system.omega0, 10.0, 3)  # iterates overflow
    exc = info.value
    assert exc.status is Status.NEWTON and exc.partial is not None and exc.partial.t.size == 1


def test_singular_newton_jacobian_is_a_newton_failure() -> None:
    """M = [[1, 1], [1, 1]] (symmetric, singular) with q1 = q2: the Cayley Jacobian is singular
    at Newton's first iterate; that is reported as Newton's failure, not as a singular system."""
    problem = ReferenceProblem(np.ones((2, 2)), lambda q: np.zeros_like(q), lambda q: 0.0)
    q0, w0 = [[0, 0, 1.0], [0, 0, 1.0]], [[1.0, 0, 0], [0, 1.0, 0]]
    with pytest.raises(NewtonFailure, match="singular Jacobian at iteration 1") as info:
        integrate(problem, "vi", q0, w0, 0.1, 3)
    assert info.value.status is Status.NEWTON and info.value.step == 0


@pytest.mark.parametrize(
    ("method", "control"),
    [("rk2", "matlab"), ("rk4", "matlab"), ("rk45", "matlab"), ("rk45", "hairer")],
)
def test_singular_inertia_operator_in_the_field_is_a_singular_system(
    method: str, control: str
) -> None:
    """The same singular M: A(q) wdot = b has no solution, a SingularSystem at step 0 (for
    rk45 already in the first field evaluation, before any step)."""
    problem = ReferenceProblem(np.ones((2, 2)), lambda q: np.zeros_like(q), lambda q: 0.0)
    q0, w0 = [[0, 0, 1.0], [0, 0, 1.0]], [[1.0, 0, 0], [0, 1.0, 0]]
    with pytest.raises(SingularSystem, match="step 0: linear solve failed") as info:
        integrate(problem, method, q0, w0, 0.1, 3, control=control)
    assert info.value.status is Status.SINGULAR
    assert info.value.partial is not None and info.value.partial.t.size == 1


@pytest.mark.parametrize("method", ["rk4", "rk45"])
def test_non_finite_gradient_is_a_non_finite_state(method: str) -> None:
    nan_below = ReferenceProblem(
        np.array([[1.0]]),
        lambda q: np.full_like(q, np.nan) if q[0, 2] < 0 else np.zeros_like(q),
        lambda q: 0.0,
    )
    with pytest.raises(NonFiniteState, match="non-finite") as info:
        integrate(nan_below, method, [[0.0, 0, 1]], [[1.0, 0, 0]], 0.1, 40)
    exc = info.value
    assert exc.status is Status.NONFINITE
    assert exc.partial is not None and 5 < exc.partial.t.size < 40


@pytest.mark.parametrize("control", ["matlab", "hairer"])
def test_rk45_step_size_underflows_at_a_force_wall(control: str) -> None:
    """A force of 1e30 switched on below the equator: crossing it at t = pi/2 (great circle at
    unit speed from the north pole), the field jumps by 1e30, so no step above the minimum step
    size (about 16 eps(t)) meets the default tolerances. (A tight rtol alone does not underflow:
    with atol = 1e-6 the control is absolute; with atol tiny as well, the run creeps near t = 0,
    where the minimum step is subnormal, instead of failing.)"""
    wall = 1e30
    problem = ReferenceProblem(
        np.array([[1.0]]),
        lambda q: np.where(q[:, 2:3] < 0.0, -wall, 0.0) * E3[None, :],
        lambda q: wall * max(0.0, -float(q[0, 2])),
    )
    with pytest.raises(StepSizeUnderflow, match="fell below") as info:
        integrate(problem, "rk45", [[0.0, 0, 1.0]], [[1.0, 0, 0]], 0.5, 4, control=control)
    exc = info.value
    assert exc.status is Status.STEPSIZE and exc.step == 3  # the step from t = 1.5 to 2
    assert exc.partial is not None
    np.testing.assert_allclose(exc.partial.t, [0.0, 0.5, 1.0, 1.5])
    assert np.all(np.isfinite(exc.partial.q)) and np.all(exc.partial.q[:, 0, 2] > 0.0)


@pytest.mark.parametrize(
    ("name", "h", "options", "status"),
    [
        ("three_bodies", 0.9, Options(), Status.INFEASIBLE),
        ("double_pendulum", 0.01, Options(newton_maxiter=2), Status.NEWTON),
    ],
)
def test_reference_backend_reports_the_status_of_the_error(
    name: str, h: float, options: Options, status: Status
) -> None:
    """simulate(backend="reference") takes the status from the error's type, as the emitted
    backends report theirs (tests/test_failures.py)."""
    with pytest.raises(IntegrationError) as info:
        simulate(builtin(name), "vi", "reference", h=h, T=90 * h, options=options)
    assert info.value.status == int(status)


def test_bad_arguments_are_rejected() -> None:
    with pytest.raises(ValueError, match="unknown method"):
        integrate(free_problem(), "euler", [[1.0, 0, 0]], [[0, 0, 1.0]], 0.1, 1)
    with pytest.raises(ValueError, match="shape"):
        integrate(free_problem(), "vi", [[1.0, 0, 0, 0]], [[0, 0, 1.0]], 0.1, 1)
    with pytest.raises(ValueError, match="control"):
        integrate(free_problem(), "rk45", [[1.0, 0, 0]], [[0, 0, 1.0]], 0.1, 1, control="x")
