"""Steps from Python through the emitted C step: `Model.stepper` (one C call per step) and
`Model.step` (the same call behind cheap checks) reproduce `integrate` bit for bit, Newton
iterations included; they refuse what `integrate` refuses and fail with its status; and
`Model.step` keeps its earlier results: one step from a new state is a one-step run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import s2gen
from s2gen.runtime.step_cache import STEP_CACHE_SIZE
from s2gen.systems import builtin

CHAIN4 = Path(__file__).parent / "specs" / "chain4.toml"
SYSTEMS = {
    "double_pendulum": (lambda: builtin("double_pendulum"), 0.01),  # dense M: Newton
    "four_pendula": (lambda: builtin("four_pendula"), 0.01),  # diagonal M: explicit steps
    "chain4": (lambda: s2gen.load(str(CHAIN4)), 0.01),
}
METHODS = ("vi", "rattle", "vi4", "rattle4", "rk2-proj", "rk4")
N = 40


def _integrated(model: s2gen.Model, name: str, h: float, n: int, **kw: object) -> s2gen.Trajectory:
    return model.integrate(name, h, n * h, energy=False, **kw)  # type: ignore[arg-type]


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("key", sorted(SYSTEMS))
@pytest.mark.parametrize("name", METHODS)
def test_stepper_reproduces_integrate_bit_for_bit(backend: str, key: str, name: str) -> None:
    factory, h = SYSTEMS[key]
    model = s2gen.compile(factory(), backend)
    tr = _integrated(model, name, h, N, params={"g": 7.5})
    stepper = model.stepper(name, h, params={"g": 7.5}, t0=0.5)
    iters = 0
    for k in range(1, N + 1):
        stepper.advance()
        iters += stepper.iterations
        assert np.array_equal(stepper.q, tr.q[k]) and np.array_equal(stepper.omega, tr.omega[k])
    assert iters == tr.stats["newton_iters"]
    assert stepper.t == pytest.approx(0.5 + N * h, rel=1e-14)
    if key != "four_pendula" and name.startswith(("vi", "rattle")):
        assert iters > N  # Newton ran, warm: the counts compared are not zeros


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("key", sorted(SYSTEMS))
@pytest.mark.parametrize("name", ["vi", "rattle4", "rk2-proj"])
def test_model_step_run_is_integrate_bit_for_bit(backend: str, key: str, name: str) -> None:
    """Each call from the state the last returned: the steps of one `integrate` run."""
    factory, h = SYSTEMS[key]
    system = factory()
    model = s2gen.compile(system, backend)
    tr = _integrated(model, name, h, N)
    q, w = system.q0, system.omega0
    for k in range(1, N + 1):
        q, w = model.step(q, w, h, name)
        assert np.array_equal(q, tr.q[k]) and np.array_equal(w, tr.omega[k]), k


def test_model_step_from_a_new_state_is_a_one_step_run() -> None:
    """Steps that alternate two step sizes, or start from states the last step did not
    return, are each the one-step `integrate` from their state (nothing carried over)."""
    system = builtin("double_pendulum")
    model = s2gen.compile(system)
    q, w = system.q0, system.omega0
    for k in range(12):
        h = 0.01 if k % 2 else 0.02
        if k % 3 == 2:
            w = w * (1 + 1e-9)  # another state than the one returned
        one = model.integrate("vi", h, h, q, w, energy=False)
        q, w = model.step(q, w, h)
        assert np.array_equal(q, one.q[-1]) and np.array_equal(w, one.omega[-1]), k
    assert len(model._steps._entries) == 1  # a new h retargets the prepared step, not a new one


def test_model_step_keeps_parameters_and_options_apart() -> None:
    """Parameters and options by value select their own prepared step: each result is the
    run's with those values, on more argument sets than the cache holds."""
    system = builtin("double_pendulum")
    model = s2gen.compile(system)
    for g in range(1, STEP_CACHE_SIZE + 3):
        for options in (None, s2gen.Options(newton_tol=1e-10)):
            got = model.step(system.q0, system.omega0, 0.05, "vi", options, {"g": float(g)})
            one = model.integrate("vi", 0.05, 0.05, options=options, params={"g": g})
            assert np.array_equal(got[0], one.q[-1]) and np.array_equal(got[1], one.omega[-1])
    fresh, tr = (system.q0, system.omega0), _integrated(model, "rattle", 0.01, 10)
    for _ in range(10):  # a new, equal options object per call steps on warm
        fresh = model.step(*fresh, 0.01, "rattle", s2gen.Options(newton_maxiter=7))
    assert np.array_equal(fresh[0], tr.q[-1]) and np.array_equal(fresh[1], tr.omega[-1])
    model.step(*fresh, 0.01, "rattle", s2gen.Options(unit_tol=1))
    with pytest.raises(ValueError, match="unit_tol"):  # equal options (True == 1), refused
        model.step(*fresh, 0.01, "rattle", s2gen.Options(unit_tol=True))
    lists = model.step(system.q0.tolist(), system.omega0.tolist(), 0.05, params=[1, 1, 1, 1, 2])
    one = model.integrate("vi", 0.05, 0.05, params={"g": 2.0, "l1": 1.0, "l2": 1.0})
    assert np.array_equal(lists[0], one.q[-1])


def _refusal(call: object) -> str:
    with pytest.raises(ValueError) as info:
        call()  # type: ignore[operator]
    return str(info.value)


@pytest.mark.parametrize(
    ("case", "change"),
    [
        ("nan omega", lambda q, w: (q, np.where(w == w[0, 0], np.nan, w))),
        ("inf q", lambda q, w: (np.where(q == q[0, 0], np.inf, q), w)),
        ("long q", lambda q, w: (q * (1 + 1e-9), w)),
        ("shape", lambda q, w: (q[:1], w[:1])),
        ("broadcast", lambda q, w: (q[0], w)),
    ],
)
@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_model_step_refuses_what_integrate_refuses(backend: str, case: str, change: object) -> None:
    system = builtin("double_pendulum")
    model = s2gen.compile(system, backend)
    model.step(system.q0, system.omega0, 0.01)  # the step for these arguments is prepared
    q, w = change(system.q0, system.omega0)  # type: ignore[operator]
    expected = _refusal(lambda: model.integrate("vi", 0.01, 0.01, q, w, energy=False))
    assert _refusal(lambda: model.step(q, w, 0.01)) == expected, case
    assert _refusal(lambda: model.step(system.q0, system.omega0, 0.01, params={"g": True}))
    assert _refusal(lambda: model.step(system.q0, system.omega0, float("nan")))


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize(
    ("name", "h", "options", "status", "steps"),
    [
        ("rk4", 50.0, s2gen.Options(unit_tol=0.0), 3, 1),  # NONFINITE after one step
        ("vi", 3.0, s2gen.Options(newton_maxiter=2), 2, 0),  # NEWTON at the first step
    ],
)
def test_failures_raise_integrates_status(
    backend: str, name: str, h: float, options: s2gen.Options | None, status: int, steps: int
) -> None:
    system = builtin("double_pendulum")
    model = s2gen.compile(system, backend)
    with pytest.raises(s2gen.IntegrationError) as run:
        model.integrate(name, h, 20 * h, options=options, energy=False)
    assert run.value.status == status and run.value.step == steps + 1
    last = run.value.partial
    stepper = model.stepper(name, h, options=options)
    for _ in range(steps):
        stepper.advance()
    with pytest.raises(s2gen.IntegrationError) as stepped:
        stepper.advance()
    assert stepped.value.status == status
    assert np.array_equal(stepper.q, last.q[-1]) and np.array_equal(stepper.omega, last.omega[-1])
    assert np.array_equal(stepped.value.partial.q[-1], last.q[-1])
    assert stepper.t == pytest.approx(steps * h)
    q, w = last.q[-1], last.omega[-1]
    with pytest.raises(s2gen.IntegrationError) as one:
        model.step(q, w, h, name, options)
    assert one.value.status == status


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_stepper_set_state_checks_and_starts_afresh(backend: str) -> None:
    system = s2gen.load(str(CHAIN4))
    model = s2gen.compile(system, backend)
    stepper = model.stepper("rattle", 0.01)
    for _ in range(5):
        stepper.advance()
    other = system.omega0 * (1 + 1e-9)
    stepper.set_state(system.q0, other)
    stepper.advance()
    one = model.integrate("rattle", 0.01, 0.01, system.q0, other, energy=False)
    assert np.array_equal(stepper.q, one.q[-1]) and np.array_equal(stepper.omega, one.omega[-1])
    assert stepper.iterations == one.stats["newton_iters"] > 0
    expected = _refusal(lambda: model.integrate("rattle", 0.01, 0.01, system.q0 * 2, other))
    assert _refusal(lambda: stepper.set_state(system.q0 * 2, other)) == expected
    with pytest.raises(ValueError, match="read-only"):
        stepper.q[0, 0] = 1.0


def test_stepper_refusals() -> None:
    system = builtin("double_pendulum")
    assert "fixed-step" in _refusal(lambda: s2gen.compile(system).stepper("rk45", 0.01))
    assert "reference backend" in _refusal(
        lambda: s2gen.compile(system, "reference").stepper("vi", 0.01)
    )
    assert "step size h" in _refusal(lambda: s2gen.compile(system).stepper("vi", -0.01))
    assert "t0" in _refusal(lambda: s2gen.compile(system).stepper("vi", 0.01, t0=float("inf")))


def test_model_step_on_the_reference_backend_is_a_one_step_run() -> None:
    system = builtin("double_pendulum")
    model = s2gen.compile(system, "reference")
    q, w = model.step(system.q0, system.omega0, 0.01, "rk4")
    one = model.integrate("rk4", 0.01, 0.01, energy=False)
    assert np.array_equal(q, one.q[-1]) and np.array_equal(w, one.omega[-1])


def test_python_step_benchmark_runs_and_checks_its_paths(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """benchmarks/python_step.py (on pytest's pythonpath) prints every path with the CPU;
    its numbers are not checked, its paths' agreement with integrate() is (exit status)."""
    import python_step

    argv = ["--systems", "double_pendulum", "--steps", "200", "--calls", "50", "--repeats", "1"]
    assert python_step.main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith("CPU: ")
    for path in (
        "C step",
        "advance()",
        "advance() (NumPy)",
        "Model.step (C)",
        "Model.step (NumPy)",
        "one-step integrate",
    ):
        assert path in out
