"""The public interface of the emitted modules, as records: functions, structs and constants.

Input: a module kind. Output: `Interface` records (each C function with its parameters and
documentation, the options and statistics structs with their fields and defaults). The
headers are rendered from them and the ctypes runtime builds its prototypes and structs from
the same records, so the C declarations and their Python mirror cannot disagree.

Parameter kinds (`Kind`) say what crosses the boundary: a double array, a scalar, a pointer to
a struct, a long array. `nullable` parameters may be NULL (the header says what NULL means).

Example:
    >>> api = interface(ModuleKind.SPHERE)
    >>> [p.name for p in api.function("integrate").params][:3]
    ['p', 'opt', 'method']
    >>> api.options[0].name, api.options[0].default
    ('rtol', '1e-3')
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from s2gen.ir import ModuleKind

__all__ = [
    "INITIAL_STATE_MAX_BODIES",
    "Field",
    "Function",
    "Interface",
    "Kind",
    "Param",
    "interface",
]

#: initial_state() carries the spec's state up to this many bodies (6 doubles each, printed in
#: full); a larger state would dominate the emitted code and its compilation.
INITIAL_STATE_MAX_BODIES = 10_000


class Kind(enum.Enum):
    """What a parameter or field is, for C declarations and the ctypes mirror."""

    DOUBLE = "double"
    INT = "int"
    LONG = "long"
    CONST_ARRAY = "const double *"  # input array of doubles
    ARRAY = "double *"  # output (or scratch) array of doubles
    LONG_ARRAY = "long *"
    INT_OUT = "int *"
    OPTIONS = "const options *"
    OPTIONS_OUT = "options *"
    STATS = "stats *"
    STEPPER = "stepper *"
    VECTOR3 = "double J[3]"
    VOID = "void"
    FEEDBACK = "feedback"  # a driven module's input callback (the header's typedef)
    POINTER = "void *"  # the caller's context of a callback


@dataclass(frozen=True)
class Param:
    """One parameter of an emitted function."""

    name: str
    kind: Kind
    nullable: bool = False


@dataclass(frozen=True)
class Function:
    """One public function: `NAME_<name>`, its return kind, parameters and header comment."""

    name: str
    returns: Kind
    params: tuple[Param, ...]
    doc: str


@dataclass(frozen=True)
class Field:
    """One field of the options or statistics struct: kind, default (C literal), comment."""

    name: str
    kind: Kind
    default: str
    doc: str


@dataclass(frozen=True)
class Interface:
    """The functions and structs one kind of module exports."""

    functions: tuple[Function, ...]
    options: tuple[Field, ...]
    stats: tuple[Field, ...]
    stepper: tuple[Field, ...] = ()  # what step() keeps between steps besides the carry

    def function(self, name: str) -> Function:
        """The function called `name` (KeyError if absent)."""
        for f in self.functions:
            if f.name == name:
                return f
        raise KeyError(name)


def _p(name: str, kind: Kind, nullable: bool = False) -> Param:
    return Param(name, kind, nullable)


_D, _CA, _A = Kind.DOUBLE, Kind.CONST_ARRAY, Kind.ARRAY

_OPTIONS_ADAPTIVE = (
    Field("rtol", Kind.DOUBLE, "1e-3", "RK45 and DOP853 relative tolerance (default 1e-3)"),
    Field("atol", Kind.DOUBLE, "1e-6", "RK45 and DOP853 absolute tolerance (default 1e-6)"),
    Field(
        "hmax",
        Kind.DOUBLE,
        "0.0",
        "RK45 and DOP853 largest step; <= 0 means 0.1 * (final time) for RK45, the final time "
        "for DOP853 (as dop853.f)",
    ),
    Field(
        "control",
        Kind.INT,
        "CONTROL_MATLAB",
        "RK45's error control: CONTROL_MATLAB (default) or CONTROL_HAIRER (DOP853 has its own)",
    ),
)

_SPHERE = Interface(
    functions=(
        Function("default_params", Kind.VOID, (_p("p", _A),), "The spec's parameter values."),
        Function(
            "default_options", Kind.VOID, (_p("opt", Kind.OPTIONS_OUT),), "The default options."
        ),
        Function(
            "potential",
            Kind.DOUBLE,
            (_p("p", _CA), _p("q", _CA)),
            "Potential energy V(q).",
        ),
        Function(
            "gradient",
            Kind.VOID,
            (_p("p", _CA), _p("q", _CA), _p("g", _A)),
            "Gradient g = dV/dq (NSTATE values).",
        ),
        Function(
            "energy",
            Kind.DOUBLE,
            (_p("p", _CA), _p("q", _CA), _p("w", _CA)),
            "Total energy, kinetic plus potential.",
        ),
        Function(
            "angular_momentum",
            Kind.VOID,
            (_p("p", _CA), _p("q", _CA), _p("w", _CA), _p("J", Kind.VECTOR3)),
            "Angular momentum J = sum_i q_i x sum_j M_ij (omega_j x q_j).",
        ),
        Function(
            "rhs",
            Kind.INT,
            (_p("p", _CA), _p("q", _CA), _p("w", _CA), _p("dq", _A), _p("dw", _A), _p("work", _A)),
            "Continuous equations: qdot_i = omega_i x q_i and omegadot from A(q) omegadot = b.",
        ),
        Function(
            "vi_step",
            Kind.INT,
            (
                _p("p", _CA),
                _p("opt", Kind.OPTIONS, True),
                _p("h", _D),
                _p("q", _CA),
                _p("w", _CA),
                _p("qn", _A),
                _p("wn", _A),
                _p("work", _A),
                _p("iters", Kind.INT_OUT, True),
            ),
            "One variational-integrator step (q, w) -> (qn, wn), Newton started cold (step() "
            "carries its solution from step to step, as integrate() does); iters (may be NULL) "
            "receives the Newton iterations (0 for the explicit update). opt NULL means the "
            "defaults.",
        ),
        Function(
            "rk_step",
            Kind.INT,
            (
                _p("p", _CA),
                _p("method", Kind.INT),
                _p("h", _D),
                _p("q", _CA),
                _p("w", _CA),
                _p("qn", _A),
                _p("wn", _A),
                _p("work", _A),
            ),
            "One fixed step of a fixed-step Runge-Kutta method (method as in the enum).",
        ),
        Function(
            "initial_state",
            Kind.INT,
            (_p("q", _A), _p("w", _A)),
            "The spec's initial state (NSTATE doubles each, body-major), as s2gen holds it: "
            "q_i normalized and omega_i projected onto the tangent plane when the spec's values "
            "were unit only to their printed digits. Returns OK, or ERR_ARGUMENT (q and w "
            "untouched) when the spec gives no initial state or has more than "
            f"{INITIAL_STATE_MAX_BODIES} bodies (read such a state from a file).",
        ),
        Function(
            "step_start",
            Kind.INT,
            (_p("st", Kind.STEPPER), _p("method", Kind.INT), _p("t0", _D)),
            "Start a run of step() with `method`, any fixed-step method (METHOD_*: not RK45 or "
            "DOP853, whose steps are adaptive), at time t0: the next step starts Newton cold. "
            "Returns OK, or ERR_ARGUMENT for another method.",
        ),
        Function(
            "step",
            Kind.INT,
            (
                _p("p", _CA),
                _p("opt", Kind.OPTIONS, True),
                _p("st", Kind.STEPPER),
                _p("h", _D),
                _p("q", _CA),
                _p("w", _CA),
                _p("qn", _A),
                _p("wn", _A),
                _p("carry", _A),
                _p("work", _A),
                _p("iters", Kind.INT_OUT, True),
            ),
            "One step of size h of st->method, (q, w) -> (qn, wn), as integrate() takes it. "
            "carry: STEP_CARRY doubles of the caller's, kept between the steps of one run (not "
            "workspace: not shared with other calls); when (q, w) is the state the previous "
            "step of the run returned (equal bit for bit, as when stepping on from it), the "
            "step reuses its gradient, RATTLE's velocities and each substep's Newton solution "
            "as starting point, and a run of steps reproduces integrate() exactly, Newton "
            "iterations included; from any other state it starts afresh. On OK, st->t advances "
            "by h and st->steps by 1. iters (may be NULL) receives the Newton iterations of "
            "all substeps. opt NULL means the defaults.",
        ),
        Function(
            "integrate",
            Kind.INT,
            (
                _p("p", _CA),
                _p("opt", Kind.OPTIONS, True),
                _p("method", Kind.INT),
                _p("h", _D),
                _p("nsteps", Kind.LONG),
                _p("q0", _CA),
                _p("w0", _CA),
                _p("q", _A),
                _p("w", _A),
                _p("energy", _A, True),
                _p("work", _A),
                _p("stats", Kind.STATS, True),
            ),
            "Integrate nsteps steps of size h (RK45 and DOP853: output spacing h, adaptive steps "
            "inside) from (q0, w0) with `method` (METHOD_*). The trajectory keeps every opt->every-th "
            "sample, the initial state first: q and w hold (nsteps / every + 1) * NSTATE "
            "doubles, energy (nsteps / every + 1) doubles (not evaluated at all when energy is "
            "NULL). opt NULL means the defaults of default_options(); stats may be NULL. "
            "Returns OK or a status code: ERR_ARGUMENT for h <= 0, nsteps < 0, an every that "
            "does not divide nsteps, an unknown method, or a q0_i that is not a unit vector "
            "(stats->fail_body names it); on a failed step the samples before "
            "stats->fail_step are valid.",
        ),
    ),
    options=(
        *_OPTIONS_ADAPTIVE,
        Field(
            "every",
            Kind.LONG,
            "1",
            "output stride: integrate() stores every `every`-th sample (default 1; nsteps must "
            "be a multiple of it)",
        ),
        Field(
            "newton_tol",
            Kind.DOUBLE,
            "1e-14",
            "Newton stops when max|delta f|, or the next update predicted by quadratic "
            "convergence, is <= tol * max(1, max|f|) (1e-14)",
        ),
        Field("newton_maxiter", Kind.INT, "50", "Newton iteration limit per step (50)"),
        Field(
            "unit_tol",
            Kind.DOUBLE,
            "1e-12",
            "integrate() refuses (ERR_ARGUMENT, stats->fail_body) a q0_i with | |q0_i| - 1 | "
            "above this (default 1e-12; <= 0: no check)",
        ),
        Field(
            "max_steps",
            Kind.LONG,
            "100000",
            "RK45 and DOP853 step budget: a run stops with ERR_STEPSIZE when it attempts more "
            "than this many steps (accepted plus rejected) between two points of the output "
            "grid t = k h (default 100000; <= 0: no limit)",
        ),
    ),
    stats=(
        Field("steps", Kind.LONG, "0", "accepted steps"),
        Field("rejected", Kind.LONG, "0", "rejected steps (RK45, DOP853)"),
        Field("gradient_evals", Kind.LONG, "0", "evaluations of dV/dq"),
        Field("newton_iters", Kind.LONG, "0", "Newton iterations, total"),
        Field("newton_max", Kind.LONG, "0", "Newton iterations, largest in one step"),
        Field(
            "fail_step",
            Kind.LONG,
            "0",
            "on failure: first sample index not computed (samples before it are valid)",
        ),
        Field(
            "fail_time",
            Kind.DOUBLE,
            "0.0",
            "RK45, DOP853: time of the last accepted step (where a failure happened)",
        ),
        Field(
            "fail_body",
            Kind.LONG,
            "-1",
            "ERR_ARGUMENT: the body (0-based) whose q0 is not a unit vector (else -1)",
        ),
    ),
    stepper=(
        Field("t", Kind.DOUBLE, "0.0", "time of the state the last step returned (t0 + the h's)"),
        Field("steps", Kind.LONG, "0", "steps taken since step_start()"),
        Field("method", Kind.INT, "0", "METHOD_* of the steps (set by step_start())"),
    ),
)


_DRIVEN_STEP = Function(
    "step",
    Kind.INT,
    (
        _p("p", _CA),
        _p("opt", Kind.OPTIONS, True),
        _p("method", Kind.INT),
        _p("t", _D),
        _p("h", _D),
        _p("u", _CA, True),
        _p("q", _CA),
        _p("w", _CA),
        _p("qn", _A),
        _p("wn", _A),
        _p("W", _A, True),
        _p("work", _A),
        _p("iters", Kind.INT_OUT, True),
    ),
    "One step of size h of a driven method (METHOD_*: the VI and RATTLE families, the "
    "Runge-Kutta methods; RK45 and DOP853 cover the step in adaptive steps under opt's "
    "tolerances, the first one estimated afresh) from (q, w) at time t to (qn, wn) at t + h, the inputs u (NINPUTS doubles, in "
    "the order of input_names; NULL: their defaults) held over the step (zero-order hold: "
    "every evaluation inside the step, at its end too, reads u). W (may be NULL) receives the "
    "work done on the system during the step: (h/2)(P + P+) per VI substep, the method's own "
    "quadrature of P for Runge-Kutta, P = dV/dt + sum_i F_i . qdot_i. Newton starts cold; "
    "iters (may be NULL) receives its iterations (those of the velocity equations of "
    "velocity-dependent forces included). Returns OK or a status: ERR_ARGUMENT for h <= 0 or "
    "a method that is not driven (rk2-proj), ERR_NONFINITE for a non-finite input or state, the "
    "step's own failures as integrate() reports them.",
)

_DRIVEN_INTEGRATE = Function(
    "integrate",
    Kind.INT,
    (
        _p("p", _CA),
        _p("opt", Kind.OPTIONS, True),
        _p("method", Kind.INT),
        _p("t0", _D),
        _p("h", _D),
        _p("nsteps", Kind.LONG),
        _p("u", _CA, True),
        _p("feedback", Kind.FEEDBACK, True),
        _p("fctx", Kind.POINTER, True),
        _p("q0", _CA),
        _p("w0", _CA),
        _p("q", _A),
        _p("w", _A),
        _p("energy", _A, True),
        _p("W", _A, True),
        _p("work", _A),
        _p("stats", Kind.STATS, True),
    ),
    "Integrate nsteps steps of size h (the VI and RATTLE families, the Runge-Kutta methods; "
    "RK45 and DOP853 cover each in adaptive steps, the step size carried from one to the next) from "
    "(q0, w0) at time t0 with `method` (METHOD_*), step k running from t0 + k h to "
    "t0 + (k + 1) h with the inputs u_k held over it: from `feedback`, when not NULL, called "
    "once per step as feedback(fctx, t_k, q_k, w_k, u_k) to write the NINPUTS inputs from the "
    "state at t_k (state feedback); else u + k * NINPUTS (u: nsteps * NINPUTS doubles; NULL: "
    "the defaults throughout). The trajectory keeps every opt->every-th "
    "sample, the initial state first: q and w hold (nsteps / every + 1) * NSTATE doubles; "
    "energy (may be NULL) the energy E(q_k, w_k, t_k) with the inputs of the step that ended "
    "at t_k (the step's own at t0); W (may be NULL) the work done since t0, including the "
    "jumps of V where a held input changes, so that E_k - E_0 - W_k is the energy-balance "
    "error. opt NULL means the defaults of default_options(); stats may be NULL. Returns OK "
    "or a status code: ERR_ARGUMENT for h <= 0, nsteps < 0, an every that does not divide "
    "nsteps, a method that is not driven (rk2-proj), or a q0_i that is not a unit vector "
    "(stats->fail_body names it); ERR_NONFINITE for a non-finite input (stats->fail_step: "
    "the samples before it are valid) or state; on a failed step the samples before "
    "stats->fail_step are valid.",
)

_DRIVEN_FIELD = Function(
    "field_at",
    Kind.INT,
    (
        _p("p", _CA),
        _p("t", _D),
        _p("u", _CA, True),
        _p("q", _CA),
        _p("w", _CA),
        _p("dq", _A),
        _p("dw", _A),
        _p("work", _A),
    ),
    "The driven continuous equations at time t with the inputs u (NINPUTS doubles; NULL: the "
    "defaults): qdot_i = omega_i x q_i and A(q) omegadot = b + q x F, the forces included "
    "(for a solver of the caller's). Returns OK or a status (ERR_NONFINITE for a non-finite "
    "input).",
)

_DRIVEN_ENERGY = Function(
    "energy_at",
    Kind.DOUBLE,
    (_p("p", _CA), _p("t", _D), _p("u", _CA, True), _p("q", _CA), _p("w", _CA)),
    "Total energy, kinetic plus V(q, t, u), at time t with the inputs u (NULL: the defaults).",
)

#: What a driven module (forces, inputs or time) replaces: step() takes the time and the
#: inputs and integrate() the start time, the inputs and the work; vi_step, rk_step and
#: step_start (whose steps know no time) are absent.
_DRIVEN_DROPS = ("vi_step", "rk_step", "step_start")
_DRIVEN = Interface(
    functions=(
        *(
            {"step": _DRIVEN_STEP, "integrate": _DRIVEN_INTEGRATE}.get(f.name, f)
            for f in _SPHERE.functions
            if f.name not in _DRIVEN_DROPS
        ),
        _DRIVEN_FIELD,
        _DRIVEN_ENERGY,
    ),
    options=_SPHERE.options,
    stats=_SPHERE.stats,
    stepper=(),
)


def interface(
    kind: ModuleKind,
    driven: bool = False,
    jacobian: bool = False,
    batch: bool = False,
    jvp: bool = False,
) -> Interface:
    """The interface of one kind of module (the angle form's in `s2gen.interface_angles`);
    `driven`: a sphere module with forces, inputs or time; `jacobian`: one with
    step_jacobian() and field_jacobian() (`s2gen.interface_jacobian`); `batch`: one with
    integrate_batch() (`s2gen.interface_batch`); `jvp`: one with step_jvp()
    (`s2gen.interface_jvp`).

    Example:
        >>> [p.name for p in interface(ModuleKind.SPHERE, driven=True).function("step").params][:6]
        ['p', 'opt', 'method', 't', 'h', 'u']
    """
    if kind is ModuleKind.SPHERE:
        api = _DRIVEN if driven else _SPHERE
        if not (jacobian or batch or jvp):
            return api
        from s2gen.interface_batch import INTEGRATE_BATCH, INTEGRATE_BATCH_DRIVEN
        from s2gen.interface_jacobian import JACOBIAN_FUNCTIONS
        from s2gen.interface_jvp import STEP_JVP

        batch_fn = INTEGRATE_BATCH_DRIVEN if driven else INTEGRATE_BATCH
        extra = (*(JACOBIAN_FUNCTIONS if jacobian else ()), *((batch_fn,) if batch else ()))
        extra += (STEP_JVP,) if jvp else ()
        return Interface((*api.functions, *extra), api.options, api.stats, api.stepper)
    from s2gen.interface_angles import ANGLES

    return ANGLES
