"""What a scene needs: the unlowered `Module` of a system, or of its angle form.

Input: a `System` (or its `AngleEquations`). Output: a `Module` (see `s2gen.ir`) holding the
kernel definitions the system needs and the decisions that shape its code: whether M couples
bodies (then Newton's method and linear solves, else the explicit updates) and how its solves
are done (`choose_solver`: dense LU and Cholesky over pair loops, or, for a banded or
max-index M, the structured solvers: pair sums as O(n) products with M and band elimination,
partials `coupled_banded` / `coupled_chain`, `band`, `*_structured`), which structured terms
are looped over how, and the partial templates (algorithm variants) that lay the module out,
in order. Nothing absent is emitted: a diagonal M gets no pair kernels, no solves and no
Newton code; a potential without cutoff terms gets no neighbour lists.

Example:
    >>> from s2gen.systems import builtin
    >>> m = sphere_module(builtin("double_pendulum"))
    >>> "vi_newton" in m.parts, m.pairs
    (True, ((0, 1),))
"""

from __future__ import annotations

import functools

from s2gen.equations.angles import MIN_PIVOT_RATIO, POLE_TOL, AngleEquations, angle_kernels
from s2gen.equations.continuous import continuous_kernels
from s2gen.equations.discrete import explicit_kernels, newton_kernels
from s2gen.equations.driven import drive_of, driven_kernels
from s2gen.equations.jacobian import has_jacobian, jacobian_kernels
from s2gen.equations.jvp import has_jvp, jvp_kernels
from s2gen.equations.operators import operator_kernels
from s2gen.equations.rattle import rattle_kernels
from s2gen.equations.rattle_jacobian import rattle_jacobian_kernels
from s2gen.equations.structure import (
    choose_solver,
    coupling_pairs,
    has_general_potential,
    per_body_inertia,
    system_kernels,
    term_kernels,
)
from s2gen.equations.vi_jacobian import vi_jacobian_kernels
from s2gen.inertia import InertiaKind
from s2gen.interface import INITIAL_STATE_MAX_BODIES
from s2gen.ir import Drive, KernelDef, Loop, LoopKind, Module, ModuleKind, TermLoop
from s2gen.monitor import monitor_kernel
from s2gen.parts.batch import BATCH_PART, has_batch
from s2gen.parts.batch_driven import DRIVEN_BATCH_PART
from s2gen.parts.jvp import JVP_C_ONLY, jvp_parts
from s2gen.system import SpecError, System, Term

__all__ = [
    "MAX_CELLS",
    "angle_module",
    "cell_grid",
    "clear_caches",
    "generic_kernel_defs",
    "sphere_module",
]

#: Most neighbour-list cells per axis (bounds the list's memory when the cutoff is tiny).
MAX_CELLS = 160


def cell_grid(cutoff: float) -> int:
    """Cells per axis of a grid over [-1, 1]^3 whose cells are at least `cutoff` wide.

    Example:
        >>> cell_grid(0.5), cell_grid(1e-6)
        (4, 160)
    """
    return max(1, min(int(2.0 / cutoff), MAX_CELLS))


#: Kernels the structured solvers take from the dense set (the rest are `operator_kernels`).
_STRUCTURED_KEEP = {
    InertiaKind.BANDED: ("kin_body", "kin_pair", "mom_body", "mom_pair", "cayley", "a_body"),
    InertiaKind.MAX_INDEX: ("cayley", "a_body"),
}


@functools.cache
def _generic(solver: InertiaKind) -> tuple[KernelDef, ...]:
    from s2gen.build import cache_dir
    from s2gen.derivations import cached

    return cached(cache_dir(), "generic", solver.value, lambda: _derive_generic(solver))


def _derive_generic(solver: InertiaKind) -> tuple[KernelDef, ...]:
    coupled = solver is not InertiaKind.DIAGONAL
    defs = continuous_kernels(coupled) + (
        newton_kernels() if coupled else explicit_kernels() + rattle_kernels()
    )
    if solver not in _STRUCTURED_KEEP:
        return tuple(defs)
    keep = [k for k in defs if k.name in _STRUCTURED_KEEP[solver]]
    return (*keep, *operator_kernels(solver is InertiaKind.MAX_INDEX, defs))


def generic_kernel_defs(coupled: bool, solver: InertiaKind | None = None) -> tuple[KernelDef, ...]:
    """The system-independent kernels: the continuous field, energy and momenta, and the
    discrete flows (Newton's residual for coupled M, the explicit updates and RATTLE's closed
    form for diagonal M); with a structured `solver`, the factored kernels of
    `s2gen.equations.operators` instead of the pair kernels. Derived once per generator version
    and read back from the disk cache (`s2gen.derivations`), then kept in the process."""
    if solver is None:
        solver = InertiaKind.DENSE if coupled else InertiaKind.DIAGONAL
    return _generic(solver)


def clear_caches() -> None:
    """Forget the generic kernels derived in this process."""
    _generic.cache_clear()


def _term_loop(index: int, term: Term, n: int) -> TermLoop:
    selection = term.selection
    if selection.fixed:
        loop = Loop(selection, term.count(n), term.members)
    else:
        assert term.cutoff is not None, "members found per call are those within the cutoff"
        loop = Loop(selection, term.count(n), (), term.cutoff, cell_grid(term.cutoff))
    return TermLoop(
        index=index,
        loop=loop,
        data=tuple((d.name, d.width, d.values) for d in term.data),
        value=f"t{index}_value",
        gradient=f"t{index}_gradient",
        body_data=tuple((d.name, d.width, r) for d, r, _ in term.body_symbols()),
    )


def _variants(solver: InertiaKind, transformed: bool) -> tuple[tuple[str, str], ...]:
    """(part, partial) where a part is laid out by a variant: the energy and momentum of a
    dense or banded M add the coupled pairs' kinetic terms; with a diagonal M the
    time-transformed driver keeps the explicit VI's component-major state across its steps."""
    if solver in (InertiaKind.DENSE, InertiaKind.BANDED):
        return (("energy", "energy_coupled"),)
    if solver is InertiaKind.DIAGONAL and transformed:
        return (("transformed", "transformed_explicit"),)
    return ()


def _parts(
    solver: InertiaKind, tables: bool, cutoff: bool, drive: Drive | None = None
) -> tuple[str, ...]:
    """The partial templates of a sphere module, in order, for its inertia solver: explicit
    updates (diagonal M), dense solves over pair loops, or the structured solves (band
    elimination after the per-call context, products with M by `coupled_banded` or
    `coupled_chain`). A driven module steps with its own driver (`driven`: time, inputs,
    forces and the work), built on the VI and RATTLE steps and the field; uncoupled with
    forces it solves its velocity equations with `lu`."""
    chain = solver is InertiaKind.MAX_INDEX
    middle: tuple[str, ...]
    if solver is InertiaKind.DIAGONAL:
        middle = ("context", "potential", "energy", "field_diagonal", "field", "vi_explicit")
        rattle = "rattle_closed"
    elif solver is InertiaKind.DENSE:
        middle = ("inertia_operator", "cholesky", "lu", "context", "potential", "energy")
        middle += ("field_coupled", "field", "vi_newton")
        rattle = "rattle_newton"
    else:
        middle = ("context", "band", "coupled_chain" if chain else "coupled_banded", "potential")
        middle += ("energy_chain" if chain else "energy", "field_structured", "field")
        middle += ("vi_structured",)
        rattle = "rattle_structured"
    head = (*(("tables",) if tables else ()), *(("neighbours",) if cutoff else ()))
    if drive is not None:
        solve = ("lu",) if drive.forces and solver is InertiaKind.DIAGONAL else ()
        return (*head, "kernels", "helpers", *solve, *middle, rattle, "driven")
    tail = ("vi_step", rattle, "rk", "rk_step", "driver", "step")
    return (*head, "kernels", "helpers", *middle, *tail)


def sphere_module(system: System) -> Module:
    """The unlowered (S^2)^n module of a system."""
    solver = choose_solver(system)
    coupled = solver is not InertiaKind.DIAGONAL
    chain = solver is InertiaKind.MAX_INDEX
    pairs = coupling_pairs(system) if coupled and not chain else ()
    terms = [(k, t) for k, t in enumerate(system.terms) if t.count(system.n) > 0]
    drive = _drive(system, solver)
    kernels: list[KernelDef] = list(system_kernels(system, solver))
    for k, t in terms:
        kernels += term_kernels(system, k, t)
    kernels += generic_kernel_defs(coupled, solver)
    kernels += driven_kernels(system) if drive is not None else []
    kernels += jacobian_kernels(system)
    kernels += vi_jacobian_kernels(system, solver)
    kernels += rattle_jacobian_kernels(system)
    kernels += jvp_kernels(system)
    monitor = monitor_kernel(system) if drive is None else None
    kernels += [monitor] if monitor is not None else []
    loops = tuple(_term_loop(k, t, system.n) for k, t in terms)
    cutoff = any(not t.loop.kind.fixed for t in loops)
    per_body = per_body_inertia(system, solver) is not None
    uniform = system.n > 1 and not per_body and kernels[0].outputs[0].size == 1
    general = has_general_potential(system)
    field = [("inertia_body" if per_body else "inertia", system.n if per_body else 1)]
    field += [*((("gradient", 1),) if general else ())]
    field += [(t.gradient, t.loop.count) for t in loops]
    if solver is InertiaKind.DENSE:
        field += [("rhs_body", system.n), ("rhs_pair", len(pairs)), ("a_pair", len(pairs))]
    elif coupled:
        field += [("src_rhs", system.n), ("rhs_coupled", system.n), ("a_blocks", system.n)]
    else:
        field.append(("rhs_diag", system.n))
    chain_data = system.chain.data if per_body and system.chain is not None else ()
    parts = _parts(solver, bool(pairs) or bool(loops) or bool(chain_data), cutoff, drive)
    if monitor is not None:  # the time-transformed driver, after the tables it reads
        at = parts.index("driver") + 1
        parts = (*parts[:at], "transformed", *parts[at:])
    parts += ("jacobian",) if has_jacobian(system) else ()
    parts += jvp_parts(not coupled) if has_jvp(system) else ()
    if has_batch(system):  # a driven system's own integrate_batch(), C only
        parts += (DRIVEN_BATCH_PART if system.driven else BATCH_PART,)
    return Module(
        kind=ModuleKind.SPHERE,
        name=system.name,
        spec_hash=system.spec_hash(),
        origin=system.origin,
        n=system.n,
        parameter_names=system.parameter_names,
        parameter_values=system.parameter_values,
        kernels=tuple(kernels),
        parts=parts,
        # NumPy: numpy.linalg, scipy.linalg (step_jvp() is C only)
        c_only=("cholesky", "lu", "band", *JVP_C_ONLY, DRIVEN_BATCH_PART),
        variants=_variants(solver, "transformed" in parts),
        pairs=pairs,
        terms=loops,
        coupling=Loop(LoopKind.COUPLING, len(pairs), pairs) if pairs else None,
        facts=(
            ("coupled", coupled),
            ("general", general),
            ("uniform_mass", uniform),
            ("neighbour_lists", cutoff),
        ),
        field_calls=tuple(field),
        solver=solver,
        inertia_data=tuple((d.name, d.values) for d in chain_data),
        body_data=tuple(
            {d.name: (d.name, d.width, d.values) for _, t in terms for d in t.body_data}.values()
        ),
        initial_state=_initial_state(system),
        drive=drive,
    )


def _drive(system: System, solver: InertiaKind) -> Drive | None:
    """The driven part of a system, or None when it is closed; a one-line SpecError for what
    the emitted code does not take yet (forces with the structured solvers, whose velocity
    equations would need their own band solves)."""
    if not system.driven:
        return None
    drive = drive_of(system)
    if drive.forces and solver in (InertiaKind.BANDED, InertiaKind.MAX_INDEX):
        raise SpecError(
            f"{system.origin}: {system.forces[0].label}: emitting code for forces with a "
            f"structured inertia solver ({solver.value}) is not supported yet; set [inertia] "
            'solver = "dense" (time and inputs in the potential are supported)'
        )
    return drive


def _initial_state(system: System) -> tuple[float, ...]:
    """The spec's initial q then omega, body-major, or () when the spec gives none or it has
    more bodies than the emitted modules carry (`INITIAL_STATE_MAX_BODIES`)."""
    if system.q0 is None or system.omega0 is None or system.n > INITIAL_STATE_MAX_BODIES:
        return ()
    return tuple(float(v) for v in (*system.q0.ravel(), *system.omega0.ravel()))


def angle_module(eq: AngleEquations) -> Module:
    """The unlowered angle-form module of a system (file stem ``<system>_angles``)."""
    system_defs, body_defs = angle_kernels(eq)
    s = eq.system
    how = "sympy.simplify on every entry" if eq.simplified else "no simplification"
    return Module(
        kind=ModuleKind.ANGLES,
        name=f"{s.name}_angles",
        spec_hash=s.spec_hash(),
        origin=s.origin,
        n=s.n,
        parameter_names=s.parameter_names,
        parameter_values=s.parameter_values,
        kernels=(*system_defs, *body_defs),
        parts=(
            "kernels",
            "helpers",
            "lu",
            "angles_context",
            "angles_convert",
            "angles_field",
            "rk",
            "angles_driver",
        ),
        facts=(
            ("system", s.name),
            ("derivation", how),
            ("simplified", eq.simplified),
            ("pole_tol", repr(POLE_TOL)),
            ("min_pivot_ratio", repr(MIN_PIVOT_RATIO)),
        ),
        field_calls=(("dynamics", 1),),
    )
