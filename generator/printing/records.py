"""The language-neutral records of a printed module: kernels, workspace, enums, solves, methods
(the partials of its optional sections: `s2gen.printing.sections`).

Input: a lowered `Module` (IR) and the tables of `s2gen.methods`. Output: frozen records,
numbers and small dicts that `print_module` gathers into the `PrintedModule` (the text of each
language comes from `printing/c.py`, `printing/c_module.py` and `printing/numpy.py`).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> work = workspace(lower_system(builtin("double_pendulum")))
    >>> work["rk_step"]["doc"]
    'y0 (12), yt (12), rk (102)'
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.ir import Kernel, Module, ModuleKind
from s2gen.methods import COMPOSITIONS, CONTROLS, METHODS, Family, Status
from s2gen.passes.opcount import kernel_profile
from s2gen.passes.workspace import CONTEXT
from s2gen.printing.c import c_kernel
from s2gen.printing.numpy import py_kernel

__all__ = [
    "PrintedKernel",
    "bands",
    "compositions",
    "context",
    "controls",
    "enums",
    "masses_partials",
    "print_kernel",
    "schemes",
    "workspace",
]


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


def print_kernel(kernel: Kernel, restrict: str) -> PrintedKernel:
    """One lowered kernel as text for both languages.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> print_kernel(m.kernel("kin_body"), "R").py_params
        'm, q, w'
    """
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


def workspace(module: Module) -> dict[str, dict[str, Any]]:
    """Per workspace layout but the per-call context (see `context`): each buffer's offset,
    the layout's `doc` (its buffers and sizes) and its `size`."""
    work: dict[str, dict[str, Any]] = {}
    for lay in module.layouts:
        if lay.name == CONTEXT:
            continue  # laid out by `context`
        entry: dict[str, Any] = {b.name: b.offset for b in lay.buffers}
        sized = [f"{b.name} ({b.size})" for b in lay.buffers if b.size]
        entry["doc"] = ", ".join(sized) or "none"
        entry["size"] = lay.size
        work[lay.name] = entry
    return work


_CONTEXT_DOC = {
    "cc": "constants of the kernels that depend only on the parameters",
    "kq": "the quadratic terms' matrix K (row-major, N3 x N3, from a 64-byte boundary)",
    "soa": "structure-of-arrays copies of q and g (x, y, z, gx, gy, gz) for the pair rows",
    "kb": "the quadratic terms' linear part b (N3), then their constant",
    "md": "M_ii, one per body",
    "mi": "1 / M_ii, one per body",
    "mp": "coupled entries, one per pair",
    "adiag": "diagonal of A(q+) in the VI velocity solve",
    "nb": "neighbour-list cells and links",
}


def context(module: Module) -> tuple[dict[str, Any], ...]:
    """The per-call context buffers: name, offset and what each holds.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> context(m)[0]
        {'name': 'md', 'offset': 0, 'doc': 'M_ii, one per body'}
    """
    chain = module.solver is InertiaKind.MAX_INDEX
    out = []
    for b in module.layout(CONTEXT).buffers:
        doc = _CONTEXT_DOC.get(b.name, f"term {b.name[1:]}'s member table")
        if b.name == "mp" and chain:
            doc = "max-index generators: a (scale), then c, one per body each"
        out.append({"name": b.name, "offset": b.offset, "doc": doc})
    return tuple(out)


Enum = tuple[tuple[str, int, str], ...]


def enums(module: Module) -> tuple[Enum, Enum]:
    """(statuses, methods) of a module kind: (C name, code, comment) each.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> statuses, methods = enums(m)
        >>> statuses[0], methods[0][:2]
        (('OK', 0, 'success'), ('METHOD_VI', 0))
    """
    sphere = module.kind is ModuleKind.SPHERE
    names = {m.name for m in METHODS if module.kind.value in m.kinds}
    statuses = [s for s in Status if sphere or s not in (Status.INFEASIBLE, Status.NEWTON)]
    if sphere:
        statuses = [s for s in statuses if s is not Status.POLE]
    meths = tuple(
        (m.c_name, m.code, f"{m.summary}, order {m.order}") for m in METHODS if m.name in names
    )
    return tuple((s.c_name, int(s), s.message) for s in statuses), meths


def controls(module: Module) -> tuple[tuple[str, int], ...]:
    """The error controls the module's methods offer: (enum suffix, code = index in CONTROLS).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> controls(lower_system(builtin("double_pendulum")))
        (('MATLAB', 0), ('HAIRER', 1))
    """
    offered = {c for m in METHODS if module.kind.value in m.kinds for c in m.controls}
    return tuple((c.upper(), i) for i, c in enumerate(CONTROLS) if c in offered)


def masses_partials(module: Module) -> tuple[str, str]:
    """(C, NumPy) partials of the masses: M's entries from one system kernel (NumPy: with or
    without the coupled entries), the max-index generators from one system kernel, or from a
    per-body kernel in a loop.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("double_pendulum"))
        >>> masses_partials(m)
        ('c/_masses.jinja', 'numpy/_masses_coupled.jinja')
    """
    names = {k.name for k in module.kernels}
    c_stem = py_stem = "masses"
    if "inertia_body" in names and module.solver is InertiaKind.DIAGONAL:
        c_stem = py_stem = "masses_body_diagonal"
    elif "inertia_body" in names:
        c_stem = py_stem = "masses_body"
    elif module.solver is InertiaKind.MAX_INDEX:
        c_stem = py_stem = "masses_generators"
    elif module.solver is not InertiaKind.DIAGONAL:
        py_stem = "masses_coupled"  # C fills mp in place either way
    return f"c/_{c_stem}.jinja", f"numpy/_{py_stem}.jinja"


def bands(module: Module) -> dict[str, dict[str, int]]:
    """Per structured solve: its block and band sizes.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("rope"))
        >>> bands(m)["newton"]["kl"], bands(m)["newton"]["rows"]
        (6, 120)
    """
    keys = ("p", "r", "nrhs", "block", "rows", "kl", "ku", "size")
    return {b.name: {k: getattr(b, k) for k in keys} for b in module.bands}


def compositions() -> tuple[dict[str, Any], ...]:
    """The step fractions of every composition a geometric method uses, as literals.

    Example:
        >>> compositions()[0]["name"], compositions()[0]["fractions"]
        ('plain', ('1.0',))
    """
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


def schemes() -> tuple[dict[str, Any], ...]:
    """Per geometric method: its enum constant, whether its basic step is RATTLE's (else the
    VI's; as C's 0 or 1 and NumPy's False or True), and its composition's table and length.

    Example:
        >>> schemes()[0]
        {'c_name': 'METHOD_VI', 'rattle': 0, 'py_rattle': 'False', 'count': 1, 'table': 'plain'}
    """
    return tuple(
        {
            "c_name": m.c_name,
            "rattle": int(m.family is Family.RATTLE),
            "py_rattle": repr(m.family is Family.RATTLE),
            "count": len(m.composition.fractions),
            "table": m.composition.name,
        }
        for m in METHODS
        if m.composition is not None
    )
