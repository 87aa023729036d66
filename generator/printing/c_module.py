"""The C printer's module-level text: macros, static tables, interface declarations, inline loops.

Input: a lowered `Module` (IR) and the `s2gen.interface` records of its kind. Output: strings
and tuples of lines, the C text of one emitted module that is not a kernel, a loop or a call
(those are in `printing/c.py`).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> c, h = c_macros(lower_system(builtin("double_pendulum")))
    >>> c[0], h[0]
    (('N3', '6', 'doubles in q (or w): 3 per body'), ('NBODIES', '2', 'bodies'))
"""

from __future__ import annotations

from s2gen.inertia import InertiaKind
from s2gen.interface import interface
from s2gen.ir import Kernel, Module, ModuleKind
from s2gen.parts.batch import BATCH_LANES, BATCH_PART
from s2gen.parts.batch_driven import DRIVEN_BATCH_PART, driven_batch_work
from s2gen.parts.jvp import JVP_PART
from s2gen.passes.workspace import padded
from s2gen.printing.c import (
    c_decl,
    c_field_decl,
    c_inline,
    c_term_tables,
    nullable_note,
    rows,
)
from s2gen.printing.c_batch import batch_work
from s2gen.printing.c_calls import c_binding
from s2gen.printing.jacobian import JACOBIAN_PART

__all__ = [
    "CTable",
    "Macro",
    "c_fields",
    "c_functions",
    "c_initial_rows",
    "c_inline_loops",
    "c_macros",
    "c_tables",
]

#: A macro: (name without the prefix, value, comment).
Macro = tuple[str, str, str]
#: A static table: (C element type, name, length, initializer rows).
CTable = tuple[str, str, int, tuple[str, ...]]


def c_macros(module: Module) -> tuple[tuple[Macro, ...], tuple[Macro, ...]]:
    """(source macros, header macros) of a module: sizes, strides and limits."""
    n = module.n
    facts = dict(module.facts)
    nparams = str(len(module.parameter_names))
    size = ("WORK_SIZE", str(module.work_size), "workspace doubles every `work` must hold")
    if module.kind is ModuleKind.ANGLES:
        return (
            ("NS", str(4 * n), "doubles in the state y = (x, xd)"),
            ("LDX", str(padded(2 * n)), "row stride of the dense NX x NX system"),
            ("LD_MAX", str(padded(2 * n)), "the largest row stride"),
        ), (
            ("NBODIES", str(n), "bodies"),
            ("NX", str(2 * n), "angles (and rates): theta_i, phi_i per body"),
            ("NPARAMS", nparams, "parameters in p"),
            size,
            ("POLE_TOL", str(facts["pole_tol"]), "sin theta below this is at a pole"),
            ("MIN_PIVOT_RATIO", str(facts["min_pivot_ratio"]), "M(x) singular below this"),
        )
    coupled = n * (n - 1) // 2 if module.solver is InertiaKind.MAX_INDEX else len(module.pairs)
    return (
        ("N3", str(3 * n), "doubles in q (or w): 3 per body"),
        ("NS", str(6 * n), "doubles in the state y = (q, w)"),
        ("LD3", str(padded(3 * n)), "row stride of the dense N3 x N3 systems"),
        ("LDN", str(padded(n)), "row stride of the dense n x n systems"),
        ("LD_MAX", str(padded(3 * n)), "the largest row stride"),
    ), (
        ("NBODIES", str(n), "bodies"),
        ("NSTATE", str(3 * n), "doubles in q (and in w): 3 per body, body-major"),
        ("NPARAMS", nparams, "parameters in p"),
        ("NPAIRS", str(coupled), "coupled pairs of M (off-diagonal entries not zero)"),
        ("NCONST", str(module.constants), "constants of the kernels (computed once per call)"),
        ("WORK_BASE", str(module.work_base), "workspace doubles before the per-call context"),
        size,
        *_step_macros(module),
    )


def _step_macros(module: Module) -> tuple[Macro, ...]:
    """step()'s carry (closed modules), or the number of inputs (driven modules, whose step()
    carries nothing)."""
    jac: tuple[Macro, ...] = ()
    if JACOBIAN_PART in module.parts:
        jac = (
            (
                "JACOBIAN_WORK_SIZE",
                str(module.layout("jacobian").size),
                "workspace doubles step_jacobian() needs (more than WORK_SIZE)",
            ),
            (
                "JACOBIAN_VI",
                "1" if any(k.name == "vi_jacobian" for k in module.kernels) else "0",
                "1: step_jacobian() differentiates the VI family too",
            ),
        )
    if BATCH_PART in module.parts:
        jac += (
            ("BATCH_LANES", str(BATCH_LANES), "members integrate_batch() advances together"),
            (
                "BATCH_WORK_SIZE",
                str(batch_work(module)["size"]),
                "workspace doubles integrate_batch() needs, whatever K",
            ),
        )
    if DRIVEN_BATCH_PART in module.parts:
        jac += (
            (
                "BATCH_WORK_SIZE",
                str(driven_batch_work(module)),
                "workspace doubles integrate_batch() needs, whatever K",
            ),
        )
    if JVP_PART in module.parts:
        jac += (
            (
                "JVP_WORK_SIZE",
                str(module.layout("jvp").size),
                "workspace doubles step_jvp() needs (more than WORK_SIZE)",
            ),
            (
                "JVP_VI",
                "1" if "jvp_vi_steps" in module.parts else "0",
                "1: step_jvp() takes the VI family too",
            ),
        )
    if module.drive is not None:
        return (("NINPUTS", str(len(module.drive.inputs)), "inputs in u (see input_names)"), *jac)
    return (("STEP_CARRY", str(module.layout("carry").size), "doubles of step()'s carry"), *jac)


def c_tables(module: Module) -> tuple[CTable, ...]:
    """The static tables of a module: coupled pairs, the terms' members and data, and the
    per-body data of M.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> c_tables(m)[0]
        ('int', 'double_pendulum_pair_i', 1, ('0',))
    """
    name = module.name
    tables: list[CTable] = []
    if module.coupling is not None:
        for r, role in enumerate(("i", "j")):
            idx = [str(p[r]) for p in module.pairs]
            tables.append(("int", f"{name}_pair_{role}", len(idx), rows(idx, 16)))
    for t in module.terms:
        tables += c_term_tables(name, t)
    for data, values in module.inertia_data:
        lits = [repr(float(v)) for v in values]
        tables.append(("double", f"{name}_inertia_{data}", len(values), rows(lits)))
    for data, _, values in module.body_data:
        lits = [repr(float(v)) for v in values]
        tables.append(("double", f"{name}_data_{data}", len(values), rows(lits)))
    return tuple(tables)


def _wrap(text: str, width: int = 92) -> tuple[str, ...]:
    lines: list[str] = []
    for word in text.split():
        if lines and len(lines[-1]) + 1 + len(word) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return tuple(lines)


def c_functions(module: Module) -> tuple[dict[str, str | tuple[str, ...]], ...]:
    """Per public function: its prototype (`c_decl`) and its comment wrapped (`doc_lines`).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> c_functions(m)[0]["c_decl"]
        'void double_pendulum_default_params(double *p)'
    """
    out: list[dict[str, str | tuple[str, ...]]] = []
    for f in interface(
        module.kind,
        module.drive is not None,
        JACOBIAN_PART in module.parts,
        BATCH_PART in module.parts or DRIVEN_BATCH_PART in module.parts,
        JVP_PART in module.parts,
    ).functions:
        note = nullable_note(f.params)
        doc = f.doc + (" " + note if note and "NULL" not in f.doc else "")
        out.append({"c_decl": c_decl(module.name, f), "doc_lines": _wrap(doc)})
    return tuple(out)


def c_fields(module: Module, which: str) -> tuple[dict[str, str], ...]:
    """The options, statistics or stepper struct's fields (`which`): name, C declaration,
    C default, NumPy default and comment (enum defaults and names with the module's prefix).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> c_fields(m, "options")[0]["c_decl"], c_fields(m, "options")[0]["c_default"]
        ('double rtol', '1e-3')
    """
    api = interface(
        module.kind,
        module.drive is not None,
        JACOBIAN_PART in module.parts,
        BATCH_PART in module.parts,
        JVP_PART in module.parts,
    )
    upper = module.name.upper()
    return tuple(
        {
            "name": f.name,
            "c_decl": c_field_decl(module.name, f),
            "c_default": f"{upper}_{f.default}" if f.default.startswith("CONTROL_") else f.default,
            "py_default": f.default,
            "doc": f.doc.replace("CONTROL_", f"{upper}_CONTROL_"),
        }
        for f in {"options": api.options, "stats": api.stats, "stepper": api.stepper}[which]
    )


def c_initial_rows(module: Module) -> tuple[str, ...]:
    """The spec's initial q then omega as rows of round-trip literals (none: no state).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> row = c_initial_rows(lower_system(builtin("double_pendulum")))[0]
        >>> [round(float(v), 12) for v in row.rstrip(",").split(", ")[:3]]
        [0.866025403784, 0.0, 0.5]
    """
    return rows([repr(v) for v in module.initial_state])


_INLINE_SCALARS = ("q", "w", "g", "qn", "gn", "wh")


def c_inline_loops(module: Module) -> dict[str, tuple[str, ...]]:
    """The explicit VI kernels' bodies inline, for the SoA loops over bodies: vector operands
    q, w, g, qn, gn are scalars (q0, q1, q2, ...), h by name, outputs qn0.., s0, wn0...;
    "loads" declares their other scalar inputs (the body's mass) as the call sites bind them;
    empty without the explicit VI (coupled M).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("dipoles"))
        >>> sorted(c_inline_loops(m))
        ['loads', 'vi_pos', 'vi_vel']
    """
    out: dict[str, tuple[str, ...]] = {}
    names = {k.name for k in module.kernels}
    loads: list[str] = []
    for name in ("vi_pos", "vi_vel"):
        if name in names:
            kernel = module.kernel(name)
            assert isinstance(kernel, Kernel), "the passes lowered every kernel"
            shared, lines = c_inline(kernel, scalars=_INLINE_SCALARS)
            assert not shared, f"{name} reads no context constants"
            out[name] = lines
            call = next(c for c in module.calls if c.site == name)
            for arg, bound in zip(kernel.inputs, call.inputs):
                line = f"const double {arg.name} = {c_binding(module.name, bound)};"
                if arg.scalar and arg.name != "h" and line not in loads:
                    loads.append(line)
    if out:
        out["loads"] = tuple(loads)
    return out
