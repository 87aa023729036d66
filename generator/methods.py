"""The one table of integration methods and the one table of status codes.

Input: nothing. Output: `METHODS` (each method once: name, code in the emitted enums, order,
gradient evaluations per step, whether it is implicit, its family, the backends and the module
kinds that have it, the driver that runs it, its tableau (fixed-step Runge-Kutta) or
composition (geometric methods) and its error controls) and `Status` (the codes every backend returns, with one message each). The spec validator, the
command line's choices, the emitted C and NumPy enums and dispatch tables, the angle form's
methods, the reference's method list, the runtime's messages and the documentation's method table all
read these tables; nothing else lists methods or statuses. A fixed-step explicit method is one
tableau in s2gen.tableaus and one `_fixed` row here.

Example:
    >>> method("vi4").order, method("vi4").backends
    (4, ('c', 'numpy'))
    >>> method("rk4").driver.value, method("rk4").evals, method("rk4").kinds
    ('fixed', 4, ('sphere', 'angles'))
    >>> Status.NEWTON.c_name, int(Status.NEWTON)
    ('ERR_NEWTON', 2)
    >>> check_method("vi4", "reference")
    Traceback (most recent call last):
    ...
    ValueError: method 'vi4' is not available on the reference backend; backends that have it: c, numpy
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from s2gen.tableaus import RK2, RK3, RK4, Explicit

__all__ = [
    "ANGLE_METHODS",
    "BACKENDS",
    "COMPOSITIONS",
    "CONTROLS",
    "DRIVEN_ADAPTIVE",
    "DRIVEN_FAMILIES",
    "KAHAN_LI8",
    "KINDS",
    "LANGUAGES",
    "METHODS",
    "NAMES",
    "PLAIN",
    "REFERENCE_METHODS",
    "TRIPLE_JUMP",
    "YOSHIDA6",
    "Composition",
    "Driver",
    "Family",
    "Method",
    "Status",
    "check_method",
    "driven_methods",
    "explicit_tableaus",
    "fixed_methods",
    "markdown_table",
    "method",
]

#: Backends that integrate: the emitted C (ctypes), the emitted NumPy module, the reference.
BACKENDS = ("c", "numpy", "reference")
#: RK45 error controls, in the order of the emitted CONTROL enum.
CONTROLS = ("matlab", "hairer")
#: Languages the generator emits.
LANGUAGES = ("c", "numpy")
#: Kinds of emitted module: the values of s2gen.ir.ModuleKind (not imported here, so that the
#: command line starts without SymPy; tests/test_tableaus.py checks they are the same).
KINDS = ("sphere", "angles")


class Driver(enum.Enum):
    """The emitted driver that runs a method: compositions of VI or RATTLE steps,
    Dormand-Prince 5(4), DOP853, or fixed steps of an explicit tableau."""

    GEOMETRIC = "geometric"
    RK45 = "rk45"
    DOP853 = "dop853"
    FIXED = "fixed"
    TIME_TRANSFORMED = "time-transformed"


class Family(enum.Enum):
    """How a method advances: the VI family (Cayley update, explicit or Newton), RATTLE
    (Cartesian positions with multipliers), fixed-step Runge-Kutta, adaptive Runge-Kutta."""

    VI = "vi"
    RATTLE = "rattle"
    FIXED_RK = "fixed-step Runge-Kutta"
    ADAPTIVE_RK = "adaptive Runge-Kutta"
    TIME_VI = "time-transformed VI"
    TIME_RATTLE = "time-transformed RATTLE"


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
    Status.STEPSIZE: "the adaptive step size fell below its minimum, or the run needed more "
    "than max_steps steps between samples (a time-transformed method: its step-size variable "
    "has no valid value)",
    Status.SINGULAR: "a linear system of the inertia was singular (the inertia is not positive "
    "definite at this state)",
    Status.POLE: "a body is at a pole of the angle chart",
}


@dataclass(frozen=True)
class Composition:
    """A symmetric composition: one step of size h is `len(fractions)` steps of the basic
    (second-order, symmetric) method of sizes gamma_k h, sum gamma_k = 1, gamma_k = gamma_{s+1-k}.

    `name` is a C identifier suffix, `order` the order of the composed method, `source` where the
    coefficients come from.
    """

    name: str
    order: int
    source: str
    fractions: tuple[float, ...]


def _symmetric(outer: tuple[float, ...]) -> tuple[float, ...]:
    """The palindrome outer + (middle,) + reversed(outer), the middle making the sum 1."""
    middle = 1.0 - 2.0 * math.fsum(outer)
    return (*outer, middle, *reversed(outer))


def _triple_jump() -> tuple[float, float, float]:
    """Yoshida's triple jump: g1 = 1/(2 - 2^(1/3)), g2 = 1 - 2 g1 (the steps add up to h)."""
    g1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
    return g1, 1.0 - 2.0 * g1, g1


#: The basic step itself.
PLAIN = Composition("plain", 2, "the basic step alone", (1.0,))
#: H. Yoshida, Construction of higher order symplectic integrators, Phys. Lett. A 150 (1990)
#: 262-268: the triple jump, order 4.
TRIPLE_JUMP = Composition(
    "triple_jump", 4, "Yoshida (1990), Phys. Lett. A 150, 262, the triple jump", _triple_jump()
)
#: Yoshida (1990), order 6, solution A (m = 3): w3, w2, w1, w0, w1, w2, w3. The paper prints 15
#: digits; these are the root of the order conditions near them to 25 digits (Newton's method
#: from the printed values in 40-digit arithmetic; tests/test_compositions.py solves the order
#: conditions again from the printed values and checks the defects).
YOSHIDA6 = Composition(
    "yoshida6",
    6,
    "Yoshida (1990), Phys. Lett. A 150, 262, order 6, solution A",
    _symmetric(
        (0.7845136104775572638194976, 0.2355732133593581336847932, -1.177679984178871006946416)
    ),
)
#: W. Kahan and R.-C. Li, Composition constants for raising the orders of unconventional
#: schemes for ordinary differential equations, Math. Comp. 66 (1997) 1089-1099, the
#: 15-stage order-8 scheme s15odr8 (its seven outer constants, 26 digits as printed; the
#: middle one makes the sum 1).
KAHAN_LI8 = Composition(
    "kahan_li8",
    8,
    "Kahan and Li (1997), Math. Comp. 66, 1089, s15odr8",
    _symmetric(
        (
            0.74167036435061295344822780,
            -0.40910082580003159399730010,
            0.19075471029623837995387626,
            -0.57386247111608226665638773,
            0.29906418130365592384446354,
            0.33462491824529818378495798,
            0.31529309239676659663205666,
        )
    ),
)
#: Every composition, in the order their tables are emitted.
COMPOSITIONS: tuple[Composition, ...] = (PLAIN, TRIPLE_JUMP, YOSHIDA6, KAHAN_LI8)


@dataclass(frozen=True)
class Method:
    """One integration method.

    `code` is its value in the emitted METHOD enums; `evals` the gradient evaluations per step
    (0 when adaptive); `implicit` means an iteration (Newton) runs when M is coupled;
    `composition` the symmetric composition of the basic VI or RATTLE step that makes one step
    (geometric methods only); `driver` the emitted driver that runs it;
    `tableau` the explicit tableau of a fixed-step method, `project` whether each q_i is
    normalized after its step; `controls` the error controls an adaptive method offers (the
    options' `control`; empty: its own); `kinds` the module kinds that have it.
    """

    name: str
    code: int
    order: int
    evals: int
    implicit: bool
    family: Family
    backends: tuple[str, ...]
    summary: str
    composition: Composition | None = None
    driver: Driver = Driver.GEOMETRIC
    tableau: Explicit | None = None
    project: bool = False
    controls: tuple[str, ...] = ()
    kinds: tuple[str, ...] = ("sphere",)
    transformed: Composition | None = None

    def __post_init__(self) -> None:
        if not set(self.kinds) <= set(KINDS):
            raise ValueError(f"method {self.name!r}: module kinds are {', '.join(KINDS)}")
        if (self.driver is Driver.FIXED) != (self.tableau is not None):
            raise ValueError(f"method {self.name!r}: a fixed-step method has a tableau")

    @property
    def c_name(self) -> str:
        """The suffix of the emitted C enum constant (NAME_METHOD_VI4, ...)."""
        return "METHOD_" + self.name.upper().replace("-", "_")

    @property
    def geometric(self) -> bool:
        """True for the structure-preserving methods (VI family, RATTLE, time-transformed VI and
        RATTLE)."""
        return self.family in (Family.VI, Family.RATTLE, Family.TIME_VI, Family.TIME_RATTLE)

    @property
    def adaptive(self) -> bool:
        """True for the adaptive Runge-Kutta methods (h is the output spacing)."""
        return self.family is Family.ADAPTIVE_RK

    @property
    def substeps(self) -> tuple[float, ...]:
        """Step fractions of the composition (empty for a plain or non-geometric method)."""
        c = self.composition
        return () if c is None or c is PLAIN else c.fractions


_ALL = ("c", "numpy", "reference")
_EMITTED = ("c", "numpy")


def _fixed(
    name: str,
    code: int,
    tableau: Explicit,
    summary: str = "",
    project: bool = False,
    kinds: tuple[str, ...] = ("sphere",),
) -> Method:
    """A fixed-step method: steps of `tableau` (one evaluation per stage), on every backend."""
    return Method(
        name,
        code,
        tableau.order,
        tableau.stages,
        False,
        Family.FIXED_RK,
        _ALL,
        summary or tableau.title,
        driver=Driver.FIXED,
        tableau=tableau,
        project=project,
        kinds=kinds,
    )


def _geometric(name: str, code: int, family: Family, comp: Composition, summary: str) -> Method:
    backends = _ALL if comp is PLAIN and family is Family.VI else _EMITTED
    return Method(
        name, code, comp.order, len(comp.fractions), True, family, backends, summary, comp
    )


def _transformed(
    name: str,
    code: int,
    comp: Composition,
    summary: str,
    family: Family = Family.TIME_VI,
    backends: tuple[str, ...] = _ALL,
) -> Method:
    """A time-transformed VI (or, with `family` TIME_RATTLE, RATTLE): steps of `comp` of sizes
    eps / xi in time (h is eps); on `backends` (every S^2 module's enum has it, the modules
    with a monitor, `s2gen.monitor`, run it)."""
    return Method(
        name,
        code,
        comp.order,
        len(comp.fractions),
        True,
        family,
        backends,
        summary,
        driver=Driver.TIME_TRANSFORMED,
        transformed=comp,
    )


#: Every method, in the order of their codes.
METHODS: tuple[Method, ...] = (
    _geometric("vi", 0, Family.VI, PLAIN, "the paper's variational integrator"),
    Method(
        "rk45",
        1,
        5,
        0,
        False,
        Family.ADAPTIVE_RK,
        _ALL,
        "Dormand-Prince 5(4), adaptive, output on the grid by its 4th-order interpolant",
        driver=Driver.RK45,
        controls=CONTROLS,
        kinds=KINDS,
    ),
    _fixed("rk2", 2, RK2),
    _fixed("rk2-proj", 3, RK2, "explicit midpoint rule, q_i normalized after each step", True),
    _fixed("rk4", 4, RK4, kinds=KINDS),
    _geometric("vi4", 5, Family.VI, TRIPLE_JUMP, "the VI composed by Yoshida's triple jump"),
    _geometric(
        "rattle", 6, Family.RATTLE, PLAIN, "RATTLE on Cartesian q_i with the constraints |q_i| = 1"
    ),
    _geometric("vi6", 7, Family.VI, YOSHIDA6, "the VI composed by Yoshida's 7-stage solution A"),
    _geometric("vi8", 8, Family.VI, KAHAN_LI8, "the VI composed by Kahan and Li's 15 stages"),
    _geometric("rattle4", 9, Family.RATTLE, TRIPLE_JUMP, "RATTLE composed by the triple jump"),
    _geometric("rattle6", 10, Family.RATTLE, YOSHIDA6, "RATTLE composed by Yoshida's solution A"),
    _geometric(
        "rattle8", 11, Family.RATTLE, KAHAN_LI8, "RATTLE composed by Kahan and Li's 15 stages"
    ),
    Method(
        "dop853",
        12,
        8,
        0,
        False,
        Family.ADAPTIVE_RK,
        _EMITTED,
        "Dormand-Prince 8(5,3) (Hairer's DOP853), adaptive, output on the grid by its 7th-order "
        "continuous extension",
        driver=Driver.DOP853,
    ),
    _fixed("rk3", 13, RK3),
    _transformed(
        "vi-adaptive",
        14,
        PLAIN,
        "the VI in a fictitious time s, dt = ds / xi, xi tracking the pair monitor reversibly; "
        "h is the step in s",
    ),
    _transformed("vi4-adaptive", 15, TRIPLE_JUMP, "vi-adaptive composed by the triple jump"),
    _transformed("vi6-adaptive", 16, YOSHIDA6, "vi-adaptive composed by Yoshida's solution A"),
    _transformed("vi8-adaptive", 17, KAHAN_LI8, "vi-adaptive composed by Kahan and Li's 15 stages"),
    *(
        _transformed(f"rattle{tag}-adaptive", code, comp, summary, Family.TIME_RATTLE)
        for tag, code, comp, summary in (
            ("", 18, PLAIN, "vi-adaptive with the RATTLE step (Cartesian q_i, multipliers)"),
            ("4", 19, TRIPLE_JUMP, "rattle-adaptive composed by the triple jump"),
            ("6", 20, YOSHIDA6, "rattle-adaptive composed by Yoshida's solution A"),
            ("8", 21, KAHAN_LI8, "rattle-adaptive composed by Kahan and Li's 15 stages"),
        )
    ),
)

#: Method names, in code order.
NAMES: tuple[str, ...] = tuple(m.name for m in METHODS)

_BY_NAME = {m.name: m for m in METHODS}

#: Methods of the emitted angle modules, with their codes (the codes of the S^2 module).
ANGLE_METHODS: dict[str, int] = {m.name: m.code for m in METHODS if "angles" in m.kinds}
#: Methods of the reference backend, in code order.
REFERENCE_METHODS: tuple[str, ...] = tuple(m.name for m in METHODS if "reference" in m.backends)


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


def fixed_methods(kind: str) -> tuple[Method, ...]:
    """The fixed-step Runge-Kutta methods of the module kind `kind`, in code order.

    Example:
        >>> [m.name for m in fixed_methods("angles")]
        ['rk4']
    """
    return tuple(m for m in METHODS if m.driver is Driver.FIXED and kind in m.kinds)


def explicit_tableaus(kind: str) -> tuple[Explicit, ...]:
    """The tableaus of `fixed_methods(kind)`, each once, in the order they are first used.

    Example:
        >>> [t.name for t in explicit_tableaus("sphere")][:2]  # rk2 and rk2-proj share one
        ['rk2', 'rk4']
    """
    found: dict[str, Explicit] = {}
    for m in fixed_methods(kind):
        assert m.tableau is not None
        found.setdefault(m.tableau.name, m.tableau)
    return tuple(found.values())


def markdown_table() -> str:
    """The method table of the documentation (docs/user_guide/methods.rst; a test keeps the page's
    table equal to it).

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
        summary = m.summary.replace("|", "\\|")  # a bar would end the cell
        rows.append(
            f"| `{m.name}` | {m.order} | {evals} | {'yes' if m.implicit else 'no'} | "
            f"{', '.join(m.backends)} | {summary} |"
        )
    return "\n".join(rows)


#: The method families a driven module integrates, and its adaptive methods.
DRIVEN_FAMILIES = (Family.VI, Family.RATTLE, Family.FIXED_RK)
DRIVEN_ADAPTIVE = ("rk45", "dop853")


def driven_methods(rattle: bool = True, adaptive: bool = True) -> tuple[str, ...]:
    """The methods of a driven module: the VI and RATTLE families, the unprojected explicit
    Runge-Kutta methods, RK45 and DOP853; without `rattle` (forces with a coupled M, whose
    RATTLE velocity projection is not the VI's) the RATTLE family is left out, without
    `adaptive` RK45 and DOP853.

    Example:
        >>> driven_methods(rattle=False, adaptive=False)
        ('vi', 'rk2', 'rk4', 'vi4', 'vi6', 'vi8', 'rk3')
    """
    return tuple(
        m.name
        for m in METHODS
        if (
            (m.family in DRIVEN_FAMILIES and not m.project)
            or (adaptive and m.name in DRIVEN_ADAPTIVE)
        )
        and (rattle or m.family is not Family.RATTLE)
    )
