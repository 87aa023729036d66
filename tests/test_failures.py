"""Failures are reported, not hidden: the emitted code returns a status code with the step,
and the Python side raises a clear error that keeps the trajectory computed so far."""

from __future__ import annotations

import numpy as np
import pytest

from s2gen.cli import main
from s2gen.runtime import IntegrationError, Options, get_backend, simulate
from s2gen.systems import builtin


def _check_partial(exc: IntegrationError, n: int) -> None:
    part = exc.partial
    assert len(part.t) == exc.step >= 1
    assert part.q.shape == (exc.step, n, 3)
    assert np.all(np.isfinite(part.q)) and np.all(np.isfinite(part.energy))
    assert f"the {exc.step} valid samples are kept" in str(exc)
    assert f"after t = {part.t[-1]:.6g}" in str(exc)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_explicit_step_infeasible(backend: str) -> None:
    s = builtin("three_bodies")
    with pytest.raises(IntegrationError, match="infeasible") as info:
        simulate(s, "vi", backend, h=0.9, T=90.0)
    assert info.value.status == 1
    _check_partial(info.value, 3)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_newton_not_converged(backend: str) -> None:
    s = builtin("double_pendulum")
    with pytest.raises(IntegrationError, match="Newton") as info:
        simulate(s, "vi", backend, h=0.01, T=1.0, options=Options(newton_maxiter=2))
    assert info.value.status == 2
    assert info.value.step == 1 and len(info.value.partial.t) == 1


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_non_finite_state(backend: str) -> None:
    """Two bodies of the cotangent potential placed on top of each other: infinite force, and
    an infinite energy already at t = 0. `simulate` refuses the state before integrating
    (with or without energy); the emitted integrator, called directly, fails at its first
    step with NONFINITE."""
    s = builtin("three_bodies")
    q0 = s.q0.copy()
    q0[1] = q0[0]
    w0 = np.zeros_like(q0)
    for energy in (True, False):
        with pytest.raises(ValueError, match="initial state the gradient of V on body 1 is not"):
            simulate(s, "rk4", backend, h=0.01, T=1.0, q0=q0, omega0=w0, energy=energy)
    be = get_backend(s, backend)
    p = np.array(s.parameter_values)
    status, *_, stats = be.integrate("rk4", 0.01, 100, q0, w0, p, Options(), 1, False)
    assert status == 3
    assert stats["fail_step"] == 1


def test_cli_failed_run_exits_1_and_keeps_partial(tmp_path, capsys) -> None:
    out = tmp_path / "traj.npz"
    code = main(["simulate", "three_bodies", "--h", "0.9", "--T", "90", "--out", str(out)])
    assert code == 1
    assert "infeasible" in capsys.readouterr().err
    saved = np.load(out)
    assert saved["q"].shape[0] == saved["t"].shape[0] >= 1


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
def test_rk45_stops_at_a_potential_that_becomes_non_finite() -> None:
    """V = 0.01 sqrt(z + 1/2) is not real below z = -1/2, where a body spinning about x goes.
    A trial step there is never accepted (its error estimate is NaN): every backend stops at
    the same sample with NONFINITE and keeps only finite samples."""
    from s2gen.spec import define_system

    s = define_system(
        name="sqrt_wall",
        bodies=1,
        parameters={"m": 1.0},
        diagonal=["m"],
        potential="0.01*sqrt(q1[2] + 0.5)",
        initial_q=[[0, 0, 1]],
        initial_omega=[[1, 0, 0]],
    )
    stops = {}
    for backend in ("c", "numpy", "reference"):
        with pytest.raises(IntegrationError) as info:
            simulate(s, "rk45", backend, h=0.01, T=10.0)
        assert info.value.status == 3, backend
        _check_partial(info.value, 1)
        # the last sample is before z = -1/2 (a quarter turn past the equator, t < 2.1)
        assert info.value.partial.q[-1, 0, 2] > -0.5
        stops[backend] = info.value.step
    assert stops["c"] == stops["numpy"] == stops["reference"], stops


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
@pytest.mark.parametrize("h", [1.0, 3.0])
@pytest.mark.parametrize("name", ["double_pendulum", "elastic_rod", "rope"])
def test_a_diverging_newton_is_a_newton_failure_on_every_backend(name: str, h: float) -> None:
    """Far too large a step: Newton's iterates grow without bound. Every backend reports
    Newton's failure at the first step (before: the C and NumPy dense and structured paths
    could take an overflowing iterate for converged, inf <= inf, and report a singular
    inertia, or a non-finite state, while the reference reported Newton)."""
    from s2gen.methods import Status

    system = builtin(name, n=8) if name == "rope" else builtin(name)
    runs = [("vi", b) for b in ("c", "numpy", "reference")] + [
        ("rattle", b) for b in ("c", "numpy")
    ]
    for method, backend in runs:
        with pytest.raises(IntegrationError) as info:
            simulate(system, method, backend, h=h, T=20 * h)
        assert (info.value.status, info.value.step) == (Status.NEWTON, 1), (method, backend)


@pytest.mark.filterwarnings("ignore:invalid value encountered:RuntimeWarning")
@pytest.mark.parametrize("method", ["vi", "vi4"])
def test_explicit_vi_stops_where_the_velocity_becomes_non_finite(method: str) -> None:
    """The explicit VI of the square-root wall: the drift that takes the body below z = -1/2 is
    feasible, the gradient there is NaN and so is the kick's velocity. The emitted integrator
    (whose kicks run fused with the next drift) reports NONFINITE at the same step as the NumPy
    one, the step whose velocity failed not counted, and keeps the same samples; `simulate`
    stops there on every backend (the reference has no compositions)."""
    from s2gen.spec import define_system

    s = define_system(
        name="sqrt_wall_vi",
        bodies=1,
        parameters={"m": 1.0},
        diagonal=["m"],
        potential="0.01*sqrt(q1[2] + 0.5)",
        initial_q=[[0, 0, 1]],
        initial_omega=[[1, 0, 0]],
    )
    runs = {}
    for backend in ("c", "numpy"):
        be = get_backend(s, backend)
        p = np.array(s.parameter_values)
        runs[backend] = be.integrate(method, 0.01, 1000, s.q0, s.omega0, p, Options(), 1, True)
    (cs, cq, cw, ce, cstats), (ns, nq, nw, ne, nstats) = runs["c"], runs["numpy"]
    assert cs == ns == 3
    keys = ("steps", "fail_step")
    assert {k: cstats[k] for k in keys} == {k: nstats[k] for k in keys}
    kept = cstats["fail_step"]
    assert np.all(np.isfinite(cw[:kept])) and np.all(np.isfinite(ce[:kept]))
    assert np.max(np.abs(cq[:kept] - nq[:kept])) < 1e-12
    assert np.max(np.abs(cw[:kept] - nw[:kept])) < 1e-12
    assert np.max(np.abs(ce[:kept] - ne[:kept])) < 1e-12
    stops = {}
    for backend in ("c", "numpy", "reference") if method == "vi" else ("c", "numpy"):
        with pytest.raises(IntegrationError) as info:
            simulate(s, method, backend, h=0.01, T=10.0)
        assert info.value.status == 3, backend
        _check_partial(info.value, 1)
        assert info.value.partial.q[-1, 0, 2] > -0.5
        stops[backend] = info.value.step
    assert set(stops.values()) == {kept}, stops


@pytest.mark.parametrize("method", ["vi", "vi4"])
def test_explicit_vi_infeasible_step_is_counted_as_on_numpy(method: str) -> None:
    """The three bodies at h = 0.3: a drift becomes infeasible after the kick before it
    completed its step (the emitted driver runs the two in one pass). The emitted integrator
    reports INFEASIBLE with the same steps, failing sample and kept samples as the NumPy one."""
    s = builtin("three_bodies")
    p = np.array(s.parameter_values)
    runs = {}
    for backend in ("c", "numpy"):
        be = get_backend(s, backend)
        runs[backend] = be.integrate(method, 0.3, 400, s.q0, s.omega0, p, Options(), 1, True)
    (cs, cq, cw, ce, cstats), (ns, nq, nw, ne, nstats) = runs["c"], runs["numpy"]
    assert cs == ns == 1
    keys = ("steps", "fail_step")
    assert {k: cstats[k] for k in keys} == {k: nstats[k] for k in keys}
    kept = cstats["fail_step"]
    assert kept > 1
    for c, n in ((cq, nq), (cw, nw), (ce, ne)):
        assert np.max(np.abs(c[:kept] - n[:kept])) < 1e-9
