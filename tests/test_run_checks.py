"""What `simulate` / `run` refuse or report (issue 8, items 4, 5 and 10).

Before the fixes: a run whose energy became NaN or infinite while the state stayed finite
returned normally (the CLI exited 0 and printed "mean nan"); `--method rk45 --rtol 1e-300
--atol 1e-300` never returned (four pendula with atol = 1e-300 did not finish a unit of time);
h = inf ran zero steps and returned one sample; T = inf raised OverflowError; a run whose
samples could not fit in memory started allocating them; Options(control="foo") escaped as
"'foo' is not in list"; `Model.integrate(params=[...])` raised AttributeError.
"""

from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pytest
from reliability_helpers import one_line_error

from s2gen.cli import main
from s2gen.runtime import (
    ATOL_FLOOR,
    RTOL_FLOOR,
    IntegrationError,
    Options,
    get_backend,
    simulate,
)
from s2gen.runtime.model import Model
from s2gen.spec import define_system
from s2gen.system import System
from s2gen.systems import builtin


def falling(c: float = 1e308) -> System:
    """A pendulum released near the top under V = c q3: its kinetic energy passes the largest
    double (c (cos 0.1 + 1) > 1.8e308) while q and omega stay finite (|omega| ~ 1e154)."""
    return define_system(
        name="fall",
        bodies=1,
        parameters={"m": 1.0, "c": c},
        diagonal=["m"],
        potential="c*q1[2]",
        initial_q=[[math.sin(0.1), 0.0, math.cos(0.1)]],
        initial_omega=[[0.0, 0.0, 0.0]],
    )


@pytest.mark.parametrize(("method", "backend"), [("vi", "c"), ("rk2", "c"), ("vi", "numpy")])
def test_energy_overflow_while_the_state_is_finite_is_a_failure(method: str, backend: str) -> None:
    with pytest.raises(IntegrationError) as info:
        simulate(falling(), method, backend, h=1e-155, T=400e-155)
    exc = info.value
    assert exc.status == 3 and exc.step > 10
    assert "the energy is not finite at t = " in str(exc) and "while the state is" in str(exc)
    part = exc.partial
    assert len(part.t) == exc.step == len(part.energy)
    assert np.all(np.isfinite(part.energy)) and np.all(np.isfinite(part.q))
    # the independent check: at the first dropped sample the exact energy is beyond a double
    assert part.energy[0] > 9.9e307


def test_a_nan_energy_from_the_start_is_refused_before_the_run() -> None:
    """V = -m g q3 + log(c) with c < 0 at run time: the gradient (and so the state) is
    finite, every energy is NaN: refused before integrating, unless no energy is kept."""
    system = define_system(
        name="nanlog",
        bodies=1,
        parameters={"m": 1.0, "g": 9.81, "c": 1.0},
        diagonal=["m"],
        potential="-m*g*q1[2] + log(c)",
        initial_q=[[0.6, 0.0, 0.8]],
        initial_omega=[[0.0, 1.0, 0.0]],
    )
    with pytest.raises(ValueError, match="at the initial state the potential V = nan is not"):
        simulate(system, "vi", "c", h=0.01, T=0.1, params=np.array([1.0, 9.81, -1.0]))
    tr = simulate(
        system, "vi", "c", h=0.01, T=0.1, params=np.array([1.0, 9.81, -1.0]), energy=False
    )
    assert np.all(np.isfinite(tr.q)) and tr.energy is None


def test_cli_reports_the_nan_energy_with_status_1(tmp_path, capsys) -> None:
    spec = tmp_path / "fall.toml"
    spec.write_text(
        'name = "fall"\nbodies = 1\n[parameters]\nm = 1.0\nc = 1e308\n[inertia]\n'
        'diagonal = ["m"]\n[potential]\nV = "c*q1[2]"\n[initial]\n'
        "q = [[0.0998334166468282, 0.0, 0.9950041652780258]]\nomega = [[0, 0, 0]]\n"
    )
    out = tmp_path / "t.npz"
    code = main(["simulate", str(spec), "--h", "1e-155", "--T", "4e-153", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1, err
    assert "the energy is not finite" in err and "Traceback" not in err
    assert np.all(np.isfinite(np.load(out)["energy"]))


@pytest.mark.parametrize(
    ("options", "fragment"),
    [
        (
            Options(rtol=1e-300, atol=1e-300),
            "rtol = 1e-300: must lie between 2.22e-14 (100 machine epsilons",
        ),
        (Options(rtol=1e-15), "rtol = 1e-15: must lie between 2.22e-14"),
        (Options(atol=1e-300), "atol = 1e-300: must be at least 1e-20"),
        (Options(atol=0.0), "atol = 0.0: must be a finite positive number"),
        (Options(rtol=math.nan), "rtol = nan: must be a finite positive number"),
        (Options(control="foo"), "control = 'foo': choose one of matlab, hairer"),
        (Options(hmax=-1.0), "hmax = -1.0: must be finite and >= 0"),
        (Options(newton_maxiter=0), "newton_maxiter = 0: must be a whole number, at least 1"),
        (Options(newton_tol=-1.0), "newton_tol = -1.0: must be a finite positive number"),
    ],
)
def test_options_out_of_range_are_refused(options: Options, fragment: str) -> None:
    s = builtin("four_pendula")
    start = time.perf_counter()
    message = one_line_error(lambda: simulate(s, "rk45", "reference", options=options), ValueError)
    assert time.perf_counter() - start < 1.0
    assert fragment in message, message


def test_cli_tiny_tolerances_exit_2_at_once(capsys) -> None:
    start = time.perf_counter()
    argv = ["simulate", "four_pendula", "--method", "rk45", "--rtol", "1e-300"]
    code = main([*argv, "--atol", "1e-300", "--T", "1", "--out", "/tmp/s2gen-never.npz"])
    err = capsys.readouterr().err
    assert code == 2 and time.perf_counter() - start < 5.0
    assert err.count("\n") == 1 and "rtol = 1e-300: must lie between 2.22e-14" in err


def test_rk45_at_the_tolerance_floors_finishes() -> None:
    """At the floors the emitted RK45 must finish (it did not at atol = 1e-300), run in a
    child process so that a hang is a failed test, not a stuck suite."""
    code = (
        "from s2gen.runtime import simulate, Options, RTOL_FLOOR, ATOL_FLOOR\n"
        "from s2gen.systems import builtin\n"
        "for name in ('four_pendula', 'double_pendulum'):\n"
        "    tr = simulate(builtin(name), 'rk45', 'c', h=0.01, T=1.0,\n"
        "                  options=Options(rtol=RTOL_FLOOR, atol=ATOL_FLOOR))\n"
        "    print(name, tr.stats['steps'])\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert proc.returncode == 0, proc.stderr
    steps = {line.split()[0]: int(line.split()[1]) for line in proc.stdout.splitlines()}
    assert 100 < steps["four_pendula"] < 10**5 and 100 < steps["double_pendulum"] < 10**5


def test_rk45_at_the_floor_agrees_with_the_reference() -> None:
    """Tight tolerances mean tight answers: the C RK45 at the floor matches the reference
    RK45 at the same floor (independent code) to 1e-11 after T = 1."""
    s = builtin("double_pendulum")
    opts = Options(rtol=RTOL_FLOOR, atol=ATOL_FLOOR)
    c = simulate(s, "rk45", "c", h=0.01, T=1.0, options=opts)
    ref = simulate(s, "rk45", "reference", h=0.01, T=1.0, options=opts)
    np.testing.assert_allclose(c.q, ref.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(c.omega, ref.omega, rtol=0, atol=1e-10)


@pytest.mark.parametrize(
    ("kwargs", "fragment"),
    [
        ({"h": math.inf, "T": 1.0}, "step size h = inf: must be a finite number"),
        ({"h": math.nan, "T": 1.0}, "step size h = nan: must be a finite number"),
        ({"h": 0.01, "T": math.inf}, "final time T = inf: must be a finite number"),
        ({"h": 0.01, "T": -1.0}, "final time T = -1: must be positive"),
        ({"h": "0.01", "T": 1.0}, "step size h = '0.01': must be a finite number"),
        ({"h": 1e-300, "T": 1e300}, "= inf steps kept every 1: more than one run may hold"),
        ({"h": 1e-9, "T": 1e-3, "params": [1, 1, 1, 1, math.inf]}, "parameter g = inf is not"),
        ({"h": 1e-9, "T": 1e3}, "= 1e+12 steps kept every 1: more than one run may hold"),
        ({"h": 1e-9, "T": 1e3, "every": 1000}, "the trajectory arrays would take 104 GiB, more"),
        (
            {"h": 0.01, "T": 1.0, "every": True},
            "every = True: must be a positive whole number of steps",
        ),
        ({"h": 0.01, "T": 1.0, "every": 3}, "every=3 must be a positive divisor of the 100 steps"),
        ({"h": 0.01, "T": 1.0, "params": np.ones(2)}, "expected 5 parameter values"),
        ({"h": 0.01, "T": 1.0, "params": [1, 1, 1, 1, math.nan]}, "parameter g = nan is not"),
        ({"h": 0.01, "T": 1.0, "params": ["a"] * 5}, "parameter values must be 5 numbers"),
        ({"h": 0.01, "T": 1.0, "q0": [["a"] * 3] * 2}, "q0 and omega0 must be arrays"),
    ],
)
def test_run_arguments_are_checked_before_anything_runs(kwargs: dict, fragment: str) -> None:
    s = builtin("double_pendulum")
    start = time.perf_counter()
    message = one_line_error(lambda: simulate(s, "vi", "c", **kwargs), ValueError)
    assert time.perf_counter() - start < 1.0
    assert fragment in message, message


def test_every_accepts_numpy_integers() -> None:
    tr = simulate(builtin("double_pendulum"), "vi", "c", h=0.01, T=1.0, every=np.int64(10))
    assert tr.q.shape == (11, 2, 3)


def test_model_params_by_name_or_in_order() -> None:
    model = Model(builtin("double_pendulum"))
    by_name = model.params({"g": 1.0})
    assert model.params([1.0, 1.0, 9.81, 9.81, 1.0]).tolist() == by_name.tolist()
    assert model.params(np.array(by_name)).tolist() == by_name.tolist()
    q = model.system.q0
    assert model.gradient(q, {"g": 1.0}) == pytest.approx(
        get_backend(model.system, "reference").gradient(q, by_name)
    )
    for bad, fragment in (
        ([1.0, 2.0], "expected 5 parameter values (m1, m2, l1, l2, g) or a dict by name"),
        ("abcde", "expected 5 parameter values"),
        ({"g": "abc"}, "parameter g must be a finite number, got 'abc'"),
        ({"g": math.inf}, "parameter g must be a finite number, got inf"),
        ({"nope": 1.0}, "unknown parameter 'nope'"),
    ):
        message = one_line_error(
            lambda b=bad: model.integrate("vi", 0.01, 0.1, params=b), ValueError
        )
        assert fragment in message, message
