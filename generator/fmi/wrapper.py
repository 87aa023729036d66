"""The C source of an FMU's wrapper: the FMI 2 or FMI 3 functions around the emitted C.

Input: an `FmuModel` and the emitted C files of its system. Output: {file name: C text},
rendered by the one jinja environment from `templates/fmu/` (the FMI version's top-level
template, the instance code: `_core.jinja` of a closed system or `_core_driven.jinja` of a
driven one, both with the shared checks `_checks.jinja`, and the advance partial of the
method's driver: fixed steps through the emitted `step()`, adaptive ones through
`integrate()`, a driven system's steps through its `integrate()` with the inputs held). Every
value a template lays out is printed here as C text (numbers by the C printer's
`double_literal`, strings as C string literals) and arrives in a frozen `WrapperSource`.

Example:
    >>> import s2gen
    >>> from s2gen.fmi.model import describe
    >>> model = describe(s2gen.load("double_pendulum"), fmi=2, kind="cs", method="vi")
    >>> files = wrapper_files(model)
    >>> sorted(files), "fmi2DoStep" in files["double_pendulum_fmi2.c"]
    (['double_pendulum_fmi2.c'], True)
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import sympy as sp

from s2gen.fmi.description import LOG_CATEGORY
from s2gen.fmi.model import Causality, FmuModel, Layout
from s2gen.methods import Status
from s2gen.methods import method as method_record
from s2gen.printing.c import c_string, double_literal
from s2gen.render import environment

__all__ = ["TANGENT_TOLERANCE", "InputDefault", "StatusText", "WrapperSource", "wrapper_files"]

#: A start value w_i is refused when |w_i . q_i| > this * (1 + |w_i|) (q_i must be a unit
#: vector to the options' unit_tol, as integrate() asks).
TANGENT_TOLERANCE = 1e-9

#: The top-level template of each FMI version.
_TEMPLATES = {2: "fmu/fmi2.c.jinja", 3: "fmu/fmi3.c.jinja"}
#: The partial that advances the state over a communication interval, by driver kind.
_ADVANCE = {False: "fmu/_advance_fixed.jinja", True: "fmu/_advance_adaptive.jinja"}
#: The instance code (state, variables, advance) of a closed and of a driven system.
_CORE = {False: "fmu/_core.jinja", True: "fmu/_core_driven.jinja"}
#: The advance partial of a driven system (its methods are all fixed-step).
_ADVANCE_DRIVEN = "fmu/_advance_driven.jinja"


#: FMI 3 variable types this FMU has none of (Float64 aside; Binary and Clock have their own
#: signatures).
_OTHER_TYPES = (
    "Float32", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64",
    "Boolean", "String",
)  # fmt: skip


@dataclass(frozen=True)
class StatusText:
    """One status code: its C constant and its message as a C string literal."""

    name: str
    message: str


@dataclass(frozen=True)
class InputDefault:
    """A driven system's input: its index in u and its start value as a C literal."""

    index: int
    literal: str


@dataclass(frozen=True)
class WrapperSource:
    """What the wrapper templates lay out (every value already C text or an integer)."""

    file: str
    header: str
    prefix: str
    macro: str
    spec_hash: str
    guid: str
    method: str
    method_enum: str
    core_part: str
    advance_part: str
    input_defaults: tuple[InputDefault, ...]
    step_size: str
    rtol: str
    atol: str
    tangent_tol: str
    log_category: str
    layout: Layout
    statuses: tuple[StatusText, ...]
    other_types: tuple[str, ...]
    co_simulation: int
    model_exchange: int


def _literal(value: float) -> str:
    fraction = Fraction(value)
    return double_literal(sp.Rational(fraction.numerator, fraction.denominator))


def source_record(model: FmuModel) -> WrapperSource:
    """The record the templates of `model`'s FMI version read."""
    macro = model.name.upper()
    record = method_record(model.method)
    return WrapperSource(
        file=f"{model.name}_fmi{model.fmi}.c",
        header=f"{model.name}.h",
        prefix=model.name,
        macro=macro,
        spec_hash=model.spec_hash,
        guid=model.guid,
        method=model.method,
        method_enum=f"{macro}_{record.c_name}",
        core_part=_CORE[model.driven],
        advance_part=_ADVANCE_DRIVEN if model.driven else _ADVANCE[model.adaptive],
        input_defaults=tuple(
            InputDefault(v.vr - model.layout.inputs, _literal(v.start))
            for v in model.variables
            if v.causality is Causality.INPUT and v.start is not None
        ),
        step_size=_literal(model.default_experiment.step_size),
        rtol=_literal(model.rtol),
        atol=_literal(model.atol),
        tangent_tol=_literal(TANGENT_TOLERANCE),
        log_category=LOG_CATEGORY,
        layout=model.layout,
        statuses=tuple(
            StatusText(f"{macro}_{s.c_name}", c_string(s.message))
            for s in Status
            if s is not Status.POLE  # the angle chart's status: not in the sphere module
        ),
        other_types=_OTHER_TYPES,
        co_simulation=int(model.co_simulation),
        model_exchange=int(model.model_exchange),
    )


def wrapper_files(model: FmuModel) -> dict[str, str]:
    """{file name: C text} of the wrapper of `model` (one file)."""
    f = source_record(model)
    return {f.file: environment().get_template(_TEMPLATES[model.fmi]).render(f=f)}
