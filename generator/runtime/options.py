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
    """Integrator options (defaults as MATLAB's ode45 for RK45, tight Newton).

    `max_steps` is the step budget of the adaptive methods (RK45, DOP853; in C, Python and the
    reference alike): a run that attempts more than `max_steps` steps (accepted plus rejected)
    between two points of its output grid t = k h stops with the stepsize status, its samples
    before that kept. Without it a state that needs tiny steps never ends: the minimum step is
    16 ulp(t), about 1e-300 near t = 0, so a spin 1e100 times too fast takes steps of 1e-102 and
    never reaches T. A floor on the step relative to T alone would still allow T / (16 ulp(T)),
    about 1e14 steps. As CVODE's mxstep the budget is per output interval, so a long run with
    many samples never exhausts it; the default 100000 (the NMAX of Hairer's DOP853) is far
    above what any sampled run here needs. 0: no limit.

    Example:
        >>> Options().max_steps, Options(max_steps=0).max_steps
        (100000, 0)
    """

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
    max_steps: int = 100000  # RK45/DOP853 attempts between two samples; 0: no limit
