"""The C interface of the step Jacobians: ``step_jacobian()`` and ``field_jacobian()``, as
`interface.Function` records (`JACOBIAN_FUNCTIONS`, in the header's order).

A sphere module emitted from `System.with_jacobians` has it (systems of at most
`s2gen.equations.jacobian.JACOBIAN_MAX_BODIES` bodies; closed or driven: one signature); its
header also defines JACOBIAN_WORK_SIZE and JACOBIAN_VI. The derivative in the parameters, P,
is an optional output of the same function (NULL: not written), so that one pass of the chain
rule gives A, B and P together.

Example:
    >>> [p.name for p in STEP_JACOBIAN.params][-4:]
    ['A', 'B', 'P', 'work']
"""

from __future__ import annotations

from s2gen.interface import Function, Kind, Param

__all__ = ["FIELD_JACOBIAN", "JACOBIAN_FUNCTIONS", "STEP_JACOBIAN"]

_D, _CA, _A = Kind.DOUBLE, Kind.CONST_ARRAY, Kind.ARRAY

STEP_JACOBIAN = Function(
    "step_jacobian",
    Kind.INT,
    (
        Param("p", _CA),
        Param("opt", Kind.OPTIONS, True),
        Param("method", Kind.INT),
        Param("t", _D),
        Param("h", _D),
        Param("u", _CA, True),
        Param("q", _CA),
        Param("w", _CA),
        Param("qn", _A),
        Param("wn", _A),
        Param("A", _A),
        Param("B", _A, True),
        Param("P", _A, True),
        Param("work", _A),
    ),
    "One step of size h of a fixed-step method (the fixed-step Runge-Kutta methods; the VI "
    "family, vi, vi4, vi6, vi8, when JACOBIAN_VI is 1: any M; the RATTLE family, rattle, "
    "rattle4, rattle6, rattle8, in a closed module or a driven one whose forces, if any, "
    "meet a diagonal M) from "
    "(q, w) at time t into (qn, wn), as step() takes it (Newton from its cold start), and its "
    "exact derivatives in the embedding coordinates: with x = (q, w) (NS = 2 NSTATE doubles, "
    "q body-major then w), A (NS x NS, row-major) receives dx+/dx and B (NS x NINPUTS, "
    "row-major; may be NULL) dx+/du and P (NS x NPARAMS, row-major, the parameters in the "
    "order of p; may be NULL) dx+/dp (through M, V and the forces); P NULL: P's columns are "
    "not computed, B and P NULL: neither are B's (A alone, the cheapest call; B NULL with P "
    "given: B's are computed, not written). Runge-Kutta: the chain "
    "rule of the tableau through its stages (and the normalization of q_i for the -proj methods) on the field's Jacobian; VI: "
    "the implicit function theorem on each substep's equations (Newton's residual in the "
    "Cayley parameters, the Cayley update and the velocity equations; diagonal M: the "
    "explicit update), the substeps' derivatives multiplied; RATTLE: the same on its "
    "constrained Stormer-Verlet equations in x = q and v = w x q (driven: with g - F at "
    "each end). SymPy derives every derivative "
    "(the Hessian of V, assembled per term member, those of the forces and of M in the "
    "parameters); no differences are taken. t and u (NINPUTS "
    "doubles; NULL: the defaults) are read by a driven module only; opt (NULL: the defaults) "
    "by the VI. work: JACOBIAN_WORK_SIZE doubles. Returns OK or the step's own status "
    "(ERR_ARGUMENT for h <= 0 or a method without a Jacobian, ERR_NONFINITE, ERR_NEWTON)",
)

FIELD_JACOBIAN = Function(
    "field_jacobian",
    Kind.INT,
    (
        Param("p", _CA),
        Param("t", _D),
        Param("u", _CA, True),
        Param("q", _CA),
        Param("w", _CA),
        Param("qd", _A, True),
        Param("wd", _A, True),
        Param("J", _A),
        Param("Ju", _A, True),
        Param("Jp", _A, True),
        Param("work", _A),
    ),
    "The continuous field at (q, w) at time t with the inputs u (NINPUTS doubles, NULL: the "
    "defaults; t and u are read by a driven module only), qdot_i = w_i x q_i and A(q) wdot = "
    "b(q, w, t, u), the forces included, into qd and wd (NSTATE doubles each; may be NULL), "
    "and its exact derivatives in the embedding coordinates x = (q, w) (NS = 2 NSTATE doubles, "
    "q body-major then w): J (NS x NS, row-major) receives d(qdot, wdot)/dx and Ju (NS x "
    "NINPUTS, row-major; may be NULL) d(qdot, wdot)/du and Jp (NS x NPARAMS, row-major, the "
    "parameters in the order of p; may be NULL) d(qdot, wdot)/dp (a NULL Ju or Jp "
    "spares columns as B and P do in step_jacobian()), the Jacobians step_jacobian() "
    "propagates through a Runge-Kutta stage (for a solver of the caller's: J is defined on the "
    "whole embedding, its restriction to the tangent space of T(S^2)^n is the field's). "
    "work: JACOBIAN_WORK_SIZE doubles. Returns OK, ERR_NONFINITE for a non-finite input or "
    "field, or ERR_SINGULAR",
)

#: The functions a module with step Jacobians adds to its interface, in the header's order
JACOBIAN_FUNCTIONS = (STEP_JACOBIAN, FIELD_JACOBIAN)
