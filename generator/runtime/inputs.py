"""The inputs of a run, checked before anything runs: the initial state and the parameters.

Input: a `System` and what a caller gave (arrays or None; parameter values by name or in
declared order). Output: the initial state (q0, omega0) and the parameter vector in declared
order, or a ValueError of one line naming what is wrong.

Example:
    >>> from s2gen.systems import builtin
    >>> parameter_vector(builtin("double_pendulum"), {"g": 1.62}).tolist()
    [1.0, 1.0, 9.81, 9.81, 1.62]
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from s2gen.system import System

__all__ = ["initial_state", "parameter_vector"]


def initial_state(
    system: System, q0: np.ndarray | None, omega0: np.ndarray | None, unit_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """The initial state (given or the spec's), checked: shapes, finite values, unit q_i.

    Example:
        >>> from s2gen.systems import builtin
        >>> initial_state(builtin("double_pendulum"), None, None, 1e-12)[0].shape
        (2, 3)
    """
    q, w = system.q0, system.omega0
    try:
        q = q if q0 is None else np.asarray(q0, dtype=float)
        w = w if omega0 is None else np.asarray(omega0, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"q0 and omega0 must be arrays of shape ({system.n}, 3) of numbers"
        ) from None
    if q is None or w is None:
        raise ValueError(f"{system.origin}: no initial state ([initial] q and omega)")
    for name, a in (("q0", q), ("omega0", w)):
        if a.shape != (system.n, 3):
            raise ValueError(f"{name} must have shape ({system.n}, 3), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains a non-finite value")
    if unit_tol > 0.0:
        off = np.abs(np.linalg.norm(q, axis=1) - 1.0)
        bad = np.flatnonzero(~(off <= unit_tol))
        if bad.size:
            i = int(bad[0])
            raise ValueError(
                f"q0 of body {i + 1} has length {np.linalg.norm(q[i]):.17g}, not 1 to within "
                f"{unit_tol:g} (normalize it, or set Options.unit_tol)"
            )
    return q, w


def parameter_vector(system: System, params: Any = None) -> np.ndarray:
    """The parameter values in declared order: the spec's, overridden by a mapping by name,
    or all of them as a sequence in declared order. ValueError for an unknown name, a wrong
    count or a value that is not a finite number.

    Example:
        >>> from s2gen.systems import builtin
        >>> parameter_vector(builtin("double_pendulum"), [1, 2, 3, 4, 5]).tolist()
        [1.0, 2.0, 3.0, 4.0, 5.0]
        >>> parameter_vector(builtin("double_pendulum"), {"k": 1.0})
        Traceback (most recent call last):
        ...
        ValueError: double_pendulum: unknown parameter 'k' (parameters: m1, m2, l1, l2, g)
    """
    names = system.parameter_names
    known = ", ".join(names) or "none"
    if isinstance(params, Mapping):
        merged = dict(system.parameters)
        for name, value in params.items():
            if name not in merged:
                raise ValueError(f"{system.name}: unknown parameter {name!r} (parameters: {known})")
            number = float(value) if isinstance(value, numbers.Real) else math.nan
            if isinstance(value, bool) or not math.isfinite(number):
                raise ValueError(
                    f"{system.name}: parameter {name} must be a finite number, got {value!r}"
                )
            merged[name] = number
        return np.array([merged[p] for p in names], dtype=float)
    if isinstance(params, (str, bytes)):
        raise ValueError(  # noqa: TRY004 (bad input is a ValueError: the CLI reports those)
            f"{system.name}: expected {len(names)} parameter values ({known}) or a dict by "
            f"name, got {params!r}"
        )
    try:
        p = np.array(system.parameter_values if params is None else params, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(
            f"{system.name}: parameter values must be {len(names)} numbers ({known}) or a dict "
            f"by name, got {params!r}"
        ) from None
    if p.shape != (len(names),):
        raise ValueError(
            f"{system.name}: expected {len(names)} parameter values ({known}) or a dict by "
            f"name, got {p.size}"
        )
    bad = np.flatnonzero(~np.isfinite(p))
    if bad.size:
        k = int(bad[0])
        raise ValueError(f"{system.name}: parameter {names[k]} = {p[k]} is not finite")
    return p
