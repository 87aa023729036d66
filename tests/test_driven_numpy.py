"""Driven systems through the emitted NumPy module: forces, time-dependent potentials, inputs.

Independent checks only: the NumPy run against the reference integrator's own forced equations
(`s2gen.reference.forced*`, which never sees the templates) and against the emitted C, for every
driven method on the four driven cases of `tests/test_driven.py`, with random array inputs and
with a state feedback (the inputs it returned recomputed from the stored samples), and on a
rope solved by the structured solvers; one step of the module's step() against one reference
step; the failures that stop a run (a feedback that raises or returns NaN, a non-finite input)
keep the samples before them as the C does.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
import pytest
from test_driven import CASES

import s2gen
from s2gen.emit import emit, emit_angles
from s2gen.methods import driven_methods, method
from s2gen.reference.driven_system import driven_problem_from_system
from s2gen.reference.forced_integrate import integrate_driven
from s2gen.runtime.c import CBackend
from s2gen.runtime.numpy_module import NumpyBackend
from s2gen.runtime.trajectory import IntegrationError
from s2gen.system import SpecError, System

Law = Callable[[float, np.ndarray, np.ndarray], list[float]]


def run(system: System, method_name: str, backend: str, **kwargs: object) -> s2gen.Trajectory:
    """A run without the energy-balance warning (coarse steps on purpose)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return s2gen.simulate(system, method_name, backend=backend, **kwargs)  # type: ignore[arg-type]


def step_of(case: str) -> float:
    return 0.01 if case != "rope_top" else 0.002


def assert_agree(a: s2gen.Trajectory, b: object, tol: float = 1e-10) -> None:
    """q, omega, energy and work of a run within tol of another's (relative to their sizes)."""
    q, omega, energy, work = (getattr(b, k) for k in ("q", "omega", "energy", "work"))
    scale = max(1.0, float(np.max(np.abs(energy))))
    assert np.max(np.abs(a.q - q)) < tol
    assert np.max(np.abs(a.omega - omega)) < tol * max(1.0, float(np.max(np.abs(omega))))
    assert a.energy is not None and np.max(np.abs(a.energy - energy)) < tol * scale
    assert a.work is not None and np.max(np.abs(a.work - work)) < tol * scale


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("method_name", driven_methods(rattle=False, adaptive=False))
def test_numpy_agrees_with_the_reference_and_the_c(case: str, method_name: str) -> None:
    """From t0 = 0.3 with random inputs that change every step (their jumps of V are work):
    q, omega, E and W of NumPy against the reference and against the emitted C, to 1e-10."""
    system = CASES[case]()
    h, n = step_of(case), 60
    U = np.random.default_rng(7).normal(size=(n, len(system.inputs.names)))
    tr = run(system, method_name, "numpy", h=h, T=n * h, t0=0.3, inputs=U)
    ref = integrate_driven(
        driven_problem_from_system(system), method_name, system.q0, system.omega0, h, n,
        inputs=U, t0=0.3,
    )  # fmt: skip
    assert np.allclose(tr.t, 0.3 + h * np.arange(n + 1), rtol=0, atol=1e-12)
    assert_agree(tr, ref)
    assert_agree(tr, run(system, method_name, "c", h=h, T=n * h, t0=0.3, inputs=U))
    assert tr.inputs is not None and np.array_equal(tr.inputs, U)


@pytest.mark.parametrize("method_name", ["vi", "vi4", "rk4"])
def test_numpy_with_structured_solves_agrees_with_the_reference_and_the_c(method_name: str) -> None:
    """The rope of 12 links whose top moves (max-index M, the structured O(n) solves, time in
    its potential): NumPy against the reference and the C, to 1e-10."""
    system = s2gen.load("rope:n=12,top_radius=0.2")
    h, n = 0.002, 20
    tr = run(system, method_name, "numpy", h=h, T=n * h, t0=0.1)
    ref = integrate_driven(
        driven_problem_from_system(system), method_name, system.q0, system.omega0, h, n, t0=0.1
    )
    assert_agree(tr, ref)
    assert_agree(tr, run(system, method_name, "c", h=h, T=n * h, t0=0.1))


def feedback_law(system: System) -> Law:
    """A state feedback of each input (none for a system without inputs)."""
    k = len(system.inputs.names)

    def law(t: float, q: np.ndarray, w: np.ndarray) -> list[float]:
        return [-2.0 * q[-1, j % 3] - 0.5 * w[0, (j + 1) % 3] + 0.1 * np.sin(t) for j in range(k)]

    return law


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("method_name", driven_methods(rattle=False, adaptive=False))
def test_numpy_feedback_agrees_with_the_c_and_the_reference(case: str, method_name: str) -> None:
    """u(t, q, w) is called once per step with t_k and the state at t_k: NumPy's held inputs
    are the law of its stored samples, and its run is the C's with the same law and the
    reference's with the inputs it held, to 1e-10."""
    system, h, n = CASES[case](), step_of(case), 40
    law = feedback_law(system)
    tr = run(system, method_name, "numpy", h=h, T=n * h, inputs=law)
    assert tr.inputs is not None and tr.inputs.shape == (n, len(system.inputs.names))
    again = np.array([law(t, q, w) for t, q, w in zip(tr.t[:-1], tr.q[:-1], tr.omega[:-1])])
    assert np.array_equal(tr.inputs, again.reshape(tr.inputs.shape))
    c = run(system, method_name, "c", h=h, T=n * h, inputs=law)
    assert_agree(tr, c)
    assert c.inputs is not None and np.max(np.abs(tr.inputs - c.inputs), initial=0.0) < 1e-9
    ref = integrate_driven(
        driven_problem_from_system(system), method_name, system.q0, system.omega0, h, n,
        inputs=tr.inputs,
    )  # fmt: skip
    assert_agree(tr, ref)


@pytest.mark.parametrize("method_name", driven_methods(rattle=False, adaptive=False))
def test_a_step_of_the_module_is_a_reference_step(method_name: str) -> None:
    """The module's step() from (q, w) at t with an input held: qn, wn and the work over the
    step are one step of the reference."""
    system = CASES["driven_ring"]()
    be = NumpyBackend(system)
    t, h, u = 0.7, 0.02, np.array([0.3, -1.2])
    status, qn, wn, W, _ = be.module.step(
        be.default_params(), method(method_name).code, t, h, system.q0, system.omega0, u
    )
    ref = integrate_driven(
        driven_problem_from_system(system), method_name, system.q0, system.omega0, h, 1,
        inputs=u[None, :], t0=t,
    )  # fmt: skip
    assert status == 0
    assert np.max(np.abs(qn - ref.q[1])) < 1e-12 and np.max(np.abs(wn - ref.omega[1])) < 1e-11
    assert abs(W - ref.work[1]) < 1e-12


def test_the_module_functions_read_time_and_inputs_only_when_given() -> None:
    """potential(p, q) of a driven module is V at t = 0 with the default inputs (as the C's),
    and potential(p, q, tu) at the time and inputs tu: here V(t, u) = u q1_z + q3_z sin t +
    the springs, whose change in u and t is known in closed form."""
    system = CASES["driven_ring"]()
    mod = NumpyBackend(system).module
    p, q = mod.default_params(), system.q0
    assert mod.TU_DEFAULTS.tolist() == [0.0, *system.inputs.values]
    base = mod.potential(p, q)
    tu = np.array([0.4, 0.5, 2.0])  # b from 0.1 to 2.0 at t = 0.4
    expected = base + (2.0 - 0.1) * q[0, 2] + np.sin(0.4) * q[2, 2]
    assert mod.potential(p, q, tu) == pytest.approx(expected, rel=1e-14, abs=1e-14)
    grad = mod.gradient(p, q, tu) - mod.gradient(p, q)
    assert grad[0, 2] == pytest.approx(1.9) and grad[2, 2] == pytest.approx(np.sin(0.4))


# ------------------------------------------------------------------ failures: as the C's
@pytest.mark.parametrize(
    ("law", "fragment"),
    [
        (lambda t, q, w: [1.0 / (t - t)], "ZeroDivisionError"),
        (lambda t, q, w: [np.nan], "expected 1 finite numbers"),
        (lambda t, q, w: [1.0, 2.0], "expected 1 finite numbers"),
    ],
)
def test_a_failing_feedback_stops_the_numpy_run_with_its_reason(law: Law, fragment: str) -> None:
    system = CASES["driven_double"]()
    with pytest.raises(IntegrationError, match=fragment) as err:
        s2gen.simulate(system, "vi", backend="numpy", h=0.01, T=0.1, inputs=law)
    assert "the input function at t = 0" in str(err.value) and "\n" not in str(err.value)


def test_a_non_finite_input_stops_the_numpy_run_and_keeps_the_samples() -> None:
    system = CASES["driven_ring"]()
    U = np.zeros((10, 2))
    U[6, 1] = np.nan
    with pytest.raises(IntegrationError, match="input is not finite") as err:
        s2gen.simulate(system, "rk4", backend="numpy", h=0.01, T=0.1, inputs=U)
    assert len(err.value.partial.t) == 7 and np.all(np.isfinite(err.value.partial.q))


def test_what_numpy_still_refuses() -> None:
    """RATTLE and the adaptive methods do not drive yet; the angle form is not emitted for a
    driven system; NumPy's module is emitted for it."""
    system = CASES["driven_timed"]()
    assert list(emit(system, "numpy")) == ["driven_timed.py"]
    with pytest.raises(ValueError, match="method 'rk45' integrates driven systems on the c"):
        s2gen.simulate(system, "rk45", backend="numpy", h=0.01, T=0.1)
    with pytest.raises(ValueError, match="method 'dop853' integrates driven systems on the c"):
        s2gen.simulate(system, "dop853", backend="numpy", h=0.01, T=0.1)
    with pytest.raises(SpecError, match=r"emitting numpy code \(angles form\) for driven"):
        emit_angles(system, "numpy")


@pytest.mark.parametrize(
    ("change", "status"),
    [
        ({"h": 0.0}, 4),
        ({"every": 3}, 4),
        ({"method_name": "rk2-proj"}, 4),
        ({"t0": float("nan")}, 4),
        ({"q0": np.array([[0.0, 0.0, 1.1], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])}, 4),
        ({"w0": np.full((3, 3), np.inf)}, 3),
    ],
)
def test_bad_arguments_get_the_c_status(change: dict[str, object], status: int) -> None:
    """integrate() refuses what the C's refuses, with the same status (ERR_ARGUMENT 4,
    ERR_NONFINITE 3), the same statistics and no sample."""
    system = CASES["driven_ring"]()
    args: dict[str, object] = {
        "method_name": "vi", "h": 0.01, "nsteps": 10, "q0": system.q0, "w0": system.omega0,
        "params": np.array(system.parameter_values), "options": s2gen.Options(), "t0": 0.0,
        "every": 1,
    }  # fmt: skip
    args.update(change)
    got = NumpyBackend(system).integrate_driven(**args)  # type: ignore[arg-type]
    want = CBackend(system).integrate_driven(**args)  # type: ignore[arg-type]
    assert got[0] == want[0] == status
    assert got[5] == want[5] and np.all(np.isnan(got[1]))


def test_step_refuses_a_bad_step_and_a_non_finite_input() -> None:
    """step(): ERR_ARGUMENT (4) for h <= 0 or a method that does not drive, ERR_NONFINITE (3)
    for a non-finite input, as the C's step."""
    system = CASES["driven_ring"]()
    be = NumpyBackend(system)
    p, q, w = be.default_params(), system.q0, system.omega0
    assert be.module.step(p, method("vi").code, 0.0, -0.01, q, w)[0] == 4
    assert be.module.step(p, method("rattle").code, 0.0, 0.01, q, w)[0] == 4
    assert be.module.step(p, method("rk4").code, 0.0, 0.01, q, w, [np.nan, 0.0])[0] == 3
    assert be.module.step(p, method("rk4").code, 0.0, 0.01, q, w, [1.0, 0.0])[0] == 0
