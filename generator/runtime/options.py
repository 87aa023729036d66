"""Integrator options shared by every backend.

Input: keyword values. Output: a frozen `Options` record, passed to `simulate` and to the
backends (the C backend mirrors it into the emitted options struct).

Example:
    >>> Options(rtol=1e-6).control
    'matlab'
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Options"]


@dataclass(frozen=True)
class Options:
    """Integrator options (defaults as MATLAB's ode45 for RK45, tight Newton)."""

    rtol: float = 1e-3
    atol: float = 1e-6
    control: str = "matlab"
    hmax: float = 0.0
    newton_tol: float = 1e-14
    newton_maxiter: int = 50
    unit_tol: float = 1e-12  # a q0_i farther than this from unit length is refused (<= 0: none)
    #: Relative energy error past which a finished run warns (`s2gen.EnergyDriftWarning`;
    #: see `s2gen.runtime.diagnostics`); 0 or inf: never.
    energy_warn: float = 1e-2
