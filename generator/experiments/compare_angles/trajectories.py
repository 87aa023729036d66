"""Accuracy of both forms from one initial state, against a converged S² reference.

Input: a `System`, `Settings` and an initial state (q, omega). Output: the reference q on the
output grid (`reference`: S² RK45 at rtol 1e-12) and one `Run` per form and method
(`accuracy`: RK45 and RK4), with the error and energy error over time, `metrics.summary`,
step counts, evaluations and wall time; the S² RK45 run also carries its accepted and
rejected steps over time (`_s2_counts`).

Example:
    >>> import s2gen
    >>> dp, s = s2gen.load("double_pendulum"), Settings(T=0.5)
    >>> state = (dp.q0, dp.omega0)
    >>> runs = accuracy(dp, s, state, reference(dp, s, state))  # doctest: +SKIP
    >>> [(r.form, r.method, r.status) for r in runs][:2]  # doctest: +SKIP
    [('s2', 'rk45', 'ok'), ('angles', 'rk45', 'PoleError')]
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from s2gen import IntegrationError, System, metrics, simulate
from s2gen.inspect import AngleIntegrationError, PoleError, get_backend, simulate_angles

from .model import Run
from .settings import ZOOM, Settings


def _energies(system: System, q: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Energy of (q, omega) samples by the S^2 module's energy function (same for both forms)."""
    be = get_backend(system, "c")
    p = np.array(system.parameter_values, float)
    return np.array([be.energy(q[k], w[k], p) for k in range(len(q))])


def _measure(r: Run, system: System, ref: np.ndarray, q: np.ndarray, w: np.ndarray) -> Run:
    k = len(q)
    r.error = np.max(np.linalg.norm(q - ref[:k], axis=2), axis=1)
    en = _energies(system, q, w)
    r.energy_error = np.abs(en - en[0])
    r.summary = metrics.summary(q, en) if k else {}
    return r


def _run_s2(
    system: System, method: str, s: Settings, state: tuple[np.ndarray, np.ndarray], ref: np.ndarray
) -> Run:
    opts = s.options()
    try:
        tr = simulate(system, method, "c", h=s.h, T=s.T, options=opts, q0=state[0], omega0=state[1])
        status, message = "ok", ""
    except IntegrationError as exc:
        tr, status, message = exc.partial, "failed", str(exc)
    r = Run("s2", method, status, message, t=tr.t, wall=tr.wall_time)
    r.steps, r.rejected = tr.stats.get("steps", 0), tr.stats.get("rejected", 0)
    r.evals = tr.stats.get("gradient_evals", 0)
    return _measure(r, system, ref, tr.q, tr.omega)


def _run_angles(
    system: System, method: str, s: Settings, state: tuple[np.ndarray, np.ndarray], ref: np.ndarray
) -> Run:
    opts = s.options()
    try:
        tr = simulate_angles(system, method, "c", s.h, s.T, opts, state[0], state[1])
        status, message = "ok", ""
    except PoleError as exc:
        return Run("angles", method, "PoleError", str(exc), wall=0.0)
    except AngleIntegrationError as exc:
        tr, status, message = exc.partial, "failed", str(exc)
    r = Run("angles", method, status, message, t=tr.t, wall=tr.wall_time)
    r.steps, r.rejected = int(tr.stats["steps"]), int(tr.stats["rejected"])
    r.evals = int(tr.stats["rhs_evals"])
    r.counts = np.column_stack([tr.t, tr.counts])
    return _measure(r, system, ref, tr.q, tr.omega)


def _s2_counts(
    system: System, s: Settings, state: tuple[np.ndarray, np.ndarray], around: float | None
) -> np.ndarray:
    """(t, accepted, rejected) of the S^2 RK45 at `windows` horizons (and at every sample within
    `ZOOM` of the time `around`), each a run from t = 0 with hmax fixed at T/10."""
    nsteps = round(s.T / s.h)
    ks = {max(1, round(nsteps * j / s.windows)) for j in range(1, s.windows + 1)}
    if around is not None:
        lo, hi = round((around - ZOOM) / s.h), round((around + ZOOM) / s.h)
        ks |= set(range(max(1, lo), min(nsteps, hi) + 1))
    rows = [(0.0, 0, 0)]
    opts = replace(s.options(), hmax=0.1 * s.T)
    for k in sorted(ks):
        try:
            tr = simulate(
                system, "rk45", "c", h=s.h, T=k * s.h, options=opts, q0=state[0], omega0=state[1]
            )
        except IntegrationError:
            break
        rows.append((k * s.h, tr.stats["steps"], tr.stats["rejected"]))
    return np.array(rows, dtype=float)


def reference(system: System, s: Settings, state: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """q on the output grid from the S^2 RK45 at rtol 1e-12 (the converged reference)."""
    opts = s.reference_options()
    tr = simulate(system, "rk45", "c", h=s.h, T=s.T, options=opts, q0=state[0], omega0=state[1])
    return tr.q


def accuracy(
    system: System,
    s: Settings,
    state: tuple[np.ndarray, np.ndarray],
    ref: np.ndarray,
    around: float | None = None,
) -> list[Run]:
    """Both forms with RK45 and RK4 against `ref`; the S^2 RK45 step counts over time (finely
    resolved near the time `around`) attached to its run."""
    runs = []
    for method in ("rk45", "rk4"):
        runs.append(_run_s2(system, method, s, state, ref))
        runs.append(_run_angles(system, method, s, state, ref))
    runs[0].counts = _s2_counts(system, s, state, around)
    return runs


def _run_line(r: Run) -> str:
    if r.status == "PoleError":
        return f"{r.form:6s} {r.method:5s} cannot start: {r.message}"
    tail = "" if r.status == "ok" else f"  FAILED at t = {r.t[-1] if r.t.size else 0:.4g}"
    return (
        f"{r.form:6s} {r.method:5s} max|q-qref| {r.max_error():.2e}  "
        f"max|dE| {r.summary.get('max_dE', float('nan')):.2e}  steps {r.steps:6d} "
        f"rejected {r.rejected:5d}{tail}"
    )
