"""Print a lowered `Module` for every language: the records the templates lay out.

Input: a lowered `Module` (IR). Output: a `PrintedModule` of plain strings, numbers, tuples,
records and small dicts (call sites by name, workspace offsets by layout and buffer), the only
thing the templates see. This module only gathers it: the C text comes from `printing/c.py`
and `printing/c_module.py`, the NumPy text from `printing/numpy.py`, the language-neutral
records from `printing/records.py`; declarations from `s2gen.interface`, enums from
`s2gen.methods`.

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
from s2gen.ir import Kernel, LoopKind, Module, ModuleKind, PassRecord, TermLoop
from s2gen.printing import records
from s2gen.printing.c import c_call, c_inline, c_loop
from s2gen.printing.c_module import (
    CTable,
    Macro,
    c_fields,
    c_functions,
    c_inline_loops,
    c_macros,
    c_tables,
)
from s2gen.printing.numpy import (
    py_call,
    py_docstring,
    py_inertia_setup,
    py_table_names,
    py_term_setup,
)
from s2gen.printing.records import PrintedKernel, print_kernel
from s2gen.printing.tableau import print_tableau
from s2gen.tableaus import DOP853
from s2gen.version import __version__

__all__ = ["PrintedKernel", "PrintedModule", "PrintedTerm", "print_module"]


@dataclass(frozen=True)
class PrintedTerm:
    """A structured term as text: its loop, the calls it makes and how gradients accumulate.

    C: `c_open`/`c_close` bracket a member loop (m the member, i and j its bodies), or
    `c_*_part` name the cell-list partials of a cutoff term. NumPy: `py_setup` defines index and
    data arrays, `py_index` names the index arrays used to scatter gradients.
    """

    index: int
    doc: str
    count: int
    c_open: tuple[str, ...]
    c_close: tuple[str, ...]
    c_value_part: str
    c_gradient_part: str
    layout: str  # "rows", "quadratic" (in K), "cutoff" or "" (the member loop): its partials
    c_value_call: str
    c_gradient_call: str
    c_table_lines: tuple[str, ...]
    c_rows_value: tuple[str, ...]  # the kernels inline, for the rows layout
    c_rows_gradient: tuple[str, ...]
    c_rows_constants: tuple[str, ...]  # the context constants they read (c<k>)
    c_rows_constants_gradient: tuple[str, ...]
    c_gradient_locals: str
    c_gradient_accumulate: tuple[str, ...]
    py_setup: tuple[str, ...]
    py_value_part: str
    py_gradient_part: str
    py_value_call: str
    py_gradient_call: str
    py_gradient_accumulate: tuple[str, ...]
    py_index: tuple[str, ...]
    cutoff: str  # round-trip literal of the cutoff distance ("" without cutoff)
    rc2: str  # its square
    cells: int  # neighbour-list cells per axis


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
    #: the VI's step is the explicit update (the assembler chose the "vi_explicit" partial):
    #: it has its own driver on component-major copies, and no Newton step exists
    explicit_vi: bool
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
    functions: tuple[dict[str, Any], ...]
    statuses: tuple[tuple[str, int, str], ...]
    methods: tuple[tuple[str, int, str], ...]
    passes: tuple[PassRecord, ...]
    compositions: tuple[dict[str, Any], ...]  # name, source, order, count, fractions (literals)
    schemes: tuple[dict[str, Any], ...]  # per geometric method: c_name, rattle, count, table
    dop853: dict[str, Any]  # DOP853's stage sums (s2gen.printing.tableau)
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


_TERM_DOC = {
    LoopKind.BODIES: "sum over bodies (all)",
    LoopKind.BODY_LIST: "sum over bodies (list)",
    LoopKind.CHAIN: "sum over pairs (chain)",
    LoopKind.PAIR_LIST: "sum over pairs (list)",
    LoopKind.ALL_PAIRS: "sum over pairs (all)",
    LoopKind.CUTOFF_PAIRS: "sum over pairs within the cutoff",
}


def _print_term(module: Module, t: TermLoop, calls: dict[str, Any]) -> PrintedTerm:
    kind = t.loop.kind
    cutoff = kind is LoopKind.CUTOFF_PAIRS
    c_open, c_close = ((), ()) if cutoff else c_loop(module.name, t, module.n)
    if kind.pairs:
        locals_, acc = (
            "double gi[3], gj[3];",
            [
                f"g[3 * {i}{s}] += g{i}[{c}];"
                for i in "ij"
                for c, s in enumerate(("", " + 1", " + 2"))
            ],
        )
    else:
        locals_, acc = (
            "double gb[3];",
            [f"g[3 * i{s}] += gb[{c}];" for c, s in enumerate(("", " + 1", " + 2"))],
        )
    setup, index = py_term_setup(t)
    value, gradient = calls[f"t{t.index}_value"], calls[f"t{t.index}_gradient"]
    py_acc: tuple[str, ...]
    if kind.pairs:
        py_acc = (
            f"gi, gj = {gradient['py']}",
            f"numpy.add.at(g, {index[0]}, gi)",
            f"numpy.add.at(g, {index[1]}, gj)",
        )
    else:
        py_acc = (f"numpy.add.at(g, {index[0]}, {gradient['py']})",)
    suffix = "_cutoff" if cutoff else "_quadratic" if t.quadratic else "_rows" if t.rows else ""
    rows_value = rows_gradient = constants_value = constants_gradient = ()
    if t.rows:
        value_kernel, gradient_kernel = module.kernel(t.value), module.kernel(t.gradient)
        assert isinstance(value_kernel, Kernel) and isinstance(gradient_kernel, Kernel)
        constants_value, rows_value = c_inline(value_kernel)
        constants_gradient, rows_gradient = c_inline(gradient_kernel)
    label = module.kernel(t.value).doc.split(":")[0]
    table_lines: tuple[str, ...] = ()
    if t.table:
        k = t.index
        table_lines = (
            f"double row[{t.table}];",
            f"const double *tab = cx->t{k} ? cx->t{k} + {t.table} * m : row;",
            f"if (!cx->t{k}) {{",
            f"    {calls[f't{k}_table']['c']};",
            "}",
        )
    return PrintedTerm(
        index=t.index,
        doc=f"term {t.index}, {label}: {_TERM_DOC[kind]}",
        count=t.loop.count,
        c_open=c_open,
        c_close=c_close,
        layout=suffix[1:],
        c_value_part=f"c/_term_value{suffix}.jinja",
        c_gradient_part=f"c/_term_gradient{suffix}.jinja",
        c_value_call=value["c"],
        c_gradient_call=gradient["c"],
        c_table_lines=table_lines,
        c_rows_value=rows_value,
        c_rows_gradient=rows_gradient,
        c_rows_constants=constants_value,
        c_rows_constants_gradient=constants_gradient,
        c_gradient_locals=locals_,
        c_gradient_accumulate=tuple(acc),
        py_setup=setup,
        py_value_part=f"numpy/_term_value{suffix}.jinja",
        py_gradient_part=f"numpy/_term_gradient{suffix}.jinja",
        py_value_call=value["py"],
        py_gradient_call=gradient["py"],
        py_gradient_accumulate=py_acc,
        py_index=index,
        cutoff="" if t.loop.cutoff is None else repr(float(t.loop.cutoff)),
        rc2="" if t.loop.cutoff is None else repr(float(t.loop.cutoff) ** 2),
        cells=t.loop.cells,
    )


def _coordinate(r: int, n: int, index: tuple[str, ...]) -> str:
    """Component-major index (u n + body) in K of a member's local coordinate r (component
    r % 3 of body i for r < 3, else of body j)."""
    return f"{r % 3 * n} + {index[r // 3]}"


def _quad_init(module: Module, t: TermLoop, calls: dict[str, Any]) -> dict[str, Any]:
    """C text adding one quadratic term's members into K and b (once per call)."""
    c_open, c_close = c_loop(module.name, t, module.n)
    n3 = 3 * module.n
    roles = ("i", "j")
    lines = []
    for slot, r, c in t.quadratic:
        if r < 0:
            lines.append(f"kb[{n3}] += row[{slot}];")
        elif c < 0:
            lines.append(f"kb[{_coordinate(r, module.n, roles)}] += row[{slot}];")
        else:
            row_i, col_i = _coordinate(r, module.n, roles), _coordinate(c, module.n, roles)
            lines.append(f"kq[({row_i}) * {n3} + {col_i}] += row[{slot}];")
            if r != c:
                lines.append(f"kq[({col_i}) * {n3} + {row_i}] += row[{slot}];")
    return {
        "c_open": c_open,
        "c_close": c_close,
        "slots": len(t.quadratic),
        "call": calls[f"t{t.index}_quad"]["c"],
        "scatter": tuple(lines),
    }


def _py_quad(t: TermLoop, calls: dict[str, Any], n: int) -> tuple[str, ...]:
    """NumPy lines adding one quadratic term's members into K and kb (component-major)."""
    up = f"T{t.index}"
    index = (f"{up}_I", f"{up}_J")
    lines = [f"coef = {calls[f't{t.index}_quad']['py']}"]
    for slot, r, c in t.quadratic:
        value = f"numpy.broadcast_to(coef[..., {slot}], {index[0]}.shape)"
        if r < 0:
            lines.append(f"kb[-1] += float(numpy.sum({value}))")
        elif c < 0:
            lines.append(f"numpy.add.at(kb, {_coordinate(r, n, index)}, {value})")
        else:
            row_i, col_i = _coordinate(r, n, index), _coordinate(c, n, index)
            lines.append(f"numpy.add.at(kq, ({row_i}, {col_i}), {value})")
            if r != c:
                lines.append(f"numpy.add.at(kq, ({col_i}, {row_i}), {value})")
    return tuple(lines)


def print_module(module: Module) -> PrintedModule:
    """Print every part of a lowered module for both languages."""
    name, upper = module.name, module.name.upper()
    sphere = module.kind is ModuleKind.SPHERE
    calls = {c.site: {"c": c_call(name, c), "py": py_call(c)} for c in module.calls}
    inline = c_inline_loops(module)
    kernels = tuple(
        print_kernel(k, f"{upper}_RESTRICT") for k in module.kernels if isinstance(k, Kernel)
    )
    terms = tuple(_print_term(module, t, calls) for t in module.terms)
    # the terms' sites are written into their records (terms, table_inits, quad_inits)
    consumed = {
        f"t{t.index}_{s}" for t in module.terms for s in ("value", "gradient", "table", "quad")
    }
    c_masses, py_masses = records.masses_partials(module)
    facts = dict(module.facts)
    n, npairs = module.n, len(module.pairs)
    statuses, meths = records.enums(module)
    c_macro, h_macro = c_macros(module)
    variant = dict(module.variants)
    partials = tuple(variant.get(p, p) for p in module.parts)
    py_title, py_state = py_docstring(module)
    c_sections, py_sections = records.sections(module)
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
        explicit_vi="vi_explicit" in module.parts,
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
                "count": t.loop.count,
                "table": t.table,
                "call": calls[f"t{t.index}_table"]["c"],
            }
            for t in module.terms
            if t.table
        ),
        py_tables=tuple(calls[f"t{t.index}_table"]["py"] for t in module.terms if t.table),
        py_table_names=py_table_names(module),
        quadratic=module.quadratic,
        quad_inits=tuple(_quad_init(module, t, calls) for t in module.terms if t.quadratic),
        py_quad_lines=tuple(
            line for t in module.terms if t.quadratic for line in _py_quad(t, calls, module.n)
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
        functions=c_functions(module),
        statuses=statuses,
        methods=meths,
        passes=module.passes,
        compositions=records.compositions(),
        schemes=records.schemes(),
        dop853=print_tableau(DOP853),
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
    )
