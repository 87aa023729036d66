"""The C interface of the Jacobian-vector products of a step: ``step_jvp()``, as an
`interface.Function` record.

A sphere module emitted from `System.with_jacobians` has it when its field is solved without
dense matrices (`s2gen.equations.jvp.has_jvp`: a diagonal M, or a banded or max-index M with
the structured solvers; closed; any n); its header also defines JVP_WORK_SIZE.

Example:
    >>> [p.name for p in STEP_JVP.params][-5:]
    ['qn', 'wn', 'dqn', 'dwn', 'work']
"""

from __future__ import annotations

from s2gen.interface import Function, Kind, Param

__all__ = ["STEP_JVP"]

_D, _CA, _A = Kind.DOUBLE, Kind.CONST_ARRAY, Kind.ARRAY

STEP_JVP = Function(
    "step_jvp",
    Kind.INT,
    (
        Param("p", _CA),
        Param("opt", Kind.OPTIONS, True),
        Param("method", Kind.INT),
        Param("h", _D),
        Param("q", _CA),
        Param("w", _CA),
        Param("dq", _CA),
        Param("dw", _CA),
        Param("qn", _A),
        Param("wn", _A),
        Param("dqn", _A),
        Param("dwn", _A),
        Param("work", _A),
    ),
    "One step of size h of a fixed-step method from (q, w) into (qn, wn) and its exact "
    "directional derivative along the tangent (dq, dw) in the embedding coordinates (NSTATE "
    "doubles each, body-major): (dqn, dwn) = A (dq, dw), A the step's Jacobian that "
    "step_jacobian() writes, without forming it, in O(n) time and memory. The fixed-step "
    "Runge-Kutta methods (rk2, rk2-proj, rk3, rk4; the step rk_step() takes, equal to it up "
    "to rounding): the "
    "tangent carried through each stage (the field's tangent: the Hessian of V times dq "
    "member by member, the products with M and the field's own structured solve). The VI "
    "family (vi, vi4, vi6, vi8; each substep as step_jacobian() takes it, Newton from its "
    "cold start, with the options opt, NULL: the defaults): a diagonal M's explicit update "
    "differentiated body by body; a banded or max-index M's by the implicit function theorem "
    "on the substep's converged equations, solved by the step's own structured solves. work: JVP_WORK_SIZE doubles. Returns OK, "
    "ERR_ARGUMENT (h <= 0 or a method it does not take), ERR_NONFINITE (a non-finite input "
    "or result), ERR_NEWTON or ERR_SINGULAR",
)
