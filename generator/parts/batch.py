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
updating once its own convergence test holds, or fails alone. Another M's field (its
structured solver) and VI substeps are the one-member code's, run lane by lane with the
lane's own context and workspace. Either way a lane's Newton iterates exactly as its
member's would alone (its own convergence test, iteration count and warm start), and a lane
whose Newton, solve or state fails stops alone with that status while the other lanes go on.

The adaptive methods (rk45, dop853; c/_batch_adaptive.jinja) run a block's lanes in masked
lockstep, not independently: every round, each live lane attempts one step of its own size
from its own time and state, so that the stages' arithmetic (y + h_l sum a_ij k_j, each lane
with its own h_l), the field (the same lane field as the fixed-step methods) and the error
norm (each lane's sums in rk45_error's or dop853_error's order) still run in loops over the
lanes, while the parts that branch per member run lane by lane: the initial step (the
one-member rk45_h0 and dop853_h0 on the lane's copies in its own workspace), accept or
reject, the step-size controller, and the samples on the output grid from the continuous
extension (the one-member drivers' text, on the lane's copies of its stages). A rejected lane retries
from its unchanged state in the next round; a lane whose member reached T or failed is
masked (the field skips it or computes garbage it never reads); DOP853's extra stages for a
sample inside a step run on the lanes that need them only. Independent lanes (each member's
whole run one after the other) would give the same numbers but no SIMD at all; lockstep keeps
the stages vectorised at the price of idle lanes once members need different numbers of
attempts (a block takes as many rounds as its slowest member). Each member's samples, energy,
status and statistics equal integrate()'s bit for bit; a failing member (a non-finite stage,
ERR_STEPSIZE, a failed solve) stops alone with its samples before the failure kept.

What is covered: closed systems (no forces, inputs or time); the VI and its compositions
(vi, vi4, vi6, vi8: explicit with a diagonal M, Newton with a coupled M), the fixed-step
Runge-Kutta methods (rk2, rk2-proj, rk3, rk4) and the adaptive ones (rk45, dop853). What is
not: RATTLE, the adaptive VI (vi-adaptive, ...) and driven systems; `batch_refusal` says
which.

Example:
    >>> from s2gen.systems import builtin
    >>> batch_refusal(builtin("double_pendulum")) is None
    True
    >>> print(batch_refusal(builtin("forced_double_pendulum")))
    forced_double_pendulum: integrate_batch() covers closed systems; this one is driven (forces, inputs or time)
"""

from __future__ import annotations

from s2gen.parts.records import Part
from s2gen.system import System

__all__ = ["BATCH_LANES", "BATCH_METHODS", "BATCH_PART", "batch_refusal", "has_batch"]

#: The part's name (`Module.parts`) and its partial, c/_batch.jinja (C only).
BATCH_PART = "batch"

#: Members advanced together: 8 doubles fill one AVX-512 register, two AVX2 or four SSE2
#: registers; fixed at generation time so that the emitted text (and the caller's workspace)
#: does not depend on the build flags.
BATCH_LANES = 8

#: The methods integrate_batch() takes (others: ERR_ARGUMENT).
BATCH_METHODS: tuple[str, ...] = ("vi", "vi4", "vi6", "vi8", "rk2", "rk2-proj", "rk3", "rk4")
#: ... and the adaptive ones, each member with its own step sizes (masked lockstep).
BATCH_METHODS = BATCH_METHODS + ("rk45", "dop853")

#: The adaptive methods' lanes use the one-member driver's buffers in their own workspaces.
PART = Part(
    BATCH_PART,
    buffers=(
        ("integrate", ("run",)),
        ("rk45", ("k", "y", "yn", "ys", "field")),
        ("dop853", ("k", "y", "yt", "yn", "ys", "field")),
    ),
)


def batch_refusal(system: System) -> str | None:
    """Why `system`'s C cannot carry integrate_batch(), in one line, or None."""
    if system.driven:
        return (
            f"{system.name}: integrate_batch() covers closed systems; this one is driven "
            "(forces, inputs or time)"
        )
    return None


def has_batch(system: System) -> bool:
    """Whether the emitted C of `system` carries integrate_batch(): asked for
    (`System.with_batch`) and covered (`batch_refusal`).

    Example:
        >>> from s2gen.systems import builtin
        >>> s = builtin("three_bodies")
        >>> has_batch(s), has_batch(s.with_batch())
        (False, True)
    """
    return system.batch and batch_refusal(system) is None
