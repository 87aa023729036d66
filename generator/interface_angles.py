"""The public interface of the angle-form modules (`s2gen.interface` holds the records and the
(S^2)^n modules' interface): conversions to and from (q, omega), the field in angles, a
classical RK4 step and an integrate() with RK4 and RK45.

Example:
    >>> [f.name for f in ANGLES.functions][:3]
    ['default_params', 'default_options', 'to_angles']
"""

from __future__ import annotations

from s2gen.interface import Field, Function, Interface, Kind, Param

__all__ = ["ANGLES"]

_D, _CA, _A = Kind.DOUBLE, Kind.CONST_ARRAY, Kind.ARRAY


def _p(name: str, kind: Kind, nullable: bool = False) -> Param:
    return Param(name, kind, nullable)


_OPTIONS_RK45 = (
    Field("rtol", Kind.DOUBLE, "1e-3", "RK45 relative tolerance (default 1e-3)"),
    Field("atol", Kind.DOUBLE, "1e-6", "RK45 absolute tolerance (default 1e-6)"),
    Field("hmax", Kind.DOUBLE, "0.0", "RK45 largest step; <= 0 means 0.1 * (final time)"),
    Field("control", Kind.INT, "CONTROL_MATLAB", "CONTROL_MATLAB (default) or CONTROL_HAIRER"),
    Field(
        "max_steps",
        Kind.LONG,
        "100000",
        "RK45 step budget: ERR_STEPSIZE after more than this many attempted steps between two "
        "output points (default 100000; <= 0: no limit)",
    ),
)

ANGLES = Interface(
    functions=(
        Function("default_params", Kind.VOID, (_p("p", _A),), "The spec's parameter values."),
        Function(
            "default_options", Kind.VOID, (_p("opt", Kind.OPTIONS_OUT),), "The default options."
        ),
        Function(
            "to_angles",
            Kind.INT,
            (_p("q", _CA), _p("w", _CA), _p("x", _A), _p("xd", _A), _p("body", Kind.INT_OUT, True)),
            "Angles and rates of a state given as q, w (NBODIES 3-vectors each, body-major), "
            "theta in [0, pi]. Returns ERR_POLE (and the 0-based body in *body, if body is not "
            "NULL) when some sin theta_i < POLE_TOL.",
        ),
        Function(
            "to_sphere",
            Kind.VOID,
            (_p("count", Kind.LONG), _p("x", _CA), _p("xd", _CA), _p("q", _A), _p("w", _A)),
            "q and omega = q x qdot of `count` angle states (x, xd: count * NX doubles each; "
            "q, w: count * 3 * NBODIES).",
        ),
        Function(
            "energy",
            Kind.DOUBLE,
            (_p("p", _CA), _p("x", _CA), _p("xd", _CA)),
            "Total energy T + V in angles.",
        ),
        Function(
            "rhs",
            Kind.INT,
            (_p("p", _CA), _p("x", _CA), _p("xd", _CA), _p("xdd", _A), _p("work", _A)),
            "Accelerations xdd from M(x) xdd = F(x, xd) (LU with partial pivoting).",
        ),
        Function(
            "rk4_step",
            Kind.INT,
            (
                _p("p", _CA),
                _p("h", _D),
                _p("x", _CA),
                _p("xd", _CA),
                _p("xn", _A),
                _p("xdn", _A),
                _p("work", _A),
            ),
            "One classical Runge-Kutta step of size h. If a field evaluation fails, xn and "
            "xdn receive the stage state where it failed.",
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
                _p("x0", _CA),
                _p("xd0", _CA),
                _p("x", _A),
                _p("xd", _A),
                _p("energy", _A, True),
                _p("counts", Kind.LONG_ARRAY, True),
                _p("work", _A),
                _p("stats", Kind.STATS, True),
            ),
            "Integrate nsteps steps of size h (RK45: output spacing h, adaptive steps inside) "
            "from (x0, xd0).",
        ),
    ),
    options=_OPTIONS_RK45,
    stats=(
        Field("steps", Kind.LONG, "0", "accepted steps"),
        Field("rejected", Kind.LONG, "0", "RK45 rejected steps"),
        Field("rhs_evals", Kind.LONG, "0", "evaluations of the vector field"),
        Field("fail_step", Kind.LONG, "0", "on failure: first sample index not computed"),
        Field(
            "fail_body",
            Kind.LONG,
            "-1",
            "on failure: the body (0-based) with the smallest |sin theta| in the state where "
            "the field failed (else in the last accepted state)",
        ),
        Field(
            "fail_time",
            Kind.DOUBLE,
            "0.0",
            "on failure: time of the last accepted state (start of the failed step)",
        ),
        Field("fail_sin", Kind.DOUBLE, "0.0", "on failure: that body's |sin theta|"),
    ),
)
