"""The language-neutral records of a printed module: kernels, workspace, enums, solves, methods.

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
from s2gen.parts.batch import has_chain_lanes, numpy_batch_refusal
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
    "sections",
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


Sections = dict[str, tuple[str, ...]]

#: The partials that lay out each optional section (C, NumPy): a module declares a section
#: only when it lays out one of them.
_OWNERS: tuple[dict[str, tuple[str, ...]], dict[str, tuple[str, ...]]] = (
    {
        "masses_locals": ("masses", "masses_generators"),
        "masses_fill": ("masses", "masses_generators"),
        "potential": ("potential",),
        "gradient": ("potential",),
        "soa_locals": ("vi_explicit",),
        "soa_init": ("vi_explicit",),
        "soa_bridge": ("vi_explicit",),
        "bridge_init": ("soa_bridge",),
        "constants": ("context",),
        "quadratic_builder": ("context",),
        "quadratic_build": ("context",),
        "table_locals": ("context",),
        "params_unused": ("context", "angles_context"),
        "step_strides": ("step",),
        "geometric_doc": ("driver",),
        "geometric_locals": ("driver",),
        "geometric_vi": ("driver",),
        "explicit_driver": ("driver",),
        "explicit_dispatch": ("driver",),
        "transformed_dispatch": ("driver",),
        "transformed_decl": ("driver",),
        "initial_table": ("context",),
        "initial_state": ("context",),
        "context_fields": ("context",),
        "context_defaults": ("context",),
        "drive_tables": ("context",),
        "drive_force": ("driven",),
        "drive_start": ("driven",),
        "drive_end": ("driven",),
        "drive_stage": ("driven",),
        "drive_operator": ("drive_force_fns",),
        "jacobian_vi": ("jacobian",),
        "jacobian_rattle": ("jacobian",),
        "batch_gradient": ("batch",),
        "batch_field": ("batch",),
        "batch_layout": ("batch",),
        "batch_dense": ("batch",),
        "batch_vi": ("batch",),
        "batch_rattle": ("batch",),
        "batch_quadratic": ("batch_gradient_lanes",),
        "batch_quadratic_field": ("batch",),
        "batch_quadratic_share": ("batch",),
        "quadratic_locals": ("quadratic",),
        "quadratic_store": ("quadratic",),
        "batch_quadratic_locals": ("batch_quadratic_lanes",),
        "batch_quadratic_store": ("batch_quadratic_lanes",),
    },
    {
        "masses_fill": ("masses", "masses_coupled", "masses_generators"),
        "constants": ("potential",),
        "potential": ("potential",),
        "gradient": ("potential",),
        "batch": ("batch",),
        "batch_field": ("batch_members",),
        "imports": ("module",),
        "initial_state": ("context",),
        "drive_tables": ("module",),
        "drive_force": ("driven",),
        "drive_operator": ("driven",),
        "vi_operator": ("vi_newton",),
        "transformed_dispatch": ("driver",),
        "drive_start": ("driven",),
        "drive_end": ("driven",),
        "drive_stage": ("driven",),
        "jacobian_vi": ("jacobian",),
        "jacobian_rattle": ("jacobian",),
    },
)


def _declared(chosen: Sections, owners: dict[str, tuple[str, ...]], laid: set[str]) -> Sections:
    """The sections whose owner is laid out (a section's own partials may own others)."""
    out: Sections = {}
    for name, partials in chosen.items():
        if set(owners[name]) & laid:
            out[name] = partials
            laid |= {p.rsplit("/_", 1)[1].removesuffix(".jinja") for p in partials}
    return out


def _lane_gradient(module: Module) -> Any:
    from s2gen.printing.c_batch import lane_gradient  # the batch printer imports this module's

    return lane_gradient(module)


def _coupled_field(module: Module) -> Any:
    from s2gen.printing.c_batch import coupled_field

    return coupled_field(module)


def sections(module: Module) -> tuple[Sections, Sections]:
    """(C, NumPy) partials of each optional section of the parts the module lays out, chosen
    by what it has: the general potential or zeros, the quadratic terms' K, the kernels'
    constants, M's uniform diagonal, the explicit VI's body-major bridge, member tables, what
    step() carries of Newton's solutions, parameters and the library solvers it imports. A template lays out a section's partials
    in order.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("dipoles"))
        >>> c, py = sections(m)
        >>> py["potential"]
        ('numpy/sections/_zero_value.jinja', 'numpy/sections/_quadratic_value.jinja')
    """
    facts = dict(module.facts)
    general, quadratic = bool(facts.get("general", False)), module.quadratic > 0
    uniform, bridge = bool(facts.get("uniform_mass", False)), module.body_major_terms
    coupled = bool(facts.get("coupled", False))  # the VI and RATTLE steps iterate (Newton)
    explicit = "vi_explicit" in module.parts  # the VI has its own driver (component-major)
    initial = bool(module.initial_state)  # the spec's initial state is carried
    driven = module.drive is not None  # time and inputs in the context, the driven driver
    forces = driven and module.drive is not None and module.drive.forces
    batch = "batch" in module.parts  # integrate_batch(): dV/dq in lane loops where it can be
    lanes = batch and explicit and _lane_gradient(module) is not None
    field = batch and not explicit and _coupled_field(module) is not None  # a dense M's, in lanes
    dense_vi = "vi_newton" in module.parts  # and its Newton VI in lanes too
    chain = has_chain_lanes(module)  # a max-index M's VI: its block solves in lanes
    dense_rattle = field and "rattle_newton" in module.parts  # and its RATTLE
    shared_k = (lanes or field) and quadratic  # Kx + b in lanes where the lanes share K
    linear = any(c < 0 <= r for t in module.terms for _, r, c in t.quadratic)  # b not zero
    rattle_jacobian = any(k.name == "rattle_jacobian" for k in module.kernels)
    members = batch and numpy_batch_refusal(module) is None  # NumPy's integrate_batch()

    def pick(lang: str, *choices: tuple[bool, str]) -> tuple[str, ...]:
        return tuple(f"{lang}/sections/_{stem}.jinja" for chosen, stem in choices if chosen)

    c = {
        "masses_locals": pick("c", (uniform, "uniform_locals")),
        "masses_fill": pick("c", (uniform, "uniform_fill")),
        "potential": pick("c", (general, "general_value"), (quadratic, "quadratic_value")),
        "gradient": pick(
            "c",
            (general, "general_gradient"),
            (not general, "zero_gradient"),
            (quadratic, "quadratic_gradient"),
        ),
        "soa_locals": pick(
            "c",
            (bridge or not quadratic, "soa_counter"),
            (bridge, "soa_bridge_locals"),
            (not bridge, "soa_no_bridge"),
        ),
        "soa_init": pick("c", (quadratic, "soa_quadratic"), (not quadratic, "soa_zero")),
        "soa_bridge": pick("c", (bridge, "soa_bridge")),
        "bridge_init": pick("c", (general, "general_gradient"), (not general, "bridge_zero")),
        "constants": pick("c", (module.constants > 0, "constants")),
        "quadratic_builder": pick("c", (quadratic, "build_quadratic")),
        "quadratic_build": pick("c", (quadratic, "build_quadratic_call")),
        "table_locals": pick("c", (any(t.table for t in module.terms), "table_counter")),
        "params_unused": pick("c", (not module.parameter_names, "unused_params")),
        "step_strides": pick(
            "c", (coupled, "step_strides_newton"), (not coupled, "step_strides_explicit")
        ),
        "geometric_doc": pick(
            "c", (not explicit, "geometric_doc_newton"), (explicit, "geometric_doc_explicit")
        ),
        "geometric_locals": pick("c", (not explicit, "geometric_newton_locals")),
        "geometric_vi": pick("c", (not explicit, "geometric_vi_branch")),
        "explicit_driver": pick("c", (explicit, "integrate_explicit")),
        "explicit_dispatch": pick("c", (explicit, "explicit_dispatch")),
        "transformed_dispatch": pick("c", ("transformed" in module.parts, "transformed_dispatch")),
        "transformed_decl": pick("c", ("transformed" in module.parts, "transformed_decl")),
        "initial_table": pick("c", (initial, "initial_table")),
        "initial_state": pick(
            "c", (initial, "initial_state_copy"), (not initial, "initial_state_none")
        ),
        "context_fields": pick("c", (driven, "tu_field")),
        "context_defaults": pick("c", (driven, "tu_defaults")),
        "drive_tables": pick("c", (driven, "tu_table")),
        "drive_force": pick("c", (forces, "drive_force_fns")),
        "drive_operator": pick(
            "c", (coupled, "drive_operator_dense"), (not coupled, "drive_operator_diagonal")
        ),
        "drive_start": pick("c", (forces, "drive_start_force")),
        "drive_end": pick("c", (forces, "drive_end_force")),
        "drive_stage": pick("c", (forces, "drive_stage_force")),
        # the step Jacobians of the VI family
        "jacobian_vi": pick(
            "c", (any(k.name == "vi_jacobian" for k in module.kernels), "jacobian_vi")
        ),
        "jacobian_rattle": pick(
            "c",
            (rattle_jacobian, "jacobian_rattle"),
            (rattle_jacobian and not driven, "jacobian_rattle_closed"),
            (rattle_jacobian and driven, "jacobian_rattle_driven"),
        ),
        # integrate_batch(): dV/dq and the field in loops over the lanes, or lane by lane
        "batch_gradient": pick(
            "c",
            (lanes or field, "batch_gradient_lanes"),
            (batch and explicit and not lanes, "batch_gradient_each"),
        ),
        "batch_field": pick(
            "c",
            (lanes, "batch_field_lanes"),
            (field, "batch_field_coupled"),
            (batch and not lanes and not field, "batch_field_each"),
        ),
        # a coupled M: the lanes hold every state body-major; the Newton VI in loops over the
        # lanes with a dense M (its field in lanes too), else lane by lane
        "batch_layout": pick(
            "c",
            (batch and explicit, "batch_layout_soa"),
            (batch and not explicit, "batch_layout_body"),
        ),
        "batch_dense": pick("c", (field, "batch_dense")),
        "batch_quadratic": pick("c", (shared_k, "batch_quadratic_lanes")),
        "batch_quadratic_field": pick("c", (shared_k, "batch_quadratic_field")),
        "batch_quadratic_share": pick("c", (shared_k, "batch_quadratic_share")),
        # b is read only where a quadratic term has a linear part (else it is zero)
        "quadratic_locals": pick(
            "c", (linear, "quadratic_locals_linear"), (quadratic and not linear, "quadratic_locals")
        ),
        "quadratic_store": pick(
            "c", (linear, "quadratic_store_linear"), (quadratic and not linear, "quadratic_store")
        ),
        "batch_quadratic_locals": pick("c", (shared_k and linear, "batch_quadratic_locals_linear")),
        "batch_quadratic_store": pick(
            "c",
            (shared_k and linear, "batch_quadratic_store_linear"),
            (shared_k and not linear, "batch_quadratic_store"),
        ),
        "batch_vi": pick(
            "c",
            (batch and explicit, "batch_vi_explicit"),
            (field and dense_vi, "batch_vi_lanes"),
            (chain, "batch_chain_vi"),
            (batch and not explicit and not (field and dense_vi) and not chain, "batch_vi_newton"),
        ),
        # RATTLE: in loops over the lanes with a diagonal or dense M, else lane by lane
        "batch_rattle": pick(
            "c",
            (lanes or dense_rattle, "batch_rattle_gradient_lanes"),
            (batch and explicit and not lanes, "batch_rattle_gradient_each"),
            ((batch and explicit) or dense_rattle, "batch_rattle_omega"),
            (batch and explicit, "batch_rattle_lanes"),
            (dense_rattle, "batch_rattle_dense"),
            (batch and not explicit and not dense_rattle, "batch_rattle_each"),
        ),
    }
    py = {
        "masses_fill": pick("numpy", (uniform, "uniform_fill")),
        "constants": pick(
            "numpy", (module.constants > 0, "constants"), (not module.constants, "no_constants")
        ),
        "potential": pick(
            "numpy",
            (general, "general_value"),
            (not general, "zero_value"),
            (quadratic, "quadratic_value"),
        ),
        "gradient": pick(
            "numpy",
            (general, "general_gradient"),
            (not general, "zero_gradient"),
            (quadratic, "quadratic_gradient"),
        ),
        # integrate_batch(): the members' code (a diagonal or dense M's field), or why not
        "batch": pick(
            "numpy", (batch and members, "batch_members"), (batch and not members, "batch_refused")
        ),
        "batch_field": pick(
            "numpy",
            (members and module.solver is InertiaKind.DIAGONAL, "batch_field_diagonal"),
            (members and module.solver is InertiaKind.DENSE, "batch_field_dense"),
        ),
        "imports": pick(
            "numpy",
            (bool(facts.get("neighbour_lists", False)), "import_kdtree"),
            (bool(module.bands), "import_banded"),
        ),
        "initial_state": pick(
            "numpy", (initial, "initial_state_copy"), (not initial, "initial_state_none")
        ),
        "drive_tables": pick("numpy", (driven, "tu_defaults")),
        "drive_force": pick("numpy", (forces, "drive_force_fns")),
        "drive_operator": pick(
            "numpy",
            (forces and coupled, "drive_operator_dense"),
            (forces and not coupled, "drive_operator_diagonal"),
        ),
        "vi_operator": pick("numpy", (forces, "vi_operator_dense")),
        "transformed_dispatch": pick(
            "numpy", ("transformed" in module.parts, "transformed_dispatch")
        ),
        "drive_start": pick("numpy", (forces, "drive_start_force")),
        "drive_end": pick("numpy", (forces, "drive_end_force")),
        "drive_stage": pick("numpy", (forces, "drive_stage_force")),
        "jacobian_vi": pick(
            "numpy", (any(k.name == "vi_jacobian" for k in module.kernels), "jacobian_vi")
        ),
        "jacobian_rattle": pick(
            "numpy",
            (rattle_jacobian, "jacobian_rattle"),
            (rattle_jacobian and not driven, "jacobian_rattle_closed"),
            (rattle_jacobian and driven, "jacobian_rattle_driven"),
        ),
    }
    variant = dict(module.variants)
    laid = {variant.get(p, p) for p in module.parts} | {"module"}
    # the context part lays out the masses
    masses = {p.rsplit("/_", 1)[1].removesuffix(".jinja") for p in masses_partials(module)}
    masses = masses if "context" in laid else set()
    return (
        _declared(c, _OWNERS[0], laid | masses),
        _declared(py, _OWNERS[1], laid | masses),
    )
