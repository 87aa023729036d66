"""Independent plain-NumPy reference integrators for Lagrangian mechanics on (S^2)^n.

This package is the project's yardstick. It is written directly from Lee, Leok & McClamroch,
"Lagrangian mechanics and variational integrators on two-spheres" (sections 2 and 3), and shares
no code with the rest of the package: it uses only NumPy, SymPy (to differentiate a `System`'s
potential), the `System` record itself, the tables of `s2gen.methods` (status codes, methods
and controls) and the coefficients of the fixed-step tableaus in `s2gen.tableaus` (numbers;
the stepping is written here).

Modules: `problem` (a `System` in numbers), `geometry` (hat maps, A(q), energy, momentum),
`field` (the continuous vector field), `vi` (the variational integrator step), `recorder` (the
output grid and the fixed-step loop), `rk` (fixed-step Runge-Kutta), `dopri` (Dormand-Prince
RK45), `errors`; this module holds the driver `integrate` and re-exports the public names.
Driven systems (forces F_i(q, w, t, u), a potential V(q, t, u), inputs u held over each step)
have modules of their own, not re-exported here: `forced` (`DrivenProblem`, the forced field
`driven_rhs`), `forced_steps` (the forced VI and RATTLE steps and a step's work) and
`forced_integrate` (`integrate_driven`: the VI and RATTLE families with their compositions and
the fixed-step Runge-Kutta methods, recording the work W so that E - E0 - W is the balance).
`adaptive` holds the time-transformed methods (``"vi-adaptive"``, ``"vi4-adaptive"``, ...,
``"rattle-adaptive"``, ...: the VI or RATTLE and their compositions in a fictitious time, steps eps / xi with xi tracking a monitor of
the pair terms; the monitor's rule is the definition in `s2gen.monitor`, shared with the
emitted code as the tableaus are). `step_jacobian` differentiates one fixed step (closed or
driven) by the complex-step derivative, and `field_jacobian` the continuous field: the steps
and the field carry complex states, inputs and parameters (`problem.numbers`), and give the
same numbers as before on real ones.

Input: a `ReferenceProblem` (inertia matrix M, potential V(q) and its gradient dV/dq), usually
built from a `System` by `problem_from_system` (structured terms are evaluated vectorized over
their members, never expanded); an initial state q0, w0 (arrays of shape (n, 3), unit vectors
q_i and angular velocities w_i with q_i . w_i = 0); a step h and a number of steps.
Output: a `RefTrajectory` (t, q, omega, energy, stats) from `integrate`, or single pieces:
`energy`, `angular_momentum`, `continuous_rhs`, `vi_step`, the Cayley residual and Jacobian.

Methods (`integrate(..., method=...)`):

* ``"vi"``: the variational integrator (paper eqs. DELw1, qikpw, DELw2m). Explicit when M is
  diagonal (eqs. qikpexp, wikpexp), Newton's method on the Cayley residual otherwise. Nothing is
  ever renormalized.
* every fixed-step method of `s2gen.methods` (``"rk2"``, explicit midpoint; ``"rk2-proj"``,
  rk2, then each q_i normalized; ``"rk4"``, classical; ...) and ``"rk45"`` (Dormand-Prince 5(4), adaptive, FSAL, Shampine's dense output on
  the grid t_k = k h, with MATLAB ode45 or Hairer/SciPy step-size control), all on the
  continuous vector field y = (q, w) in R^{6n} of paper eqs. ELq and ELwm.

Conventions: q and w are (n, 3) arrays, body i in row i-1; g_i = dV/dq_i; qdot_i = w_i x q_i;
the 3n x 3n matrix A(q) has blocks A_ii = M_ii I and A_ij = -M_ij hat(q_i) hat(q_j).
Failures raise a `ReferenceIntegrationError(step, message)`, one subclass per cause
(`InfeasibleStep`, `NewtonFailure`, `NonFiniteState`, `SingularSystem`, `StepSizeUnderflow`);
``exc.status`` is the `s2gen.methods.Status` of that cause and ``exc.partial`` holds the
trajectory up to the last good point t_step.

Derivation notes (checked against the discrete Legendre transforms of
L_d = 1/(2h) sum M_ij (q_i+ - q_i).(q_j+ - q_j) - h/2 V(q) - h/2 V(q+)):
q_i x (-D_1 L_d)_i gives d_i (`vi_d`) and q_i+ x (D_2 L_d)_i gives the right side of DELw2m
(`_vi_velocity`); both equal (A(q) w)_i. The Cayley residual keeps the factor q_i.q_i of
q_i x (f_i x q_i) = (q_i.q_i) f_i (f_i _|_ q_i) instead of setting it to 1: the two agree on
the sphere, but with the factor the discrete momentum map stays conserved when |q_i| carries
round-off (over 10^4 double-pendulum steps: e3.J drift 5e-13 relative instead of 9e-12).

Example:
    >>> import numpy as np
    >>> free = ReferenceProblem(M=np.array([[1.0]]), grad=lambda q: np.zeros_like(q),
    ...                         potential=lambda q: 0.0)
    >>> tr = integrate(free, "vi", [[1.0, 0, 0]], [[0, 0, 1.0]], h=0.01, nsteps=100)
    >>> tr.q.shape, bool(abs(tr.energy[-1] - 0.5) < 1e-14)
    ((101, 1, 3), True)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from s2gen.methods import CONTROLS, REFERENCE_METHODS, Driver
from s2gen.methods import method as method_row
from s2gen.reference.adaptive import MonitorFn, integrate_time_transformed
from s2gen.reference.dopri import _rk45_hairer, _rk45_matlab
from s2gen.reference.errors import (
    InfeasibleStep,
    NewtonFailure,
    NonFiniteState,
    ReferenceIntegrationError,
    SingularSystem,
    StepSizeUnderflow,
)
from s2gen.reference.field import continuous_rhs
from s2gen.reference.geometry import angular_momentum, energy, hat, inertia_operator
from s2gen.reference.problem import Array, ReferenceProblem, problem_from_system
from s2gen.reference.recorder import RefTrajectory, _Recorder, _run_fixed, _state
from s2gen.reference.rk import _rk_advance
from s2gen.reference.vi import _vi_advance, vi_d, vi_jacobian, vi_residual, vi_step

__all__ = [
    "CONTROLS",
    "METHODS",
    "InfeasibleStep",
    "NewtonFailure",
    "NonFiniteState",
    "RefTrajectory",
    "ReferenceIntegrationError",
    "ReferenceProblem",
    "SingularSystem",
    "StepSizeUnderflow",
    "angular_momentum",
    "continuous_rhs",
    "energy",
    "hat",
    "inertia_operator",
    "integrate",
    "problem_from_system",
    "vi_d",
    "vi_jacobian",
    "vi_residual",
    "vi_step",
]

METHODS = REFERENCE_METHODS


def _check_inputs(
    problem: ReferenceProblem,
    method: str,
    q0: Array,
    w0: Array,
    h: float,
    nsteps: int,
    control: str,
) -> None:
    if method not in METHODS:
        raise ValueError(f"integrate: unknown method {method!r}; choose from {METHODS}")
    if control not in CONTROLS:
        raise ValueError(f"integrate: unknown control {control!r}; choose from {CONTROLS}")
    for name, a in (("q0", q0), ("w0", w0)):
        if a.shape != (problem.n, 3):
            raise ValueError(f"integrate: {name} must have shape ({problem.n}, 3), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"integrate: {name} contains a non-finite value")
    if not (np.isfinite(h) and h > 0.0):
        raise ValueError(f"integrate: the step h must be positive and finite, got {h!r}")
    if int(nsteps) != nsteps or nsteps < 0:
        raise ValueError(f"integrate: nsteps must be a non-negative integer, got {nsteps!r}")


def integrate(
    problem: ReferenceProblem,
    method: str,
    q0: Array | Sequence[Sequence[float]],
    w0: Array | Sequence[Sequence[float]],
    h: float,
    nsteps: int,
    *,
    rtol: float = 1e-3,
    atol: float = 1e-6,
    control: str = "matlab",
    hmax: float | None = None,
    newton_tol: float = 1e-14,
    newton_maxiter: int = 50,
    monitor: MonitorFn | None = None,
    every: int = 1,
    max_steps: int = 100000,
) -> RefTrajectory:
    """Integrate from (q0, w0) at t = 0 and sample at t_k = k h, k = 0..nsteps.

    `method` is one of METHODS. For "rk45", h is only the output spacing; steps are adaptive
    with tolerances rtol/atol, `control` "matlab" (ode45; hmax defaults to T/10) or "hairer"
    (SciPy's RK45; hmax defaults to infinity) and at most `max_steps` attempted steps
    between two samples (0: no limit; more raise StepSizeUnderflow). For "vi" with coupled M, Newton stops when
    max|update| <= newton_tol * max(1, max|f|) and fails after newton_maxiter iterations.
    A time-transformed method (``"vi-adaptive"``, ...) takes h as its fictitious step eps,
    needs the `monitor` (`adaptive.monitor_from_system`) and samples only t_k = k every h
    (each sample costs it an extra step); the other methods ignore `every`.
    The initial state is used as given (not normalized). Raises a ReferenceIntegrationError
    (with .step, .status and .partial): InfeasibleStep, NewtonFailure, NonFiniteState,
    SingularSystem or StepSizeUnderflow.

    Example:
        >>> e3 = np.array([0.0, 0.0, 1.0])
        >>> pend = ReferenceProblem(np.array([[1.0]]), lambda q: -9.81 * e3[None, :],
        ...                         lambda q: -9.81 * q[0, 2])
        >>> tr = integrate(pend, "rk45", [[1.0, 0, 0]], [[0, 0, 0.0]], h=0.1, nsteps=10)
        >>> float(tr.t[-1]), tr.stats["steps"] > 0
        (1.0, True)
    """
    q0a = np.array(q0, dtype=float)
    w0a = np.array(w0, dtype=float)
    _check_inputs(problem, method, q0a, w0a, h, nsteps, control)
    if method_row(method).driver is Driver.TIME_TRANSFORMED:
        if monitor is None:
            raise ValueError(f"integrate: method {method!r} needs a monitor")
        return integrate_time_transformed(
            problem,
            monitor,
            method,
            q0a,
            w0a,
            h,
            int(nsteps),
            every,
            newton_tol=newton_tol,
            newton_maxiter=newton_maxiter,
        )
    rec = _Recorder(problem, method, h, int(nsteps))
    y0 = _state(q0a, w0a)
    rec.push(y0)
    if method == "vi":
        _run_fixed(rec, _vi_advance(rec, h, newton_tol, newton_maxiter), int(nsteps))
    elif method != "rk45":
        _run_fixed(rec, _rk_advance(rec, method, h), int(nsteps))
    elif nsteps > 0:
        T = float(rec.t[-1])
        if control == "matlab":
            _rk45_matlab(rec, y0, T, rtol, atol, 0.1 * T if hmax is None else hmax, max_steps)
        else:
            _rk45_hairer(rec, y0, T, rtol, atol, np.inf if hmax is None else hmax, max_steps)
    return rec.trajectory()
