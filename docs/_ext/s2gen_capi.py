"""The C API reference, written at build time from `s2gen.interface` and `s2gen.methods`.

The header of every emitted module is rendered from the same records (functions with their
parameters and comments, the options and statistics structs with their defaults, the method
and status tables), and the prototypes here are written by the C printer that writes the
header's, so the reference and the header cannot disagree.

``.. s2gen-c-api:: sphere`` (or ``angles``) inserts the reference of one module kind;
`c_api_rst(kind)` is the text it inserts (reStructuredText), usable without Sphinx.
"""

from __future__ import annotations

import re
from typing import Any

from s2gen.interface import Field, Function, Interface, Kind, interface
from s2gen.ir import ModuleKind
from s2gen.methods import CONTROLS, METHODS, Status
from s2gen.printing.c import c_decl, c_field_decl, nullable_note

#: The prefix shown for a module's name (the spec's `name`; upper case for constants); the
#: angle module of a system is called NAME_angles.
PREFIX = "NAME"
PREFIXES = {ModuleKind.SPHERE: PREFIX, ModuleKind.ANGLES: f"{PREFIX}_angles"}

_KIND_WORDS = {
    Kind.DOUBLE: "a double",
    Kind.INT: "an int",
    Kind.LONG: "a long",
    Kind.CONST_ARRAY: "input array of doubles",
    Kind.ARRAY: "output (or scratch) array of doubles",
    Kind.LONG_ARRAY: "output array of longs",
    Kind.INT_OUT: "output int",
    Kind.OPTIONS: "the options (read only)",
    Kind.OPTIONS_OUT: "the options struct to fill",
    Kind.STATS: "the statistics struct to fill",
    Kind.STEPPER: "the stepper record (``step_start`` fills it, ``step`` advances it)",
    Kind.VECTOR3: "output 3-vector",
    Kind.FEEDBACK: "the state feedback (``NAME_feedback``, below)",
    Kind.POINTER: "the caller's pointer, handed to the feedback as its ``ctx``",
}

_SIZES = {
    "p": f"{PREFIX}_NPARAMS doubles",
    "q": f"{PREFIX}_NSTATE doubles",
    "w": f"{PREFIX}_NSTATE doubles",
    "g": f"{PREFIX}_NSTATE doubles",
    "q0": f"{PREFIX}_NSTATE doubles",
    "w0": f"{PREFIX}_NSTATE doubles",
    "qn": f"{PREFIX}_NSTATE doubles",
    "wn": f"{PREFIX}_NSTATE doubles",
    "dq": f"{PREFIX}_NSTATE doubles",
    "dw": f"{PREFIX}_NSTATE doubles",
    "work": f"{PREFIX}_WORK_SIZE doubles",
    "carry": f"{PREFIX}_STEP_CARRY doubles",
}


def esc(text: str) -> str:
    """Plain text as reStructuredText: bars, stars and underscores are not markup here."""
    return re.sub(r"([\\|*_])", r"\\\1", text)


def _statuses(kind: ModuleKind) -> list[Status]:
    """The status codes a module kind's header declares: the sphere module never meets a pole,
    the angle module has no VI (so no infeasible step and no Newton)."""
    if kind is ModuleKind.SPHERE:
        return [s for s in Status if s is not Status.POLE]
    return [s for s in Status if s not in (Status.INFEASIBLE, Status.NEWTON)]


def _methods(kind: ModuleKind) -> list[Any]:
    return [m for m in METHODS if kind.value in m.kinds]


def _table(title: str, header: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    out = [f".. list-table:: {title}", "   :header-rows: 1", ""]
    for row in (header, *rows):
        out.append(f"   * - {row[0]}")
        out.extend(f"     - {cell}" for cell in row[1:])
    return [*out, ""]


def _function(f: Function, prefix: str, sizes: dict[str, str]) -> list[str]:
    decl = " ".join(part.strip() for part in c_decl(prefix, f).splitlines())
    note = nullable_note(f.params)
    doc = f.doc + (" " + note if note and "NULL" not in f.doc else "")
    out = [f".. c:function:: {decl}", "", f"   {esc(doc)}", ""]
    for p in f.params:
        size = sizes.get(p.name)
        text = _KIND_WORDS[p.kind]
        if size and p.kind is Kind.CONST_ARRAY:
            text = f"input, {size}"
        elif size and p.kind is Kind.ARRAY:
            text = f"{'workspace' if p.name == 'work' else 'output'}, {size}"
        if p.nullable:
            text += "; may be NULL"
        out.append(f"   :param {p.name}: {text}")
    if f.returns is not Kind.VOID:
        what = "a status code (OK on success)" if f.returns is Kind.INT else "the value"
        out.append(f"   :returns: {what}")
    return [*out, ""]


def _struct(
    name: str, fields: tuple[Field, ...], what: str, prefix: str, defaults: bool
) -> list[str]:
    upper = prefix.upper()
    out = [f".. c:struct:: {prefix}_{name}", "", f"   {what}", ""]
    for f in fields:
        default = f"{upper}_{f.default}" if f.default.startswith("CONTROL_") else f.default
        doc = f.doc.replace("CONTROL_", f"{upper}_CONTROL_")
        out += [f"   .. c:member:: {c_field_decl(prefix, f)}", "", f"      {esc(doc)}", ""]
        if defaults:
            out += [f"      Default: ``{default}``.", ""]
    return out


def c_api_rst(kind: ModuleKind) -> str:
    """The reference of one module kind's C interface, as reStructuredText.

    Example:
        >>> "NAME_integrate" in c_api_rst(ModuleKind.SPHERE)
        True
        >>> "NAME_angles_to_sphere" in c_api_rst(ModuleKind.ANGLES)
        True
    """
    api: Interface = interface(kind)
    prefix = PREFIXES[kind]
    upper = prefix.upper()
    sizes = _SIZES if kind is ModuleKind.SPHERE else {"work": f"{upper}_WORK_SIZE doubles"}
    lines: list[str] = []
    lines += _table(
        "Status codes (``enum``)",
        ("constant", "value", "meaning"),
        [(f"``{upper}_{s.c_name}``", str(int(s)), esc(s.message)) for s in _statuses(kind)],
    )
    lines += _table(
        "Methods (``enum``; the ``method`` argument)",
        ("constant", "value", "order", "what it is"),
        [
            (f"``{upper}_{m.c_name}``", str(m.code), str(m.order), esc(m.summary))
            for m in _methods(kind)
        ],
    )
    lines += _table(
        "RK45 error control (``enum``; the ``control`` option)",
        ("constant", "value"),
        [(f"``{upper}_CONTROL_{c.upper()}``", str(k)) for k, c in enumerate(CONTROLS)],
    )
    lines += _struct(
        "options",
        api.options,
        f"Integrator options; ``{prefix}_default_options`` fills it with the defaults below.",
        prefix,
        defaults=True,
    )
    lines += _struct(
        "stats",
        api.stats,
        "What a call of ``integrate`` did; ``integrate`` fills it (the pointer may be NULL).",
        prefix,
        defaults=False,
    )
    if api.stepper:
        lines += _struct(
            "stepper",
            api.stepper,
            f"Where a run of ``{prefix}_step`` calls stands; ``{prefix}_step_start`` fills it.",
            prefix,
            defaults=False,
        )
    for f in api.functions:
        lines += _function(f, prefix, sizes)
    return "\n".join(lines) + "\n"


def c_api_driven_rst() -> str:
    """What a driven system's module (forces, inputs or time) declares differently: its
    inputs, the feedback type, and step() and integrate() with time and inputs (vi_step,
    rk_step and step_start are absent; everything else is the sphere module's).

    Example:
        >>> text = c_api_driven_rst()
        >>> "NAME_feedback" in text and "double t0" in text
        True
    """
    api = interface(ModuleKind.SPHERE, driven=True)
    sizes = {
        **_SIZES,
        "u": f"{PREFIX}_NINPUTS doubles (integrate: nsteps * {PREFIX}_NINPUTS)",
        "W": "1 double (integrate: nsteps / every + 1)",
    }
    lines = [
        f".. c:macro:: {PREFIX.upper()}_NINPUTS",
        "",
        "   The number of inputs in ``u``.",
        "",
        f".. c:var:: const char *const {PREFIX}_input_names[]",
        "",
        "   The input names in the order of ``u``, NULL-terminated.",
        "",
        (
            f".. c:type:: void (*{PREFIX}_feedback)(void *ctx, double t, const double *q, "
            "const double *w, double *u)"
        ),
        "",
        (
            "   State feedback for ``integrate``: writes the inputs held over the step that starts "
            "at time t from the state (q, w) there."
        ),
        "",
    ]
    for f in api.functions:
        if f.name in ("step", "integrate", "field_at", "energy_at"):
            lines += _function(f, PREFIX, sizes)
    # in a C namespace of their own: the closed module's step and integrate have these names
    return "\n".join([".. c:namespace:: driven", "", *lines, ".. c:namespace:: NULL", ""]) + "\n"


def c_api_jacobian_rst() -> str:
    """step_jacobian(), field_jacobian() and their sizes (modules of systems of a few bodies).

    Example:
        >>> "JACOBIAN_WORK_SIZE" in c_api_jacobian_rst()
        True
    """
    from s2gen.interface_jacobian import JACOBIAN_FUNCTIONS

    upper = PREFIX.upper()
    sizes = {
        **_SIZES,
        "u": f"{upper}_NINPUTS doubles (a driven module's)",
        "A": f"(2 {upper}_NSTATE)^2 doubles",
        "B": f"2 {upper}_NSTATE * {upper}_NINPUTS doubles",
        "J": f"(2 {upper}_NSTATE)^2 doubles",
        "Ju": f"2 {upper}_NSTATE * {upper}_NINPUTS doubles",
        "qd": f"{upper}_NSTATE doubles",
        "wd": f"{upper}_NSTATE doubles",
        "work": f"{upper}_JACOBIAN_WORK_SIZE doubles",
    }
    lines = [
        f".. c:macro:: {upper}_JACOBIAN_WORK_SIZE",
        "",
        (
            "   The doubles ``work`` must hold for step_jacobian and field_jacobian (more than "
            "WORK_SIZE)."
        ),
        "",
        f".. c:macro:: {upper}_JACOBIAN_VI",
        "",
        "   1 when step_jacobian differentiates the VI family too, else 0.",
        "",
    ]
    for f in JACOBIAN_FUNCTIONS:
        lines += _function(f, PREFIX, sizes)
    return "\n".join(lines) + "\n"


def c_api_batch_rst() -> str:
    """integrate_batch() and its sizes (modules emitted with ``--batch``).

    Example:
        >>> "BATCH_WORK_SIZE" in c_api_batch_rst()
        True
    """
    from s2gen.interface_batch import INTEGRATE_BATCH

    upper = PREFIX.upper()
    sizes = {
        **_SIZES,
        "p": f"{upper}_NPARAMS * K doubles, p[j * K + k]",
        "q0": f"{upper}_NSTATE * K doubles, member-innermost",
        "w0": f"{upper}_NSTATE * K doubles, member-innermost",
        "q": f"(nsteps / every + 1) * {upper}_NSTATE * K doubles",
        "w": f"(nsteps / every + 1) * {upper}_NSTATE * K doubles",
        "energy": "(nsteps / every + 1) * K doubles",
        "work": f"{upper}_BATCH_WORK_SIZE doubles",
        "stats": "K structs",
        "status": "K ints",
    }
    lines = [
        f".. c:macro:: {upper}_BATCH_LANES",
        "",
        "   The members integrate_batch advances together (the SIMD lanes).",
        "",
        f".. c:macro:: {upper}_BATCH_WORK_SIZE",
        "",
        "   The doubles ``work`` must hold for integrate_batch, whatever K.",
        "",
    ]
    return "\n".join(lines + _function(INTEGRATE_BATCH, PREFIX, sizes)) + "\n"


def c_api_batch_driven_rst() -> str:
    """A driven system's integrate_batch() (modules of driven systems emitted with
    ``--batch``), in the C namespace of the driven module's functions.

    Example:
        >>> text = c_api_batch_driven_rst()
        >>> "double t0" in text and "double *W" in text
        True
    """
    from s2gen.interface_batch import INTEGRATE_BATCH_DRIVEN

    upper = PREFIX.upper()
    member = f"{upper}_NSTATE * K doubles, member-innermost"
    sizes = {
        **_SIZES,
        "p": f"{upper}_NPARAMS * K doubles, p[j * K + k]",
        "u": f"nsteps * {upper}_NINPUTS * K doubles, member-innermost",
        "q0": member,
        "w0": member,
        "q": f"(nsteps / every + 1) * {upper}_NSTATE * K doubles",
        "w": f"(nsteps / every + 1) * {upper}_NSTATE * K doubles",
        "energy": "(nsteps / every + 1) * K doubles",
        "W": "(nsteps / every + 1) * K doubles",
        "work": f"{upper}_BATCH_WORK_SIZE doubles",
        "stats": "K structs",
        "status": "K ints",
    }
    lines = _function(INTEGRATE_BATCH_DRIVEN, PREFIX, sizes)
    return "\n".join([".. c:namespace:: driven", "", *lines, ".. c:namespace:: NULL", ""]) + "\n"


def c_api_jvp_rst() -> str:
    """step_jvp() and its workspace size (modules emitted with ``--jacobians`` whose field
    is solved without dense matrices).

    Example:
        >>> "JVP_WORK_SIZE" in c_api_jvp_rst()
        True
    """
    from s2gen.interface_jvp import STEP_JVP

    upper = PREFIX.upper()
    sizes = {
        **_SIZES,
        **{x: f"{upper}_NSTATE doubles" for x in ("dq", "dw", "dqn", "dwn")},
        "work": f"{upper}_JVP_WORK_SIZE doubles",
    }
    lines = [
        f".. c:macro:: {upper}_JVP_WORK_SIZE",
        "",
        "   The doubles ``work`` must hold for step_jvp (more than WORK_SIZE; O(n)).",
        "",
        f".. c:macro:: {upper}_JVP_VI",
        "",
        "   1 when step_jvp takes the VI family too, else 0.",
        "",
    ]
    return "\n".join(lines + _function(STEP_JVP, PREFIX, sizes)) + "\n"


def setup(app: Any) -> dict[str, Any]:
    """Register ``.. s2gen-c-api:: sphere|angles`` (Sphinx is imported here only, so that the
    tests can call `c_api_rst` without it)."""
    from sphinx.util.docutils import SphinxDirective

    class CApiDirective(SphinxDirective):
        """``.. s2gen-c-api:: sphere|angles``: the generated C reference of that module kind."""

        required_arguments = 1

        def run(self) -> list[Any]:
            if self.arguments[0] == "driven":
                return self.parse_text_to_nodes(c_api_driven_rst())
            if self.arguments[0] == "jacobian":
                return self.parse_text_to_nodes(c_api_jacobian_rst())
            if self.arguments[0] == "batch":
                return self.parse_text_to_nodes(c_api_batch_rst())
            if self.arguments[0] == "batch_driven":
                return self.parse_text_to_nodes(c_api_batch_driven_rst())
            if self.arguments[0] == "jvp":
                return self.parse_text_to_nodes(c_api_jvp_rst())
            kinds = {"sphere": ModuleKind.SPHERE, "angles": ModuleKind.ANGLES}
            kind = kinds.get(self.arguments[0])
            if kind is None:
                raise self.error(
                    f"unknown module kind {self.arguments[0]!r}; use sphere, driven or angles"
                )
            return self.parse_text_to_nodes(c_api_rst(kind))

    app.add_directive("s2gen-c-api", CApiDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
