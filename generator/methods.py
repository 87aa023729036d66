"""The one table of integration methods and the one table of status codes.

Input: nothing. Output: `METHODS` (each method once: name, code in the emitted enums, order,
gradient evaluations per step, whether it is implicit, its family, the backends that have it)
and `Status` (the codes every backend returns, with one message each). The spec validator, the
command line's choices, the emitted C and NumPy enums, the runtime's messages and the README's
method table all read these tables; nothing else lists methods or statuses.

Example:
    >>> method("vi4").order, method("vi4").backends
    (4, ('c', 'numpy'))
    >>> Status.NEWTON.c_name, int(Status.NEWTON)
    ('ERR_NEWTON', 2)
    >>> check_method("vi4", "reference")
    Traceback (most recent call last):
    ...
    ValueError: method 'vi4' is not available on the reference backend; backends that have it: c, numpy
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = [
    "BACKENDS",
    "CONTROLS",
    "LANGUAGES",
    "METHODS",
    "NAMES",
    "Family",
    "Method",
    "Status",
    "check_method",
    "markdown_table",
    "method",
]

#: Backends that integrate: the emitted C (ctypes), the emitted NumPy module, the reference.
BACKENDS = ("c", "numpy", "reference")
#: RK45 error controls, in the order of the emitted CONTROL enum.
CONTROLS = ("matlab", "hairer")
#: Languages the generator emits.
LANGUAGES = ("c", "numpy")


class Family(enum.Enum):
    """How a method advances: the VI family (Cayley update, explicit or Newton), RATTLE
    (Cartesian positions with multipliers), fixed-step Runge-Kutta, adaptive Runge-Kutta."""

    VI = "vi"
    RATTLE = "rattle"
    FIXED_RK = "fixed-step Runge-Kutta"
    ADAPTIVE_RK = "adaptive Runge-Kutta"


class Status(enum.IntEnum):
    """Status codes of every backend (the emitted enums are generated from this table)."""

    OK = 0
    INFEASIBLE = 1
    NEWTON = 2
    NONFINITE = 3
    ARGUMENT = 4
    STEPSIZE = 5
    SINGULAR = 6
    POLE = 7

    @property
    def c_name(self) -> str:
        """The suffix of the emitted C enum constant (NAME_ERR_NEWTON, NAME_OK, ...)."""
        return "OK" if self is Status.OK else f"ERR_{self.name}"

    @property
    def message(self) -> str:
        """One line saying what happened and what to do about it."""
        return _MESSAGES[self]


_MESSAGES = {
    Status.OK: "success",
    Status.INFEASIBLE: "explicit step infeasible (|a_i| > 1 for some body): reduce the step size",
    Status.NEWTON: "Newton's method did not converge in an implicit step: reduce the step size "
    "or raise the iteration limit",
    Status.NONFINITE: "the state or its gradient became non-finite",
    Status.ARGUMENT: "invalid argument",
    Status.STEPSIZE: "the adaptive step size fell below its minimum",
    Status.SINGULAR: "a linear system of the inertia was singular (the inertia is not positive "
    "definite at this state)",
    Status.POLE: "a body is at a pole of the angle chart",
}


@dataclass(frozen=True)
class Method:
    """One integration method.

    `code` is its value in the emitted METHOD enums; `evals` the gradient evaluations per step
    (0 when adaptive); `implicit` means an iteration (Newton) runs when M is coupled;
    `substeps` are the step fractions of a symmetric composition (empty for a plain method).
    """

    name: str
    code: int
    order: int
    evals: int
    implicit: bool
    family: Family
    backends: tuple[str, ...]
    summary: str
    substeps: tuple[float, ...] = ()

    @property
    def c_name(self) -> str:
        """The suffix of the emitted C enum constant (NAME_METHOD_VI4, ...)."""
        return "METHOD_" + self.name.upper().replace("-", "_")

    @property
    def geometric(self) -> bool:
        """True for the structure-preserving methods (VI family and RATTLE)."""
        return self.family in (Family.VI, Family.RATTLE)


def _triple_jump() -> tuple[float, float, float]:
    """Yoshida's triple jump: g1 = 1/(2 - 2^(1/3)), g2 = 1 - 2 g1 (the steps add up to h)."""
    g1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
    return g1, 1.0 - 2.0 * g1, g1


_ALL = ("c", "numpy", "reference")
_EMITTED = ("c", "numpy")

#: Every method, in the order of their codes.
METHODS: tuple[Method, ...] = (
    Method("vi", 0, 2, 1, True, Family.VI, _ALL, "the paper's variational integrator"),
    Method(
        "rk45",
        1,
        5,
        0,
        False,
        Family.ADAPTIVE_RK,
        _ALL,
        "Dormand-Prince 5(4), adaptive, output on the grid by its 4th-order interpolant",
    ),
    Method("rk2", 2, 2, 2, False, Family.FIXED_RK, _ALL, "explicit midpoint rule"),
    Method(
        "rk2-proj",
        3,
        2,
        2,
        False,
        Family.FIXED_RK,
        _ALL,
        "explicit midpoint rule, q_i normalized after each step",
    ),
    Method("rk4", 4, 4, 4, False, Family.FIXED_RK, _ALL, "classical Runge-Kutta"),
    Method(
        "vi4",
        5,
        4,
        3,
        True,
        Family.VI,
        _EMITTED,
        "the VI composed by Yoshida's triple jump",
        _triple_jump(),
    ),
    Method(
        "rattle",
        6,
        2,
        1,
        True,
        Family.RATTLE,
        _EMITTED,
        "RATTLE on Cartesian q_i with the constraints |q_i| = 1",
    ),
)

#: Method names, in code order.
NAMES: tuple[str, ...] = tuple(m.name for m in METHODS)

_BY_NAME = {m.name: m for m in METHODS}


def method(name: str) -> Method:
    """The method called `name` (ValueError listing the methods otherwise).

    Example:
        >>> method("rk4").evals
        4
    """
    found = _BY_NAME.get(name)
    if found is None:
        raise ValueError(f"unknown method {name!r}; methods are: {', '.join(NAMES)}")
    return found


def check_method(name: str, backend: str) -> Method:
    """The method `name` if `backend` has it; else a ValueError naming the backends that do.

    Example:
        >>> check_method("rk4", "reference").name
        'rk4'
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; backends are: {', '.join(BACKENDS)}")
    m = method(name)
    if backend not in m.backends:
        raise ValueError(
            f"method {name!r} is not available on the {backend} backend; backends that have "
            f"it: {', '.join(m.backends)}"
        )
    return m


def markdown_table() -> str:
    """The README's method table (a test keeps the README equal to it).

    Example:
        >>> markdown_table().splitlines()[0]
        '| method | order | gradients per step | implicit when M is coupled | backends | what it is |'
    """
    rows = [
        "| method | order | gradients per step | implicit when M is coupled | backends | what it is |",
        "|---|---|---|---|---|---|",
    ]
    for m in METHODS:
        evals = "adaptive" if m.evals == 0 else str(m.evals)
        rows.append(
            f"| `{m.name}` | {m.order} | {evals} | {'yes' if m.implicit else 'no'} | "
            f"{', '.join(m.backends)} | {m.summary} |"
        )
    return "\n".join(rows)
