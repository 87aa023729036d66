"""Parts: each algorithmic piece of an emitted module and what it needs, declared in one place.

A `Part` is a driver, a step, a solver, an energy routine, the vector field, the per-call
context, ...: it is laid out by one partial template per language (`c/_<name>.jinja`,
`numpy/_<name>.jinja`, and what those include), calls kernels at its call sites (`Site`: the
kernel, the context it is called from and the typed bindings `s2gen.bindings` that override
the context's rule for an argument) and reads buffers of the workspace layouts
(`s2gen.passes.workspace`). Lowering selects a module's parts by name (`Module.parts`, each
laid out by its own partial or by the variant `Module.variants` names); the `calls` pass
resolves the sites of the selected parts, and `tests/test_parts.py` checks, part by part,
that a partial reads only the sites and buffers its part declares, and reads all of them.
A term's loop declares its sites from its `TermLoop` (`term_sites`).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> [p.name for p in selected(lower_system(builtin("double_pendulum")))][-6:]
    ['vi_step', 'rattle_newton', 'rk', 'rk_step', 'driver', 'step']
    >>> PARTS["field_diagonal"].partial("c"), [s.name for s in PARTS["field_diagonal"].sites]
    ('c/_field_diagonal.jinja', ['rhs_diag'])
"""

from __future__ import annotations

from s2gen.bindings import Binding, BodyDatum, Local, MemberSlot, TermDatum, TermTable
from s2gen.ir import Module, TermLoop
from s2gen.parts.angles import ANGLE_PARTS
from s2gen.parts.records import CC, Context, Part, Site
from s2gen.parts.sphere import SPHERE_PARTS

__all__ = ["PARTS", "Context", "Part", "Site", "selected", "term_sites"]

#: Every part of every module kind, by the name of its partial.
PARTS: dict[str, Part] = {p.name: p for p in (*SPHERE_PARTS, *ANGLE_PARTS)}


def selected(module: Module) -> tuple[Part, ...]:
    """The parts laid out in `module`, in order (a part's variant in place of the part)."""
    variant = dict(module.variants)
    return tuple(PARTS[variant.get(p, p)] for p in module.parts)


def term_sites(t: TermLoop) -> tuple[Site, ...]:
    """The value, gradient and table sites of one term loop (data read at member m; the
    member's table row at `tab`, the context constants at cc).

    Example:
        >>> from s2gen.ir import Loop, LoopKind
        >>> t = TermLoop(2, Loop(LoopKind.CHAIN, 3), (), "t2_value", "t2_gradient")
        >>> [s.name for s in term_sites(t)], term_sites(t)[0].bind["qj"]
        (['t2_value', 't2_gradient'], MemberSlot(term=2, body='j'))
    """
    kind = t.loop.kind.kind
    bind: dict[str, Binding] = {
        role: MemberSlot(t.index, i) for role, i in zip(kind.roles, kind.indices)
    }
    bind.update(
        {"v": Local("v", address=True), "g": Local("gb", vector="g"), "tab": TermTable(t.index)}
    )
    bind.update(CC)
    for name, width, _ in t.data:
        bind[f"d_{name}"] = TermDatum(t.index, name, width)
    for name, width, r in t.body_data:
        body = kind.indices[r]
        local = name if kind.arity == 1 else f"{name}{body}"
        bind[f"b_{local}"] = BodyDatum(t.index, name, width, body)
    sites = [
        Site(f"t{t.index}_value", t.value, Context.SYSTEM, bind),
        Site(f"t{t.index}_gradient", t.gradient, Context.SYSTEM, bind),
    ]
    if t.table:
        row = {**bind, "tab": TermTable(t.index, row=True)}
        sites.append(Site(f"t{t.index}_table", f"t{t.index}_table", Context.SYSTEM, row))
    if t.quadratic:
        coef = {**bind, "coef": Local("row", vector="coef")}
        sites.append(Site(f"t{t.index}_quad", f"t{t.index}_quad", Context.SYSTEM, coef))
    return tuple(sites)
