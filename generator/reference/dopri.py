"""Dormand-Prince 5(4) with dense output on the grid, MATLAB ode45 or Hairer/SciPy control.

Input: a `_Recorder` (problem, output grid t_k = k h), the initial flat state y0, the final
time T, tolerances rtol/atol, the largest step hmax and the step budget (the most attempted
steps between two grid points; 0: none).
Output: the recorder filled at every grid point (accepted steps advance adaptively, FSAL; grid
points inside a step come from Shampine's 4th-order interpolant) and its counts of accepted
and rejected steps and field evaluations. Failures raise `SingularSystem`, `NonFiniteState`
or `StepSizeUnderflow`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s2gen.reference.errors import NonFiniteState, SingularSystem, StepSizeUnderflow
from s2gen.reference.problem import Array
from s2gen.reference.recorder import _Recorder, _vector_field

# Dormand-Prince 5(4): nodes, stage matrix (row 6 = the 5th-order weights: FSAL), weights,
# error weights E = b5 - b4, and Shampine's 4th-order continuous extension (MATLAB ntrp45):
# y(t + s h) = y + h sum_i K_i (BI[i] . [s, s^2, s^3, s^4]).
_DP_A = np.array(
    [
        [0, 0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
    ]
)
_DP_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
_DP_E = np.array([71 / 57600, 0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])
_DP_BI = np.array(
    [
        [1, -183 / 64, 37 / 12, -145 / 128],
        [0, 0, 0, 0],
        [0, 1500 / 371, -1000 / 159, 1000 / 371],
        [0, -125 / 32, 125 / 12, -375 / 64],
        [0, 9477 / 3392, -729 / 106, 25515 / 6784],
        [0, -11 / 7, 11 / 3, -55 / 28],
        [0, 3 / 2, -4, 5 / 2],
    ]
)


def _dp_attempt(
    rec: _Recorder, fun: Callable[[Array], Array], y: Array, k1: Array, h: float
) -> tuple[Array, Array]:
    """One Dormand-Prince attempt: (y_new (5th order), K (7, m)) with K[6] = f(y_new)."""
    K = np.empty((7, y.size))
    K[0] = k1
    try:
        for s in range(1, 6):
            K[s] = fun(y + h * (_DP_A[s, :s] @ K[:s]))
        y_new = y + h * (_DP_B @ K[:6])
        K[6] = fun(y_new)
    except np.linalg.LinAlgError as exc:
        raise rec.fail(SingularSystem, f"linear solve failed ({exc})") from exc
    if not (np.all(np.isfinite(y_new)) and np.all(np.isfinite(K))):
        raise rec.fail(NonFiniteState, f"non-finite state in a Dormand-Prince step of size {h:g}")
    return y_new, K


def _initial_slope(rec: _Recorder, fun: Callable[[Array], Array], y0: Array) -> Array:
    """f(y0), the first stage of the first step; a failed solve is a `SingularSystem` at step 0
    as in any later stage."""
    try:
        return fun(y0)
    except np.linalg.LinAlgError as exc:
        raise rec.fail(SingularSystem, f"linear solve failed ({exc})") from exc


def _emit_dense(
    rec: _Recorder, t: float, y: Array, t_new: float, y_new: Array, K: Array, h: float
) -> None:
    """Record every grid point t_k in (t, t_new] (Shampine's interpolant; y_new at t_new)."""
    while rec.count < rec.t.size and rec.t[rec.count] <= t_new:
        tk = rec.t[rec.count]
        if tk == t_new:
            rec.push(y_new)
        else:
            s = (tk - t) / h
            rec.push(y + h * (K.T @ (_DP_BI @ np.array([s, s**2, s**3, s**4]))))


class _Budget:
    """The step budget: attempts since the recorder's last grid point, a `StepSizeUnderflow`
    before one past `limit` (0: no limit)."""

    def __init__(self, rec: _Recorder, limit: int) -> None:
        self.rec, self.limit, self.mark, self.tries = rec, limit, rec.count, 0

    def attempt(self, t: float) -> None:
        """Count one attempted step from t (raises when the budget is spent)."""
        if self.rec.count != self.mark:  # a grid point passed: a new budget
            self.mark, self.tries = self.rec.count, 0
        if 0 < self.limit <= self.tries:
            raise self.rec.fail(
                StepSizeUnderflow, f"more than {self.limit} steps between samples (t = {t:g})"
            )
        self.tries += 1


def _matlab_initial_step(
    k1: Array, y0: Array, T: float, rtol: float, threshold: float, hmax: float
) -> float:
    """ode45's first step: min(hmax, T), cut to 1/rh where

    rh = max_i |f0_i| / max(|y0_i|, threshold) / (0.8 rtol^(1/5)).
    """
    absh = min(hmax, T)
    rh = float(np.max(np.abs(k1) / np.maximum(np.abs(y0), threshold))) / (0.8 * rtol**0.2)
    if absh * rh > 1.0:
        absh = 1.0 / rh
    return max(absh, 16.0 * float(np.spacing(0.0)))


def _matlab_step(
    rec: _Recorder,
    fun: Callable[[Array], Array],
    t: float,
    y: Array,
    k1: Array,
    absh: float,
    done: bool,
    T: float,
    rtol: float,
    threshold: float,
    budget: _Budget,
) -> tuple[float, Array, Array, float, float, float, bool, bool]:
    """Attempt until accepted; returns (t_new, y_new, K, h, absh, err, nofailed, done)."""
    h = T - t if done else absh
    nofailed = True
    while True:
        hmin = 16.0 * float(np.spacing(t))
        budget.attempt(t)
        y_new, K = _dp_attempt(rec, fun, y, k1, h)
        t_new = T if done else t + h
        h = t_new - t  # "purify" h, as ode45 does
        scale = np.maximum(np.maximum(np.abs(y), np.abs(y_new)), threshold)
        err = absh * float(np.max(np.abs(K.T @ _DP_E) / scale))
        if err <= rtol:
            return t_new, y_new, K, h, absh, err, nofailed, done
        rec.stats["rejected"] += 1
        if absh <= hmin:
            raise rec.fail(
                StepSizeUnderflow, f"step size {absh:g} at t = {t:g} fell below hmin = {hmin:g}"
            )
        if nofailed:
            absh = max(hmin, absh * max(0.1, 0.8 * (rtol / err) ** 0.2))
        else:
            absh = max(hmin, 0.5 * absh)
        nofailed, done, h = False, False, absh


def _rk45_matlab(
    rec: _Recorder, y0: Array, T: float, rtol: float, atol: float, hmax: float, max_steps: int
) -> None:
    """Dormand-Prince with MATLAB ode45's error norm and step-size logic."""
    fun = _vector_field(rec)
    threshold = atol / rtol
    t, y, k1 = 0.0, y0, _initial_slope(rec, fun, y0)
    absh = _matlab_initial_step(k1, y0, T, rtol, threshold, hmax)
    budget = _Budget(rec, max_steps)
    done = False
    while not done:
        absh = min(hmax, max(16.0 * float(np.spacing(t)), absh))
        if 1.1 * absh >= T - t:  # stretch the last step to hit T
            absh, done = T - t, True
        t_new, y_new, K, h, absh, err, nofailed, done = _matlab_step(
            rec, fun, t, y, k1, absh, done, T, rtol, threshold, budget
        )
        rec.stats["steps"] += 1
        _emit_dense(rec, t, y, t_new, y_new, K, h)
        if nofailed:
            temp = 1.25 * (err / rtol) ** 0.2
            absh = absh / temp if temp > 0.2 else 5.0 * absh
        t, y, k1 = t_new, y_new, K[6]


def _rms(x: Array) -> float:
    return float(np.linalg.norm(x)) / x.size**0.5


def _hairer_initial_step(
    fun: Callable[[Array], Array],
    y0: Array,
    k1: Array,
    T: float,
    hmax: float,
    rtol: float,
    atol: float,
) -> float:
    """Hairer-Norsett-Wanner (II.4) starting step for an order-4 error estimator (as SciPy)."""
    scale = atol + np.abs(y0) * rtol
    d0, d1 = _rms(y0 / scale), _rms(k1 / scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, T)
    d2 = _rms((fun(y0 + h0 * k1) - k1) / scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.2
    return min(100.0 * h0, h1, T, hmax)


def _hairer_step(
    rec: _Recorder,
    fun: Callable[[Array], Array],
    t: float,
    y: Array,
    k1: Array,
    h_abs: float,
    T: float,
    rtol: float,
    atol: float,
    hmax: float,
    budget: _Budget,
) -> tuple[float, Array, Array, float, float]:
    """Attempt until accepted; returns (t_new, y_new, K, h, next h_abs)."""
    min_step = 10.0 * abs(float(np.nextafter(t, np.inf)) - t)
    h_abs = hmax if h_abs > hmax else max(h_abs, min_step)
    rejected = False
    while True:
        if h_abs < min_step:
            raise rec.fail(
                StepSizeUnderflow, f"step size {h_abs:g} at t = {t:g} fell below {min_step:g}"
            )
        budget.attempt(t)
        t_new = min(t + h_abs, T)  # clip the last step at T
        h = t_new - t
        y_new, K = _dp_attempt(rec, fun, y, k1, h)
        scale = atol + np.maximum(np.abs(y), np.abs(y_new)) * rtol
        err = _rms(h * (K.T @ _DP_E) / scale)
        if err <= 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err**-0.2)
            if rejected:
                factor = min(1.0, factor)
            return t_new, y_new, K, h, h * factor
        rec.stats["rejected"] += 1
        h_abs = h * max(0.2, 0.9 * err**-0.2)
        rejected = True


def _rk45_hairer(
    rec: _Recorder, y0: Array, T: float, rtol: float, atol: float, hmax: float, max_steps: int
) -> None:
    """Dormand-Prince with Hairer's (SciPy's) RMS error norm and step-size logic."""
    fun = _vector_field(rec)
    t, y, k1 = 0.0, y0, _initial_slope(rec, fun, y0)
    try:
        h_abs = _hairer_initial_step(fun, y0, k1, T, hmax, rtol, atol)
    except np.linalg.LinAlgError as exc:
        raise rec.fail(SingularSystem, f"linear solve failed ({exc})") from exc
    budget = _Budget(rec, max_steps)
    while t < T:
        t_new, y_new, K, h, h_abs = _hairer_step(
            rec, fun, t, y, k1, h_abs, T, rtol, atol, hmax, budget
        )
        rec.stats["steps"] += 1
        _emit_dense(rec, t, y, t_new, y_new, K, h)
        t, y, k1 = t_new, y_new, K[6]
