"""Print a lowered `Module` for every language: the text records the templates lay out.

Input: a lowered `Module` (IR). Output: a `PrintedModule` of plain strings, numbers, tuples and
small dicts (call sites by name, workspace offsets by layout and buffer), the only thing the
templates see. The C and NumPy printers live in `printing/c.py` and `printing/numpy.py`;
declarations come from `s2gen.interface`, enums from `s2gen.methods`.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> pm = print_module(lower_system(builtin("double_pendulum")))
    >>> pm.call["kin_body"]["c"]
    'double_pendulum_k_kin_body(md[i], q + 3 * i, w + 3 * i, &t)'
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.interface import interface
from s2gen.ir import Kernel, Module, ModuleKind, PassRecord
from s2gen.methods import COMPOSITIONS, CONTROLS, METHODS, Family, Status, explicit_tableaus
from s2gen.passes.opcount import kernel_profile
from s2gen.passes.workspace import CONTEXT, padded
from s2gen.printing.c import (
    c_call,
    c_decl,
    c_field_decl,
    c_inline,
    c_kernel,
    c_term_tables,
    nullable_note,
    rows,
)
from s2gen.printing.numpy import py_call, py_kernel
from s2gen.printing.tableau import (
    PrintedExplicit,
    PrintedFixed,
    PrintedPair,
    print_explicit,
    print_fixed,
    print_pair,
    print_tableau,
)
from s2gen.printing.terms import PrintedTerm, print_term, py_quad_lines, quad_init
from s2gen.tableaus import DOP853, DOPRI5
from s2gen.version import __version__

__all__ = ["PrintedKernel", "PrintedModule", "PrintedTerm", "print_module"]


@dataclass(frozen=True)
class PrintedKernel:
    """One kernel as text: C signature and body lines, NumPy signature and body lines."""

    name: str
    doc: str
    c_params: str
    c_lines: tuple[str, ...]
    py_params: str
    py_lines: tuple[str, ...]
    ops_before: int
    ops_after: int
    profile: str  # ops_after by kind
    temporaries: int
    c_function: bool = True  # False: the C code writes it inline only (no function emitted)


@dataclass(frozen=True)
class PrintedModule:
    """Everything the templates lay out for one module."""

    kind: str
    name: str
    upper: str
    spec_hash: str
    origin: str
    n: int
    n2: int  # 2 n: offset of the third component row in a component-major (SoA) copy
    n3: int
    nx: int
    ns: int
    npairs: int
    npairs_or_one: int
    ncoupled: int  # doubles of mp: coupled entries (one per pair) or max-index generators (2n)
    coupled: bool
    #: the VI's step is the explicit update (the assembler chose the "vi_explicit" partial):
    #: it has its own driver on component-major copies, and no Newton step exists
    explicit_vi: bool
    general: bool
    soa_bridge: bool  # the component-major gradient needs the body-major one for some terms
    uniform_mass: bool
    neighbour_lists: bool
    parameters: tuple[tuple[str, str], ...]  # (name, value as a round-trip literal)
    pair_i: tuple[int, ...]
    pair_j: tuple[int, ...]
    kernels: tuple[PrintedKernel, ...]
    terms: tuple[PrintedTerm, ...]
    call: dict[str, dict[str, str]]  # site -> {"c": ..., "py": ...}
    inline: dict[str, tuple[str, ...]]  # kernel -> its body inline (explicit VI loops)
    work: dict[str, dict[str, Any]]  # layout -> {buffer: offset, "doc": ..., "size": ...}
    context: tuple[dict[str, Any], ...]  # the per-call context buffers (name, offset, doc)
    work_base: int
    work_size: int
    constants: int
    constants_or_one: int
    table_inits: tuple[dict[str, Any], ...]  # per term with a table: index, count, table, call
    py_tables: tuple[str, ...]  # calls computing the terms' member tables (NumPy)
    quadratic: int  # order of the quadratic terms' matrix K (0: none)
    quad_inits: tuple[dict[str, Any], ...]  # per quadratic term: loop, coefficient call, scatter
    py_quad_lines: tuple[str, ...]  # NumPy lines building K and b
    py_table_names: tuple[str, ...]
    c_parts: tuple[str, ...]
    py_parts: tuple[str, ...]
    parts: tuple[str, ...]
    c_macros: tuple[tuple[str, str, str], ...]
    h_macros: tuple[tuple[str, str, str], ...]
    c_tables: tuple[tuple[str, str, int, tuple[str, ...]], ...]
    options: tuple[dict[str, str], ...]
    stats: tuple[dict[str, str], ...]
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
    solver: str  # InertiaKind value of the coupled solves
    band: dict[str, dict[str, int]]  # structured solves: name -> p, r, nrhs, kl, ku, rows, ...
    c_masses: str  # the partial that computes M's entries or generators (C, NumPy)
    py_masses: str
    py_inertia_setup: tuple[str, ...]  # NumPy: the body index and per-body data of M


def print_kernel(kernel: Kernel, restrict: str) -> PrintedKernel:
    """One lowered kernel as text for both languages."""
    c_params, c_lines = c_kernel(kernel, restrict)
    py_params, py_lines = py_kernel(kernel)
    return PrintedKernel(
        name=kernel.name,
        doc=kernel.doc,
        c_params=c_params,
        c_lines=c_lines,
        py_params=py_params,
        py_lines=py_lines,
        ops_before=kernel.ops_before,
        ops_after=kernel.ops_after,
        profile=str(kernel_profile(kernel)),
        temporaries=kernel.temporaries,
    )


_INLINE_SCALARS = ("q", "w", "g", "qn", "gn", "wh")


def _inline(module: Module) -> dict[str, tuple[str, ...]]:
    """The explicit VI kernels' bodies inline, for the SoA loops over bodies: vector operands
    q, w, g, qn, gn are scalars (q0, q1, q2, ...), h by name, outputs qn0.., s0, wn0...;
    "loads" declares their other scalar inputs (the body's mass) as the call sites bind them."""
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
            for arg, bound in zip(kernel.inputs, call.c_args):
                line = f"const double {arg.name} = {bound};"
                if arg.scalar and arg.name != "h" and line not in loads:
                    loads.append(line)
    if out:
        out["loads"] = tuple(loads)
    return out


def _doc(buffers: list[tuple[str, int]]) -> str:
    return ", ".join(f"{name} ({size})" for name, size in buffers if size) or "none"


def _work(module: Module) -> dict[str, dict[str, Any]]:
    work: dict[str, dict[str, Any]] = {}
    for lay in module.layouts:
        entry: dict[str, Any] = {b.name: b.offset for b in lay.buffers}
        entry["doc"] = _doc([(b.name, b.size) for b in lay.buffers])
        entry["size"] = lay.size
        work[lay.name] = entry
    return work


_CONTEXT_DOC = {
    "cc": "constants of the kernels that depend only on the parameters",
    "kq": "the quadratic terms' matrix K (row-major, N3 x N3)",
    "soa": "structure-of-arrays copies of q and g (x, y, z, gx, gy, gz) for the pair rows",
    "kb": "the quadratic terms' linear part b (N3), then their constant",
    "md": "M_ii, one per body",
    "mi": "1 / M_ii, one per body",
    "mp": "coupled entries, one per pair",
    "adiag": "diagonal of A(q+) in the VI velocity solve",
    "nb": "neighbour-list cells and links",
}


def _context_doc(name: str, chain: bool) -> str:
    if name == "mp" and chain:
        return "max-index generators: a (scale), then c, one per body each"
    return _CONTEXT_DOC.get(name, f"term {name[1:]}'s member table")


def _functions(module: Module, prefix: str) -> tuple[dict[str, Any], ...]:
    out = []
    for f in interface(module.kind).functions:
        note = nullable_note(f.params)
        doc = f.doc + (" " + note if note and "NULL" not in f.doc else "")
        out.append({"c_decl": c_decl(prefix, f), "doc_lines": _wrap(doc)})
    return tuple(out)


def _wrap(text: str, width: int = 92) -> tuple[str, ...]:
    lines: list[str] = []
    for word in text.split():
        if lines and len(lines[-1]) + 1 + len(word) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return tuple(lines)


def _fields(module: Module, which: str, prefix: str) -> tuple[dict[str, str], ...]:
    api = interface(module.kind)
    fields = api.options if which == "options" else api.stats
    upper = prefix.upper()
    return tuple(
        {
            "name": f.name,
            "c_decl": c_field_decl(prefix, f),
            "c_default": f"{upper}_{f.default}" if f.default.startswith("CONTROL_") else f.default,
            "py_default": f.default,
            "doc": f.doc.replace("CONTROL_", f"{upper}_CONTROL_"),
        }
        for f in fields
    )


def _enums(module: Module) -> tuple[tuple[tuple[str, int, str], ...], ...]:
    sphere = module.kind is ModuleKind.SPHERE
    names = {m.name for m in METHODS if module.kind.value in m.kinds}
    statuses = [s for s in Status if sphere or s not in (Status.INFEASIBLE, Status.NEWTON)]
    if sphere:
        statuses = [s for s in statuses if s is not Status.POLE]
    meths = tuple(
        (m.c_name, m.code, f"{m.summary}, order {m.order}") for m in METHODS if m.name in names
    )
    return tuple((s.c_name, int(s), s.message) for s in statuses), meths


def _controls(module: Module) -> tuple[tuple[str, int], ...]:
    """The error controls the module's methods offer, (enum suffix, code = index in CONTROLS)."""
    offered = {c for m in METHODS if module.kind.value in m.kinds for c in m.controls}
    return tuple((c.upper(), i) for i, c in enumerate(CONTROLS) if c in offered)


def _masses_parts(module: Module) -> tuple[str, str]:
    """(C, NumPy) partials of the masses: M's entries from one system kernel, the
    max-index generators from one system kernel, or from a per-body kernel in a loop."""
    names = {k.name for k in module.kernels}
    if "inertia_body" in names and module.solver is InertiaKind.DIAGONAL:
        stem = "masses_body_diagonal"
    elif "inertia_body" in names:
        stem = "masses_body"
    elif module.solver is InertiaKind.MAX_INDEX:
        stem = "masses_generators"
    else:
        stem = "masses"
    return f"c/_{stem}.jinja", f"numpy/_{stem}.jinja"


def _inertia_tables(
    module: Module,
) -> tuple[list[tuple[str, str, int, tuple[str, ...]]], tuple[str, ...]]:
    """C tables and NumPy arrays of the per-body data of M (and NumPy's body index)."""
    c_tables = []
    py = []
    if (
        module.inertia_data
        or module.kind is ModuleKind.SPHERE
        and any(k.name == "inertia_body" for k in module.kernels)
    ):
        py.append("INDEX = numpy.arange(1.0, NBODIES + 1.0)")
    for name, values in module.inertia_data:
        lits = [repr(float(v)) for v in values]
        c_tables.append(("double", f"{module.name}_inertia_{name}", len(values), rows(lits)))
        py.append(f"INERTIA_{name.upper()} = numpy.array([{', '.join(lits)}])")
    return c_tables, tuple(py)


def _bands(module: Module) -> dict[str, dict[str, int]]:
    return {
        b.name: {
            "p": b.p,
            "r": b.r,
            "nrhs": b.nrhs,
            "block": b.block,
            "rows": b.rows,
            "kl": b.kl,
            "ku": b.ku,
            "size": b.size,
        }
        for b in module.bands
    }


def _compositions() -> tuple[dict[str, Any], ...]:
    """The step fractions of every composition a geometric method uses, as literals."""
    used = {m.composition for m in METHODS if m.composition is not None}
    return tuple(
        {
            "name": c.name,
            "source": c.source,
            "order": c.order,
            "count": len(c.fractions),
            "fractions": tuple(repr(g) for g in c.fractions),
        }
        for c in COMPOSITIONS
        if c in used
    )


def _schemes() -> tuple[dict[str, Any], ...]:
    """Per geometric method: its enum constant, whether its basic step is RATTLE's (else the
    VI's), and its composition's table and length."""
    return tuple(
        {
            "c_name": m.c_name,
            "rattle": int(m.family is Family.RATTLE),
            "count": len(m.composition.fractions),
            "table": m.composition.name,
        }
        for m in METHODS
        if m.composition is not None
    )


def print_module(module: Module) -> PrintedModule:
    """Print every part of a lowered module for both languages."""
    name, upper = module.name, module.name.upper()
    sphere = module.kind is ModuleKind.SPHERE
    restrict = f"{upper}_RESTRICT"
    calls = {c.site: {"c": c_call(name, c), "py": py_call(c)} for c in module.calls}
    inline = _inline(module)
    kernels = tuple(
        replace(print_kernel(k, restrict), c_function=k.name not in inline)
        for k in module.kernels
        if isinstance(k, Kernel)
    )
    terms = tuple(print_term(module, t, calls) for t in module.terms)
    tables: list[tuple[str, str, int, tuple[str, ...]]] = []
    if module.coupling is not None:
        for r, role in enumerate(("i", "j")):
            idx = [str(p[r]) for p in module.pairs]
            tables.append(("int", f"{name}_pair_{role}", len(idx), rows(idx, 16)))
    for t in module.terms:
        tables += c_term_tables(name, t)
    inertia_tables, py_inertia = _inertia_tables(module)
    tables += inertia_tables
    c_masses, py_masses = _masses_parts(module)
    facts = dict(module.facts)
    n, npairs = module.n, len(module.pairs)
    chain = module.solver is InertiaKind.MAX_INDEX
    coupled_pairs = n * (n - 1) // 2 if chain else npairs
    statuses, meths = _enums(module)
    context = module.layout(CONTEXT)
    c_macros: tuple[tuple[str, str, str], ...]
    h_macros: tuple[tuple[str, str, str], ...]
    if sphere:
        c_macros = (
            ("N3", str(3 * n), "doubles in q (or w): 3 per body"),
            ("NS", str(6 * n), "doubles in the state y = (q, w)"),
            ("LD3", str(padded(3 * n)), "row stride of the dense N3 x N3 systems"),
            ("LDN", str(padded(n)), "row stride of the dense n x n systems"),
            ("LD_MAX", str(padded(3 * n)), "the largest row stride"),
        )
        h_macros = (
            ("NBODIES", str(n), "bodies"),
            ("NSTATE", str(3 * n), "doubles in q (and in w): 3 per body, body-major"),
            ("NPARAMS", str(len(module.parameter_names)), "parameters in p"),
            ("NPAIRS", str(coupled_pairs), "coupled pairs of M (off-diagonal entries not zero)"),
            ("NCONST", str(module.constants), "constants of the kernels (computed once per call)"),
            ("WORK_BASE", str(module.work_base), "workspace doubles before the per-call context"),
            ("WORK_SIZE", str(module.work_size), "workspace doubles every `work` must hold"),
        )
    else:
        c_macros = (
            ("NS", str(4 * n), "doubles in the state y = (x, xd)"),
            ("LDX", str(padded(2 * n)), "row stride of the dense NX x NX system"),
            ("LD_MAX", str(padded(2 * n)), "the largest row stride"),
        )
        h_macros = (
            ("NBODIES", str(n), "bodies"),
            ("NX", str(2 * n), "angles (and rates): theta_i, phi_i per body"),
            ("NPARAMS", str(len(module.parameter_names)), "parameters in p"),
            ("WORK_SIZE", str(module.work_size), "workspace doubles every `work` must hold"),
            ("POLE_TOL", str(facts["pole_tol"]), "sin theta below this is at a pole"),
            ("MIN_PIVOT_RATIO", str(facts["min_pivot_ratio"]), "M(x) singular below this"),
        )
    return PrintedModule(
        kind=module.kind.value,
        name=name,
        upper=upper,
        spec_hash=module.spec_hash,
        origin=module.origin,
        n=n,
        n2=2 * n,
        n3=3 * n,
        nx=2 * n,
        ns=6 * n if sphere else 4 * n,
        npairs=npairs,
        npairs_or_one=max(npairs, 1),
        ncoupled=2 * n if module.solver is InertiaKind.MAX_INDEX else max(npairs, 1),
        coupled=bool(facts.get("coupled", False)),
        explicit_vi="vi_explicit" in module.parts,
        general=bool(facts.get("general", False)),
        soa_bridge=module.body_major_terms,
        uniform_mass=bool(facts.get("uniform_mass", False)),
        neighbour_lists=bool(facts.get("neighbour_lists", False)),
        parameters=tuple(
            (p, repr(float(v))) for p, v in zip(module.parameter_names, module.parameter_values)
        ),
        pair_i=tuple(i for i, _ in module.pairs),
        pair_j=tuple(j for _, j in module.pairs),
        kernels=kernels,
        terms=terms,
        call=calls,
        inline=inline,
        work=_work(module),
        context=tuple(
            {"name": b.name, "offset": b.offset, "doc": _context_doc(b.name, chain)}
            for b in context.buffers
        ),
        work_base=module.work_base,
        work_size=module.work_size,
        constants=module.constants,
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
        py_table_names=tuple(f"tab{t.index}" for t in module.terms if t.table),
        quadratic=module.quadratic,
        quad_inits=tuple(quad_init(module, t, calls) for t in module.terms if t.quadratic),
        py_quad_lines=tuple(
            line for t in module.terms if t.quadratic for line in py_quad_lines(t, calls, module.n)
        ),
        c_parts=tuple(f"c/_{p}.jinja" for p in module.parts),
        py_parts=tuple(f"numpy/_{p}.jinja" for p in module.parts if p not in module.c_only),
        parts=module.parts,
        c_macros=c_macros,
        h_macros=h_macros,
        c_tables=tuple(tables),
        options=_fields(module, "options", name),
        stats=_fields(module, "stats", name),
        functions=_functions(module, name),
        statuses=statuses,
        methods=meths,
        passes=module.passes,
        compositions=_compositions(),
        schemes=_schemes(),
        dop853=print_tableau(DOP853),
        dopri5=print_pair(DOPRI5),
        explicit=tuple(
            print_explicit(t, f"{upper}_NS") for t in explicit_tableaus(module.kind.value)
        ),
        fixed=print_fixed(module.kind.value),
        controls=_controls(module),
        evals="gradient_evals" if sphere else "rhs_evals",
        state_doc="(q, omega)" if sphere else "(x, xd)",
        py_doc_title=(
            f'Equations of motion and integrators for the system "{name}" on (S^2)^{n} (NumPy).'
            if sphere
            else f'The classical spherical-angle form of the system "{facts.get("system", name)}" '
            f"({n} bodies), NumPy."
        ),
        py_doc_state=(
            f"States are arrays q, w of shape ({n}, 3)."
            if sphere
            else f"Body i has the angles (theta_i, phi_i) and q_i = (sin theta_i cos phi_i, "
            f"sin theta_i sin phi_i, cos theta_i); SymPy derived M(x) xdd = F(x, xd) from "
            f"L = 1/2 sum_ij M_ij qdot_i . qdot_j - V(q) ({facts.get('derivation', '')}). States "
            f"x = (theta_1, phi_1, ...) and xd are arrays of {2 * n}. Where sin theta_i = 0 "
            "phi_i is arbitrary and M(x) singular: to_angles returns ERR_POLE when sin theta_i < "
            "POLE_TOL, rhs returns ERR_SINGULAR when min |pivot| <= MIN_PIVOT_RATIO max |pivot|."
        ),
        generator_version=__version__,
        system=str(facts.get("system", name)),
        derivation=str(facts.get("derivation", "")),
        pole_tol=str(facts.get("pole_tol", "")),
        min_pivot_ratio=str(facts.get("min_pivot_ratio", "")),
        solver=module.solver.value,
        band=_bands(module),
        c_masses=c_masses,
        py_masses=py_masses,
        py_inertia_setup=py_inertia,
    )
