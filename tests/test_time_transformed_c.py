"""The time-transformed VI methods in the emitted C (vi-adaptive, vi4-, vi6-, vi8-adaptive).

- the C run against the reference integrator (`s2gen.reference.adaptive`, Python, written
  independently of the emitted code) to 1e-10 on the sampled grid, with the same steps and
  gradient count: the three bodies (cotangent pairs, explicit VI), the encounter cluster
  (softened pairs) and the double pendulum with a monitor given as [run] g (coupled M:
  Newton);
- time reversibility of the C runs on the three bodies (forward to T, then from the end state
  with the velocities reversed back to the start: a symmetric step-size update retraces its
  chain, up to the O(eps^2) offset of xi_N from R(q_N) where the second run restarts xi) and
  unit length through the cluster's encounters;
- a broken variant of the emitted C (the one-sided step-size update xi_{n+1/2} = xi_n) fails
  both the agreement and the reversibility checks;
- bounded energy error over 10^5 steps through repeated close encounters of a softened pair;
- a system without a monitor (and an FMU) is refused in one line, a step that does not
  resolve the monitor stops with ERR_STEPSIZE, and a run with progress reports gives the
  same samples.
"""

from __future__ import annotations

from importlib.resources import files

import numpy as np
import pytest

import s2gen
from s2gen.emit import emit
from s2gen.methods import Status
from s2gen.runtime import IntegrationError
from s2gen.runtime.options import Options
from s2gen.spec import load_spec_text
from s2gen.systems import builtin

THREE = builtin("three_bodies")
CLUSTER = builtin("encounter_cluster")
PENDULUM_G = load_spec_text(
    (files("s2gen.systems.examples") / "double_pendulum.toml").read_text()
    + 'g = "3 + dot(q1, q2)"\n'
)
ALL = ("vi-adaptive", "vi4-adaptive", "vi6-adaptive", "vi8-adaptive")
#: The one-sided step-size update: not symmetric, so neither reversible nor the reference's.
ONE_SIDED = ("half = 0.5 * (xi + sqrt(disc));", "half = xi + 0.0 * disc;")


def _agreement(model: s2gen.Model, name: str, eps: float, T: float, every: int) -> float:
    ref = s2gen.Model(model.system, backend="reference").integrate(name, h=eps, T=T, every=every)
    tr = model.integrate(name, h=eps, T=T, every=every)
    np.testing.assert_array_equal(tr.t, ref.t)
    assert tr.stats["steps"] == ref.stats["steps"] > 0
    assert tr.stats["gradient_evals"] == ref.stats["gradient_evaluations"]
    return max(np.abs(tr.q - ref.q).max(), np.abs(tr.omega - ref.omega).max())


@pytest.mark.parametrize(
    ("system", "names", "eps", "T", "every"),
    [
        (THREE, ALL, 0.05, 1.0, 2),
        (CLUSTER, ("vi-adaptive", "vi4-adaptive"), 0.01, 1.0, 5),
        (PENDULUM_G, ("vi-adaptive", "vi4-adaptive"), 0.02, 1.0, 5),
    ],
    ids=["three_bodies", "encounter_cluster", "double_pendulum_g"],
)
def test_the_c_agrees_with_the_reference(system, names, eps: float, T: float, every: int) -> None:
    model = s2gen.Model(system)
    for name in names:
        assert _agreement(model, name, eps, T, every) < 1e-10, name


def _round_trip(model: s2gen.Model, name: str, eps: float, T: float) -> float:
    q0, w0 = np.array(model.system.q0, float), np.array(model.system.omega0, float)
    tr = model.integrate(name, h=eps, T=T)
    back = model.integrate(name, h=eps, T=T, q0=tr.q[-1], omega0=-tr.omega[-1])
    return max(np.abs(back.q[-1] - q0).max(), np.abs(back.omega[-1] + w0).max())


def test_the_driver_follows_the_inertia() -> None:
    """A diagonal M (explicit VI) lays out the driver that keeps the explicit step's
    component-major state across the run, whatever the system's name; a coupled M the one on
    the Newton VI's body-major steps."""
    from test_time_transformed import PAIR

    from s2gen.passes import lower_system

    for system in (THREE, CLUSTER, PAIR):
        assert dict(lower_system(system).variants)["transformed"] == "transformed_explicit"
    assert "transformed" not in dict(lower_system(PENDULUM_G).variants)
    assert "transformed" in lower_system(PENDULUM_G).parts


def test_the_c_runs_are_reversible() -> None:
    """Both runs start with xi = R(q): the chains differ only by the O(eps^2) offset of xi_N
    from R(q_N), which the symmetric update carries through to a tiny error."""
    assert _round_trip(s2gen.Model(THREE), "vi4-adaptive", 0.01, 2.0) < 1e-11


def test_a_one_sided_step_size_update_is_caught() -> None:
    broken = {k: v.replace(*ONE_SIDED) for k, v in emit(THREE, "c").items()}
    assert broken != emit(THREE, "c")
    model = s2gen.Model(THREE, files=broken)
    ref = s2gen.Model(THREE, backend="reference").integrate("vi4-adaptive", h=0.05, T=1.0)
    assert np.abs(model.integrate("vi4-adaptive", h=0.05, T=1.0).q - ref.q).max() > 1e-7
    assert _round_trip(model, "vi4-adaptive", 0.01, 2.0) > 1e-10


def test_unit_length_through_the_encounters() -> None:
    tr = s2gen.Model(CLUSTER).integrate("vi4-adaptive", h=0.02, T=10.0)
    assert tr.stats["steps"] > 2000
    assert np.abs(np.linalg.norm(tr.q, axis=2) - 1.0).max() < 1e-13


def test_a_system_without_a_monitor_is_refused_in_one_line() -> None:
    with pytest.raises(ValueError, match="closed systems with pair terms") as e:
        s2gen.Model(builtin("double_pendulum")).integrate("vi-adaptive", h=0.01, T=0.1)
    assert "\n" not in str(e.value)


def test_a_step_that_does_not_resolve_the_monitor_stops() -> None:
    """eps far beyond the encounters' time scale: no real root for xi_{n+1/2} at the first
    close approach."""
    with pytest.raises(IntegrationError, match="step size") as e:
        s2gen.Model(CLUSTER).integrate("vi-adaptive", h=1.0, T=100.0)
    assert e.value.status == int(Status.STEPSIZE) and "\n" not in str(e.value)


def test_a_given_monitor_is_part_of_the_spec_hash() -> None:
    """[run] g changes the emitted C: a cached library of the spec without it must not be
    taken for it."""
    assert PENDULUM_G.spec_hash() != builtin("double_pendulum").spec_hash()


def test_an_fmu_refuses_the_methods_in_one_line() -> None:
    """An FMU advances by step() (fixed steps) or by integrate() over one step of an adaptive
    Runge-Kutta method: neither is a time-transformed run."""
    from s2gen.fmi.model import describe

    with pytest.raises(ValueError, match="take no fixed step") as e:
        describe(THREE, 2, "cs", "vi4-adaptive")
    assert "\n" not in str(e.value)


def test_energy_error_is_bounded_over_1e5_steps_in_c() -> None:
    """The softened pair of tests/test_time_transformed.py (about 270 close encounters within
    0.02) over 10^5 steps: the windowed maxima of |dE| / |E| do not grow (fitted slope in
    log-log <= 0.1), where a drift fits a slope near 1."""
    from test_time_transformed import PAIR, _slope

    quiet = Options(energy_warn=1.0)  # the error at an encounter is about 5%, and bounded
    tr = s2gen.Model(PAIR).integrate("vi-adaptive", h=0.05, T=1800.0, every=10, options=quiet)
    assert tr.energy is not None and tr.stats["steps"] >= 100_000
    assert np.linalg.norm(tr.q[:, 0] - tr.q[:, 1], axis=1).min() < 0.02
    worst = np.abs(tr.energy - tr.energy[0]).max() / abs(tr.energy[0])
    assert _slope(tr.t, tr.energy) <= 0.1 and worst < 0.2


def test_a_run_with_progress_reports_and_gives_the_same_samples() -> None:
    """With `progress` the C call runs in a thread that reports the samples stored so far."""
    seen: list[float] = []
    model = s2gen.Model(CLUSTER)
    plain = model.integrate("vi4-adaptive", h=0.01, T=5.0, every=10)
    tr = s2gen.simulate(CLUSTER, "vi4-adaptive", h=0.01, T=5.0, every=10, progress=seen.append)
    np.testing.assert_array_equal(tr.q, plain.q)
    assert seen and seen[-1] == 1.0 and all(0.0 <= f <= 1.0 for f in seen)
