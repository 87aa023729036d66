"""The time-transformed RATTLE methods (rattle-adaptive, rattle4-, rattle6-, rattle8-adaptive).

- the emitted C and NumPy against the reference integrator (`s2gen.reference.adaptive` with
  the reference's RATTLE step, Newton on the position multipliers, written independently of
  the emitted closed-form and Newton steps) to 1e-10 on the sampled grid, and C against NumPy
  to round-off with the same chain of steps, gradient count and Newton iterations: the three
  bodies (all four methods), the encounter cluster and the double pendulum with [run] g
  (coupled M: Newton on the multipliers), and C against NumPy on the pendulum chain's
  structured solver;
- vi-adaptive's statuses and refusals: ERR_STEPSIZE at the same sample, the same one-line
  refusal of a system without a driver;
- rattle-adaptive against vi-adaptive on the same system and eps: RATTLE on the sphere is the
  same discrete flow as the VI, so the two chains take the same steps and their samples
  agree to round-off (measured: at most 2e-12 on the cluster with rattle8-adaptive, ~1e-13
  otherwise), without being the same floating-point operations (a difference above 0 shows
  the RATTLE step ran);
- the observed order in eps (2 and 4) against scipy's DOP853 on the reference field;
- time reversibility of the reference's chain (which a one-sided step-size update breaks) and
  of the C runs; unit length over more than
  1,000 steps through the cluster's encounters;
- broken variants fail: the C composition with the first fraction in every RATTLE substep,
  the NumPy with v = q x omega for v = omega x q.
"""

from __future__ import annotations

from importlib.resources import files

import numpy as np
import pytest
from conftest import reference_path

import s2gen
from s2gen.emit import emit
from s2gen.methods import Family, Status, method
from s2gen.reference import adaptive
from s2gen.reference.adaptive import (
    integrate_time_transformed,
    monitor_from_system,
    transformed_steps,
)
from s2gen.reference.problem import problem_from_system
from s2gen.runtime import IntegrationError
from s2gen.runtime.numpy_module import import_cached
from s2gen.runtime.options import Options
from s2gen.spec import load_spec_text
from s2gen.system import System
from s2gen.systems import builtin

THREE = builtin("three_bodies")
CLUSTER = builtin("encounter_cluster")
PENDULUM_G = load_spec_text(
    (files("s2gen.systems.examples") / "double_pendulum.toml").read_text()
    + 'g = "3 + dot(q1, q2)"\n'
)
#: Six bodies whose M the structured (max-index) solver takes, with [run] g
CHAIN_G = load_spec_text(
    (files("s2gen.systems.examples") / "pendulum_chain.toml")
    .read_text()
    .replace('scale = "l"', 'scale = "l"\nsolver = "structured"')
    + 'g = "3 + dot(q1, q2)"\n'
)
ALL = ("rattle-adaptive", "rattle4-adaptive", "rattle6-adaptive", "rattle8-adaptive")
#: The reference's Newton on the position multipliers stalls at ~1.2e-14 with the double
#: pendulum's large M (round-off in |x|^2 - 1 over a Jacobian 2 M^-1 of ~0.02), above its
#: default tolerance 1e-14; every backend runs that case with this one.
COUPLED = Options(newton_tol=1e-12)


def _gap(a: s2gen.Trajectory, b: s2gen.Trajectory) -> float:
    return float(max(np.abs(a.q - b.q).max(), np.abs(a.omega - b.omega).max()))


def test_the_methods_follow_the_vi_ones() -> None:
    """Codes after vi8-adaptive's, and each with its VI counterpart's order and stages."""
    for code, name in enumerate(ALL, start=18):
        m, vi = method(name), method(name.replace("rattle", "vi"))
        assert m.code == code and m.family is Family.TIME_RATTLE and m.driver is vi.driver
        assert (m.order, m.evals, m.backends) == (vi.order, vi.evals, vi.backends)


@pytest.mark.parametrize(
    ("system", "names", "eps", "T", "every", "options"),
    [
        (THREE, ALL, 0.05, 1.0, 2, None),
        (CLUSTER, ("rattle4-adaptive",), 0.01, 1.0, 5, None),
        (PENDULUM_G, ("rattle-adaptive", "rattle4-adaptive"), 0.02, 1.0, 5, COUPLED),
    ],
    ids=["three_bodies", "encounter_cluster", "double_pendulum_g"],
)
def test_c_numpy_and_the_reference_agree(
    system: System,
    names: tuple[str, ...],
    eps: float,
    T: float,
    every: int,
    options: Options | None,
) -> None:
    for name in names:
        run = {"h": eps, "T": T, "every": every, "options": options}
        ref = s2gen.Model(system, backend="reference").integrate(name, **run)
        c = s2gen.Model(system).integrate(name, **run)
        py = s2gen.Model(system, backend="numpy").integrate(name, **run)
        np.testing.assert_array_equal(c.t, ref.t)
        np.testing.assert_array_equal(py.t, ref.t)
        assert c.stats["steps"] == py.stats["steps"] == ref.stats["steps"] > 0
        assert c.stats["gradient_evals"] == ref.stats["gradient_evaluations"]
        for key in ("gradient_evals", "newton_iters", "newton_max"):
            assert c.stats[key] == py.stats[key], (name, key)
        assert _gap(c, ref) < 1e-10 and _gap(py, ref) < 1e-10, (name, _gap(c, ref))
        assert _gap(c, py) < 1e-12, (name, _gap(c, py))


def test_the_structured_solver_agrees_with_the_c() -> None:
    """The max-index solver's RATTLE (Newton on band solves) under the time-transformed driver:
    the NumPy and the C take the same steps and Newton iterations, and follow vi-adaptive."""
    c = s2gen.Model(CHAIN_G).integrate("rattle-adaptive", h=0.02, T=0.2)
    py = s2gen.Model(CHAIN_G, backend="numpy").integrate("rattle-adaptive", h=0.02, T=0.2)
    vi = s2gen.Model(CHAIN_G).integrate("vi-adaptive", h=0.02, T=0.2)
    assert py.stats["steps"] == c.stats["steps"] == vi.stats["steps"] > 0
    assert py.stats["newton_iters"] == c.stats["newton_iters"] > 0
    assert _gap(c, py) < 1e-12 and 0.0 < _gap(c, vi) < 1e-11, (_gap(c, py), _gap(c, vi))


def test_statuses_and_refusals_are_vi_adaptive_s() -> None:
    """A step that does not resolve the monitor stops with ERR_STEPSIZE at the sample where
    vi-adaptive stops; a system whose module has no driver is refused in vi-adaptive's words."""
    for backend in ("c", "numpy", "reference"):
        model, stops = s2gen.Model(CLUSTER, backend=backend), []
        for name in ("rattle-adaptive", "vi-adaptive"):
            with pytest.raises(IntegrationError, match="step size") as e:
                model.integrate(name, h=1.0, T=100.0)
            assert e.value.status == int(Status.STEPSIZE) and "\n" not in str(e.value)
            stops.append(e.value.step)
        assert stops[0] == stops[1], backend
    for backend in ("c", "numpy"):
        said = []
        for name in ("rattle-adaptive", "vi-adaptive"):
            with pytest.raises(ValueError) as refused:
                s2gen.Model(builtin("double_pendulum"), backend=backend).integrate(
                    name, h=0.01, T=0.1
                )
            said.append(str(refused.value))
        assert said[0] == said[1] and "time-transformed" in said[0], backend


@pytest.mark.parametrize(
    ("system", "names", "eps", "T", "tol"),
    [
        (THREE, ALL, 0.05, 1.0, 1e-12),
        (CLUSTER, ALL, 0.01, 1.0, 1e-11),
        (PENDULUM_G, ("rattle-adaptive", "rattle4-adaptive"), 0.02, 1.0, 1e-12),
    ],
    ids=["three_bodies", "encounter_cluster", "double_pendulum_g"],
)
def test_rattle_adaptive_is_the_vi_adaptive_flow(
    system: System, names: tuple[str, ...], eps: float, T: float, tol: float
) -> None:
    """The same chain of steps and samples to round-off, by other operations (gap > 0)."""
    for backend in ("c", "numpy"):
        model = s2gen.Model(system, backend=backend)
        for name in names:
            rattle = model.integrate(name, h=eps, T=T, every=5)
            vi = model.integrate(name.replace("rattle", "vi"), h=eps, T=T, every=5)
            assert rattle.stats["steps"] == vi.stats["steps"] > 0
            assert 0.0 < _gap(rattle, vi) < tol, (backend, name, _gap(rattle, vi))


@pytest.mark.parametrize(
    ("name", "order", "eps"), [("rattle-adaptive", 2, 0.02), ("rattle4-adaptive", 4, 0.1)]
)
def test_observed_order_in_the_fictitious_step(name: str, order: int, eps: float) -> None:
    """The reference's samples at t = 0.5, 1.0, 1.5, 2.0 against DOP853 as eps halves."""
    T = 2.0
    times = np.linspace(0.5, T, 4)
    want = reference_path(THREE, T, times)
    p, mon = problem_from_system(THREE), monitor_from_system(THREE)
    errors = []
    for e in (eps, eps / 2, eps / 4):
        nsteps = round(T / e)
        tr = integrate_time_transformed(
            p, mon, name, THREE.q0, THREE.omega0, e, nsteps, nsteps // 4
        )
        np.testing.assert_allclose(tr.t[1:], times, rtol=1e-14)
        got = np.concatenate([tr.q[1:].reshape(4, -1), tr.omega[1:].reshape(4, -1)], axis=1)
        errors.append(np.abs(got - want).max())
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.3), (errors, observed)


def _reference_round_trip(system: System, name: str, eps: float, n: int) -> float:
    """n steps with eps, then n with -eps from the end (q, w, xi): the distance from the start."""
    p, mon = problem_from_system(system), monitor_from_system(system)
    q0, w0 = np.array(system.q0, float), np.array(system.omega0, float)
    xi0, _ = mon(q0, w0)
    q, w, xi, t = transformed_steps(p, mon, name, q0, w0, xi0, eps, n)
    q, w, xi, back = transformed_steps(p, mon, name, q, w, xi, -eps, n)
    assert t > 0.0
    return float(max(np.abs(q - q0).max(), np.abs(w - w0).max(), abs(t + back)))


@pytest.mark.parametrize(
    ("system", "name", "eps", "n"),
    [(THREE, "rattle4-adaptive", 0.05, 100), (CLUSTER, "rattle-adaptive", 0.02, 300)],
    ids=["three_bodies", "encounter_cluster"],
)
def test_the_reference_chain_is_reversible(system: System, name: str, eps: float, n: int) -> None:
    """Measured: 1.2e-12 on the cluster (the multipliers' Newton stops at 1e-14), below 1e-13
    on the three bodies."""
    assert _reference_round_trip(system, name, eps, n) < 1e-11


def test_a_non_symmetric_step_size_update_breaks_reversibility(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The check is live: with xi_{n+1/2} = xi_n the round trip misses by far more."""
    monkeypatch.setattr(adaptive, "_half", lambda xi, rate, eps, step: xi)
    assert _reference_round_trip(THREE, "rattle4-adaptive", 0.05, 100) > 1e-6


def _round_trip(model: s2gen.Model, name: str, eps: float, T: float) -> float:
    """Forward over T, then from the end state with the velocities reversed back to the start
    (both runs start xi at R(q): a symmetric update retraces the chain to round-off)."""
    q0, w0 = np.array(model.system.q0, float), np.array(model.system.omega0, float)
    tr = model.integrate(name, h=eps, T=T)
    back = model.integrate(name, h=eps, T=T, q0=tr.q[-1], omega0=-tr.omega[-1])
    return float(max(np.abs(back.q[-1] - q0).max(), np.abs(back.omega[-1] + w0).max()))


def test_the_c_runs_are_reversible() -> None:
    assert _round_trip(s2gen.Model(THREE), "rattle4-adaptive", 0.01, 2.0) < 1e-11


def test_unit_length_through_the_encounters() -> None:
    for backend in ("c", "reference"):
        tr = s2gen.Model(CLUSTER, backend=backend).integrate("rattle-adaptive", h=0.05, T=10.0)
        assert tr.stats["steps"] > 1000
        assert np.abs(np.linalg.norm(tr.q, axis=2) - 1.0).max() < 1e-14, backend


#: Every RATTLE substep of the emitted C with the composition's first fraction.
FIRST_FRACTION = (
    "_rattle_advance(cx, opt, sc->fractions[sub] * h,",
    "_rattle_advance(cx, opt, sc->fractions[0] * h,",
)
#: The emitted NumPy's RATTLE velocities with the wrong sign.
SWAPPED_CROSS = ("numpy.cross(w0, q0) if rattle", "numpy.cross(q0, w0) if rattle")


def test_broken_variants_fail() -> None:
    """Each variant is off the reference by far more than the agreement's 1e-10."""
    ref = s2gen.Model(THREE, backend="reference").integrate("rattle4-adaptive", h=0.05, T=1.0)
    emitted = emit(THREE, "c")
    broken = {k: v.replace(*FIRST_FRACTION) for k, v in emitted.items()}
    assert broken != emitted
    c = s2gen.Model(THREE, files=broken).integrate("rattle4-adaptive", h=0.05, T=1.0)
    assert np.abs(c.q - ref.q).max() > 1e-6
    ((fname, text),) = emit(THREE, "numpy").items()
    assert SWAPPED_CROSS[0] in text
    module = import_cached(fname, text.replace(*SWAPPED_CROSS))
    p = np.array(THREE.parameter_values, dtype=float)
    q0, w0 = np.array(THREE.q0, float), np.array(THREE.omega0, float)
    status, q, _, _, _ = module.integrate(p, method("rattle4-adaptive").code, 0.05, 20, q0, w0)
    assert status == 0 and np.abs(q[-1] - ref.q[-1]).max() > 1e-6
