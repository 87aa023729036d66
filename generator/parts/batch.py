"""Batches: integrate_batch(), K members of one system per call, SIMD across members.

A sphere module emitted from `System.with_batch` carries ``NAME_integrate_batch``: K members,
each with its own parameters and initial state, laid out member-innermost (see
`s2gen.interface_batch` for the caller's layout). Inside, the members run `BATCH_LANES` at a
time: every quantity of the one-member step becomes a lane array (lane innermost), and the
arithmetic of the step (the explicit VI's position and velocity updates, the Runge-Kutta
stages and the uncoupled vector field) runs in loops over the lanes that the compiler
vectorises (OpenMP SIMD hints). Each lane performs the one-member code's operations in the
same order on its own numbers, so that a member's trajectory, energy and statistics equal
integrate()'s bit for bit. dV/dq runs in loops over the lanes too where it is a general
kernel, member loops over fixed members, or the quadratic matrix K alone, shared by a
block's lanes whose K are equal bit for bit (`s2gen.printing.c_batch.lane_gradient`);
otherwise it, like the energy always, is the one-member code's own function, called lane by
lane (its member loops, neighbour lists and member tables kept as they are).

With a coupled M (dense, banded or max-index), the lanes hold the state body-major: the
Runge-Kutta stages' arithmetic still runs in loops over the lanes, and so does a dense M's
field (dV/dq where it runs in lanes, the field's kernels inline, A(q) and its pivoted
elimination with each lane's own pivots: `s2gen.printing.c_batch.coupled_field`), and a
dense M's VI substeps (Newton on the Cayley parameters, then A(q+) w+ = c), the kernels of
the one-member vi_advance inline in loops over the lanes and its LU and Cholesky solves on
all lanes at once (`s2gen.printing.c_batch_newton`), each lane under its own mask: it stops
updating once its own convergence test holds, or fails alone. A max-index M's VI substeps
keep the one-member kernels and products with M, lane by lane on each lane's workspace, and
solve their Newton and velocity systems on all lanes at once (the block elimination over
the lanes, each lane's own pivots and decline flag; a declining lane redoes its solve with
the one-member solver on its own copy: `s2gen.printing.c_batch_chain`), with the same masks.
Another M's field (its structured solver) and a banded M's VI substeps are the one-member
code's, run lane by lane with the lane's own context and workspace. Either way a lane's
Newton iterates exactly as its member's would alone (its own convergence test, iteration
count and warm start), and a lane whose Newton, solve or state fails stops alone with that
status while the other lanes go on.

RATTLE and its compositions keep the one-member step's body-major state: with a diagonal M
its substep (each body's closed-form position and velocity updates, dV/dq between them) runs
in loops over the lanes, dV/dq through the lane gradient where the Runge-Kutta field uses it
and else the one-member gradient_cx lane by lane; with a dense M (whose field runs in the
lanes) so does its Newton on the multipliers, each lane under its own mask, its small LU and
Cholesky solves the one-member solvers on each lane's copy; with another coupled M each
lane runs the one-member rattle_advance with its own context and workspace
(`s2gen.printing.c_batch_rattle`).

The adaptive methods (rk45, dop853; c/_batch_adaptive.jinja) run a block's lanes in masked
lockstep, not independently: every round, each live lane attempts one step of its own size
from its own time and state, so that the stages' arithmetic (y + h_l sum a_ij k_j, each lane
with its own h_l), the field (the same lane field as the fixed-step methods) and the error
norm (each lane's sums in rk45_error's or dop853_error's order) still run in loops over the
lanes, while the parts that branch per member run lane by lane: the initial step (the
one-member rk45_h0 and dop853_h0 on the lane's copies in its own workspace), accept or
reject, the step-size controller, and the samples on the output grid from the continuous
extension (the one-member drivers' text, on the lane's copies of its stages). A rejected lane
retries from its unchanged state in the next round; a lane whose member reached T or failed
is masked (the field skips it or computes garbage it never reads); DOP853's extra stages for
a sample inside a step run on the lanes that need them only. Independent lanes (each
member's whole run one after the other) would give the same numbers but no SIMD at all;
lockstep keeps the stages vectorised at the price of idle lanes once members need different
numbers of attempts (a block takes as many rounds as its slowest member). Each member's
samples, energy, status and statistics equal integrate()'s bit for bit; a failing member (a
non-finite stage, ERR_STEPSIZE, a failed solve) stops alone with its samples before the
failure kept.

What is covered: closed systems (no forces, inputs or time); the VI and its compositions
(vi, vi4, vi6, vi8: explicit with a diagonal M, Newton with a coupled M), RATTLE and its
compositions (rattle, rattle4, rattle6, rattle8), the fixed-step Runge-Kutta methods (rk2,
rk2-proj, rk3, rk4) and the adaptive ones (rk45, dop853). What is not: the time-transformed
methods (vi-adaptive, rattle-adaptive, ...) and driven systems, which carry an
integrate_batch() of their own (`s2gen.parts.batch_driven`); `batch_refusal` says which.

The NumPy module of the same system carries integrate_batch() too, vectorised over the
members (`s2gen.printing.numpy_batch`): the VI's and the fixed-step Runge-Kutta methods
(not RATTLE's or the adaptive ones) with a diagonal or dense M (the
dense M's Newton VI with a convergence mask per member), for terms that read the state,
constants, tables and parameters; `numpy_batch_refusal` says why a module has none
(quadratic terms, cutoff terms, per-body term data, a structured M: C only).

Example:
    >>> from s2gen.systems import builtin
    >>> batch_refusal(builtin("double_pendulum")) is None
    True
    >>> print(batch_refusal(builtin("forced_double_pendulum")))
    forced_double_pendulum: integrate_batch() covers closed systems; this one is driven (forces, inputs or time)
"""

from __future__ import annotations

from s2gen.bindings import ContextArray, Element, Local, MemberSlot, Slot, TermTable
from s2gen.inertia import InertiaKind
from s2gen.ir import Module
from s2gen.parts.records import Part, Site
from s2gen.system import System

__all__ = [
    "BATCH_LANES",
    "BATCH_METHODS",
    "BATCH_PART",
    "batch_refusal",
    "has_batch",
    "has_chain_lanes",
    "numpy_batch_refusal",
]

#: The part's name (`Module.parts`) and its partial, c/_batch.jinja (C only).
BATCH_PART = "batch"

#: Members advanced together: 8 doubles fill one AVX-512 register, two AVX2 or four SSE2
#: registers; fixed at generation time so that the emitted text (and the caller's workspace)
#: does not depend on the build flags.
BATCH_LANES = 8

#: The methods integrate_batch() takes (others: ERR_ARGUMENT).
BATCH_METHODS: tuple[str, ...] = ("vi", "vi4", "vi6", "vi8", "rk2", "rk2-proj", "rk3", "rk4")
#: and RATTLE's (in loops over the lanes with a diagonal M, else lane by lane)
BATCH_METHODS += ("rattle", "rattle4", "rattle6", "rattle8")
#: and the adaptive ones, each member with its own step sizes (masked lockstep; C only)
BATCH_METHODS += ("rk45", "dop853")

#: The call sites NumPy's members' code reads (`s2gen.printing.numpy_batch`), by the part
#: that declares each for the one-member code
_NUMPY_SITES = {
    "energy": ("kin_body",),
    "energy_coupled": ("kin_body", "kin_pair"),
    "field_diagonal": ("rhs_diag",),
    "field_coupled": ("rhs_body", "rhs_pair"),
    "vi_explicit": ("vi_pos", "vi_vel"),
    "inertia_operator": ("a_pair",),
    "vi_newton": (
        "d_body",
        "d_pair",
        "res_body",
        "res_pair",
        "cayley",
        "c_body",
        "c_pair",
        "a_body",
    ),
}


#: Bindings whose NumPy text keeps its shape for members: the state at bodies or members, the
#: per-member constants and tables, the inverse masses (everything else, such as a term's
#: data, has a body axis alone and would broadcast against the member axis)
_MEMBER_SAFE = (MemberSlot, Slot, ContextArray, TermTable, Element, Local)


def numpy_batch_refusal(module: Module) -> str | None:
    """Why the NumPy module of `module` carries no integrate_batch(), in one line, or None.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> print(numpy_batch_refusal(lower_system(builtin("dipoles").with_batch())))
        dipoles: integrate_batch() on the NumPy backend covers no quadratic terms (C only)
    """
    facts = dict(module.facts)
    why = None
    if module.solver not in (InertiaKind.DIAGONAL, InertiaKind.DENSE):
        why = f"covers a diagonal or dense M, not a {module.solver.value} one"
    elif module.quadratic > 0:
        why = "covers no quadratic terms"
    elif facts.get("neighbour_lists", False):
        why = "covers no cutoff terms (neighbour lists)"
    elif not all(
        isinstance(b, _MEMBER_SAFE)
        for c in module.calls
        if c.site.startswith("t") and c.site.endswith(("_value", "_gradient"))
        for b in c.inputs
    ):
        why = (
            "covers terms reading the state and tables only (not per-body data at every evaluation)"
        )
    if why is None:
        return None
    return f"{module.name}: integrate_batch() on the NumPy backend {why} (C only)"


def _numpy_sites(module: Module) -> tuple[Site, ...]:
    """The one-member sites NumPy's members' code calls again, with members on an axis."""
    if "batch" not in module.parts or numpy_batch_refusal(module) is not None:
        return ()
    from s2gen.parts.sphere import PARTS_BY_NAME  # which imports this module

    variant = dict(module.variants)
    laid = {variant.get(p, p) for p in module.parts}
    return tuple(
        site
        for name, wanted in _NUMPY_SITES.items()
        if name in laid
        for site in PARTS_BY_NAME[name].sites
        if site.name in wanted
    )


def has_chain_lanes(module: Module) -> bool:
    """Whether `module`'s batch solves its VI's block systems in loops over the lanes: the
    batch part, the Newton VI (no explicit VI) and a max-index M.

    Example:
        >>> from s2gen.systems import builtin, resolve
        >>> from s2gen.passes import lower_system
        >>> has_chain_lanes(lower_system(resolve("rope:n=10").with_batch()))
        True
        >>> has_chain_lanes(lower_system(builtin("double_pendulum").with_batch()))
        False
    """
    return (
        BATCH_PART in module.parts
        and "vi_explicit" not in module.parts
        and module.solver is InertiaKind.MAX_INDEX
    )


#: The structured VI's sites the max-index batch writes inline in its lane loops instead
#: (`s2gen.printing.c_batch_chain.chain_lanes`).
_CHAIN_INLINE = ("disp", "res_coupled", "c_coupled", "a_body", "a_blocks_vi")


def _sites(module: Module) -> tuple[Site, ...]:
    """The one-member sites the batch calls again: NumPy's members' code, and with a
    max-index M the structured VI's kernels it runs lane by lane
    (c/sections/_batch_chain_vi)."""
    if not has_chain_lanes(module):
        return _numpy_sites(module)
    from s2gen.parts.sphere import PARTS_BY_NAME  # which imports this module

    chain = PARTS_BY_NAME["vi_structured"].sites
    return (*_numpy_sites(module), *(s for s in chain if s.name not in _CHAIN_INLINE))


#: The adaptive methods' lanes use the one-member driver's buffers in their own workspaces.
PART = Part(
    BATCH_PART,
    buffers=(
        ("integrate", ("run",)),
        ("rk45", ("k", "y", "yn", "ys", "field")),
        ("dop853", ("k", "y", "yt", "yn", "ys", "field")),
    ),
    module_sites=_sites,
)


def batch_refusal(system: System) -> str | None:
    """Why `system`'s C cannot carry this integrate_batch() (the closed systems' one, SIMD
    across members), in one line, or None; a driven system's C carries its own
    (`s2gen.parts.batch_driven`)."""
    if system.driven:
        return (
            f"{system.name}: integrate_batch() covers closed systems; this one is driven "
            "(forces, inputs or time)"
        )
    return None


def has_batch(system: System) -> bool:
    """Whether the emitted C of `system` carries integrate_batch(): asked for
    (`System.with_batch`) and covered (`batch_refusal`), or driven (`s2gen.parts.batch_driven`).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("three_bodies")
        >>> has_batch(s), has_batch(s.with_batch())
        (False, True)
    """
    return system.batch and (system.driven or batch_refusal(system) is None)
