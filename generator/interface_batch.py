"""The C interface of batches: ``integrate_batch()``, as an `interface.Function`.

A sphere module emitted from `System.with_batch` has it (closed systems, see
`s2gen.parts.batch`); its header also defines BATCH_LANES and BATCH_WORK_SIZE. A driven
system's module has `INTEGRATE_BATCH_DRIVEN` instead (`s2gen.parts.batch_driven`; its header
defines BATCH_WORK_SIZE).

Layout: every per-member array is member-innermost, element e of member k at [e * K + k] (the
parameters: p[j * K + k]; the initial state: q0[(3 i + c) * K + k]; sample s of the
trajectory: q[(s * NSTATE + 3 i + c) * K + k], energy[s * K + k]). Why not blocks of
BATCH_LANES: the caller's layout then depends on K alone, not on a lane count the generator
chose (and may choose otherwise for another machine), and one member is one strided column,
as NumPy holds an array of shape (..., K); the members go through the lanes block by block
inside, in a workspace of BATCH_WORK_SIZE doubles whatever K is.

Example:
    >>> [p.name for p in INTEGRATE_BATCH.params][:4]
    ['K', 'p', 'opt', 'method']
"""

from __future__ import annotations

from s2gen.interface import Function, Kind, Param

__all__ = ["INTEGRATE_BATCH", "INTEGRATE_BATCH_DRIVEN"]

_D, _CA, _A = Kind.DOUBLE, Kind.CONST_ARRAY, Kind.ARRAY

INTEGRATE_BATCH = Function(
    "integrate_batch",
    Kind.INT,
    (
        Param("K", Kind.LONG),
        Param("p", _CA),
        Param("opt", Kind.OPTIONS, True),
        Param("method", Kind.INT),
        Param("h", _D),
        Param("nsteps", Kind.LONG),
        Param("q0", _CA),
        Param("w0", _CA),
        Param("q", _A),
        Param("w", _A),
        Param("energy", _A, True),
        Param("work", _A),
        Param("stats", Kind.STATS),
        Param("status", Kind.INT_OUT),
    ),
    "integrate() for K members of the system at once, each with its own parameters and "
    "initial state, BATCH_LANES members at a time in SIMD lanes; each member's samples, energy, "
    "stats[k] and status[k] equal integrate()'s for that member bit for bit (same build "
    "flags). Arrays are member-innermost: p[j * K + k] (NPARAMS * K doubles), q0 and w0 "
    "[(3 i + c) * K + k] (NSTATE * K), q and w [(s * NSTATE + 3 i + c) * K + k] ((nsteps / "
    "every + 1) * NSTATE * K), energy [s * K + k] (not evaluated when NULL). Methods: VI, VI4, "
    "VI6, VI8, RATTLE, RATTLE4, RATTLE6, RATTLE8, RK2, RK2_PROJ, RK3, RK4, RK45 and DOP853 (h "
    "the output spacing, each member its own step sizes). A member that "
    "fails (status[k] as integrate() would "
    "return it: a non-finite or non-unit q0, an infeasible or non-finite step, a Newton "
    "iteration that does not converge, a singular solve, a step size at its limit) stops alone, "
    "its samples before stats[k].fail_step valid; the others go on. work: BATCH_WORK_SIZE "
    "doubles, whatever K. Returns ERR_ARGUMENT (nothing written) for K < 1, h <= 0, nsteps < "
    "0, an every that does not divide nsteps, a method it does not take or (RK45, DOP853) "
    "rtol or atol <= 0; else OK when every "
    "member's status is OK, otherwise the status of the first member that failed.",
)

#: A driven module's integrate_batch() (`s2gen.parts.batch_driven`): the driven integrate()'s
#: start time, inputs and work, for K members
INTEGRATE_BATCH_DRIVEN = Function(
    "integrate_batch",
    Kind.INT,
    (
        Param("K", Kind.LONG),
        Param("p", _CA),
        Param("opt", Kind.OPTIONS, True),
        Param("method", Kind.INT),
        Param("t0", _D),
        Param("h", _D),
        Param("nsteps", Kind.LONG),
        Param("u", _CA, True),
        Param("q0", _CA),
        Param("w0", _CA),
        Param("q", _A),
        Param("w", _A),
        Param("energy", _A, True),
        Param("W", _A, True),
        Param("work", _A),
        Param("stats", Kind.STATS),
        Param("status", Kind.INT_OUT),
    ),
    "integrate() for K members of the driven system, each with its own parameters, initial "
    "state and input schedule, from one t0 with one h and nsteps, one member after the other; "
    "each member's samples, energy, work W, stats[k] and status[k] equal integrate()'s for "
    "that member (no feedback) bit for bit. Arrays are member-innermost: p[j * K + k] "
    "(NPARAMS * K doubles), q0 and w0 [(3 i + c) * K + k] (NSTATE * K), u [(s * NINPUTS + j) "
    "* K + k], input j held by member k over step s (nsteps * NINPUTS * K doubles; NULL: the "
    "defaults throughout), q and w [(s * NSTATE + 3 i + c) * K + k] ((nsteps / every + 1) * "
    "NSTATE * K), energy and W [s * K + k] (not written when NULL). Methods: those of "
    "integrate(). State feedback is not taken (integrate() takes it, one member at a time). "
    "A member that fails (status[k] as integrate() would return it: a non-finite or non-unit "
    "q0, a non-finite input, an infeasible or non-finite step) stops alone, its samples "
    "before stats[k].fail_step valid; the others go on. work: BATCH_WORK_SIZE doubles, "
    "whatever K. Returns ERR_ARGUMENT (nothing written) for K < 1, h <= 0, nsteps < 0, an "
    "every that does not divide nsteps, a non-finite t0 or a method that is not driven; else "
    "OK when every member's status is OK, otherwise the status of the first member that "
    "failed.",
)
