"""A max-index M's Newton VI of a batch with its block solves in loops over the lanes.

Input: a lowered sphere module with the ``batch`` part whose M is max-index (the VI's Newton
and velocity systems solved by c/_coupled_chain.jinja's block elimination). Output: the
offsets of the lane arrays c/sections/_batch_chain_vi.jinja uses (`chain_lane_work`): the
lanes' max-index generators a and c, and lane copies of a structured solve's blocks E, H, K,
its right-hand sides and the elimination's workspace (element e of lane l at [e * L + l]).
The lanes' kernels stay the one-member code's, called lane by lane on each lane's own
workspace; the block elimination, which is latency-bound in one member, runs on all lanes
at once with each lane's own pivots, and a lane whose elimination declines redoes its solve
with the one-member solver (block elimination, then the band LU) on its own copy.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> w = chain_lane_work(lower_system(builtin("rope", n=4).with_batch()), 0, 8)
    >>> w["csa"], w["ce"], w["end"] - w["cw"]
    (0, 64, 768)
"""

from __future__ import annotations

from s2gen.inertia import InertiaKind
from s2gen.ir import Module

__all__ = ["chain_lane_work", "has_chain_lanes"]

#: The structured solves of the VI whose block elimination runs in the lanes.
_SOLVES = ("newton", "velocity")


def has_chain_lanes(module: Module) -> bool:
    """Whether `module`'s batch runs its VI's block solves in loops over the lanes: the
    batch part, a coupled M (Newton VI) and a max-index M.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> has_chain_lanes(lower_system(builtin("rope", n=4).with_batch()))
        True
        >>> has_chain_lanes(lower_system(builtin("double_pendulum").with_batch()))
        False
    """
    return (
        "batch" in module.parts
        and "vi_explicit" not in module.parts
        and module.solver is InertiaKind.MAX_INDEX
    )


def chain_lane_work(module: Module, at: int, lanes: int) -> dict[str, int]:
    """Offsets (doubles, from `at`) of the lane arrays of a max-index M's batch VI: the
    generators a then c (`csa`, 2 n), the blocks E (p p), H (p r), K (r p) and the
    right-hand sides (p nrhs) of a solve per body (`ce`, `ch`, `ck`, `cb`), the block
    elimination's workspace (`cw`, (p + r)(r + nrhs) per body), each sized for the larger of
    the Newton and velocity solves; `end` past them.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> w = chain_lane_work(lower_system(builtin("rope", n=4).with_batch()), 100, 2)
        >>> w["ch"] - w["ce"], w["cb"] - w["ck"]
        (72, 72)
    """
    n = module.n
    bands = [b for b in module.bands if b.name in _SOLVES]
    p = max(b.p for b in bands)
    r = max(b.r for b in bands)
    nrhs = max(b.nrhs for b in bands)
    sizes = {
        "csa": 2 * n,
        "ce": n * p * p,
        "ch": n * p * r,
        "ck": n * r * p,
        "cb": n * p * nrhs,
        "cw": n * (p + r) * (r + nrhs),
    }
    off: dict[str, int] = {}
    for name, size in sizes.items():
        off[name] = at
        at += size * lanes
    off["end"] = at
    return off
