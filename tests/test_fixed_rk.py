"""Every fixed-step Runge-Kutta method of s2gen.methods, on the emitted C and NumPy.

- measured order: on the double pendulum, the error at T = 2 against scipy's DOP853 on the
  independent reference field falls as h^p with p the method's order (+- 0.25), on both
  emitted backends;
- the emitted C agrees with the reference backend's own stepping of the same tableau, and
  counts one gradient evaluation per stage of its tableau.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import final_state, reference_final

from s2gen import metrics
from s2gen.methods import METHODS, Method
from s2gen.runtime import simulate
from s2gen.systems import builtin

FIXED = [m for m in METHODS if m.tableau is not None]
T = 2.0


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("method", FIXED, ids=lambda m: m.name)
def test_measured_order(method: Method, backend: str) -> None:
    s = builtin("double_pendulum")
    exact = reference_final(s, T)
    hs = 0.04 / 2.0 ** np.arange(4)
    errs = [
        np.max(np.abs(final_state(simulate(s, method.name, backend, h=h, T=T)) - exact)) for h in hs
    ]
    assert abs(metrics.observed_order(hs, errs) - method.order) < 0.25, errs


@pytest.mark.parametrize("method", FIXED, ids=lambda m: m.name)
def test_c_agrees_with_the_reference_and_counts_its_stages(method: Method) -> None:
    s = builtin("double_pendulum")
    c = simulate(s, method.name, "c", h=0.01, T=1.0)
    ref = simulate(s, method.name, "reference", h=0.01, T=1.0)
    assert np.max(np.abs(c.q - ref.q)) < 1e-11
    assert np.max(np.abs(c.omega - ref.omega)) < 1e-10
    assert c.stats["gradient_evals"] == method.evals * c.stats["steps"] == method.evals * 100
