"""Driven systems through the emitted C: forces, time-dependent potentials and held inputs.

Independent checks only: agreement with the reference integrator's own forced equations
(`s2gen.reference.forced*`, which never sees the templates) for every driven method on a
coupled system with velocity-dependent forces, a diagonal one with a cross-body force and a
force term, one with time only and the rope whose top moves (structured solver); the inputs a
state feedback was called with, recomputed from the trajectory; the energy balance
E - E0 - W converging at each method's order and the state's observed orders; the forced
Noether theorem (the change of J.e3 equals the discrete impulse of a torque about e3); and
Kapitza's criterion a^2 W^2 > 2 g l for the inverted pendulum.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import s2gen
from s2gen.methods import driven_methods
from s2gen.reference.driven_system import driven_problem_from_system
from s2gen.reference.forced_integrate import integrate_driven
from s2gen.runtime.trajectory import IntegrationError
from s2gen.spec import define_system, load_spec_text
from s2gen.system import SpecError, System

SPECS = Path(__file__).parent / "specs"
#: Driven systems: coupled M, velocity-dependent forces, time and an input; diagonal M with a
#: cross-body velocity-dependent force, a force term and two inputs; time only; the rope
#: (max-index M, structured solves) with a moving top
CASES = {
    "driven_double": lambda: s2gen.load(str(SPECS / "driven_double.toml")),
    "driven_ring": lambda: s2gen.load(str(SPECS / "driven_ring.toml")),
    "driven_timed": lambda: s2gen.load(str(SPECS / "driven_timed.toml")),
    "rope_top": lambda: s2gen.load("rope:n=4,top_radius=0.2"),
}
ORDERS = {"vi": 2, "vi4": 4, "vi6": 6, "vi8": 8, "rk2": 2, "rk3": 3, "rk4": 4}
ORDERS |= {"rattle": 2, "rattle4": 4, "rattle6": 6, "rattle8": 8}
#: RATTLE takes forces only with a diagonal M: driven_double (coupled, forces) runs the rest
RUNS = [
    (case, method)
    for case in sorted(CASES)
    for method in driven_methods(rattle=case != "driven_double", adaptive=False)
]


def quiet_simulate(system: System, method: str, **kwargs: object) -> s2gen.Trajectory:
    """A run without the energy-balance warning (coarse steps on purpose)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return s2gen.simulate(system, method, **kwargs)  # type: ignore[arg-type]


@pytest.mark.parametrize(("case", "method"), RUNS)
def test_emitted_c_agrees_with_the_reference(case: str, method: str) -> None:
    """q, omega, E and W of the emitted C against the reference, from t0 = 0.3 with random
    inputs that change every step (their jumps of V are work)."""
    system = CASES[case]()
    h, n = 0.01 if case != "rope_top" else 0.002, 60
    rng = np.random.default_rng(7)
    U = rng.normal(size=(n, len(system.inputs.names)))
    tr = quiet_simulate(system, method, h=h, T=n * h, t0=0.3, inputs=U)
    ref = integrate_driven(
        driven_problem_from_system(system), method, system.q0, system.omega0, h, n, inputs=U, t0=0.3
    )
    assert np.allclose(tr.t, 0.3 + h * np.arange(n + 1), rtol=0, atol=1e-12)
    scale = max(1.0, float(np.max(np.abs(ref.energy))))
    assert np.max(np.abs(tr.q - ref.q)) < 1e-10
    assert np.max(np.abs(tr.omega - ref.omega)) < 1e-10 * max(1.0, np.max(np.abs(ref.omega)))
    assert np.max(np.abs(tr.energy - ref.energy)) < 1e-10 * scale
    assert tr.work is not None and np.max(np.abs(tr.work - ref.work)) < 1e-10 * scale
    assert tr.inputs is not None and np.array_equal(tr.inputs, U)


def test_state_feedback_is_called_with_the_state_of_each_step() -> None:
    """u(t, q, w) is called once per step with t_k and the state at t_k: the inputs held are
    the function of the stored samples, and the run is the reference's with those inputs."""
    system = CASES["driven_double"]()

    def law(t: float, q: np.ndarray, w: np.ndarray) -> list[float]:
        return [-2.0 * q[1, 0] - 0.5 * w[1, 1] + 0.1 * np.sin(t)]

    h, n = 0.01, 80
    tr = quiet_simulate(system, "vi4", h=h, T=n * h, inputs=law)
    assert tr.inputs is not None and tr.inputs.shape == (n, 1)
    again = np.array([law(t, q, w) for t, q, w in zip(tr.t[:-1], tr.q[:-1], tr.omega[:-1])])
    assert np.array_equal(tr.inputs, again)
    ref = integrate_driven(
        driven_problem_from_system(system), "vi4", system.q0, system.omega0, h, n, inputs=tr.inputs
    )
    assert np.max(np.abs(tr.q - ref.q)) < 1e-10


@pytest.mark.parametrize("method", sorted(ORDERS))
def test_energy_balance_and_state_converge_at_the_method_order(method: str) -> None:
    """On the damped, periodically forced double pendulum (built-in; for RATTLE, whose forces
    need a diagonal M here, the driven ring): max |E - E0 - W| over the run falls like h^p as
    h halves (the VI and RATTLE families), or converges (Runge-Kutta), and the state's error
    (step doubling) falls like h^p."""
    rattle = method.startswith("rattle")
    system = CASES["driven_ring"]() if rattle else s2gen.load("forced_double_pendulum")
    p = ORDERS[method]
    hs = (0.08, 0.04, 0.02) if p >= 6 else (0.02, 0.01, 0.005)
    if rattle:  # the ring's motion is slower: coarser steps keep the errors above round-off
        hs = (0.2, 0.1, 0.05) if p >= 6 else (0.08, 0.04, 0.02)
    runs = [quiet_simulate(system, method, h=h, T=2.0) for h in hs]
    balance = [float(np.max(np.abs(tr.balance))) for tr in runs]  # type: ignore[arg-type]
    end = [np.concatenate([tr.q[-1].ravel(), tr.omega[-1].ravel()]) for tr in runs]
    rate = np.log2(np.max(np.abs(end[0] - end[1])) / np.max(np.abs(end[1] - end[2])))
    assert rate > p - 0.3, (method, rate)
    if method.startswith(("vi", "rattle")):
        assert np.log2(balance[1] / balance[2]) > p - 0.5, (method, balance)
    else:
        assert balance[2] < balance[0] / 2 ** (p - 1), (method, balance)


def test_forced_noether_for_the_vi() -> None:
    """An axisymmetric coupled system (the double pendulum, gravity along e3) driven by a
    torque input tau about e3 on link 1: the change of J.e3 over each VI step equals the
    discrete impulse (h/2) e3.(q x F at both ends of the step) to round-off."""
    system = define_system(
        name="spun",
        bodies=2,
        parameters={"m1": 1.0, "m2": 1.5, "l1": 1.0, "l2": 0.8, "g": 9.81},
        inputs={"tau": 0.0},
        inertia=[["(m1 + m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]],
        potential="(m1 + m2)*g*l1*q1[2] + m2*g*l2*q2[2]",
        forces={"F1": "tau*cross(e3, q1)"},
        initial_q=[[0.6, 0.0, -0.8], [0.0, 0.6, -0.8]],
        initial_omega=[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
    )
    h, n = 0.01, 300
    U = np.sin(0.05 * np.arange(n))[:, None] * 3.0
    tr = quiet_simulate(system, "vi", h=h, T=n * h, inputs=U)
    J = tr.momentum[:, 2]  # type: ignore[index]
    q1 = tr.q[:, 0]
    # q x (tau e3 x q) . e3 = tau (1 - q_z^2) for a unit q
    torque = 1.0 - q1[:, 2] ** 2
    impulse = 0.5 * h * U[:, 0] * (torque[:-1] + torque[1:])
    assert np.max(np.abs(np.diff(J) - impulse)) < 1e-12 * max(1.0, np.max(np.abs(J)))
    assert np.max(np.abs(np.diff(J))) > 1e-3  # the torque does change J


@pytest.mark.parametrize(("rate", "upright"), [(60.0, True), (30.0, False)])
def test_kapitza_inverted_pendulum(rate: float, upright: bool) -> None:
    """Kapitza's pendulum (built-in), started 0.05 rad from the top at rest, over 200 periods
    of its support: within 0.1 rad of the top when a^2 W^2 > 2 g l (a W = 6 > 4.43), leaving
    it when a^2 W^2 < 2 g l (a W = 3)."""
    system = s2gen.load(f"kapitza:W={rate}")
    p = system.parameters
    assert (p["a"] ** 2 * rate**2 > 2 * p["g"] * p["l"]) == upright
    periods = 200
    T = round(periods * 2 * np.pi / rate, 2)
    tr = quiet_simulate(system, "vi", h=1e-3, T=T, every=10)
    angle = np.arccos(np.clip(tr.q[:, 0, 2], -1.0, 1.0))
    assert (np.max(angle) < 0.1) == upright, float(np.max(angle))


def test_held_inputs_are_the_defaults_without_inputs() -> None:
    """No inputs given: the spec's defaults are held (the same run as giving them)."""
    system = CASES["driven_ring"]()
    defaults = np.tile(system.inputs.values, (50, 1))
    a = quiet_simulate(system, "rk4", h=0.01, T=0.5)
    b = quiet_simulate(system, "rk4", h=0.01, T=0.5, inputs=defaults)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.inputs, defaults)  # type: ignore[arg-type]


def test_a_saved_driven_trajectory_keeps_work_and_inputs(tmp_path: Path) -> None:
    system = CASES["driven_double"]()
    tr = quiet_simulate(system, "vi", h=0.01, T=0.2, inputs=np.full((20, 1), 0.5))
    back = s2gen.Trajectory.load(tr.save(tmp_path / "run.npz"))
    assert np.array_equal(back.work, tr.work) and np.array_equal(back.inputs, tr.inputs)  # type: ignore[arg-type]


# ------------------------------------------------------------------ bad input: one line each
def test_inputs_of_the_wrong_shape() -> None:
    system = CASES["driven_ring"]()
    with pytest.raises(ValueError, match=r"inputs of shape \(10, 1\): expected \(10, 2\)"):
        s2gen.simulate(system, "vi", h=0.01, T=0.1, inputs=np.zeros((10, 1)))


def test_a_non_finite_input_stops_the_run_and_keeps_the_samples() -> None:
    system = CASES["driven_ring"]()
    U = np.zeros((10, 2))
    U[6, 1] = np.nan
    with pytest.raises(IntegrationError, match="input is not finite") as err:
        s2gen.simulate(system, "vi", h=0.01, T=0.1, inputs=U)
    assert len(err.value.partial.t) == 7 and np.all(np.isfinite(err.value.partial.q))


@pytest.mark.parametrize(
    ("law", "fragment"),
    [
        (lambda t, q, w: [1.0 / (t - t)], "ZeroDivisionError"),
        (lambda t, q, w: [np.nan], "expected 1 finite numbers"),
        (lambda t, q, w: [1.0, 2.0], "expected 1 finite numbers"),
    ],
)
def test_a_failing_feedback_stops_the_run_with_its_reason(law: object, fragment: str) -> None:
    system = CASES["driven_double"]()
    with pytest.raises(IntegrationError, match=fragment) as err:
        s2gen.simulate(system, "vi", h=0.01, T=0.1, inputs=law)
    assert "the input function at t = 0" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("method", ["rk2-proj"])
def test_methods_that_do_not_drive_yet_are_refused(method: str) -> None:
    with pytest.raises(ValueError, match=f"method '{method}' does not integrate driven"):
        s2gen.simulate(CASES["driven_timed"](), method, h=0.01, T=0.1)


def test_rattle_with_forces_and_a_coupled_inertia_is_refused() -> None:
    with pytest.raises(ValueError, match="method 'rattle4' takes forces only with a diagonal"):
        s2gen.simulate(CASES["driven_double"](), "rattle4", h=0.01, T=0.1)


def test_the_reference_backend_refuses_driven_systems() -> None:
    system = CASES["driven_timed"]()
    with pytest.raises(SpecError, match="building the reference problem for driven systems"):
        s2gen.simulate(system, "vi", backend="reference", h=0.01, T=0.1)


def test_inputs_for_a_closed_system_and_a_bad_start_time() -> None:
    with pytest.raises(ValueError, match="the system has no \\[inputs\\]"):
        s2gen.simulate(s2gen.load("double_pendulum"), h=0.01, T=0.1, inputs=np.zeros((10, 0)))
    with pytest.raises(ValueError, match="t0 = nan: must be a finite number"):
        s2gen.simulate(CASES["driven_timed"](), h=0.01, T=0.1, t0=float("nan"))


def test_forces_with_a_structured_solver_are_refused() -> None:
    text = (SPECS / "chain4.toml").read_text()
    text = text.replace("[inertia]\n", '[inertia]\nsolver = "structured"\n')
    text += '\n[forces]\nF1 = "-0.1*cross(w1, q1)"\n'
    system = load_spec_text(text)
    with pytest.raises(SpecError, match='forces with a structured inertia solver.*"dense"'):
        s2gen.simulate(system, "vi", h=0.01, T=0.1)


def test_what_does_not_take_driven_systems_yet_says_so() -> None:
    system = CASES["driven_timed"]()
    with pytest.raises(ValueError, match="the stepper does not take driven systems yet"):
        s2gen.compile(system).stepper("vi", h=0.01)
    with pytest.raises(ValueError, match="method 'rk2-proj' does not integrate driven"):
        s2gen.fmu(system, "unused.fmu", method="rk2-proj", h=0.01)


@pytest.mark.parametrize("method", ["vi", "rattle"])
def test_forced_noether_with_a_diagonal_inertia(method: str) -> None:
    """Two bodies (diagonal M) with an axisymmetric potential and a torque input about e3 on
    body 1: for the VI and RATTLE, the change of J.e3 over each step equals the discrete
    impulse (h/2) e3.(q x F) at both ends of the step, to round-off."""
    system = define_system(
        name="spun2",
        bodies=2,
        parameters={"k": 2.0},
        inputs={"tau": 0.0},
        diagonal=["1.5", "0.8"],
        potential="9.81*(q1[2] + 0.5*q2[2]) + k*dot(q1, q2)",
        forces={"F1": "tau*cross(e3, q1)"},
        initial_q=[[0.6, 0.0, -0.8], [0.0, 0.6, -0.8]],
        initial_omega=[[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]],
    )
    h, n = 0.01, 300
    U = np.sin(0.05 * np.arange(n))[:, None] * 3.0
    tr = quiet_simulate(system, method, h=h, T=n * h, inputs=U)
    J = tr.momentum[:, 2]  # type: ignore[index]
    torque = 1.0 - tr.q[:, 0, 2] ** 2
    impulse = 0.5 * h * U[:, 0] * (torque[:-1] + torque[1:])
    assert np.max(np.abs(np.diff(J) - impulse)) < 1e-13
    assert np.max(np.abs(np.diff(J))) > 1e-3


CHAIN3 = """\
name = "chain3"
bodies = 3
[parameters]
m = 1.0
g = 9.81
c = 0.3
[inertia]
M = [["3*m", "2*m", "m"], ["2*m", "2*m", "m"], ["m", "m", "m"]]
[potential]
V = "m*g*(3*q1[2] + 2*q2[2] + q3[2])"
[initial]
q = [[0.6, 0.0, -0.8], [0.0, 0.6, -0.8], [0.8, 0.0, -0.6]]
omega = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]
"""
JOINTS = """
[[forces.pair]]
Fi = "cross(c*(wj - wi), qi)"
Fj = "cross(-c*(wj - wi), qj)"
pairs = "chain"
"""
SPELLED = """
[forces]
F1 = "cross(c*(w2 - w1), q1)"
F2 = "cross(-c*(w2 - w1), q2) + cross(c*(w3 - w2), q2)"
F3 = "cross(-c*(w3 - w2), q3)"
"""


@pytest.mark.parametrize("method", ["vi4", "rk4"])
def test_joint_damping_as_a_pair_term(method: str) -> None:
    """Joint damping between neighbours as one [[forces.pair]] term: the same run as the same
    forces spelled body by body, and the reference's; it only dissipates (the power
    -c |w_j - w_i|^2 <= 0: W never grows) and the balance holds at the method's error."""
    from s2gen.spec import load_spec_text

    pair, spelled = load_spec_text(CHAIN3 + JOINTS), load_spec_text(CHAIN3 + SPELLED)
    h, n = 0.005, 200
    a = quiet_simulate(pair, method, h=h, T=n * h)
    b = quiet_simulate(spelled, method, h=h, T=n * h)
    assert np.max(np.abs(a.q - b.q)) < 1e-13 and np.max(np.abs(a.work - b.work)) < 1e-12  # type: ignore[operator]
    ref = integrate_driven(
        driven_problem_from_system(pair),
        method,
        pair.q0,
        pair.omega0,
        h,
        n,
        inputs=np.zeros((n, 0)),
    )
    assert np.max(np.abs(a.q - ref.q)) < 1e-10
    assert np.all(np.diff(a.work) <= 1e-15) and a.work[-1] < -1e-3  # type: ignore[arg-type,index]
    assert np.max(np.abs(a.balance)) < 1e-4 * abs(a.work[-1])  # type: ignore[arg-type,index]


def test_rattle_on_numpy_is_refused_for_driven_systems() -> None:
    with pytest.raises(ValueError, match="method 'rattle' integrates driven systems on the c"):
        s2gen.simulate(CASES["driven_timed"](), "rattle", backend="numpy", h=0.01, T=0.1)


@pytest.mark.parametrize("method", ["rk45", "dop853"])
@pytest.mark.parametrize("case", ["driven_double", "driven_ring", "driven_timed"])
def test_adaptive_methods_agree_with_scipy_on_the_forced_field(case: str, method: str) -> None:
    """The emitted RK45 and DOP853 of a driven system (each output interval in adaptive steps with its
    inputs held, stages at their own times) against SciPy's DOP853 at 1e-12 on the
    reference's forced field (`s2gen.reference.forced.driven_rhs`) with the same held inputs,
    the work as one more component W' = P; rtol 1e-10 gives agreement to about 1e-8."""
    from scipy.integrate import solve_ivp

    from s2gen.reference.forced import driven_rhs

    system = CASES[case]()
    problem = driven_problem_from_system(system)
    h, n = 0.02, 25
    rng = np.random.default_rng(3)
    U = rng.normal(size=(n, len(system.inputs.names)))
    opts = s2gen.Options(rtol=1e-10, atol=1e-12)
    tr = quiet_simulate(system, method, h=h, T=n * h, t0=0.3, inputs=U, options=opts)
    shape = system.q0.shape
    y = np.concatenate([system.q0.ravel(), system.omega0.ravel(), [0.0]])
    for k in range(n):

        def rhs(t: float, y: np.ndarray, u: np.ndarray = U[k]) -> np.ndarray:
            q = y[: system.n * 3].reshape(shape)
            w = y[system.n * 3 : system.n * 6].reshape(shape)
            dq, dw = driven_rhs(problem, t, q, w, u)
            return np.concatenate([dq.ravel(), dw.ravel(), [problem.power(q, w, t, u)]])

        t0 = 0.3 + k * h
        y = solve_ivp(rhs, (t0, t0 + h), y, method="DOP853", rtol=1e-12, atol=1e-12).y[:, -1]
    q, w, W = y[: system.n * 3], y[system.n * 3 : system.n * 6], y[-1]
    assert np.max(np.abs(tr.q[-1].ravel() - q)) < 1e-7
    assert np.max(np.abs(tr.omega[-1].ravel() - w)) < 1e-7 * max(1.0, np.max(np.abs(w)))
    jumps = sum(
        problem.V(ref_q, 0.3 + k * h, U[k]) - problem.V(ref_q, 0.3 + k * h, U[k - 1])
        for k, ref_q in ((k, tr.q[k]) for k in range(1, n))
    )
    assert abs(tr.work[-1] - (W + jumps)) < 1e-7 * max(1.0, abs(W))  # type: ignore[index]
    assert tr.stats["rejected"] >= 0 and tr.stats["steps"] >= n


@pytest.mark.parametrize("method", ["vi", "rattle4", "rk4", "rk45"])
def test_model_step_of_a_driven_system_is_a_one_step_run(method: str) -> None:
    """Model.step(q, w, h, t=, u=) (the emitted step() called directly) returns what a
    one-step run from t with u held does, bit for bit; a bad input falls back to the checked
    run and its one-line error."""
    system = CASES["driven_ring"]()
    model = s2gen.compile(system)
    u = [0.3, -0.2]
    q, w = model.step(system.q0, system.omega0, 0.01, method, t=0.7, u=u)
    tr = quiet_simulate(system, method, h=0.01, T=0.01, t0=0.7, inputs=np.array([u]), energy=False)
    assert np.array_equal(q, tr.q[-1]) and np.array_equal(w, tr.omega[-1])
    with pytest.raises(ValueError, match=r"inputs of shape \(1, 1\): expected \(1, 2\)"):
        model.step(system.q0, system.omega0, 0.01, method, t=0.7, u=[0.3])


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_driven_field_and_energy_at_t_and_u(case: str) -> None:
    """NAME_field_at and NAME_energy_at (for a solver of the caller's) against the reference's
    forced field and energy at a random time, inputs and state."""
    from s2gen.reference.forced import driven_rhs
    from s2gen.runtime.c import CBackend

    system = CASES[case]()
    be, problem = CBackend(system), driven_problem_from_system(system)
    rng = np.random.default_rng(11)
    q = system.q0 + 0.1 * rng.normal(size=system.q0.shape)
    q /= np.linalg.norm(q, axis=1)[:, None]
    w = np.cross(q, rng.normal(size=q.shape))  # tangent
    u = rng.normal(size=len(system.inputs.names))
    t, p = 0.37, be.default_params()
    dq, dw = np.zeros(q.size), np.zeros(q.size)
    uu = u if u.size else None
    status = be._fn["field_at"](p, t, None if uu is None else uu.ctypes.data, q, w, dq, dw, be.work)
    rq, rw = driven_rhs(problem, t, q, w, u)
    assert status == 0
    assert np.max(np.abs(dq.reshape(q.shape) - rq)) < 1e-12
    assert np.max(np.abs(dw.reshape(q.shape) - rw)) < 1e-10 * max(1.0, np.max(np.abs(rw)))
    e = be._fn["energy_at"](p, t, None if uu is None else uu.ctypes.data, q, w)
    assert abs(e - problem.energy(q, w, t, u)) < 1e-12 * max(1.0, abs(e))
