"""A driven spec in numbers (`driven_problem_from_system`) against the same physics by hand.

The damped, periodically driven double pendulum of tests/test_reference_forced.py (its
`DrivenProblem` written in NumPy by hand) is written here as a spec; the spec's problem must
give the same V, dV/dq, dV/dt and F at random states, and the reference integrator the same
trajectory and work to round-off. Forced Noether on the spec's problem: the change of J.e3
equals the discrete impulse of a torque about e3 computed from its closed form.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_reference_forced import E3, damped_driven, held_inputs, start

from s2gen.reference import angular_momentum
from s2gen.reference.driven_system import driven_problem_from_system
from s2gen.reference.forced_integrate import integrate_driven
from s2gen.spec import define_system, load_spec_text

SPEC = """\
name = "damped_driven"
bodies = 2
[parameters]
m1 = 1.0
m2 = 1.5
l1 = 1.0
l2 = 0.8
g = 9.81
c = 0.4
Om = 2.3
[inputs]
a = 0.0
b = 0.0
[inertia]
M = [["(m1 + m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]]
[potential]
V = "(m1 + m2)*g*l1*q1[2] + m2*g*l2*q2[2] + a*sin(Om*t)*q1[0]"
[forces]
F2 = "b*cos(Om*t)*l2*e1"
[[forces.body]]
F = "-c*cross(w, q)"
"""


def random_states(count: int, seed: int = 5) -> list[tuple[np.ndarray, np.ndarray, float]]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        q = rng.normal(size=(2, 3))
        q /= np.linalg.norm(q, axis=1)[:, None]
        out.append((q, rng.normal(size=(2, 3)), float(rng.uniform(0, 5))))
    return out


def test_the_spec_problem_evaluates_like_the_hand_written_one() -> None:
    spec = driven_problem_from_system(load_spec_text(SPEC, origin="spec.toml"))
    hand = damped_driven()
    np.testing.assert_allclose(spec.M, hand.M, rtol=1e-15)
    u = np.array([1.3, -0.7])
    for q, w, t in random_states(5):
        assert spec.V(q, t, u) == pytest.approx(hand.V(q, t, u), rel=1e-13)
        np.testing.assert_allclose(spec.dVdq(q, t, u), hand.dVdq(q, t, u), rtol=1e-13)
        assert spec.dVdt(q, t, u) == pytest.approx(hand.dVdt(q, t, u), rel=1e-13)
        np.testing.assert_allclose(spec.F(q, w, t, u), hand.F(q, w, t, u), atol=1e-14)
    assert spec.implicit_velocity and spec.n_inputs == 2


@pytest.mark.parametrize("method", ["vi", "vi4", "rattle", "rk4"])
def test_the_spec_problem_integrates_like_the_hand_written_one(method: str) -> None:
    """300 steps with held inputs that jump every 0.1: states and work to 1e-10."""
    h, n = 0.01, 300
    q0, w0 = start()
    U = held_inputs(h, n)
    spec = driven_problem_from_system(load_spec_text(SPEC, origin="spec.toml"))
    a = integrate_driven(spec, method, q0, w0, h, n, inputs=U, t0=0.25)
    b = integrate_driven(damped_driven(), method, q0, w0, h, n, inputs=U, t0=0.25)
    np.testing.assert_allclose(a.q, b.q, atol=1e-10)
    np.testing.assert_allclose(a.omega, b.omega, atol=1e-10)
    np.testing.assert_allclose(a.work, b.work, atol=1e-10)
    assert np.max(np.abs(a.work)) > 0.1


def test_forced_noether_on_the_spec_problem() -> None:
    """An axisymmetric pendulum (gravity along e3) turned by an input torque about e3 and
    damped: J.e3 changes by the discrete impulse e3 . sum_i h/2 (q_i x F_i + q_i+ x F_i+)
    of the closed-form force."""
    system = define_system(
        name="turned",
        bodies=1,
        parameters={"m": 1.2, "g": 9.81, "c": 0.3},
        inputs={"tau": 0.0},
        diagonal=["m"],
        potential="m*g*q1[2]",
        force_terms=[{"F": "tau*(1 + cos(1.7*t)/2)*cross(e3, q) - c*cross(w, q)"}],
    )
    p = driven_problem_from_system(system)
    q0 = np.array([[0.6, 0.0, -0.8]])
    w0 = np.array([[0.0, 0.4, 0.0]])
    h, n = 0.01, 400
    U = np.column_stack([3.0 + np.sin(np.arange(n))])
    tr = integrate_driven(p, "vi", q0, w0, h, n, inputs=U)

    def force(q: np.ndarray, w: np.ndarray, t: float, u: float) -> np.ndarray:
        return u * (1 + np.cos(1.7 * t) / 2) * np.cross(E3, q) - 0.3 * np.cross(w, q)

    J3 = np.array([angular_momentum(p.base, q, w)[2] for q, w in zip(tr.q, tr.omega)])
    impulse = [
        0.5
        * h
        * float(
            E3
            @ (
                np.cross(tr.q[k, 0], force(tr.q[k, 0], tr.omega[k, 0], tr.t[k], U[k, 0]))
                + np.cross(
                    tr.q[k + 1, 0],
                    force(tr.q[k + 1, 0], tr.omega[k + 1, 0], tr.t[k + 1], U[k, 0]),
                )
            )
        )
        for k in range(n)
    ]
    assert abs(J3[-1] - J3[0]) > 0.1
    assert np.max(np.abs(J3[1:] - J3[0] - np.cumsum(impulse))) < 1e-12


def test_a_closed_system_has_no_drive() -> None:
    s = define_system(
        name="p", bodies=1, parameters={"m": 1.0}, diagonal=["m"], potential="m*q1[2]"
    )
    p = driven_problem_from_system(s)
    assert p.force is None and p.n_inputs == 0
    q = np.array([[0.0, 0.6, 0.8]])
    assert p.dVdt(q, 1.0, np.zeros(0)) == 0.0
    np.testing.assert_allclose(p.dVdq(q, 1.0, np.zeros(0)), [[0.0, 0.0, 1.0]])
