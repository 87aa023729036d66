"""What a run is checked for around the integration: a finite initial state, and energy drift.

Input: a backend, the initial state and the parameter values (before the run); the energy
samples and the threshold `Options.energy_warn` (after it). Output: a ValueError when the
energy or the potential's gradient is not finite at the initial state (so that nothing is
integrated or written), the run's energy scale, and the first sample whose relative energy
error passes the threshold, announced as an `EnergyDriftWarning`.

Relative energy error of sample k: |E_k - E_0| / S, where the energy scale is
S = K_0 + |V_0| + sum_i |P_i grad_i V(q_0)| (floored at the smallest normal double): the
kinetic energy, the magnitude of the potential and, through the tangential part of the
gradient (P_i = I - q_i q_i^T), the energy the potential exchanges over a rotation of one
radian. S is taken at the initial state only (a blow-up must not enlarge its own yardstick);
it is at least |E_0| and stays meaningful when E_0 is about 0 (a pendulum released at rest
where V = 0 has S = m g l, not 0).

Example:
    >>> import numpy as np
    >>> first_drift(np.array([1.0, 1.001, 1.05, 0.9]), 1.0, 1e-2)
    2
    >>> first_drift(np.array([1.0, 1.001]), 1.0, 1e-2) is None
    True
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import numpy as np

__all__ = [
    "EnergyDriftWarning",
    "checked",
    "drift_message",
    "energy_scale",
    "first_drift",
    "first_nonfinite",
]

#: Smallest energy scale (a system at rest at a critical point where V = 0 has S = 0).
SCALE_FLOOR = float(np.finfo(float).tiny)


class EnergyDriftWarning(UserWarning):
    """A conservative run's relative energy error passed `Options.energy_warn` (the run's
    numbers are kept as computed; the step size is usually too large for the motion)."""


def energy_scale(
    be: Any, q0: np.ndarray, w0: np.ndarray, params: np.ndarray, energy: bool = True
) -> float | None:
    """The energy scale S of the initial state (module docstring); ValueError when the
    potential's gradient, or (with `energy`) the energy or the potential, is not finite
    there. None without `energy` (a run that keeps no energy is not checked for drift).

    Example:
        >>> from s2gen.runtime import get_backend
        >>> from s2gen.systems import builtin
        >>> s = builtin("double_pendulum")
        >>> be = get_backend(s, "numpy")
        >>> q = np.array([[1.0, 0, 0], [1.0, 0, 0]])  # both links horizontal, at rest: V = 0
        >>> S = energy_scale(be, q, np.zeros((2, 3)), np.array(s.parameter_values))
        >>> bool(abs(S - (2 + 1) * 9.81 * 9.81) < 1e-9)  # (m1 + m2) g l1 + m2 g l2
        True
    """
    where = f"{be.system.name}: at the initial state"
    q0 = np.ascontiguousarray(q0, dtype=float)
    w0 = np.ascontiguousarray(w0, dtype=float)
    with np.errstate(all="ignore"):  # a non-finite value is reported below, by name
        grad = np.asarray(be.gradient(q0, params), dtype=float).reshape(-1, 3)
    if not np.all(np.isfinite(grad)):
        body = int(np.flatnonzero(~np.all(np.isfinite(grad), axis=1))[0]) + 1
        raise ValueError(
            f"{where} the gradient of V on body {body} is not finite (two bodies at the same "
            "point under 1/|qi - qj|, a log of 0, ...): change the initial state or V"
        )
    if not energy:
        return None
    with np.errstate(all="ignore"):
        potential = float(be.energy(q0, np.zeros_like(w0), params))
        total = float(be.energy(q0, w0, params))
    if not math.isfinite(potential):
        raise ValueError(
            f"{where} the potential V = {potential} is not finite (two bodies at the same "
            "point under 1/|qi - qj|, a log of 0 or of a negative number, ...): change the "
            "initial state, V or the parameters"
        )
    if not math.isfinite(total):
        raise ValueError(f"{where} the kinetic energy is not finite: check omega0 and M")
    tangential = grad - np.einsum("ij,ij->i", grad, q0)[:, None] * q0
    kinetic = max(total - potential, 0.0)
    scale = kinetic + abs(potential) + float(np.linalg.norm(tangential, axis=1).sum())
    return max(scale, SCALE_FLOOR)


def first_drift(energy: np.ndarray, scale: float, threshold: float) -> int | None:
    """The first sample whose |E_k - E_0| / scale passes `threshold` (None: none does, or the
    threshold is 0 or inf, which switch the check off)."""
    if not (0.0 < threshold < math.inf) or len(energy) == 0:
        return None
    over = np.flatnonzero(np.abs(energy - energy[0]) / scale > threshold)
    return int(over[0]) if over.size else None


def first_nonfinite(energy: np.ndarray | None, valid: int) -> int | None:
    """The first of the `valid` samples whose energy is not finite (None: all finite).

    Example:
        >>> first_nonfinite(np.array([1.0, np.inf, np.nan]), 3)
        1
    """
    if energy is None:
        return None
    bad = np.flatnonzero(~np.isfinite(energy[:valid]))
    return int(bad[0]) if bad.size else None


def checked(tr: Any, system: Any, scale: float | None, threshold: float, warn: bool = True) -> Any:
    """`tr` with its angular momentum (at the run's parameters) and its energy check filled
    in (a run that kept no energy is returned as it is); with `warn` (a finished run), an `EnergyDriftWarning` of one line when the relative
    energy error passed `threshold` (the trajectory is kept as computed; a failed run's error
    says enough).

    Example:
        >>> from s2gen.runtime.trajectory import Trajectory
        >>> from s2gen.systems import builtin
        >>> q = np.tile([[0.0, 0, -1], [0, 0, -1]], (2, 1, 1))
        >>> tr = Trajectory(np.arange(2.0), q, 0 * q, np.array([1.0, 1.0]), "vi", "c", 1.0)
        >>> out = checked(tr, builtin("double_pendulum"), 1.0, 1e-2)
        >>> out.momentum.shape, out.drift_sample, out.energy_warn
        ((2, 3), None, 0.01)
    """
    if tr.energy is None or scale is None:  # a bare run (energy=False, as `Model.step`)
        return tr
    sample = first_drift(tr.energy if tr.work is None else tr.energy - tr.work, scale, threshold)
    tr = dataclasses.replace(
        tr,
        momentum=tr.angular_momentum(system, tr.params or None),
        energy_warn=float(threshold),
        energy_scale=float(scale),
        drift_sample=sample,
    )
    if warn and sample is not None:
        warnings.warn(drift_message(tr, sample, scale, threshold), EnergyDriftWarning, stacklevel=4)
    return tr


def drift_message(tr: Any, sample: int, scale: float, threshold: float) -> str:
    """One line naming the run, the first sample past the threshold and the largest error.

    Example:
        >>> from s2gen.runtime.trajectory import Trajectory
        >>> z = np.zeros((3, 1, 3))
        >>> tr = Trajectory(np.arange(3.0), z, z, np.array([1.0, 1.5, 3.0]), "vi", "c", 1.0,
        ...                 system="p")
        >>> drift_message(tr, 1, 1.0, 0.01)  # doctest: +NORMALIZE_WHITESPACE
        'p: vi on c: the relative energy error |E - E0| / 1 passed 0.01 at sample 1 (t = 1),
        largest 2 at t = 2; the step h = 1 is likely too large for this motion (a smaller h
        or an adaptive method)'
    """
    from s2gen.methods import NAMES
    from s2gen.methods import method as method_record

    rel = np.abs(tr.balance) / scale
    worst = int(np.nanargmax(rel))
    adaptive = tr.method in NAMES and method_record(tr.method).adaptive
    hint = (
        "tighten rtol and atol"
        if adaptive
        else f"the step h = {tr.h:g} is likely too large for this motion (a smaller h or an "
        "adaptive method)"
    )
    return (
        f"{tr.system or 'trajectory'}: {tr.method} on {tr.backend}: the relative energy error "
        f"|E - E0{'' if tr.work is None else ' - W'}| / {scale:.4g} passed {threshold:g} at sample {sample} (t = {tr.t[sample]:.6g}),"
        f" largest {rel[worst]:.3g} at t = {tr.t[worst]:.6g}; {hint}"
    )
