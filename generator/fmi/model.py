"""What an FMU of a system declares: its variables, their value references, its experiment.

Input: a `System` and the export choices (FMI version, interface kinds, method, step size).
Output: an `FmuModel`, a frozen record that both the model description writer
(`s2gen.fmi.description`) and the wrapper source (`s2gen.fmi.wrapper`) read, so the value
references of the XML and of the C code come from one place.

Value references: 0 is time, then the parameters in the spec's order, the Co-Simulation
sub-step size, the state (q1_x .. qn_z, then w1_x .. wn_z, body-major as the emitted C), the
derivatives of the state (Model Exchange), the energy and J_x, J_y, J_z; a driven system
(forces, inputs or time t) then has the work done and its inputs in the spec's order.

Example:
    >>> import s2gen
    >>> model = describe(s2gen.load("double_pendulum"), fmi=2, kind="both", method="vi")
    >>> [v.name for v in model.variables][:4], model.layout.state
    (['time', 'm1', 'm2', 'l1'], 7)
    >>> model.variables[-1].name, model.default_experiment.step_size
    ('J_z', 0.01)
"""

from __future__ import annotations

import enum
import hashlib
import uuid
from dataclasses import dataclass

from s2gen.methods import Driver
from s2gen.methods import method as method_record
from s2gen.runtime.driven import check_driven_method
from s2gen.system import System

__all__ = [
    "FMI_VERSIONS",
    "KINDS",
    "Causality",
    "Experiment",
    "FmuModel",
    "Layout",
    "Variable",
    "describe",
]

#: FMI versions an FMU can follow.
FMI_VERSIONS = (2, 3)
#: Interface kinds: Co-Simulation, Model Exchange, or both in one FMU.
KINDS = ("cs", "me", "both")
_AXES = ("x", "y", "z")


class Causality(enum.Enum):
    """The FMI causality of a variable (the same words in FMI 2 and 3)."""

    INDEPENDENT = "independent"
    PARAMETER = "parameter"
    INPUT = "input"
    OUTPUT = "output"
    LOCAL = "local"


@dataclass(frozen=True)
class Variable:
    """One real variable. `start` is None for a calculated one; `derivative_of` is the value
    reference of the state a derivative belongs to (else None)."""

    name: str
    vr: int
    causality: Causality
    variability: str
    initial: str | None
    start: float | None
    description: str
    derivative_of: int | None = None


@dataclass(frozen=True)
class Layout:
    """First value reference of each group (contiguous; `end` is one past the last). A closed
    system has no work and no inputs: `work`, `inputs` and `end` are then equal."""

    time: int
    params: int
    step_size: int
    state: int
    derivatives: int
    energy: int
    momentum: int
    work: int
    inputs: int
    end: int


@dataclass(frozen=True)
class Experiment:
    """The default experiment, from the spec's [run] (stop time None when it has no T)."""

    start_time: float
    stop_time: float | None
    step_size: float


@dataclass(frozen=True)
class FmuModel:
    """Everything an FMU of `name` declares, for the XML writer and the wrapper source."""

    name: str
    fmi: int
    co_simulation: bool
    model_exchange: bool
    method: str
    adaptive: bool
    variables: tuple[Variable, ...]
    layout: Layout
    default_experiment: Experiment
    nstate: int
    spec_hash: str
    description: str
    #: the adaptive methods' tolerances in doStep: the spec's [run] rtol and atol, else the
    #: command line's defaults (as `s2gen simulate` takes them)
    rtol: float = 1e-3
    atol: float = 1e-6
    #: a driven system: the driven integrate() and field, inputs held, the work output
    driven: bool = False

    @property
    def guid(self) -> str:
        """The GUID (FMI 2) or instantiation token (FMI 3): a hash of what the FMU declares,
        so a binary and a model description of different exports never pair up."""
        h = hashlib.sha256(repr((self.spec_hash, self.fmi, self.method, self.variables)).encode())
        return "{" + str(uuid.UUID(bytes=h.digest()[:16])) + "}"


def _state_variables(system: System, first: int) -> list[Variable]:
    if system.q0 is None or system.omega0 is None:
        raise ValueError(
            f"{system.origin}: an FMU needs the spec's [initial] state (its start values)"
        )
    out: list[Variable] = []
    for group, values, what in (
        ("q", system.q0, "unit vector"),
        ("w", system.omega0, "angular velocity"),
    ):
        for i in range(system.n):
            for c, axis in enumerate(_AXES):
                out.append(
                    Variable(
                        name=f"{group}{i + 1}_{axis}",
                        vr=first + len(out),
                        causality=Causality.OUTPUT,
                        variability="continuous",
                        initial="exact",
                        start=float(values[i][c]),
                        description=f"{axis} component of body {i + 1}'s {what}",
                    )
                )
    return out


def _check_choices(system: System, fmi: int, kind: str, method: str) -> None:
    if fmi not in FMI_VERSIONS:
        raise ValueError(f"--fmi {fmi}: choose 2 or 3")
    if kind not in KINDS:
        raise ValueError(f"--kind {kind!r}: choose one of {', '.join(KINDS)}")
    if system.driven:
        check_driven_method(system, method)  # the rule of s2gen's own driven runs
        return
    record = method_record(method)
    if "c" not in record.backends or "sphere" not in record.kinds:
        raise ValueError(f"--method {method}: not a method of the emitted C")
    if record.driver is Driver.TIME_TRANSFORMED:
        raise ValueError(f"--method {method}: the time-transformed methods take no fixed step")


def _driven_variables(system: System, layout: Layout) -> list[Variable]:
    """The work output and the inputs (start: the spec's defaults) of a driven system."""
    out = [
        Variable(
            "work",
            layout.work,
            Causality.OUTPUT,
            "continuous",
            "calculated",
            None,
            "work done on the system since the start: the forces' and dV/dt's work over the "
            "steps plus the jumps of the energy where an input or a parameter changes "
            "(Co-Simulation; 0 in Model Exchange, where the importer integrates)",
        )
    ]
    for k, (name, value) in enumerate(zip(system.inputs.names, system.inputs.values)):
        out.append(
            Variable(
                name,
                layout.inputs + k,
                Causality.INPUT,
                "continuous",
                None,
                float(value),
                f"input {name} of the spec, held over each step (zero-order hold)",
            )
        )
    return out


def describe(
    system: System, fmi: int, kind: str | None, method: str, h: float | None = None
) -> FmuModel:
    """The variables and experiment of an FMU of `system` (`kind` None: "both", "cs" for a
    driven system; `h`: the sub-step size, default the spec's [run] h). Raises ValueError for
    a choice the FMU cannot make: a driven system (forces, inputs or time t) is Co-Simulation
    only, by a method that integrates it (`s2gen.runtime.driven.check_driven_method`).

    Example:
        >>> import s2gen
        >>> m = describe(s2gen.load("double_pendulum"), fmi=3, kind="cs", method="vi")
        >>> m.model_exchange, m.layout.energy == m.layout.derivatives + 2 * m.nstate
        (False, True)
        >>> k = describe(s2gen.load("kapitza"), fmi=2, kind=None, method="vi")
        >>> k.co_simulation, k.model_exchange, k.variables[-1].name, k.variables[-1].vr
        (True, False, 'work', 23)
    """
    kind = kind if kind is not None else ("cs" if system.driven else "both")
    _check_choices(system, fmi, kind, method)
    record = method_record(method)
    step = h if h is not None else system.run.h
    if step is None or not step > 0:
        raise ValueError(f"{system.origin}: no step size: give [run] h in the spec, or h > 0")
    cs, me = kind in ("cs", "both"), kind in ("me", "both")
    nstate = 3 * system.n
    np_ = len(system.parameter_names)
    layout = Layout(
        time=0,
        params=1,
        step_size=1 + np_,
        state=2 + np_,
        derivatives=2 + np_ + 2 * nstate,
        energy=2 + np_ + 4 * nstate,
        momentum=3 + np_ + 4 * nstate,
        work=6 + np_ + 4 * nstate,
        inputs=6 + np_ + 4 * nstate + int(system.driven),
        end=6 + np_ + 4 * nstate + int(system.driven) + len(system.inputs.names),
    )
    variables = [
        Variable("time", 0, Causality.INDEPENDENT, "continuous", None, None, "simulation time")
    ]
    for k, (name, value) in enumerate(zip(system.parameter_names, system.parameter_values)):
        variables.append(
            Variable(
                name,
                layout.params + k,
                Causality.PARAMETER,
                "tunable",
                "exact",
                float(value),
                f"parameter {name} of the spec",
            )
        )
    if cs:
        variables.append(
            Variable(
                "stepSize",
                layout.step_size,
                Causality.PARAMETER,
                "tunable",
                "exact",
                float(step),
                f"sub-step size of {method} inside a communication interval",
            )
        )
    states = _state_variables(system, layout.state)
    variables += states
    if me:
        for k, state in enumerate(states):
            variables.append(
                Variable(
                    f"der({state.name})",
                    layout.derivatives + k,
                    Causality.LOCAL,
                    "continuous",
                    "calculated",
                    None,
                    f"time derivative of {state.name}",
                    derivative_of=state.vr,
                )
            )
    variables.append(
        Variable(
            "energy",
            layout.energy,
            Causality.OUTPUT,
            "continuous",
            "calculated",
            None,
            "total energy, kinetic plus potential",
        )
    )
    for c, axis in enumerate(_AXES):
        variables.append(
            Variable(
                f"J_{axis}",
                layout.momentum + c,
                Causality.OUTPUT,
                "continuous",
                "calculated",
                None,
                f"{axis} component of the angular momentum",
            )
        )
    if system.driven:
        variables += _driven_variables(system, layout)
    return FmuModel(
        name=system.name,
        fmi=fmi,
        co_simulation=cs,
        model_exchange=me,
        method=method,
        adaptive=record.adaptive,
        variables=tuple(variables),
        layout=layout,
        default_experiment=Experiment(0.0, system.run.T, float(step)),
        nstate=nstate,
        spec_hash=system.spec_hash(),
        description=f"{system.name} on (S^2)^{system.n}, generated by s2gen",
        rtol=system.run.rtol or 1e-3,
        atol=system.run.atol or 1e-6,
        driven=system.driven,
    )
