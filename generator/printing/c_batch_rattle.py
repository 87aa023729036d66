"""RATTLE in integrate_batch(): the record of c/sections/_batch_rattle_*.jinja.

Input: a lowered sphere module with the ``batch`` part (`s2gen.parts.batch`). Output: the
record `m.batch.rattle`. With a diagonal M (the explicit VI's modules, whose RATTLE step is
rattle_closed: a closed form per body) the step runs in loops over the lanes, the lanes holding the state
body-major as the one-member step does: `pos` and `vel` are the rattle_pos and rattle_vel
kernels' bodies inline (the C printer's `c_inline`, operands read from small per-lane arrays
x, v, g and xn, vh, gn, so that a lane performs the one-member kernel's operations in their
order), `lanes` the offsets of the lane arrays inside the Runge-Kutta region (which a RATTLE
block does not otherwise use). With a dense M whose field runs in the lanes
(`s2gen.printing.c_batch.coupled_field`) the step of rattle_newton runs in loops over the
lanes too, each lane's Newton under its own mask: `dense` are its lane arrays (in the
Runge-Kutta region and past the other lane arrays: `rattle_dense_work`) and, in each lane's
workspace, rattle_advance's buffers where the one-member solvers run on the lane's copy.
With another coupled M each lane runs the one-member rattle_advance on its own workspace:
`each` are the offsets, in a lane's workspace (WORK_SIZE), of the buffers
integrate_geometric() gives it, inside integrate()'s run region, so that a lane's Newton
iterations, warm starts and failures are its member's own.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> from s2gen.printing.c_batch import print_batch
    >>> r = print_batch(lower_system(builtin("four_pendula").with_batch()))["rattle"]
    >>> r["pos"][-1], sorted(r["lanes"])[:3]
    ('const double disc0 = x10;', ['chk', 'disc', 'g'])
    >>> r = print_batch(lower_system(builtin("double_pendulum").with_batch()))["rattle"]
    >>> sorted(r["each"])[:4]
    ['a', 'b', 'g', 'gn']
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Kernel, Module
from s2gen.printing.c import c_inline

__all__ = ["rattle_batch", "rattle_dense_work"]

#: The buffers of integrate_geometric()'s workspace a lane's RATTLE step uses (coupled M).
_EACH = ("g", "gn", "a", "b", "va", "vb", "vc", "vd", "qk", "wk", "q1", "w1", "s", "step")

#: The lane arrays of the RATTLE step in lanes (N3 doubles per lane each; disc: n per lane).
_LANES = ("v", "g", "xn", "vn", "gn", "vh", "disc")


#: A dense M's RATTLE lane arrays inside the Runge-Kutta region (N3 doubles per lane each).
_DENSE = ("v", "g", "xn", "vn", "gn", "gw", "y", "u")


def rattle_dense_work(module: Module, at: int, lanes: int) -> dict[str, int]:
    """Offsets (doubles, from `at`) of a dense M's RATTLE lane arrays that the Runge-Kutta
    region does not hold: W = M^-1 (`rw`, n x n per lane), the multipliers of every substep
    (`rsv`, n per lane and substep, as integrate_geometric keeps them), Newton's right side
    (`rr`) and matrix (`rjm`); `end` past them.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> w = rattle_dense_work(lower_system(builtin("double_pendulum").with_batch()), 0, 8)
        >>> w["rsv"], w["rr"] - w["rsv"], w["end"]
        (32, 240, 320)
    """
    n = module.n
    layouts = {lay.name: lay for lay in module.layouts}
    substeps = next(b.size for b in layouts["geometric"].buffers if b.name == "s") // n
    off = {"rw": at, "rsv": at + n * n * lanes}
    off["rr"] = off["rsv"] + substeps * n * lanes
    off["rjm"] = off["rr"] + n * lanes
    off["end"] = off["rjm"] + n * n * lanes
    return off


def _dense(module: Module, work: dict[str, int], lanes: int) -> dict[str, int]:
    """The dense record: lane arrays (`_DENSE` in the Runge-Kutta region, x and omega where
    the block starts them, W, sv, r, jm) and, in a lane's workspace, rattle_advance's jm and
    r (`ljm`, `lr`), where the lane's one-member solves run."""
    n3 = 3 * module.n
    off = {name: work["rk_yn"] + k * n3 * lanes for k, name in enumerate(_DENSE)}
    assert off["u"] + n3 * lanes <= work["rk_chk"], "the RK region holds them"
    off["x"], off["om"], off["chk"] = work["rk_y0"], work["rk_y0"] + n3 * lanes, work["rk_chk"]
    off.update({"w": work["rw"], "sv": work["rsv"], "r": work["rr"], "jm": work["rjm"]})
    layouts = {lay.name: lay for lay in module.layouts}
    step = layouts["integrate"].offset("run") + layouts["geometric"].offset("step")
    off["ljm"] = step + layouts["rattle_advance"].offset("jm")
    off["lr"] = step + layouts["rattle_advance"].offset("r")
    return off


def _inline(module: Module, name: str) -> tuple[str, ...]:
    kernel = module.kernel(name)
    assert isinstance(kernel, Kernel), "the passes lowered every kernel"
    scalars = [a.name for a in kernel.inputs if a.scalar]
    assert scalars == ["h", "mi"], f"{name}: the batch loads h and mi only, not {scalars}"
    shared, lines = c_inline(kernel, scalars=())
    assert not shared, f"{name} reads no context constants"
    return lines


def rattle_batch(
    module: Module, work: dict[str, int], lanes: int, dense_lanes: bool = False
) -> dict[str, Any]:
    """The RATTLE record of a batch module: `pos`, `vel` and `lanes` (a diagonal M, whose
    step runs in loops over the lanes; `work` is `s2gen.printing.c_batch.batch_work`'s
    record, whose Runge-Kutta region holds the lane arrays), or `each` (a coupled M, lane by
    lane) and, with `dense_lanes` (a dense M whose field runs in the lanes), `dense` (its
    step in loops over the lanes); the other keys empty."""
    if "vi_explicit" not in module.parts:
        layouts = {lay.name: lay for lay in module.layouts}
        run = layouts["integrate"].offset("run")
        each = {name: run + layouts["geometric"].offset(name) for name in _EACH}
        dense = _dense(module, work, lanes) if dense_lanes else {}
        return {"pos": (), "vel": (), "lanes": {}, "each": each, "dense": dense}
    assert "rattle_closed" in module.parts, "a diagonal M's RATTLE step is closed per body"
    n3 = 3 * module.n
    start = work["rk_yn"]
    offsets = {name: start + k * n3 * lanes for k, name in enumerate(_LANES)}
    assert offsets["disc"] + module.n * lanes <= work["rk_chk"], "the RK region holds them"
    offsets["x"], offsets["om"] = work["rk_y0"], work["rk_y0"] + n3 * lanes
    offsets["chk"], offsets["mi"] = work["rk_chk"], work["rk_mi"]
    return {
        "pos": _inline(module, "rattle_pos"),
        "vel": _inline(module, "rattle_vel"),
        "lanes": offsets,
        "each": {},
        "dense": {},
    }
