"""The symmetric compositions vi4/vi6/vi8 and rattle4/rattle6/rattle8.

- their coefficients add up to 1, read the same backwards, and satisfy the order conditions of
  a symmetric composition of a generic symmetric method (checked by composing exponentials of
  random matrices as power series in h), with Yoshida's order-6 values solved again from the
  15 digits printed in his paper;
- the emitted methods have the orders 4, 6 and 8 against a reference solution computed by
  scipy's DOP853 on the independent reference field (s2gen.reference);
- C and NumPy agree, the compositions are time-reversible, keep unit length and their energy
  error stays bounded (long runs in the slow suite).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SYSTEMS, final_state, reference_final

from s2gen import metrics
from s2gen.methods import COMPOSITIONS, KAHAN_LI8, METHODS, TRIPLE_JUMP, YOSHIDA6, method
from s2gen.runtime import simulate
from s2gen.systems import builtin

COMPOSED = [m.name for m in METHODS if m.substeps]
NEW = ("vi6", "vi8", "rattle4", "rattle6", "rattle8")

# ------------------------------------------------------------------ the order conditions
#: Truncation degree of the power series in h, matrix size, random generators.
DEGREE, SIZE = 9, 5
_RNG = np.random.default_rng(20240601)
X, Y3, Y5, Y7 = (_RNG.standard_normal((SIZE, SIZE)) for _ in range(4))


def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Product of two matrix power series in h, truncated at DEGREE."""
    out = np.zeros_like(a)
    for i in range(DEGREE + 1):
        out[i:] += np.einsum("ij,kjl->kil", a[i], b[: DEGREE + 1 - i])
    return out


def _exp(z: np.ndarray) -> np.ndarray:
    """exp of a matrix power series without constant term."""
    out = np.zeros_like(z)
    out[0] = np.eye(SIZE)
    term = out.copy()
    for k in range(1, DEGREE + 1):
        term = _mul(term, z) / k
        out += term
    return out


def _basic(g: float) -> np.ndarray:
    """A generic symmetric method of order 2 with step g h: exp(g h X + (g h)^3 Y3 + ...)."""
    z = np.zeros((DEGREE + 1, SIZE, SIZE))
    z[1], z[3], z[5], z[7] = g * X, g**3 * Y3, g**5 * Y5, g**7 * Y7
    return _exp(z)


def _error_series(fractions) -> np.ndarray:
    """Coefficients of h^1..h^DEGREE of the composition minus the exact flow exp(h X)."""
    psi = np.zeros((DEGREE + 1, SIZE, SIZE))
    psi[0] = np.eye(SIZE)
    for g in fractions:
        psi = _mul(psi, _basic(g))
    z = np.zeros((DEGREE + 1, SIZE, SIZE))
    z[1] = X
    return (psi - _exp(z))[1:]


def defects(fractions) -> np.ndarray:
    """max |coefficient of h^p| of the composition's error, p = 1..DEGREE."""
    return np.abs(_error_series(fractions)).max(axis=(1, 2))


def _palindrome(outer) -> list[float]:
    return [*outer, 1.0 - 2.0 * sum(outer), *reversed(outer)]


@pytest.mark.parametrize("comp", COMPOSITIONS, ids=lambda c: c.name)
def test_fractions_add_up_to_one_and_are_symmetric(comp) -> None:
    f = comp.fractions
    assert abs(sum(f) - 1.0) < 4e-16 * len(f)
    assert f == tuple(reversed(f))


@pytest.mark.parametrize("comp", [TRIPLE_JUMP, YOSHIDA6, KAHAN_LI8], ids=lambda c: c.name)
def test_order_conditions(comp) -> None:
    """The defects vanish (to round-off) up to the composition's order and not beyond it."""
    d = defects(comp.fractions)
    assert np.all(d[: comp.order] < 1e-12), d
    assert d[comp.order] > 1e-3, d  # degree order + 1: the composition is not of higher order


def test_yoshida6_solves_the_order_conditions_from_the_printed_values() -> None:
    """Newton's method on the order conditions, started from the 15 digits Yoshida printed
    (w3, w2, w1), lands on the table's values."""
    w = np.array([0.784513610477560, 0.235573213359357, -1.17767998417887])

    def residual(v: np.ndarray) -> np.ndarray:
        return _error_series(_palindrome(v))[: YOSHIDA6.order].ravel()

    for _ in range(3):
        r = residual(w)
        jac = np.empty((r.size, w.size))
        for i in range(w.size):
            e = np.zeros(w.size)
            e[i] = 1e-6
            jac[:, i] = (residual(w + e) - residual(w - e)) / 2e-6
        w = w + np.linalg.lstsq(jac, -r, rcond=None)[0]
    assert np.max(np.abs(w - np.array(YOSHIDA6.fractions[:3]))) < 1e-13


def test_the_methods_table_composes_the_right_schemes() -> None:
    for name, comp, order in (
        ("vi4", TRIPLE_JUMP, 4),
        ("vi6", YOSHIDA6, 6),
        ("vi8", KAHAN_LI8, 8),
        ("rattle4", TRIPLE_JUMP, 4),
        ("rattle6", YOSHIDA6, 6),
        ("rattle8", KAHAN_LI8, 8),
    ):
        m = method(name)
        assert (m.composition, m.order, m.evals) == (comp, order, len(comp.fractions))


# ---------------------------------------------------------------- the emitted methods


#: (system, method, steps over T = 1): errors between about 1e-4 and 1e-11, where they fall
#: as h^order (the reference is good to about 1e-13).
ORDER_CASES = [
    ("double_pendulum", "vi6", (11, 16, 22, 32)),
    ("double_pendulum", "rattle8", (7, 10, 14, 20)),
    ("three", "rattle6", (20, 28, 40, 56)),
    ("lj_ring", "vi8", (8, 12, 18, 25)),
]


@pytest.mark.parametrize(("name", "meth", "steps"), ORDER_CASES)
def test_measured_order(name: str, meth: str, steps: tuple[int, ...]) -> None:
    """Order 6 +- 0.3 and 8 +- 0.5 against the reference, on a coupled and a diagonal system."""
    s = SYSTEMS[name]()
    T = 1.0
    ref = reference_final(s, T)
    hs = np.array([T / n for n in steps])
    errs = [np.max(np.abs(final_state(simulate(s, meth, "c", h=h, T=T)) - ref)) for h in hs]
    order = method(meth).order
    assert errs[-1] > 1e-12, errs  # above the reference's own error
    assert abs(metrics.observed_order(hs, errs) - order) < (0.3 if order == 6 else 0.5), errs


@pytest.mark.parametrize("name", ["double_pendulum", "three"])
@pytest.mark.parametrize("meth", NEW)
def test_time_reversibility(name: str, meth: str) -> None:
    """N steps forward, velocities reversed, N steps forward: back to the start to round-off
    (for a symmetric composition of the reversible VI/RATTLE step this is stepping back by -h)."""
    s = SYSTEMS[name]()
    h, n = 0.01, 200
    fwd = simulate(s, meth, "c", h=h, T=n * h)
    back = simulate(s, meth, "c", h=h, T=n * h, q0=fwd.q[-1], omega0=-fwd.omega[-1])
    wscale = max(1.0, float(np.max(np.abs(fwd.omega))))
    assert np.max(np.abs(back.q[-1] - s.q0)) < 1e-11
    assert np.max(np.abs(back.omega[-1] + s.omega0)) < 1e-11 * wscale


@pytest.mark.parametrize("meth", NEW)
def test_c_and_numpy_agree(system, meth: str) -> None:
    """The same composition in both languages: states to 1e-10, the same counts."""
    h = float(system.run.h or 0.01)
    n = max(4, 150 // len(method(meth).substeps))
    c = simulate(system, meth, "c", h=h, T=n * h)
    py = simulate(system, meth, "numpy", h=h, T=n * h)
    wscale = max(1.0, float(np.max(np.abs(c.omega))))
    assert np.max(np.abs(c.q - py.q)) < 1e-10
    assert np.max(np.abs(c.omega - py.omega)) < 1e-10 * wscale
    for key in ("steps", "gradient_evals", "fail_step"):
        assert c.stats[key] == py.stats[key], key
    assert c.stats["gradient_evals"] == 1 + n * len(method(meth).substeps)


def test_vi_and_rattle_compositions_are_the_same_discrete_flow() -> None:
    """VI and RATTLE generate the same flow, so their compositions agree to round-off."""
    s = builtin("double_pendulum")
    for a, b in (("vi6", "rattle6"), ("vi8", "rattle8")):
        va = simulate(s, a, "c", h=0.01, T=0.5)
        ra = simulate(s, b, "c", h=0.01, T=0.5)
        assert np.max(np.abs(va.q - ra.q)) < 1e-12


def _small_oscillation() -> tuple[np.ndarray, np.ndarray]:
    """A double pendulum state near its stable equilibrium (q_i = e3): quasi-periodic motion."""
    a, b = 0.3, -0.2
    q0 = np.array([[np.sin(a), 0.0, np.cos(a)], [np.sin(b), 0.0, np.cos(b)]])
    w0 = np.array([[0.0, 0.0, 0.0], [0.0, 0.2, 0.0]])
    return q0, w0 - np.einsum("ij,ij->i", w0, q0)[:, None] * q0


@pytest.mark.parametrize("meth", ["vi6", "vi8", "rattle6", "rattle8"])
def test_energy_bounded_and_unit_length(meth: str) -> None:
    """10^4 large steps (h = 0.2, a fifth of the period) of small oscillations of the double
    pendulum: the energy error over the last quarter is no larger than over the first, and
    |q_i| = 1 to 1e-12. RK4 at the same step drifts (the check can fail)."""
    s = builtin("double_pendulum")
    q0, w0 = _small_oscillation()
    quarters = {}
    for m in (meth, "rk4"):
        tr = simulate(s, m, "c", h=0.2, T=2000.0, every=10, q0=q0, omega0=w0)
        de = np.abs(tr.energy - tr.energy[0])
        q = len(de) // 4
        quarters[m] = (de[:q].max(), de[-q:].max())
        if m == meth:
            assert metrics.unit_length_error(tr.q)["max_norm"] < 1e-12
    first, last = quarters[meth]
    assert last <= 1.2 * first, quarters
    assert quarters["rk4"][1] > 3 * quarters["rk4"][0], quarters


#: Steps per order at which a composition's energy error is its own (1e-9 to 1e-6 relative),
#: not round-off's: at 10^6 steps of h = 0.01 the sixth- and eighth-order ones sit at round-off
#: (below 1e-10), whose sum grows linearly, by less than an ulp of E per substep (the next test).
_TRUNCATION_H = {4: 0.05, 6: 0.1, 8: 0.3}


def _million_steps(name: str, meth: str, h: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """10^6 steps of h from a regular state (the double pendulum's small oscillations, the
    three bodies' rotating triangle; the paper's states are chaotic, and there the running
    maximum of |E - E0| creeps up as the motion wanders, slope 0.14-0.5 for every method):
    the sample times, the running maximum of |E - E0| / |E0| and the largest unit-length error."""
    s = builtin(name)
    if name == "three_bodies":
        from s2gen.experiments.bench.long_study import rotating_triangle

        q0, w0 = rotating_triangle()
    else:
        q0, w0 = _small_oscillation()
    steps = 10**6
    tr = simulate(s, meth, "c", h=h, T=steps * h, every=1000, q0=q0, omega0=w0)
    run = np.maximum.accumulate(np.abs(tr.energy - tr.energy[0]))[1:] / abs(tr.energy[0])
    return tr.t[1:], run, metrics.unit_length_error(tr.q)["max_norm"], float(steps)


@pytest.mark.slow
@pytest.mark.parametrize("meth", COMPOSED)
@pytest.mark.parametrize("name", ["double_pendulum", "three_bodies"])
def test_energy_drift_over_a_million_steps(name: str, meth: str) -> None:
    """10^6 steps where the method's own error dominates: the running maximum of |E - E0| has
    a fitted log-log slope <= 0.1 over the last two decades of time (RK4 drifts with slope 1),
    and unit length stays below 1e-12."""
    t, run, unit, _ = _million_steps(name, meth, _TRUNCATION_H[method(meth).order])
    keep = (t >= t[-1] / 100) & (run > 0)
    slope = float(np.polyfit(np.log(t[keep]), np.log(run[keep]), 1)[0])
    assert run[-1] > 1e-10, run[-1]  # the method's error, well above round-off's
    assert slope <= 0.1, slope
    assert unit < 1e-12


@pytest.mark.slow
@pytest.mark.parametrize("meth", ["vi8", "rattle8"])
@pytest.mark.parametrize("name", ["double_pendulum", "three_bodies"])
def test_round_off_over_a_million_steps(name: str, meth: str) -> None:
    """10^6 steps of h = 0.01, where the eighth-order compositions' own error is below
    round-off: |E - E0| / |E0| grows (linearly: each rounding is not unbiased), but by less
    than one unit in the last place per substep (measured: the VI about 0.01-0.2 ulp, RATTLE
    less), and so does | |q_i| - 1 | (the VI's 1.5 10^7 Cayley rotations of the double pendulum
    leave 9e-12, 0.003 ulp per substep)."""
    _, run, unit, steps = _million_steps(name, meth, 0.01)
    bound = steps * len(method(meth).substeps) * np.finfo(float).eps
    assert run[-1] < bound, run[-1]
    assert unit < bound, unit
