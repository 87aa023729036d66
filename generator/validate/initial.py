"""Validation of the initial state: unit vectors q_i and tangent velocities omega_i.

Input: the initial q and omega (n 3-vectors each, or neither), the number of bodies and the
location for messages. Output: both as (n, 3) arrays, q normalized and omega projected on the
tangent planes when they are off by round-off only (a `SpecWarning` says so), or a `SpecError`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from s2gen.errors import SpecError, SpecWarning

__all__ = ["UNIT_LENGTH_TOLERANCE"]

#: A q_i further than this from unit length is an error; closer ones are normalized (warning).
UNIT_LENGTH_TOLERANCE = 1e-3


def _validate_initial(
    q0: Sequence[Sequence[float]] | np.ndarray | None,
    omega0: Sequence[Sequence[float]] | np.ndarray | None,
    n: int,
    where: str,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Check shapes, normalize q_i rounded to printed digits, project omega_i on T_q S^2."""
    if q0 is None and omega0 is None:
        return None, None
    if q0 is None or omega0 is None:
        raise SpecError(f"{where}: [initial]: give both 'q' and 'omega' (or neither)")
    try:
        q = np.array(q0, dtype=float)
        w = np.array(omega0, dtype=float)
    except (TypeError, ValueError) as exc:
        raise SpecError(f"{where}: [initial]: not a list of numeric 3-vectors ({exc})") from None
    for key, arr in (("q", q), ("omega", w)):
        if arr.shape != (n, 3):
            raise SpecError(
                f"{where}: [initial] {key}: expected {n} vectors of 3 components, "
                f"got shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise SpecError(f"{where}: [initial] {key}: contains a non-finite value")
    norms = np.linalg.norm(q, axis=1)
    notes = []
    for i in range(n):
        dev = abs(norms[i] - 1.0)
        if dev > UNIT_LENGTH_TOLERANCE:
            raise SpecError(
                f"{where}: [initial] q{i + 1}: length {norms[i]:.6g} is not a unit vector "
                f"(off by {dev:.3g} > {UNIT_LENGTH_TOLERANCE:g})"
            )
        if dev > 8 * np.finfo(float).eps:
            notes.append(f"q{i + 1} normalized (length was 1{norms[i] - 1.0:+.3g})")
    qn = q / norms[:, None]
    radial = np.einsum("ij,ij->i", qn, w)
    wn = w - radial[:, None] * qn
    for i in range(n):
        scale = max(1.0, float(np.linalg.norm(w[i])))
        if abs(radial[i]) > UNIT_LENGTH_TOLERANCE * scale:  # as q_i's length: not round-off
            raise SpecError(
                f"{where}: [initial] omega{i + 1}: its component {radial[i]:.6g} along q{i + 1} is "
                f"more than {UNIT_LENGTH_TOLERANCE:g} of max(1, |omega{i + 1}|); omega must be "
                "tangent to the sphere (omega_i . q_i = 0)"
            )
        if radial[i] != 0.0 and abs(radial[i]) > 4 * np.finfo(float).eps * scale:
            notes.append(
                f"omega{i + 1} projected onto the tangent plane (removed {radial[i]:+.3g})"
            )
    if notes:
        warnings.warn(f"{where}: [initial]: " + "; ".join(notes), SpecWarning, stacklevel=3)
    return qn, wn
