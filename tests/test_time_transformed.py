"""The time-transformed VI methods (vi-adaptive, vi4-adaptive, vi6-adaptive, vi8-adaptive).

- the pair monitor: its rate is the closed form derived by hand for the three bodies' cotangent
  potential, it grows at both singular points of that potential, it stays positive through the
  inflection point of the softened cluster's potential; systems and terms it does not cover
  are refused in one line (the emitted C and NumPy refuse them with the same words:
  tests/test_time_transformed_c.py, tests/test_time_transformed_numpy.py);
- the orders 2 and 4 in the fictitious step eps (error of the sampled state against scipy's
  DOP853 on the reference field, samples reached by the extra partial step), on the grid;
- time reversibility (n steps with eps, then n with -eps, back to 1e-12), which a
  non-symmetric step-size update breaks; unit length on the encounter cluster; bounded energy
  error through repeated close encounters of a softened pair (the fitted slope of the window
  maxima of |dE| against time in log-log; 10^5 steps in the slow suite).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from conftest import reference_path

import s2gen
from s2gen.monitor import C, monitor
from s2gen.reference import adaptive
from s2gen.reference.adaptive import (
    integrate_time_transformed,
    monitor_from_system,
    transformed_steps,
)
from s2gen.reference.problem import problem_from_system
from s2gen.runtime.trajectory import stat_counts
from s2gen.spec import load_spec_text
from s2gen.system import SpecError
from s2gen.systems import builtin

THREE = builtin("three_bodies")
CLUSTER = builtin("encounter_cluster")


def _setup(system):
    return problem_from_system(system), monitor_from_system(system)


def _start(system):
    return np.array(system.q0, dtype=float), np.array(system.omega0, dtype=float)


# ------------------------------------------------------------------------------ the monitor
def test_the_three_bodies_rate_is_the_closed_form() -> None:
    """V = -gamma c / sqrt(1 - c^2): f' = -gamma (1 - c^2)^(-3/2), V'' = -2 gamma c (1 - c^2)^(-3/2)
    (by hand), so r^4 = gamma^2 (1 + 4 c^2) / (1 - c^2)^3."""
    (rate,) = monitor(THREE).rates
    gamma = sp.Symbol("gamma", real=True)
    want = sp.sqrt(gamma) * (1 + 4 * C**2) ** sp.Rational(1, 4) * (1 - C**2) ** sp.Rational(-3, 4)
    for c in (-0.9, -0.3, 0.0, 0.4, 0.99):
        got, ref = (float(e.subs({C: c, gamma: 2.0})) for e in (rate.rate, want))
        assert got == pytest.approx(ref, rel=1e-13)
    near = [float(rate.rate.subs({C: c, gamma: 1.0})) for c in (-1 + 1e-6, 1 - 1e-6)]
    assert min(near) > 1e4  # both singular points (antipodal and coincident) are covered


def test_the_cluster_rate_stays_positive_through_the_inflection_point() -> None:
    """Plummer's V = -k (d^2 + a^2)^(-1/2) has V'' = 0 at d = a / sqrt(2); the monitor's
    curvature part keeps r > 0 there and everywhere on [-1, 1]."""
    (rate,) = monitor(CLUSTER).rates
    values = {sp.Symbol(p, real=True): v for p, v in CLUSTER.parameters.items()}
    r = sp.lambdify([C], rate.rate.subs(values), "numpy")
    cs = np.linspace(-1.0, 1.0, 20001)
    assert np.all(r(cs) > 0.1)
    assert r(1.0) > 10 * r(0.0)  # fast near an encounter


def test_systems_the_monitor_does_not_cover_are_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="closed systems with pair terms") as e:
        monitor(builtin("double_pendulum"))
    assert "\n" not in str(e.value)
    odd = load_spec_text(
        'name = "odd"\nbodies = 2\n[inertia]\ndiagonal = ["1", "1"]\n'
        '[[potential.pair]]\nV = "qi[0]*qj[1]"\npairs = "all"\n'
    )
    with pytest.raises(ValueError, match="not a function of qi.qj alone"):
        monitor(odd)


def _with_monitor(name: str, g: object) -> str:
    """The built-in `name`'s TOML text with [run] g set."""
    from importlib.resources import files

    text = (files("s2gen.systems.examples") / f"{name}.toml").read_text()
    return text + f"g = {g!r}\n".replace("'", '"')


def test_a_monitor_given_as_run_g_is_used() -> None:
    """The three bodies' derived monitor typed by hand as [run] g gives the same run."""
    pairs = ((1, 2), (1, 3), (2, 3))
    rule = "(1 + 4*dot(q{0}, q{1})**2)**0.25*(1 - dot(q{0}, q{1})**2)**(-0.75)"
    g = " + ".join(rule.format(i, j) for i, j in pairs)
    spec = (
        f'name = "three_bodies_g"\nbodies = 3\n[parameters]\ngamma = 1.0\n'
        f'[inertia]\ndiagonal = ["1", "1", "1"]\n[[potential.pair]]\n'
        f'V = "-gamma*dot(qi, qj)/sqrt(1 - dot(qi, qj)**2)"\npairs = "all"\n'
        f"[initial]\nq = {THREE.q0.tolist()}\nomega = {THREE.omega0.tolist()}\n"
        f'[run]\ng = "{g}"\n'
    )
    given = load_spec_text(spec)
    assert monitor(given).given is not None
    runs = []
    for system in (THREE, given):
        p, mon = _setup(system)
        runs.append(
            integrate_time_transformed(p, mon, "vi4-adaptive", THREE.q0, THREE.omega0, 0.05, 20)
        )
    assert runs[0].stats["steps"] == runs[1].stats["steps"]
    np.testing.assert_allclose(runs[1].q, runs[0].q, rtol=0, atol=1e-12)


def test_a_given_monitor_takes_any_closed_system() -> None:
    """The double pendulum (no pair terms, coupled M: Newton) with g = 3 + q1.q2 steps
    reversibly."""
    system = load_spec_text(_with_monitor("double_pendulum", "3 + dot(q1, q2)"))
    assert _round_trip(system, "vi4-adaptive", 0.02, 50) < 1e-12


@pytest.mark.parametrize(
    ("g", "message"),
    [("1 + t", "not on time t"), ("1 + x", "x"), (2, "expected an expression")],
)
def test_bad_run_g_is_refused_in_one_line(g: object, message: str) -> None:
    with pytest.raises(SpecError, match=message) as e:
        load_spec_text(_with_monitor("double_pendulum", g))
    assert "\n" not in str(e.value) and "[run] g" in str(e.value)


# ------------------------------------------------------------------------ order and the grid
@pytest.mark.parametrize(
    ("name", "order", "eps"), [("vi-adaptive", 2, 0.02), ("vi4-adaptive", 4, 0.1)]
)
def test_observed_order_in_the_fictitious_step(name: str, order: int, eps: float) -> None:
    """Samples at t = 0.5, 1.0, 1.5, 2.0 (the extra partial steps included) against DOP853."""
    T, every = 2.0, None
    times = np.linspace(0.5, T, 4)
    want = reference_path(THREE, T, times)
    p, mon = _setup(THREE)
    errors = []
    for e in (eps, eps / 2, eps / 4):
        nsteps = round(T / e)
        every = nsteps // 4
        tr = integrate_time_transformed(p, mon, name, THREE.q0, THREE.omega0, e, nsteps, every)
        np.testing.assert_allclose(tr.t[1:], times, rtol=1e-14)
        got = np.concatenate([tr.q[1:].reshape(4, -1), tr.omega[1:].reshape(4, -1)], axis=1)
        errors.append(np.abs(got - want).max())
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.3), (errors, observed)


def test_the_reference_backend_samples_on_the_grid() -> None:
    """Model.integrate on the reference backend: t_k = k every h, the state at T of the direct
    driver, and the energy of each sample."""
    model = s2gen.Model(THREE, backend="reference")
    tr = model.integrate("vi4-adaptive", h=0.05, T=1.0, every=5)
    np.testing.assert_allclose(tr.t, np.arange(5) * 0.25, atol=1e-15)
    p, mon = _setup(THREE)
    direct = integrate_time_transformed(p, mon, "vi4-adaptive", THREE.q0, THREE.omega0, 0.05, 20)
    np.testing.assert_array_equal(tr.q[-1], direct.q[-1])
    counts = stat_counts(tr.stats, tr.method)
    assert counts["steps"] == direct.stats["steps"] > 0
    assert counts["gradient_evals"] == 1 + 3 * (direct.stats["steps"] + 4)  # 4 output steps
    assert tr.energy[-1] == pytest.approx(model.energy(tr.q[-1], tr.omega[-1]), rel=1e-14)


# ------------------------------------------------------------- reversibility and structure
def _round_trip(system, name: str, eps: float, n: int) -> float:
    p, mon = _setup(system)
    q0, w0 = _start(system)
    xi0, _ = mon(q0, w0)
    q, w, xi, t = transformed_steps(p, mon, name, q0, w0, xi0, eps, n)
    assert t > 0.0
    q, w, xi, back = transformed_steps(p, mon, name, q, w, xi, -eps, n)
    return max(np.abs(q - q0).max(), np.abs(w - w0).max(), abs(xi - xi0) / xi0, abs(t + back))


@pytest.mark.parametrize(
    ("system", "name", "eps", "n"),
    [(THREE, "vi4-adaptive", 0.05, 100), (CLUSTER, "vi-adaptive", 0.02, 300)],
    ids=["three_bodies", "encounter_cluster"],
)
def test_time_reversibility(system, name: str, eps: float, n: int) -> None:
    assert _round_trip(system, name, eps, n) < 1e-12


def test_a_non_symmetric_step_size_update_breaks_reversibility(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The check is live: with xi_{n+1/2} = xi_n (the explicit, one-sided update) the round
    trip misses by far more than round-off."""
    monkeypatch.setattr(adaptive, "_half", lambda xi, rate, eps, step: xi)
    assert _round_trip(THREE, "vi4-adaptive", 0.05, 100) > 1e-6


def test_unit_length_is_kept() -> None:
    p, mon = _setup(CLUSTER)
    tr = integrate_time_transformed(p, mon, "vi-adaptive", CLUSTER.q0, CLUSTER.omega0, 0.05, 200)
    assert tr.stats["steps"] > 500
    assert np.abs(np.linalg.norm(tr.q, axis=2) - 1.0).max() < 1e-14


#: Two unit masses with the cluster's softened attraction (a = 0.02) on an eccentric orbit: their
#: relative motion is integrable, and they meet about every 6.7 time units, passing within 0.01.
PAIR = load_spec_text(
    'name = "pair"\nbodies = 2\n[parameters]\nk = 1.0\na = 0.02\n'
    '[inertia]\ndiagonal = ["1", "1"]\n'
    '[[potential.pair]]\nV = "-k/sqrt(dot(qi - qj, qi - qj) + a**2)"\npairs = "all"\n'
    "[initial]\nq = [[1, 0, 0], [0, 1, 0]]\nomega = [[0, -0.03, 0], [-0.03, 0, 0]]\n"
)


def _slope(t: np.ndarray, energy: np.ndarray, windows: int = 10) -> float:
    """Fitted slope of log max|dE| per window against log of the window's end time."""
    de = np.abs(energy - energy[0]) / abs(energy[0])
    parts = np.array_split(np.arange(1, len(de)), windows)
    ends = np.array([t[x[-1]] for x in parts])
    peaks = np.array([de[x].max() for x in parts])
    return float(np.polyfit(np.log(ends), np.log(peaks), 1)[0])


def _energy_growth(system, name: str, eps: float, T: float):
    """`_slope` of a run, its largest relative energy error, its steps and closest approach."""
    p, mon = _setup(system)
    tr = integrate_time_transformed(p, mon, name, system.q0, system.omega0, eps, round(T / eps))
    worst = np.abs(tr.energy - tr.energy[0]).max() / abs(tr.energy[0])
    closest = np.linalg.norm(tr.q[:, 0] - tr.q[:, 1], axis=1).min()
    return _slope(tr.t, tr.energy), float(worst), int(tr.stats["steps"]), float(closest)


def test_energy_error_is_bounded_through_repeated_encounters() -> None:
    """About 30 encounters in 1.1e4 steps: the energy error (O(eps^2) at each encounter)
    does not grow from window to window."""
    slope, worst, steps, closest = _energy_growth(PAIR, "vi-adaptive", 0.05, 200.0)
    assert steps > 10_000 and closest < 0.02
    assert slope <= 0.1 and worst < 0.2, (slope, worst)
    # the measure sees a drift: RK4 (emitted C) through the same encounters fits a slope near 1
    rk4 = s2gen.Model(PAIR).integrate("rk4", h=2e-4, T=200.0, every=10)
    assert _slope(rk4.t, rk4.energy) > 0.5


@pytest.mark.slow
def test_energy_error_is_bounded_over_1e5_steps() -> None:
    slope, worst, steps, closest = _energy_growth(PAIR, "vi-adaptive", 0.05, 1800.0)
    assert steps >= 100_000 and closest < 0.02
    assert slope <= 0.1 and worst < 0.2, (slope, worst)


def test_refusals_that_need_no_derivation_come_first(monkeypatch: pytest.MonkeyPatch) -> None:
    """Pair terms within a cutoff, or more monitored pairs than the emitted driver takes, are
    refused without deriving the monitor (a large system's generation would pay for it); a
    system the driver takes is derived, and one without a monitor says why."""
    from s2gen import monitor as module
    from s2gen.spec import define_system

    many = define_system(
        name="many",
        bodies=12,
        parameters={"k": 1.0},
        diagonal="1",
        pair_terms=[{"V": "k/(2 - dot(qi, qj))", "pairs": "all"}],
    )
    derived = []
    real = module.monitor
    monkeypatch.setattr(module, "monitor", lambda s: derived.append(s.name) or real(s))
    said = module.emitted_refusal(builtin("lj_cutoff"))
    assert said is not None and "cutoff" in said
    said = module.emitted_refusal(many)
    assert said is not None and f"at most {module.MONITOR_MAX_PAIRS} monitored pairs" in said
    assert "(this system has 66)" in said and derived == []
    assert module.emitted_refusal(THREE) is None and derived == [THREE.name]
    said = module.emitted_refusal(builtin("double_pendulum"))
    assert said is not None and ("other potential" in said or "no pair term" in said)
