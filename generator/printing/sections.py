"""The partials of each optional section of a printed module, chosen by what the module has.

Input: a lowered `Module` (IR). Output: per language (C, NumPy), a dict from section name to
the partials (template paths under templates/) that lay it out, in order; a module declares
a section only when it lays out a part that owns it (`_OWNERS`). Templates lay out what the
records say; the choices are made here (`tests/test_parts.py` checks that every partial is
laid out by some case and every section is read).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> c, py = sections(lower_system(builtin("dipoles")))
    >>> c["quadratic_store"]
    ('c/sections/_quadratic_store.jinja',)
"""

from __future__ import annotations

from typing import Any

from s2gen.inertia import InertiaKind
from s2gen.ir import Module
from s2gen.parts.batch import has_chain_lanes, numpy_batch_refusal
from s2gen.printing.records import masses_partials

__all__ = ["Sections", "sections"]

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
