"""A max-index M's Newton VI of a batch with its block solves in loops over the lanes.

Input: a lowered sphere module with the ``batch`` part whose M is max-index (the VI's Newton
and velocity systems solved by c/_coupled_chain.jinja's block elimination). Output: the
offsets of the lane arrays c/sections/_batch_chain_vi.jinja uses (`chain_lane_work`): the
lanes' max-index generators a and c, and lane copies of a structured solve's blocks E, H, K,
its right-hand sides and the elimination's workspace (element e of lane l at [e * L + l]).
The kernels of Newton's iteration and of the velocity side (the Cayley displacement with the
block K, M's product, the residual with the blocks E and H; the velocity's right-hand side
and A(q+)'s blocks: `chain_lanes`) run inline in loops over the lanes, each lane's
operations the one-member kernels' in their order, and store the blocks and right-hand sides
straight into the lane copies the block solve reads; the known side d, the Cayley map and
dV/dq stay the one-member code's, called lane by lane on each lane's own workspace. The block
elimination, which is latency-bound in one member, runs on all lanes at once with each
lane's own pivots, and a lane whose elimination declines redoes its solve with the
one-member solver (block elimination, then the band LU) on its own copy.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> w = chain_lane_work(lower_system(builtin("rope", n=10).with_batch()), 0, 8)
    >>> w["csa"], w["ce"], w["end"] - w["cw"]
    (0, 160, 3760)
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Kernel, Module
from s2gen.parts.batch import has_chain_lanes
from s2gen.printing.c_batch_newton import lane_inline

__all__ = ["chain_lane_work", "chain_lanes", "chain_vi_work"]

#: The structured solves of the VI whose block elimination runs in the lanes.
_SOLVES = ("newton", "velocity")
#: The one-member vi_advance's buffers a lane's kernels and fallback solves use.
_VI_BUFFERS = ("d", "r", "u", "z", "e", "hb", "kb", "solve")


def chain_vi_work(module: Module) -> dict[str, int]:
    """Offsets (doubles) of the one-member vi_advance's buffers in its workspace (as
    c/_vi_structured.jinja lays them out), which each lane's kernels and fallback solves use
    in the lane's own workspace; empty without a max-index M's batch.

    Example:
        >>> from s2gen.systems import resolve
        >>> from s2gen.passes import lower_system
        >>> w = chain_vi_work(lower_system(resolve("rope:n=10").with_batch()))
        >>> w["d"], w["r"] - w["d"]
        (0, 30)
    """
    if not has_chain_lanes(module):
        return {}
    layout = next(lay for lay in module.layouts if lay.name == "vi_advance")
    return {name: layout.offset(name) for name in _VI_BUFFERS}


#: The kernels the lanes run inline: each input 3-vector's lane array (as vi_advance binds
#: it: A(q+)'s kernels read q+) and each output's lane array, with whether it is stored
#: negated (the residual: the Newton solve's right-hand side -r; negation is exact, as
#: vi_advance's r[k] = -r[k]). Their scalars: the substep h, M_ii (`cm`) and A(q+)_ii (`ca`).
_KERNELS: dict[str, tuple[dict[str, str], dict[str, tuple[str, bool]]]] = {
    "disp": ({"q": "cq", "f": "cf"}, {"u": ("cu", False), "kd": ("ck", False)}),
    "res_coupled": (
        {"q": "cq", "f": "cf", "d": "cd", "z": "cz"},
        {"r": ("cb", True), "e": ("ce", False), "hq": ("ch", False)},
    ),
    "c_coupled": (
        {"q": "cq", "f": "cf", "qn": "cqn", "gn": "cgn", "z": "cz"},
        {"c": ("cb", False)},
    ),
    "a_body": ({"q": "cqn"}, {"a": ("ca", False)}),
    "a_blocks": (
        {"q": "cqn"},
        {"e": ("ce", False), "hq": ("ch", False), "kq": ("ck", False)},
    ),
}
_SCALARS = {"h": "h", "m": "cm[i * L + l]", "a": "ca[i * L + l]"}


def chain_lanes(module: Module) -> dict[str, Any]:
    """The kernels of a max-index M's vi_advance after the state's (d, the Cayley map and
    dV/dq stay lane by lane) inline for loops over lanes l and body i (empty for another
    module): `disp` (u and K_i), `res_coupled` (the Newton solve's right-hand side -r, E_i
    and H_i), `c_coupled` (the velocity solve's right-hand side), `a_body` and `a_blocks`
    (A(q+)'s diagonal and blocks), each output slot k of a body stored at
    [(size i + k) * L + l] of its lane array (size: the output's length, the stride of
    vi_advance's buffers).

    Example:
        >>> from s2gen.systems import resolve
        >>> from s2gen.passes import lower_system
        >>> r = chain_lanes(lower_system(resolve("rope:n=10").with_batch()))
        >>> r["res_coupled_stores"][0], r["a_body_stores"]
        ('cb[(3 * i + 0) * L + l] = -r0;', ('ca[(1 * i + 0) * L + l] = a0;',))
    """
    if not has_chain_lanes(module):
        return {}
    out: dict[str, Any] = {}
    for name, (arrays, stores) in _KERNELS.items():
        kernel = module.kernel(name)
        assert isinstance(kernel, Kernel), "the passes lowered every kernel"
        vectors = {arg: (array, "i") for arg, array in arrays.items()}
        out[name] = lane_inline(kernel, vectors, _SCALARS)
        lines: list[str] = []
        for output in kernel.outputs:
            array, negated = stores[output.name]
            sign = "-" if negated else ""
            lines.extend(
                f"{array}[({output.size} * i + {k}) * L + l] = {sign}{output.name}{k};"
                for k in range(output.size)
            )
        out[f"{name}_stores"] = tuple(lines)
    return out


def chain_lane_work(module: Module, at: int, lanes: int) -> dict[str, int]:
    """Offsets (doubles, from `at`) of the lane arrays of a max-index M's batch VI: the
    generators a then c (`csa`, 2 n), the blocks E (p p), H (p r), K (r p) and the
    right-hand sides (p nrhs) of a solve per body (`ce`, `ch`, `ck`, `cb`), the block
    elimination's workspace (`cw`, (p + r)(r + nrhs) per body), each sized for the larger of
    the Newton and velocity solves; the inline kernels' lanes of q, f, d, u, z, q+ and dV/dq
    there (`cq`, `cf`, `cd`, `cu`, `cz`, `cqn`, `cgn`, 3 n), M_ii and A(q+)_ii (`cm`, `ca`,
    n); `end` past them.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> w = chain_lane_work(lower_system(builtin("rope", n=10).with_batch()), 100, 2)
        >>> w["ch"] - w["ce"], w["cb"] - w["ck"]
        (180, 180)
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
        **{array: 3 * n for array in ("cq", "cf", "cd", "cu", "cz", "cqn", "cgn")},
        "cm": n,
        "ca": n,
    }
    off: dict[str, int] = {}
    for name, size in sizes.items():
        off[name] = at
        at += size * lanes
    off["end"] = at
    return off
