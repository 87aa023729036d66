"""The time-transformed VI methods in the emitted NumPy (vi-adaptive, vi4-, vi6-, vi8-adaptive).

- the NumPy run against the reference integrator (`s2gen.reference.adaptive`, written
  independently of the emitted code) to 1e-10 on the sampled grid, and against the emitted C
  to round-off with the same chain of steps, gradient count and Newton iterations: the three
  bodies (cotangent pairs, explicit VI; all four methods), the encounter cluster (softened
  pairs) and the double pendulum with a monitor given as [run] g (coupled M: the Newton VI),
  and the pendulum chain with [run] g on its structured (max-index) solver against the C;
- time reversibility of the NumPy runs on the three bodies, and a broken variant of the
  emitted NumPy (the one-sided step-size update xi_{n+1/2} = xi_n) that fails both the
  agreement and the reversibility checks;
- unit length through the cluster's encounters;
- a step that does not resolve the monitor stops with ERR_STEPSIZE; a system whose emitted
  module has no driver (no monitor, or pair terms within a cutoff) is refused in one line, with
  the C backend's words.
"""

from __future__ import annotations

from importlib.resources import files
from types import ModuleType

import numpy as np
import pytest

import s2gen
from s2gen.emit import emit
from s2gen.methods import Status, method
from s2gen.runtime import IntegrationError
from s2gen.runtime.numpy_module import import_cached
from s2gen.spec import load_spec_text
from s2gen.system import System
from s2gen.systems import builtin

THREE = builtin("three_bodies")
CLUSTER = builtin("encounter_cluster")


def _with_g(name: str, g: str, replace: tuple[str, str] = ("", "")) -> System:
    """The built-in `name` (its TOML text, with `replace` made) and [run] g (its last table)."""
    text = (files("s2gen.systems.examples") / f"{name}.toml").read_text()
    return load_spec_text(text.replace(*replace) + f'g = "{g}"\n')


PENDULUM_G = _with_g("double_pendulum", "3 + dot(q1, q2)")
#: Six bodies whose M the structured (max-index) solver takes: the Newton VI on band solves
CHAIN_G = _with_g(
    "pendulum_chain", "3 + dot(q1, q2)", ('scale = "l"', 'scale = "l"\nsolver = "structured"')
)
ALL = ("vi-adaptive", "vi4-adaptive", "vi6-adaptive", "vi8-adaptive")
#: The one-sided step-size update: not symmetric, so neither reversible nor the reference's.
ONE_SIDED = ("half = 0.5 * (xi + numpy.sqrt(disc))", "half = xi + 0.0 * disc")


def _agreement(system: System, name: str, eps: float, T: float, every: int) -> tuple[float, float]:
    """(largest difference from the reference, from the C) of the NumPy run's samples; the
    three runs share the grid and the chain of steps, and count the same gradients."""
    ref = s2gen.Model(system, backend="reference").integrate(name, h=eps, T=T, every=every)
    c = s2gen.Model(system).integrate(name, h=eps, T=T, every=every)
    tr = s2gen.Model(system, backend="numpy").integrate(name, h=eps, T=T, every=every)
    np.testing.assert_array_equal(tr.t, ref.t)
    assert tr.stats["steps"] == ref.stats["steps"] == c.stats["steps"] > 0
    assert tr.stats["gradient_evals"] == ref.stats["gradient_evaluations"]
    for key in ("gradient_evals", "newton_iters", "newton_max"):
        assert tr.stats[key] == c.stats[key], key

    def gap(other: s2gen.Trajectory) -> float:
        return float(max(np.abs(tr.q - other.q).max(), np.abs(tr.omega - other.omega).max()))

    return gap(ref), gap(c)


@pytest.mark.parametrize(
    ("system", "names", "eps", "T", "every"),
    [
        (THREE, ALL, 0.05, 1.0, 2),
        (CLUSTER, ("vi4-adaptive",), 0.01, 1.0, 5),
        (PENDULUM_G, ("vi-adaptive", "vi4-adaptive"), 0.02, 1.0, 5),
    ],
    ids=["three_bodies", "encounter_cluster", "double_pendulum_g"],
)
def test_the_numpy_agrees_with_the_reference_and_the_c(
    system: System, names: tuple[str, ...], eps: float, T: float, every: int
) -> None:
    for name in names:
        to_ref, to_c = _agreement(system, name, eps, T, every)
        assert to_ref < 1e-10 and to_c < 1e-12, (name, to_ref, to_c)


def test_the_structured_solver_agrees_with_the_c() -> None:
    """The max-index solver's Newton VI under the time-transformed driver (the reference
    backend solves dense, so the C is the comparison): the same steps and Newton iterations."""
    c = s2gen.Model(CHAIN_G).integrate("vi-adaptive", h=0.02, T=0.2)
    tr = s2gen.Model(CHAIN_G, backend="numpy").integrate("vi-adaptive", h=0.02, T=0.2)
    assert tr.stats["steps"] == c.stats["steps"] > 0
    assert tr.stats["newton_iters"] == c.stats["newton_iters"] > 0
    assert np.abs(tr.q - c.q).max() < 1e-12 and np.abs(tr.omega - c.omega).max() < 1e-12


def _module(text: str | None = None) -> ModuleType:
    """The three bodies' emitted NumPy module (or `text` in its place), imported."""
    ((fname, emitted),) = emit(THREE, "numpy").items()
    return import_cached(fname, emitted if text is None else text)


def _run(module: ModuleType, name: str, eps: float, T: float, q0, w0) -> tuple[np.ndarray, ...]:
    """The module's integrate() from (q0, w0) over T in steps eps: (q, w) at T."""
    p = np.array(THREE.parameter_values, dtype=float)
    status, q, w, _, _ = module.integrate(p, method(name).code, eps, round(T / eps), q0, w0)
    assert status == 0
    return q[-1], w[-1]


def _round_trip(module: ModuleType, name: str, eps: float, T: float) -> float:
    """Forward over T, then from the end state with the velocities reversed back to the start
    (both runs start xi at R(q): a symmetric update retraces the chain to round-off)."""
    q0, w0 = np.array(THREE.q0, float), np.array(THREE.omega0, float)
    q1, w1 = _run(module, name, eps, T, q0, w0)
    q2, w2 = _run(module, name, eps, T, q1, -w1)
    return float(max(np.abs(q2 - q0).max(), np.abs(w2 + w0).max()))


def test_the_numpy_runs_are_reversible() -> None:
    assert _round_trip(_module(), "vi4-adaptive", 0.01, 2.0) < 1e-11


def test_a_one_sided_step_size_update_is_caught() -> None:
    ((_, text),) = emit(THREE, "numpy").items()
    assert text.count(ONE_SIDED[0]) == 1
    broken = _module(text.replace(*ONE_SIDED))
    q0, w0 = np.array(THREE.q0, float), np.array(THREE.omega0, float)
    ref = s2gen.Model(THREE, backend="reference").integrate("vi4-adaptive", h=0.05, T=1.0)
    assert np.abs(_run(broken, "vi4-adaptive", 0.05, 1.0, q0, w0)[0] - ref.q[-1]).max() > 1e-7
    assert _round_trip(broken, "vi4-adaptive", 0.01, 2.0) > 1e-10


def test_unit_length_through_the_encounters() -> None:
    tr = s2gen.Model(CLUSTER, backend="numpy").integrate("vi4-adaptive", h=0.02, T=4.0)
    assert tr.stats["steps"] > 1000
    assert np.abs(np.linalg.norm(tr.q, axis=2) - 1.0).max() < 1e-13


def test_a_step_that_does_not_resolve_the_monitor_stops() -> None:
    """eps far beyond the encounters' time scale: no real root for xi_{n+1/2} at the first
    close approach, at the same sample as the C."""
    fails = []
    for backend in ("numpy", "c"):
        with pytest.raises(IntegrationError, match="step size") as e:
            s2gen.Model(CLUSTER, backend=backend).integrate("vi-adaptive", h=1.0, T=100.0)
        assert e.value.status == int(Status.STEPSIZE) and "\n" not in str(e.value)
        fails.append(e.value.step)
    assert fails[0] == fails[1]


@pytest.mark.parametrize("name", ["double_pendulum", "lj_cutoff"])
def test_a_system_without_a_driver_is_refused_as_by_the_c(name: str) -> None:
    """No monitor (the double pendulum), or pair terms within a cutoff: one line, the C's."""
    system = builtin(name)
    said = []
    for backend in ("numpy", "c"):
        with pytest.raises(ValueError) as e:
            s2gen.Model(system, backend=backend).integrate("vi-adaptive", h=0.01, T=0.1)
        said.append(str(e.value))
    assert said[0] == said[1] and "\n" not in said[0] and "time-transformed" in said[0]
