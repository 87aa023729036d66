"""Print a module's structured terms: their loops, calls, tables and gradient scatters.

Input: a lowered `Module`, one of its `TermLoop`s and the printed call sites (site ->
{"c": ..., "py": ...}). Output: a `PrintedTerm` per term (and the quadratic terms' K
assembly), built from the C printer's and the NumPy printer's term functions; the loop shape
follows the term's `s2gen.terms.Selection`.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> from s2gen.printing import print_module
    >>> print_module(lower_system(builtin("dipoles"))).terms[0].doc
    'term 0, dipole-dipole: sum over pairs (list)'
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from s2gen.bindings import BodyDatum
from s2gen.ir import Kernel, Module, TermLoop
from s2gen.printing.c import (
    c_inline,
    c_loop,
    c_quad_scatter,
    c_term_gradient,
    c_term_row,
)
from s2gen.printing.c_calls import c_binding
from s2gen.printing.c_fission import SplitRows, c_split_rows
from s2gen.printing.numpy import py_quad, py_term_gradient, py_term_setup
from s2gen.terms import body_names

__all__ = [
    "PrintedTerm",
    "c_cells_data",
    "c_rows_data",
    "c_table_loop",
    "print_term",
    "py_quad_lines",
    "quad_init",
]


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
    c_value_call: str
    c_gradient_call: str
    c_table_lines: tuple[str, ...]
    c_rows_value: tuple[str, ...]  # the kernels inline, for the rows layout
    c_rows_gradient: tuple[str, ...]
    c_rows_constants: tuple[str, ...]  # the context constants they read (c<k>)
    c_rows_constants_gradient: tuple[str, ...]
    c_rows_data_value: tuple[tuple[str, ...], ...]  # (row i, partner j) per-body data reads
    c_rows_data_gradient: tuple[tuple[str, ...], ...]
    c_rows_split: SplitRows | None  # the rows gradient split at its calls (`TermLoop.fission`)
    c_rows_prelude: tuple[str, ...]  # lines before the row loop (the split's buffers)
    c_rows_partners_part: str  # the partial of the partner loop(s): split or one pass
    c_gradient_locals: str
    c_gradient_accumulate: tuple[str, ...]
    py_setup: tuple[str, ...]
    py_value_part: str
    py_gradient_part: str
    py_value_call: str
    py_gradient_call: str
    py_gradient_accumulate: tuple[str, ...]
    py_index: tuple[str, ...]
    #: sorted cells (`TermLoop.sorted_cells`): the sorted copies of the per-body numbers in
    #: the cell storage (declarations), the copy of body k's numbers to sorted place s, and
    #: (row i, partner j) reads of them for the inlined gradient kernel
    c_cells_buffers: tuple[str, ...]
    c_cells_copy: tuple[str, ...]
    c_cells_data: tuple[tuple[str, ...], ...]
    cutoff: str  # round-trip literal of the cutoff distance ("" without cutoff)
    rc2: str  # its square
    cells: int  # neighbour-list cells per axis


def c_rows_data(prefix: str, t: TermLoop, kernel: Kernel) -> tuple[tuple[str, ...], ...]:
    """(declarations for body i, for body j) of the per-body data an inlined rows kernel
    reads, as its argument names b_<datum>i and b_<datum>j: a number, or a pointer to the
    body's 3-vector.

    Example:
        >>> import sympy as sp
        >>> from s2gen.ir import Argument, Loop, LoopKind
        >>> t = TermLoop(0, Loop(LoopKind.ALL_PAIRS, 1), (), "v", "g", body_data=(("c", 1, 1),))
        >>> k = Kernel("v", "", (Argument("b_cj", (sp.Symbol("cj"),), scalar=True),), (), (), 0, 0)
        >>> c_rows_data("s", t, k)
        ((), ('const double b_cj = s_data_c[j];',))
    """
    kind = t.loop.kind.kind
    read = {a.name for a in kernel.inputs}
    out: tuple[list[str], list[str]] = ([], [])
    for name, width, r in t.body_data:
        arg = f"b_{body_names(name, kind)[r]}"
        if arg in read:
            at = c_binding(prefix, BodyDatum(t.index, name, width, kind.indices[r]))
            decl = f"const double {arg}" if width == 1 else f"const double *const {arg}"
            out[r].append(f"{decl} = {at};")
    return tuple(out[0]), tuple(out[1])


def c_cells_data(
    prefix: str, t: TermLoop, n: int
) -> tuple[tuple[str, ...], tuple[str, ...], tuple[tuple[str, ...], ...]]:
    """(buffer declarations, copy lines, (row reads, partner reads)) of the per-body numbers a
    sorted-cells term reads: datum number d is copied to cl_d<d>, n doubles after the sorted
    gradient (cl_gz) or the previous copy.

    Example:
        >>> from s2gen.ir import Loop, LoopKind
        >>> t = TermLoop(0, Loop(LoopKind.CUTOFF_PAIRS, 1), (), "v", "g",
        ...              body_data=(("c", 1, 0), ("c", 1, 1)))
        >>> buffers, copy, reads = c_cells_data("s", t, 4)
        >>> buffers, copy, reads
        (('double *const cl_d0 = cl_gz + 4;',), ('cl_d0[s] = s_data_c[k];',), (('const double b_ci = cl_d0[i];',), ('const double b_cj = cl_d0[j];',)))
    """
    kind = t.loop.kind.kind
    names = list(dict.fromkeys(name for name, _, _ in t.body_data))
    buffers, copy = [], []
    for d, name in enumerate(names):
        before = f"cl_d{d - 1}" if d else "cl_gz"
        buffers.append(f"double *const cl_d{d} = {before} + {n};")
        copy.append(f"cl_d{d}[s] = {c_binding(prefix, BodyDatum(t.index, name, 1, 'k'))};")
    reads: tuple[list[str], list[str]] = ([], [])
    for name, _, r in t.body_data:
        arg = f"b_{body_names(name, kind)[r]}"
        reads[r].append(f"const double {arg} = cl_d{names.index(name)}[{'ij'[r]}];")
    return tuple(buffers), tuple(copy), (tuple(reads[0]), tuple(reads[1]))


def print_term(module: Module, t: TermLoop, calls: dict[str, Any]) -> PrintedTerm:
    """One term of `module` as text for both languages (`calls`: the printed call sites)."""
    selection = t.loop.kind
    fixed = selection.fixed
    c_open, c_close = c_loop(module.name, t, module.n) if fixed else ((), ())
    locals_, acc = c_term_gradient(selection.kind)
    setup, index = py_term_setup(t)
    value, gradient = calls[f"t{t.index}_value"], calls[f"t{t.index}_gradient"]
    suffix = "_cutoff" if not fixed else "_quadratic" if t.quadratic else "_rows" if t.rows else ""
    rows_value = rows_gradient = constants_value = constants_gradient = ()
    data_value: tuple[tuple[str, ...], ...] = ((), ())
    data_gradient = data_value
    cells_buffers: tuple[str, ...] = ()
    cells_copy: tuple[str, ...] = ()
    cells_data: tuple[tuple[str, ...], ...] = ((), ())
    split: SplitRows | None = None
    if t.sorted_cells:
        gradient_kernel = module.kernel(t.gradient)
        assert isinstance(gradient_kernel, Kernel)
        constants_gradient, rows_gradient = c_inline(gradient_kernel)
        cells_buffers, cells_copy, cells_data = c_cells_data(module.name, t, module.n)
    if t.rows:
        value_kernel, gradient_kernel = module.kernel(t.value), module.kernel(t.gradient)
        assert isinstance(value_kernel, Kernel) and isinstance(gradient_kernel, Kernel)
        constants_value, rows_value = c_inline(value_kernel)
        constants_gradient, rows_gradient = c_inline(gradient_kernel)
        data_value = c_rows_data(module.name, t, value_kernel)
        data_gradient = c_rows_data(module.name, t, gradient_kernel)
        if t.fission is not None:
            split = c_split_rows(t.fission, gradient_kernel, data_gradient[1], module.n)
    label = module.kernel(t.value).doc.split(":")[0]
    table_lines = c_term_row(t, calls[f"t{t.index}_table"]["c"]) if t.table else ()
    return PrintedTerm(
        index=t.index,
        doc=f"term {t.index}, {label}: {selection.doc}",
        count=t.loop.count,
        c_open=c_open,
        c_close=c_close,
        c_value_part=f"c/_term_value{suffix}.jinja",
        c_gradient_part=f"c/_term_gradient{'_cells' if t.sorted_cells else suffix}.jinja",
        c_value_call=value["c"],
        c_gradient_call=gradient["c"],
        c_table_lines=table_lines,
        c_rows_value=rows_value,
        c_rows_gradient=rows_gradient,
        c_rows_constants=constants_value,
        c_rows_constants_gradient=constants_gradient,
        c_rows_data_value=data_value,
        c_rows_data_gradient=data_gradient,
        c_rows_split=split,
        c_rows_prelude=split.prelude if split else (),
        c_rows_partners_part=(
            "c/sections/_rows_partners_split.jinja" if split else "c/sections/_rows_partners.jinja"
        ),
        c_gradient_locals=locals_,
        c_gradient_accumulate=acc,
        py_setup=setup,
        py_value_part=f"numpy/_term_value{suffix}.jinja",
        py_gradient_part=f"numpy/_term_gradient{suffix}.jinja",
        py_value_call=value["py"],
        py_gradient_call=gradient["py"],
        py_gradient_accumulate=py_term_gradient(t, gradient["py"]),
        py_index=index,
        c_cells_buffers=cells_buffers,
        c_cells_copy=cells_copy,
        c_cells_data=cells_data,
        cutoff="" if t.loop.cutoff is None else repr(float(t.loop.cutoff)),
        rc2="" if t.loop.cutoff is None else repr(float(t.loop.cutoff) ** 2),
        cells=t.loop.cells,
    )


def quad_init(module: Module, t: TermLoop, calls: dict[str, Any]) -> dict[str, Any]:
    """C text adding one quadratic term's members into K and b (once per call)."""
    c_open, c_close = c_loop(module.name, t, module.n)
    return {
        "c_open": c_open,
        "c_close": c_close,
        "slots": len(t.quadratic),
        "call": calls[f"t{t.index}_quad"]["c"],
        "scatter": c_quad_scatter(t, module.n),
    }


def py_quad_lines(t: TermLoop, calls: dict[str, Any], n: int) -> tuple[str, ...]:
    """NumPy lines adding one quadratic term's members into K and kb (component-major)."""
    return py_quad(t, calls[f"t{t.index}_quad"]["py"], n)


def c_table_loop(module: Module, t: TermLoop) -> dict[str, Any]:
    """The loop computing a term's member table in the context (once per call): over the
    members m, with their bodies i (and j) when the table reads per-body data.

    Example:
        >>> from s2gen.spec import define_system
        >>> from s2gen.passes import lower_system
        >>> s = define_system(name="tl", bodies=3, diagonal="1", data={"c": [1.0, 2.0, 3.0]},
        ...                   pair_terms=[{"V": "k*ci*cj*dot(qi, qj)", "pairs": "chain"}],
        ...                   parameters={"k": 1.0})
        >>> m = lower_system(s)
        >>> c_table_loop(m, m.terms[0])["open"][-1].strip()
        'const long i = m, j = m + 1;'
    """
    call = next(c for c in module.calls if c.site == f"t{t.index}_table")
    if any(isinstance(b, BodyDatum) for b in call.inputs):
        c_open, c_close = c_loop(module.name, t, module.n)
        return {"open": c_open, "close": c_close, "indent": " " * 12}
    head = f"    for (m = 0; m < {t.loop.count}; ++m) {{"
    return {"open": (head,), "close": ("    }",), "indent": " " * 8}
