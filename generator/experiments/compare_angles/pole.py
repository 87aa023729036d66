"""Near a pole: states sent past the pole of the angle chart at chosen distances.

Input: a `System` (with an initial state) and `Settings` (`alpha`, `tilts`). Output: one
`PoleCase` per tilt (`pole_study`): the body nearest a pole is turned onto it, moved back
along its motion by alpha and tilted by beta (`tilted_state`); beta* passes through the pole
(`through_tilt`, bisection on the side of the pass, `_passage`) and beta* + delta about delta
from it; each case holds the pass distance and time and the runs of both forms.

Example:
    >>> pole_body(np.array([[1.0, 0, 0], [0.1, 0, 0.99]]))
    1
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from s2gen import System, simulate

from .model import PoleCase, Settings
from .trajectories import _run_line, accuracy, reference


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix about the unit vector `axis` (Rodrigues)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def pole_body(q: np.ndarray) -> int:
    """The body (0-based) whose q_i is nearest a pole +-e3."""
    return int(np.argmin(np.hypot(q[:, 0], q[:, 1])))


def tilted_state(
    q0: np.ndarray, w0: np.ndarray, body: int, alpha: float, beta: float
) -> tuple[np.ndarray, np.ndarray]:
    """Body `body` turned onto its nearest pole, moved back along its great circle by `alpha`
    and tilted by `beta` about its direction of motion there: it then passes about `beta` from
    the pole (exactly, for a free body) after an arc `alpha`.

    Example:
        >>> q, w = tilted_state(np.array([[0, 0, 1.0]]), np.array([[0, 1.0, 0]]), 0, 0.5, 1e-3)
        >>> np.round(q, 4).tolist(), float(np.round(np.dot(q[0], w[0]), 15))
        ([[-0.4794, -0.0009, 0.8776]], 0.0)
    """
    q, w = np.array(q0, float), np.array(w0, float)
    pole = np.array([0.0, 0.0, 1.0 if q[body, 2] >= 0 else -1.0])
    turn = np.cross(q[body], pole)
    if np.linalg.norm(turn) > 0:
        angle = np.arctan2(np.linalg.norm(turn), np.dot(q[body], pole))
        onto = _rotation(turn / np.linalg.norm(turn), angle)
        q[body], w[body] = pole, onto @ w[body]
    if not np.linalg.norm(w[body]) > 0:
        raise ValueError(f"body {body + 1} does not move; it cannot be sent past the pole")
    axis = w[body] / np.linalg.norm(w[body])
    motion = np.cross(axis, q[body])
    rot = _rotation(motion / np.linalg.norm(motion), beta) @ _rotation(axis, -alpha)
    q[body], w[body] = rot @ q[body], rot @ w[body]
    return q, w


def _passage(
    system: System, s: Settings, state: tuple[np.ndarray, np.ndarray], body: int, window: float
) -> tuple[float, float]:
    """(signed distance, time) of the body's closest pass by the e3 axis within `window`.

    The distance is that of the local tangent line, L_z / |v_xy| with L_z = (q x v) . e3, so
    it is accurate even when the pass falls between samples; its sign tells the side.
    """
    fine = s.h / 10
    opts = s.reference_options()
    nsteps = max(1, int(np.ceil(window / fine)))
    tr = simulate(system, "rk45", "c", fine, nsteps * fine, opts, q0=state[0], omega0=state[1])
    q, w = tr.q[:, body], tr.omega[:, body]
    k = int(np.argmin(np.hypot(q[:, 0], q[:, 1])))
    v = np.cross(w[k], q[k])
    lz = q[k, 0] * v[1] - q[k, 1] * v[0]
    return float(lz / max(np.hypot(v[0], v[1]), 1e-300)), float(tr.t[k])


def _pass_window(system: System, s: Settings, body: int) -> float:
    """How long to look for the pass: three times the time the body takes to travel `alpha`."""
    assert system.omega0 is not None
    speed = float(np.linalg.norm(system.omega0[body]))
    return min(s.T, 3.0 * s.alpha / max(speed, 1e-12))


def through_tilt(system: System, s: Settings, body: int, iterations: int = 60) -> float:
    """The tilt beta* whose trajectory passes through the pole (bisection on the pass side).

    Returns 0 when +-0.25 rad do not bracket a passage (the body then passes near, not through).
    """
    assert system.q0 is not None and system.omega0 is not None
    window = _pass_window(system, s, body)

    def side(beta: float) -> float:
        q0, w0 = system.q0, system.omega0
        assert q0 is not None and w0 is not None
        state = tilted_state(q0, w0, body, s.alpha, beta)
        return _passage(system, s, state, body, window)[0]

    lo, hi = -0.25, 0.25
    slo, shi = side(lo), side(hi)
    if not slo * shi < 0:
        return 0.0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        smid = side(mid)
        if smid == 0.0 or hi - lo < 1e-15:
            return mid
        lo, hi, slo = (lo, mid, slo) if slo * smid < 0 else (mid, hi, smid)
    return 0.5 * (lo + hi)


def pole_study(system: System, s: Settings, log: Callable[[str], None] = print) -> list[PoleCase]:
    """The tilt through the pole and the tilts beta* + delta for delta in `Settings.tilts`."""
    assert system.q0 is not None and system.omega0 is not None
    body = pole_body(system.q0)
    window = _pass_window(system, s, body)
    star = through_tilt(system, s, body)
    log(f"  body {body + 1}; tilt through the pole beta* = {star:.15g}")
    out = []
    for label, delta in [("through", 0.0)] + [(f"{d:g}", d) for d in s.tilts]:
        state = tilted_state(system.q0, system.omega0, body, s.alpha, star + delta)
        passage, when = _passage(system, s, state, body, window)
        ref = reference(system, s, state)
        sin_grid = np.hypot(ref[:, body, 0], ref[:, body, 1])
        runs = accuracy(system, s, state, ref, around=when)
        out.append(PoleCase(label, star + delta, body, passage, when, sin_grid, runs))
        for r in runs:
            log(f"  {label:>8s} (pass {passage:9.2e} at t {when:5.3f}) {_run_line(r)}")
    return out
