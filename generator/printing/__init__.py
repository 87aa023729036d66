"""Print a lowered `Module` for every language: the records the templates lay out.

Input: a lowered `Module` (IR). Output: a `PrintedModule` of plain strings, numbers, tuples,
records and small dicts (call sites by name, workspace offsets by layout and buffer), the only
thing the templates see. This module only gathers it: the C text comes from `printing/c.py`
and `printing/c_module.py`, the NumPy text from `printing/numpy.py`, the language-neutral
records from `printing/records.py` and `printing/sections.py`; declarations from
`s2gen.interface`, enums from `s2gen.methods`.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> pm = print_module(lower_system(builtin("double_pendulum")))
    >>> pm.call["kin_body"]["c"]
    'double_pendulum_k_kin_body(md[i], q + 3 * i, w + 3 * i, &t)'
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.ir import Kernel, Module, ModuleKind, PassRecord
from s2gen.methods import explicit_tableaus
from s2gen.printing import records
from s2gen.printing.c_batch import print_batch
from s2gen.printing.c_calls import c_call
from s2gen.printing.c_module import (
    CTable,
    Macro,
    c_fields,
    c_functions,
    c_initial_rows,
    c_inline_loops,
    c_macros,
    c_tables,
)
from s2gen.printing.driven import print_drive
from s2gen.printing.jacobian import JACOBIAN_SITES, print_jacobian
from s2gen.printing.jvp import print_jvp
from s2gen.printing.numpy import (
    py_call,
    py_data_setup,
    py_docstring,
    py_inertia_setup,
    py_table_names,
)
from s2gen.printing.numpy_batch import print_numpy_batch
from s2gen.printing.numpy_jacobian import print_numpy_jacobian
from s2gen.printing.rattle_jacobian import RATTLE_SITES, print_rattle_jacobian
from s2gen.printing.records import PrintedKernel, print_kernel
from s2gen.printing.sections import sections
from s2gen.printing.tableau import (
    PrintedExplicit,
    PrintedFixed,
    PrintedPair,
    print_explicit,
    print_fixed,
    print_pair,
    print_tableau,
)
from s2gen.printing.terms import (
    PrintedTerm,
    c_table_loop,
    print_term,
    py_quad_lines,
    quad_init,
)
from s2gen.printing.transformed import print_transformed
from s2gen.tableaus import DOP853, DOPRI5
from s2gen.version import __version__

__all__ = ["PrintedKernel", "PrintedModule", "PrintedTerm", "print_module"]


@dataclass(frozen=True)
class PrintedModule:
    """Everything the templates lay out for one module."""

    kind: str
    name: str
    upper: str
    spec_hash: str
    n: int
    n2: int  # 2 n: offset of the third component row in a component-major (SoA) copy
    n3: int
    nx: int
    npairs: int
    npairs_or_one: int
    ncoupled: int  # doubles of mp: coupled entries (one per pair) or max-index generators (2n)
    soa_bridge: bool  # the component-major gradient needs the body-major one for some terms
    parameters: tuple[tuple[str, str], ...]  # (name, value as a round-trip literal)
    pair_i: tuple[int, ...]
    pair_j: tuple[int, ...]
    kernels: tuple[PrintedKernel, ...]
    c_kernels: tuple[PrintedKernel, ...]  # those the C code calls (the others it writes inline)
    terms: tuple[PrintedTerm, ...]
    soa_terms: tuple[PrintedTerm, ...]  # laid out as rows: component-major gradients
    bridged_terms: tuple[PrintedTerm, ...]  # neither rows nor in K: body-major gradients
    call: dict[str, dict[str, str]]  # site -> {"c": ..., "py": ...}
    inline: dict[str, tuple[str, ...]]  # kernel -> its body inline (explicit VI loops)
    work: dict[str, dict[str, Any]]  # layout -> {buffer: offset, "doc": ..., "size": ...}
    context: tuple[dict[str, Any], ...]  # the per-call context buffers (name, offset, doc)
    constants_or_one: int
    table_inits: tuple[dict[str, Any], ...]  # per term with a table: index, count, table, call
    py_tables: tuple[str, ...]  # calls computing the terms' member tables (NumPy)
    quadratic: int  # order of the quadratic terms' matrix K (0: none)
    c_includes: tuple[str, ...]  # more headers: stdint.h (uintptr_t) for 64-byte aligned buffers,
    # string.h (memcmp) for a batch whose lanes may share K
    quad_inits: tuple[dict[str, Any], ...]  # per quadratic term: loop, coefficient call, scatter
    py_quad_lines: tuple[str, ...]  # NumPy lines building K and b
    py_table_names: tuple[str, ...]
    c_parts: tuple[str, ...]
    c_sections: dict[str, tuple[str, ...]]  # optional section -> the partials laying it out
    py_sections: dict[str, tuple[str, ...]]
    py_parts: tuple[str, ...]
    parts: tuple[str, ...]
    c_macros: tuple[Macro, ...]
    h_macros: tuple[Macro, ...]
    c_tables: tuple[CTable, ...]
    options: tuple[dict[str, str], ...]
    stats: tuple[dict[str, str], ...]
    stepper: tuple[dict[str, str], ...]  # the fields of step()'s record (none: no step())
    initial_rows: tuple[str, ...]  # the spec's q then omega as rows of literals (none: no state)
    functions: tuple[dict[str, Any], ...]
    statuses: tuple[tuple[str, int, str], ...]
    methods: tuple[tuple[str, int, str], ...]
    passes: tuple[PassRecord, ...]
    compositions: tuple[dict[str, Any], ...]  # name, source, order, count, fractions (literals)
    schemes: tuple[dict[str, Any], ...]  # per geometric method: c_name, rattle, count, table
    dop853: dict[str, Any]  # DOP853's stage sums (s2gen.printing.tableau)
    dopri5: PrintedPair  # Dormand-Prince 5(4)'s tables
    explicit: tuple[PrintedExplicit, ...]  # the fixed-step tableaus of this kind of module
    fixed: tuple[PrintedFixed, ...]  # the fixed-step methods' dispatch rows
    controls: tuple[tuple[str, int], ...]  # the error controls' enum (suffix, code)
    evals: str  # the statistics counter of vector-field / gradient evaluations
    state_doc: str
    py_doc_title: str
    py_doc_state: str
    generator_version: str
    system: str
    derivation: str
    pole_tol: str
    min_pivot_ratio: str
    band: dict[str, dict[str, int]]  # structured solves: name -> p, r, nrhs, kl, ku, rows, ...
    c_masses: str  # the partial that computes M's entries or generators (C, NumPy)
    py_masses: str
    py_inertia_setup: tuple[str, ...]  # NumPy: the body index and per-body data of M
    py_data_setup: tuple[str, ...]  # NumPy: the per-body arrays of [data] the terms read
    drive: dict[str, Any]  # a driven module's inputs, methods and tables (empty: closed)
    jac: dict[str, Any]  # the step Jacobians' methods and lines (empty: no step_jacobian)
    py_jac: dict[str, Any]  # NumPy's step Jacobians: methods and lines (empty: none)
    rattle_jac: dict[str, Any]  # RATTLE's step Jacobians: methods, C and NumPy lines (or empty)
    batch: dict[str, Any]  # integrate_batch()'s lanes, workspace and lines (empty: none)
    py_batch: dict[str, Any]  # NumPy's integrate_batch(): partial, kernels, lines (or empty)
    jvp: dict[str, Any]  # step_jvp()'s methods and lines (empty: no step_jvp)
    transformed: tuple[dict[str, Any], ...]  # time-transformed methods: c_name, count, table
    py_transformed: tuple[dict[str, Any], ...]  # the same for NumPy, with py_rattle


def print_module(module: Module) -> PrintedModule:
    """Print every part of a lowered module for both languages."""
    name, upper = module.name, module.name.upper()
    sphere = module.kind is ModuleKind.SPHERE
    calls = {c.site: {"c": c_call(name, c), "py": py_call(c)} for c in module.calls}
    inline = c_inline_loops(module)
    kernels = tuple(
        print_kernel(k, f"{upper}_RESTRICT") for k in module.kernels if isinstance(k, Kernel)
    )
    terms = tuple(print_term(module, t, calls) for t in module.terms)
    # the terms' sites are written into their records (terms, table_inits, quad_inits)
    consumed = {
        f"t{t.index}_{s}"
        for t in module.terms
        for s in ("value", "gradient", "table", "quad", "hessian", "hvp")
    }
    consumed |= JACOBIAN_SITES | RATTLE_SITES  # and the step Jacobians' into m.jac, m.rattle_jac
    c_masses, py_masses = records.masses_partials(module)
    facts = dict(module.facts)
    n, npairs = module.n, len(module.pairs)
    statuses, meths = records.enums(module)
    c_macro, h_macro = c_macros(module)
    variant = dict(module.variants)
    partials = tuple(variant.get(p, p) for p in module.parts)
    py_title, py_state = py_docstring(module)
    c_sections, py_sections = sections(module)
    return PrintedModule(
        kind=module.kind.value,
        name=name,
        upper=upper,
        spec_hash=module.spec_hash,
        n=n,
        n2=2 * n,
        n3=3 * n,
        nx=2 * n,
        npairs=npairs,
        npairs_or_one=max(npairs, 1),
        ncoupled=2 * n if module.solver is InertiaKind.MAX_INDEX else max(npairs, 1),
        soa_bridge=module.body_major_terms,
        parameters=tuple(
            (p, repr(float(v))) for p, v in zip(module.parameter_names, module.parameter_values)
        ),
        pair_i=tuple(i for i, _ in module.pairs),
        pair_j=tuple(j for _, j in module.pairs),
        kernels=kernels,
        c_kernels=tuple(k for k in kernels if k.name not in inline),
        terms=terms,
        soa_terms=tuple(pt for pt, t in zip(terms, module.terms) if t.rows),
        bridged_terms=tuple(
            pt for pt, t in zip(terms, module.terms) if not (t.rows or t.quadratic)
        ),
        call={site: text for site, text in calls.items() if site not in consumed},
        inline=inline,
        work=records.workspace(module),
        context=records.context(module),
        constants_or_one=max(1, module.constants),
        table_inits=tuple(
            {
                "index": t.index,
                "table": t.table,
                "call": calls[f"t{t.index}_table"]["c"],
                **c_table_loop(module, t),
            }
            for t in module.terms
            if t.table
        ),
        py_tables=tuple(calls[f"t{t.index}_table"]["py"] for t in module.terms if t.table),
        py_table_names=py_table_names(module),
        quadratic=module.quadratic,
        c_includes=(
            ("stdint.h",)
            if module.quadratic > 0
            or any(lay.name == "explicit" for lay in module.layouts)
            or "batch" in module.parts
            else ()
        )
        + (("string.h",) if module.quadratic > 0 and "batch" in module.parts else ()),
        quad_inits=tuple(quad_init(module, t, calls) for t in module.terms if t.quadratic),
        py_quad_lines=tuple(
            line for t in module.terms if t.quadratic for line in py_quad_lines(t, calls, module.n)
        ),
        c_parts=tuple(f"c/_{p}.jinja" for p in partials),
        py_parts=tuple(
            f"numpy/_{v}.jinja" for p, v in zip(module.parts, partials) if p not in module.c_only
        ),
        c_sections=c_sections,
        py_sections=py_sections,
        parts=module.parts,
        c_macros=c_macro,
        h_macros=h_macro,
        c_tables=c_tables(module),
        options=c_fields(module, "options"),
        stats=c_fields(module, "stats"),
        stepper=c_fields(module, "stepper"),
        initial_rows=c_initial_rows(module),
        functions=c_functions(module),
        statuses=statuses,
        methods=meths,
        passes=module.passes,
        compositions=records.compositions(),
        schemes=records.schemes(),
        dop853=print_tableau(DOP853),
        dopri5=print_pair(DOPRI5),
        explicit=tuple(
            print_explicit(t, f"{upper}_NS") for t in explicit_tableaus(module.kind.value)
        ),
        fixed=print_fixed(module.kind.value),
        controls=records.controls(module),
        evals="gradient_evals" if sphere else "rhs_evals",
        state_doc="(q, omega)" if sphere else "(x, xd)",
        py_doc_title=py_title,
        py_doc_state=py_state,
        generator_version=__version__,
        system=str(facts.get("system", name)),
        derivation=str(facts.get("derivation", "")),
        pole_tol=str(facts.get("pole_tol", "")),
        min_pivot_ratio=str(facts.get("min_pivot_ratio", "")),
        band=records.bands(module),
        c_masses=c_masses,
        py_masses=py_masses,
        py_inertia_setup=py_inertia_setup(module),
        py_data_setup=py_data_setup(module),
        drive=print_drive(module),
        jac=print_jacobian(module),
        py_jac=print_numpy_jacobian(module),
        rattle_jac=print_rattle_jacobian(module),
        batch=print_batch(module),
        py_batch=print_numpy_batch(module),
        jvp=print_jvp(module),
        transformed=print_transformed(module),
        py_transformed=print_transformed(module, "numpy"),
    )
