"""DOP853 (method "dop853"), emitted in C and NumPy.

- the tableau (s2gen.tableaus) meets every order condition of its three weight vectors, from
  Butcher's rooted trees: order 8 for the solution, 5 and 3 for the two error estimates, and
  not one order more;
- with fixed steps (hmax, loose tolerance) the emitted method has order 8 against a reference
  computed by scipy's DOP853 on the independent reference field;
- adaptive, it agrees with scipy's DOP853 to the tolerance and takes about as many steps;
- its continuous extension gives samples as accurate as the steps, without changing them;
- C and NumPy take the same steps; a non-finite trial step is reported as ERR_NONFINITE with
  the samples before it kept; the counters and options behave as documented.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from conftest import SYSTEMS, final_state, reference_final, reference_path

from s2gen import metrics
from s2gen.experiments import peers
from s2gen.runtime import IntegrationError, Options, simulate
from s2gen.spec import define_system
from s2gen.systems import builtin
from s2gen.tableaus import DOP853

# ------------------------------------------------------------- order conditions by trees
Tree = tuple  # a rooted tree: the sorted tuple of its root's subtrees


@cache
def trees(n: int) -> tuple[Tree, ...]:
    """Every rooted tree with n vertices."""
    if n == 1:
        return ((),)
    found: set[Tree] = set()

    def forests(left: int, largest: int) -> list[tuple[Tree, ...]]:
        if left == 0:
            return [()]
        out = []
        for size in range(min(left, largest), 0, -1):
            for t in trees(size):
                out += [(t, *rest) for rest in forests(left - size, size)]
        return out

    for forest in forests(n - 1, n - 1):
        found.add(tuple(sorted(forest)))
    return tuple(sorted(found))


def _order(t: Tree) -> int:
    return 1 + sum(_order(c) for c in t)


def _density(t: Tree) -> int:
    """gamma(t): the tree's order times the densities of its subtrees."""
    return _order(t) * int(np.prod([_density(c) for c in t]))


def _weights(t: Tree, a: np.ndarray) -> np.ndarray:
    """Per stage, the elementary weight of t: the product over subtrees of A times theirs."""
    out = np.ones(a.shape[0])
    for c in t:
        out = out * (a @ _weights(c, a))
    return out


def _defects(b: np.ndarray, upto: int) -> dict[int, float]:
    """Largest |b . Phi(t) - 1/gamma(t)| over the trees of each order 1..upto."""
    a = np.zeros((DOP853.stages, DOP853.stages))
    for i, row in enumerate(DOP853.a):
        a[i, : len(row)] = row
    return {
        p: max(abs(float(b @ _weights(t, a)) - 1.0 / _density(t)) for t in trees(p))
        for p in range(1, upto + 1)
    }


def test_trees_are_counted_right() -> None:
    assert [len(trees(n)) for n in range(1, 10)] == [1, 1, 2, 4, 9, 20, 48, 115, 286]


def test_nodes_are_the_row_sums() -> None:
    """c_i = sum_j a_ij, to the rounding of coefficients as large as 43."""
    sums = [math.fsum(row) for row in DOP853.a]
    assert np.max(np.abs(np.array(sums) - np.array(DOP853.c))) < 1e-14


@pytest.mark.parametrize(("which", "order"), [("b", 8), ("e5", 5), ("e3", 3)])
def test_order_conditions(which: str, order: int) -> None:
    """The solution has order 8; b - e5 and b - e3 (the embedded solutions whose differences
    with it estimate the error) orders 5 and 3; none has one order more."""
    b = np.array(DOP853.b)
    w = b if which == "b" else b - np.array(getattr(DOP853, which))
    d = _defects(w, order + 1)
    assert all(d[p] < 1e-14 for p in range(1, order + 1)), d
    assert d[order + 1] > 1e-6, d


# ---------------------------------------------------------------------------- the method


def test_measured_order_with_fixed_steps() -> None:
    """hmax = T/n and a tolerance no step fails: n steps of T/n; errors fall as h^8 +- 0.5."""
    s = builtin("double_pendulum")
    T = 1.0
    ref = reference_final(s, T)
    ns = (11, 16, 22)
    errs = []
    for n in ns:
        tr = simulate(s, "dop853", "c", h=T, T=T, options=Options(rtol=1.0, atol=1.0, hmax=T / n))
        assert tr.stats["steps"] == n and tr.stats["rejected"] == 0
        errs.append(np.max(np.abs(final_state(tr) - ref)))
    assert errs[-1] > 1e-12, errs
    assert abs(metrics.observed_order(T / np.array(ns), errs) - 8.0) < 0.5, errs


@pytest.mark.parametrize("tol", [1e-6, 1e-9])
@pytest.mark.parametrize("name", ["double_pendulum", "three"])
def test_agrees_with_scipy_dop853(name: str, tol: float) -> None:
    """Same tolerance, same problem: final states within 10 tol of each other and of the
    reference, and a number of field evaluations within a factor 1.5 of scipy's."""
    s = SYSTEMS[name]()
    T = 2.0
    problem_ref = reference_final(s, T)
    ours = simulate(s, "dop853", "c", h=T, T=T, options=Options(rtol=tol, atol=tol))
    theirs = peers.scipy_run(s, "DOP853", tol, T, samples=1)
    scale = max(1.0, float(np.max(np.abs(problem_ref))))
    mine = final_state(ours)
    other = np.concatenate([theirs.q.ravel(), theirs.omega.ravel()])
    assert np.max(np.abs(mine - other)) < 10 * tol * scale
    assert np.max(np.abs(mine - problem_ref)) < 10 * tol * scale
    assert 1 / 1.5 < ours.stats["gradient_evals"] / theirs.evals < 1.5


def test_c_and_numpy_take_the_same_steps(system) -> None:
    h = float(system.run.h or 0.01)
    opts = Options(rtol=1e-7, atol=1e-9)
    c = simulate(system, "dop853", "c", h=h, T=100 * h, options=opts, every=10)
    n = simulate(system, "dop853", "numpy", h=h, T=100 * h, options=opts, every=10)
    for key in ("steps", "rejected", "gradient_evals", "fail_step"):
        assert c.stats[key] == n.stats[key], key
    assert np.max(np.abs(c.q - n.q)) < 1e-10


def test_counters_and_the_continuous_extension() -> None:
    """12 evaluations per accepted step, 11 per rejected one, 2 to start, and 3 more in a step
    with a sample inside it; the steps do not depend on the samples kept (the final state is
    the same to the bit), and the samples from the extension agree with the reference to the
    tolerance."""
    s = builtin("double_pendulum")
    T, tol = 4.0, 1e-9
    opts = Options(rtol=tol, atol=tol)
    alone = simulate(s, "dop853", "c", h=T, T=T, options=opts)
    sampled = simulate(s, "dop853", "c", h=0.01, T=T, options=opts)
    st = alone.stats
    assert st["gradient_evals"] == 2 + 12 * st["steps"] + 11 * st["rejected"]
    for key in ("steps", "rejected"):
        assert sampled.stats[key] == st[key]
    extra = sampled.stats["gradient_evals"] - st["gradient_evals"]
    assert extra % 3 == 0 and 0 < extra <= 3 * st["steps"]
    assert np.array_equal(sampled.q[-1], alone.q[-1])
    ref = reference_path(s, T, sampled.t)
    got = np.concatenate(
        [sampled.q.reshape(len(sampled.t), -1), sampled.omega.reshape(len(sampled.t), -1)], axis=1
    )
    assert np.max(np.abs(got - ref)) < 30 * tol


def test_hmax_is_honoured() -> None:
    s = builtin("double_pendulum")
    tr = simulate(s, "dop853", "c", h=2.0, T=2.0, options=Options(rtol=1e-3, hmax=0.05))
    assert tr.stats["steps"] >= 40


def _edge() -> object:
    """One body whose potential k sqrt(q_z + 1/2) is not defined below q_z = -1/2, moving
    towards it: a trial step past the edge has a NaN gradient."""
    return define_system(
        name="edge",
        bodies=1,
        parameters={"m": 1.0, "k": 0.01},
        diagonal=["m"],
        potential="k*sqrt(q1[2] + 0.5)",
        initial_q=[[0.0, 0.0, 1.0]],
        initial_omega=[[1.0, 0.0, 0.0]],
        run={"h": 0.1, "T": 10.0},
    )


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_non_finite_trial_step_is_reported(backend: str) -> None:
    s = _edge()
    with pytest.raises(IntegrationError, match="non-finite") as info:
        simulate(s, "dop853", backend, h=0.1, T=10.0, options=Options(rtol=1e-8, atol=1e-8))
    exc = info.value
    assert exc.status == 3 and 1 < exc.step < 101
    part = exc.partial
    assert np.all(np.isfinite(part.q)) and np.all(part.q[:, 0, 2] > -0.5)


def test_scipy_reference_is_converged() -> None:
    """The reference of these tests: two tolerances of scipy's DOP853 agree to 1e-12."""
    s = builtin("double_pendulum")
    assert np.max(np.abs(reference_final(s, 1.0) - reference_final(s, 1.0, 1e-12))) < 1e-11
