"""Time-transformed variational integrators: the VI, RATTLE and their compositions in a
fictitious time.

Input: a `ReferenceProblem`, a monitor R(q) (`monitor_from_system`: the pair rule of
`s2gen.monitor`, or the spec's [run] g), a time-transformed method of `s2gen.methods` (its
composition of the VI step, or of the RATTLE step for ``"rattle-adaptive"``, ...), an initial
state, the step eps in the fictitious time s (the user's h) and an output
grid. Output: a `RefTrajectory` on the grid t_k = k every eps (`integrate_time_transformed`),
or the raw chain of steps (`transformed_steps`, for reversibility checks).

The scheme (Sundman transformation dt/ds = 1/xi with the reversible step-size variable of
W. Huang and B. Leimkuhler, The adaptive Verlet method, SIAM J. Sci. Comput. 18 (1997)
239-256): xi follows R along the solution, d xi/ds = R'(t)/xi with R' = dR/dt = grad R . qdot,
and one step from (q_n, w_n, xi_n) is

    xi_{n+1/2} = xi_n + (eps/2) R'_n / xi_{n+1/2}      (the root near xi_n of a quadratic)
    (q_{n+1}, w_{n+1}) = one step of the composed VI of size h_n = eps / xi_{n+1/2}
    xi_{n+1} = xi_{n+1/2} + (eps/2) R'_{n+1} / xi_{n+1/2}.

It is symmetric: the step with -eps from (q_{n+1}, w_{n+1}, xi_{n+1}) returns to
(q_n, w_n, xi_n), because the composed VI with -h_n inverts the one with h_n. Each step is the
fixed-step method with a step size that varies smoothly, so the error in t is O(eps^p) for a
method of order p. The RATTLE methods differ only in the basic step (`forced_rattle_step` of a
problem without forces: Cartesian q_i with multipliers, the same discrete flow). A sample time t_k in (t_n, t_n + h_n] is reached by one extra step of the
composed VI of size t_k - t_n from (q_n, w_n), which keeps the order and does not enter the
chain. When the quadratic has no real root (eps |R'| / xi^2 > 1/2: the step does not resolve
the monitor) or h_n underflows, the run stops with `StepSizeUnderflow`.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.reference.problem import problem_from_system
    >>> s = builtin("three_bodies")
    >>> p, mon = problem_from_system(s), monitor_from_system(s)
    >>> tr = integrate_time_transformed(p, mon, "vi4-adaptive", s.q0, s.omega0, 0.05, 20)
    >>> float(tr.t[-1]), tr.stats["steps"] > 0
    (1.0, True)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import sympy as sp

from s2gen.methods import Driver, Family, method
from s2gen.monitor import C, monitor
from s2gen.reference.errors import NonFiniteState, ReferenceIntegrationError, StepSizeUnderflow
from s2gen.reference.forced import DrivenProblem
from s2gen.reference.forced_steps import forced_rattle_step
from s2gen.reference.geometry import _cross
from s2gen.reference.problem import Array, ReferenceProblem, _parameter_values
from s2gen.reference.recorder import RefTrajectory, _Recorder, _state
from s2gen.reference.vi import vi_step
from s2gen.symbols import q_symbols
from s2gen.system import System

__all__ = ["MonitorFn", "integrate_time_transformed", "monitor_from_system", "transformed_steps"]

#: (q+, w+, Newton iterations) of a step.
_Step = tuple[Array, Array, int]
#: (q, w) -> (R(q), dR/dt = grad R(q) . qdot).
MonitorFn = Callable[[Array, Array], tuple[float, float]]


def monitor_from_system(
    system: System, parameter_values: Sequence[float] | Mapping[str, float] | None = None
) -> MonitorFn:
    """R and dR/dt of the system's pair monitor (`s2gen.monitor`), vectorized over the pairs:
    R = sum r(qi.qj), dR/dt = sum r'(qi.qj) (qdot_i.qj + qi.qdot_j), qdot_i = w_i x q_i.

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("three_bodies")
        >>> R, dR = monitor_from_system(s)(np.array(s.q0, float), np.array(s.omega0, float))
        >>> round(R, 12)  # three orthogonal pairs: r(0) = 1 each
        3.0
    """
    mon = monitor(system)
    values = _parameter_values(system, parameter_values)
    at = dict(zip(mon.parameters, values))
    if mon.given is not None:
        return _given(mon.given.subs(at), system.n)
    parts = []
    for r in mon.rates:
        i, j = (np.array(x, dtype=np.intp) for x in zip(*r.members))
        rate = sp.lambdify([C], sp.sympify(r.rate).subs(at), "numpy")
        slope = sp.lambdify([C], sp.sympify(r.slope).subs(at), "numpy")
        parts.append((i, j, rate, slope))

    def evaluate(q: Array, w: Array) -> tuple[float, float]:
        qd = _cross(w, q)
        R = dR = 0.0
        for i, j, rate, slope in parts:
            c = np.einsum("ka,ka->k", q[i], q[j])
            dc = np.einsum("ka,ka->k", qd[i], q[j]) + np.einsum("ka,ka->k", q[i], qd[j])
            R += float(np.sum(rate(c) * np.ones_like(c)))
            dR += float(np.sum(slope(c) * dc))
        return R, dR

    return evaluate


def _given(expr: sp.Expr, n: int) -> MonitorFn:
    """R and dR/dt = sum_i dR/dq_i . qdot_i of a monitor written in q1_0..qn_2."""
    qs = q_symbols(n)
    value = sp.lambdify(qs, expr, "numpy")
    grad = sp.lambdify(qs, [sp.diff(expr, s) for s in qs], "numpy")

    def evaluate(q: Array, w: Array) -> tuple[float, float]:
        flat = q.ravel()
        g = np.array(grad(*flat), dtype=float).reshape(n, 3)
        return float(value(*flat)), float(np.sum(g * _cross(w, q)))

    return evaluate


#: One basic step (q, w) -> (q+, w+, Newton iterations) of size h (the VI's or RATTLE's).
_Basic = Callable[[Array, Array, float, float, int, int], tuple[Array, Array, int]]


def _scheme(problem: ReferenceProblem, name: str) -> tuple[tuple[float, ...], _Basic]:
    """The composition's fractions and the basic step (the VI's or RATTLE's) of `name`."""
    row = method(name)
    if row.driver is not Driver.TIME_TRANSFORMED or row.transformed is None:
        raise ValueError(f"{name!r} is not a time-transformed method")
    if row.family is Family.TIME_RATTLE:
        free = DrivenProblem(problem)

        def rattle(q: Array, w: Array, h: float, tol: float, its: int, k: int) -> _Step:
            return forced_rattle_step(
                free, q, w, 0.0, h, np.zeros(0), newton_tol=tol, newton_maxiter=its, step=k
            )

        return row.transformed.fractions, rattle

    def vi(q: Array, w: Array, h: float, tol: float, its: int, k: int) -> _Step:
        return vi_step(problem, q, w, h, newton_tol=tol, newton_maxiter=its, step=k)

    return row.transformed.fractions, vi


def _composed(
    basic: _Basic,
    fractions: tuple[float, ...],
    q: Array,
    w: Array,
    h: float,
    tol: float,
    maxiter: int,
    step: int,
) -> _Step:
    """One step of size h of the composition `fractions` of the basic step."""
    total = 0
    for f in fractions:
        q, w, its = basic(q, w, f * h, tol, maxiter, step)
        total += its
    return q, w, total


def _half(xi: float, rate: float, eps: float, step: int) -> float:
    """xi_{n+1/2}: the root near xi of x^2 - xi x - (eps/2) rate = 0."""
    disc = xi * xi + 2.0 * eps * rate
    if not xi > 0.0:
        raise StepSizeUnderflow(step, f"the monitor must stay positive, got xi = {xi:.6g}")
    if not disc >= 0.0:
        raise StepSizeUnderflow(
            step,
            f"the step does not resolve the monitor (eps |dR/dt| / xi^2 = "
            f"{abs(eps * rate) / (xi * xi):.3g} > 1/2): reduce h",
        )
    return 0.5 * (xi + np.sqrt(disc))


def transformed_steps(
    problem: ReferenceProblem,
    mon: MonitorFn,
    name: str,
    q: Array,
    w: Array,
    xi: float,
    eps: float,
    nsteps: int,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> tuple[Array, Array, float, float]:
    """`nsteps` steps of the method `name` with fictitious step eps (negative: backwards) from
    (q, w, xi); returns (q, w, xi, elapsed time). xi = R(q) starts a run.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.reference.problem import problem_from_system
        >>> s = builtin("three_bodies")
        >>> p, mon = problem_from_system(s), monitor_from_system(s)
        >>> q0, w0 = np.array(s.q0, float), np.array(s.omega0, float)
        >>> q, w, xi, t = transformed_steps(p, mon, "vi-adaptive", q0, w0, 3.0, 0.1, 5)
        >>> q, w, xi, back = transformed_steps(p, mon, "vi-adaptive", q, w, xi, -0.1, 5)
        >>> bool(np.abs(q - q0).max() < 1e-13 and abs(t + back) < 1e-13)
        True
    """
    fractions, basic = _scheme(problem, name)
    q, w = np.asarray(q, dtype=float), np.asarray(w, dtype=float)
    t = 0.0
    _, rate = mon(q, w)
    for k in range(nsteps):
        half = _half(xi, rate, eps, k)
        h = eps / half
        q, w, _ = _composed(basic, fractions, q, w, h, newton_tol, newton_maxiter, k)
        t += h
        _, rate = mon(q, w)
        xi = half + 0.5 * eps * rate / half
    return q, w, xi, t


def integrate_time_transformed(
    problem: ReferenceProblem,
    mon: MonitorFn,
    name: str,
    q0: Array | Sequence[Sequence[float]],
    w0: Array | Sequence[Sequence[float]],
    h: float,
    nsteps: int,
    every: int = 1,
    *,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
) -> RefTrajectory:
    """The method `name` with fictitious step eps = h from (q0, w0) at t = 0, sampled on
    t_k = k every h, k = 0..nsteps // every (the grid of a fixed-step run with the same h).

    `stats`: ``steps`` (steps of the chain), ``output_steps`` (the extra steps to the
    samples), ``monitor_evaluations``, ``gradient_evaluations`` (of the emitted cost model:
    one per substep, the last gradient reused by the next step, so stages per step and per
    output step, plus one at the start) and Newton's iteration counts. Raises a
    `ReferenceIntegrationError` carrying the samples so far.
    """
    fractions, basic = _scheme(problem, name)
    q, w = np.array(q0, dtype=float), np.array(w0, dtype=float)
    spacing, count = h * every, nsteps // every
    rec = _Recorder(problem, name, spacing, count)
    rec.stats.update(output_steps=0, monitor_evaluations=1, gradient_evaluations=1)
    rec.push(_state(q, w))
    xi, rate = mon(q, w)
    t, k, n = 0.0, 1, 0
    try:
        while k <= count:
            half = _half(xi, rate, h, n)
            step = h / half
            if not (step > 1e-14 * max(1.0, t)):
                raise StepSizeUnderflow(n, f"the time step {step:.3g} underflowed at t = {t:.6g}")
            while k <= count and k * spacing <= t + step:
                qs, ws, its = _composed(
                    basic, fractions, q, w, k * spacing - t, newton_tol, newton_maxiter, n
                )
                _count(rec, its, len(fractions), "output_steps")
                rec.push(_state(qs, ws))
                k += 1
            if k > count:
                break
            q, w, its = _composed(basic, fractions, q, w, step, newton_tol, newton_maxiter, n)
            if not (np.all(np.isfinite(q)) and np.all(np.isfinite(w))):
                raise NonFiniteState(n, "non-finite state")
            _count(rec, its, len(fractions), "steps")
            t, n = t + step, n + 1
            _, rate = mon(q, w)
            rec.stats["monitor_evaluations"] += 1
            xi = half + 0.5 * h * rate / half
    except ReferenceIntegrationError as exc:
        exc.partial = rec.trajectory()
        raise
    return rec.trajectory()


def _count(rec: _Recorder, iterations: int, stages: int, key: str) -> None:
    s = rec.stats
    s[key] += 1
    s["gradient_evaluations"] += stages
    s["newton_iterations_total"] += iterations
    s["newton_iterations_max"] = max(s["newton_iterations_max"], iterations)
