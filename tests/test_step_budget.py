"""The adaptive methods' step budget (`Options.max_steps`): every run of RK45 or DOP853 ends.

A state spinning 1e100 times faster than the spec's makes the adaptive step about 1e-102 near
t = 0; the minimum step 16 ulp(t) accepts it, so without a budget the run would never reach
T. With it the run stops with the stepsize status after max_steps attempted steps (accepted
plus rejected) between two output grid points, its samples before that kept. Checked on the
emitted C (one member, the batch, a driven system), the emitted NumPy and the reference
integrator, against each other and against step counts of unlimited runs: a budget equal to
the attempts a run needs lets it finish, one less stops it after exactly that many attempts.
Each test carries a timeout by pytest-timeout's thread method (a hang inside the emitted C
never returns to Python, where the signal method would act), so that a driver that ignores the
budget fails the run instead of stalling it.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_batch import K, bits

from s2gen import Options, simulate
from s2gen.methods import Status
from s2gen.parts.batch import BATCH_LANES
from s2gen.runtime.batch import integrate_batch
from s2gen.runtime.c import CBackend
from s2gen.runtime.trajectory import IntegrationError, Trajectory
from s2gen.system import System
from s2gen.systems import builtin

ADAPTIVE = ("rk45", "dop853")
SPIN = 1e100  # the factor on the spec's angular velocity: far past what any step resolves


def pendula() -> tuple[System, np.ndarray, np.ndarray]:
    """four_pendula and its spec's initial state (a unit q0, a nonzero omega0)."""
    s = builtin("four_pendula")
    assert np.abs(s.omega0).max() > 0
    return s, np.array(s.q0), np.array(s.omega0)


def failure(s: System, method: str, backend: str, opts: Options, **kw: object) -> IntegrationError:
    """The IntegrationError of a run that must fail."""
    with pytest.raises(IntegrationError) as info:
        simulate(s, method, backend=backend, options=opts, **kw)  # type: ignore[arg-type]
    return info.value


def attempts(tr: Trajectory) -> int:
    """Accepted plus rejected steps of a finished (or failed) run."""
    return int(tr.stats["steps"]) + int(tr.stats["rejected"])


@pytest.mark.timeout(60, method="thread")
@pytest.mark.parametrize("method", ADAPTIVE)
def test_spin_ends_on_c_with_the_default_budget(method: str) -> None:
    """The 1e100 spin on the emitted C with the default options: ERR_STEPSIZE after exactly
    100000 attempts in the first output interval, the initial sample kept (as given)."""
    s, q0, w0 = pendula()
    exc = failure(s, method, "c", Options(), h=0.25, T=1.0, q0=q0, omega0=SPIN * w0)
    assert exc.status == Status.STEPSIZE and exc.step == 1
    assert "max_steps" in str(exc)
    assert attempts(exc.partial) == Options().max_steps == 100000
    assert exc.partial.t.tolist() == [0.0]
    assert np.array_equal(exc.partial.q[0], q0)
    assert np.array_equal(exc.partial.omega[0], SPIN * w0)
    assert 0.0 < float(exc.partial.stats["fail_time"]) < 1e-90  # steps of ~1e-102


@pytest.mark.timeout(120, method="thread")
@pytest.mark.parametrize("method", ADAPTIVE)
def test_spin_backends_agree(method: str) -> None:
    """The 1e100 spin with a budget of 300 on C, NumPy and (RK45) the reference: all stop with
    the stepsize status at the first sample, after 300 attempts, at the same time t."""
    s, q0, w0 = pendula()
    opts = Options(max_steps=300)
    kw = {"h": 0.25, "T": 1.0, "q0": q0, "omega0": SPIN * w0}
    backends = ("c", "numpy", "reference") if method == "rk45" else ("c", "numpy")
    fails = {be: failure(s, method, be, opts, **kw) for be in backends}
    for be, exc in fails.items():
        assert exc.status == Status.STEPSIZE and exc.step == 1, be
        assert exc.partial.t.tolist() == [0.0], be
        assert np.array_equal(exc.partial.omega[0], SPIN * w0), be
    assert attempts(fails["c"].partial) == attempts(fails["numpy"].partial) == 300
    c, py = fails["c"].partial.stats, fails["numpy"].partial.stats
    assert float(c["fail_time"]) == pytest.approx(float(py["fail_time"]), rel=1e-12)


def single_interval(s: System, method: str, backend: str, budget: int) -> Trajectory:
    """A run of T = 2 with one output interval (h = T) from the spec's state, or the
    IntegrationError's partial trajectory if it fails (re-raised when not STEPSIZE)."""
    kw = {"h": 2.0, "T": 2.0, "q0": np.array(s.q0), "omega0": np.array(s.omega0)}
    try:
        return simulate(s, method, backend=backend, options=Options(max_steps=budget), **kw)  # type: ignore[arg-type]
    except IntegrationError as exc:
        assert exc.status == Status.STEPSIZE and exc.step == 1
        raise


@pytest.mark.timeout(300, method="thread")
@pytest.mark.parametrize(
    ("method", "backend"),
    [("rk45", "c"), ("dop853", "c"), ("rk45", "numpy"), ("dop853", "numpy"), ("rk45", "reference")],
)
def test_budget_just_large_enough(method: str, backend: str) -> None:
    """Over one output interval a run needs (steps + rejected) attempts, counted by an
    unlimited run (max_steps = 0): that budget lets it finish with the same samples, one less
    stops it with the stepsize status after exactly that many attempts."""
    s, _, _ = pendula()
    free = single_interval(s, method, backend, 0)
    need = attempts(free)
    assert need > 20  # a real adaptive run: many steps inside the one interval
    exact = single_interval(s, method, backend, need)
    assert attempts(exact) == need
    assert np.array_equal(exact.q, free.q) and np.array_equal(exact.omega, free.omega)
    with pytest.raises(IntegrationError) as info:
        single_interval(s, method, backend, need - 1)
    if backend != "reference":  # its failures report the samples kept, not the counts
        assert attempts(info.value.partial) == need - 1
    assert info.value.partial.t.tolist() == [0.0]


@pytest.mark.timeout(300, method="thread")
def test_budget_mid_run_backends_agree() -> None:
    """The pendula from rest just off upside down (rtol 1e-6): they speed up as they fall, so
    a later output interval needs the most attempts. The smallest budget that lets the
    reference (RK45, ode45's control) finish is found by bisection; one less stops it mid-run.
    C and NumPy stop at the same sample with the stepsize status, their kept samples the
    reference's to round-off, and those are the unlimited run's."""
    s, q0, _ = pendula()
    q0 = -q0 + 1e-3
    q0 /= np.linalg.norm(q0, axis=1, keepdims=True)
    kw = {"h": 0.5, "T": 8.0, "q0": q0, "omega0": np.zeros_like(q0)}

    def reference(budget: int) -> Trajectory:
        opts = Options(rtol=1e-6, max_steps=budget)
        return simulate(s, "rk45", backend="reference", options=opts, **kw)  # type: ignore[arg-type]

    free = reference(0)
    lo, hi = 1, attempts(free)
    while lo < hi:
        mid = (lo + hi) // 2
        try:
            reference(mid)
            hi = mid
        except IntegrationError:
            lo = mid + 1
    opts = Options(rtol=1e-6, max_steps=lo - 1)
    fails = {be: failure(s, "rk45", be, opts, **kw) for be in ("reference", "c", "numpy")}
    ref = fails["reference"]
    assert ref.status == Status.STEPSIZE and 1 < ref.step < free.t.size
    assert np.array_equal(ref.partial.q, free.q[: ref.step])
    for be in ("c", "numpy"):
        exc = fails[be]
        assert exc.status == Status.STEPSIZE and exc.step == ref.step, be
        assert np.allclose(exc.partial.q, ref.partial.q, rtol=0.0, atol=1e-9), be
        assert np.allclose(exc.partial.omega, ref.partial.omega, rtol=0.0, atol=1e-8), be


def batch_against_members(
    method: str, q0: np.ndarray, w0: np.ndarray, opts: Options
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """integrate_batch on four_pendula (h 0.05, 20 steps, every 2nd kept), every member bit
    for bit its one-member integrate() with the same options: (statuses, batch stats)."""
    s = builtin("four_pendula")
    one, batched = CBackend(s, opt="portable"), CBackend(s.with_batch(), opt="portable")
    p = np.repeat(np.array(s.parameter_values)[None], K, axis=0)
    b = integrate_batch(batched, method, 0.05, 20, q0, w0, p, opts, 2)
    for k in range(K):
        status, q, w, _, stats = one.integrate(method, 0.05, 20, q0[k], w0[k], p[k], opts, 2)
        done = int(stats["fail_step"]) if status else q.shape[0]
        assert int(b.status[k]) == status, k
        assert np.array_equal(bits(b.q[k, :done]), bits(q[:done])), k
        assert np.array_equal(bits(b.omega[k, :done]), bits(w[:done])), k
        assert np.isnan(b.q[k, done:]).all(), k
        for f in ("steps", "rejected", "fail_step"):
            assert int(b.stats[f][k]) == stats[f], (k, f)
    return np.asarray(b.status), b.stats


def batch_states(spread: float) -> tuple[np.ndarray, np.ndarray]:
    """K perturbed copies of four_pendula's initial state, the speeds scaled by factors in
    [1, 1 + spread)."""
    s = builtin("four_pendula")
    rng = np.random.default_rng(5)
    q0 = np.array(s.q0)[None] + 1e-2 * rng.standard_normal((K, s.n, 3))
    q0 /= np.linalg.norm(q0, axis=2, keepdims=True)
    w0 = np.repeat(np.array(s.omega0)[None], K, axis=0) * (1 + spread * rng.random((K, 1, 1)))
    return q0, w0


@pytest.mark.timeout(120, method="thread")
@pytest.mark.parametrize("method", ADAPTIVE)
def test_batch_lane_spin_fails_alone(method: str) -> None:
    """integrate_batch with one member spinning 1e100 times too fast (default options): that
    lane stops with ERR_STEPSIZE after 100000 attempts, every member (it too) bit for bit its
    one-member run, the others finish."""
    q0, w0 = batch_states(0.0)
    spin = 1  # in the first block, with live neighbours
    assert spin < BATCH_LANES
    w0[spin] *= SPIN
    status, stats = batch_against_members(method, q0, w0, Options())
    assert status[spin] == Status.STEPSIZE and stats["fail_step"][spin] == 1
    assert stats["steps"][spin] + stats["rejected"][spin] == 100000
    assert (np.delete(status, spin) == 0).all()


@pytest.mark.timeout(120, method="thread")
@pytest.mark.parametrize(("method", "budget"), [("rk45", 8), ("dop853", 3)])
def test_batch_budget_per_lane(method: str, budget: int) -> None:
    """A tight budget (rtol 1e-6) on members of different speeds: each lane spends its own
    budget, reset at each of its own grid points, so some finish and others stop (DOP853: some
    of them mid-run), each bit for bit its one-member run."""
    q0, w0 = batch_states(3.0)
    status, stats = batch_against_members(method, q0, w0, Options(rtol=1e-6, max_steps=budget))
    assert (status == 0).any() and (status == Status.STEPSIZE).any()
    assert set(status.tolist()) <= {0, int(Status.STEPSIZE)}
    if method == "dop853":
        late = stats["fail_step"][status == Status.STEPSIZE]
        assert (late > 1).any()


@pytest.mark.timeout(120, method="thread")
@pytest.mark.parametrize("method", ADAPTIVE)
def test_driven_spin_ends(method: str) -> None:
    """A driven system (forced_double_pendulum, its default inputs) spinning 1e60 times too
    fast: the driven C stops with ERR_STEPSIZE in its first interval after max_steps attempts;
    with the budget off (0) a normal run still finishes. (At 1e100 the driven DOP853's first
    step estimate overflows: ERR_NONFINITE before any step, which ends the run too.)"""
    s = builtin("forced_double_pendulum")
    q0, w0 = np.array(s.q0), np.array(s.omega0)
    assert np.abs(w0).max() > 0
    exc = failure(s, method, "c", Options(max_steps=5000), h=0.1, T=0.5, q0=q0, omega0=1e60 * w0)
    assert exc.status == Status.STEPSIZE and exc.step == 1
    assert attempts(exc.partial) == 5000
    tr = simulate(s, method, h=0.1, T=0.5, options=Options(max_steps=0))
    assert tr.t.size == 6 and np.isfinite(tr.q).all()


@pytest.mark.parametrize("bad", [-1, 1.5, True, "10", 2**40])
def test_bad_budget_refused_in_one_line(bad: object) -> None:
    """max_steps must be a whole number in [0, 2^31 - 1]: anything else is a one-line
    ValueError naming the option, before any run."""
    s, _, _ = pendula()
    with pytest.raises(ValueError, match="max_steps") as info:
        simulate(s, "rk45", h=0.1, T=0.2, backend="numpy", options=Options(max_steps=bad))  # type: ignore[arg-type]
    assert "\n" not in str(info.value)


@pytest.mark.timeout(60, method="thread")
def test_cli_max_steps(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    """``s2gen simulate --max-steps``: a negative budget is one line on stderr (exit 2); a
    budget of 1 stops the spec's RK45 run at its first interval (exit 1: a failed
    integration), where the default budget finishes it."""
    from s2gen.cli import main

    out = str(tmp_path / "t.npz")
    args = ["simulate", "four_pendula", "--method", "rk45", "--T", "0.5", "--out", out]
    assert main([*args, "--max-steps", "-1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "max_steps" in err and "\n" not in err
    assert main([*args, "--max-steps", "1"]) == 1
    assert main(args) == 0
