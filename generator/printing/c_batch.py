"""The batch part's record for c/_batch.jinja: lanes, workspace offsets, the field inline.

Input: a lowered sphere module with the ``batch`` part (`s2gen.parts.batch`). Output: a
`PrintedBatch` (empty `{}` without the part), read by the template as `m.batch`. The VI's
position and velocity updates are the module's own inline lines (`m.inline`); the
uncoupled vector field's kernel (rhs_diag) is written inline here by the same printer
(`c_inline`), so that a lane performs the very operations of the one-member kernel.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> b = print_batch(lower_system(builtin("four_pendula").with_batch()))
    >>> b["lanes"], b["work"]["lane_work"], b["rhs"][0]
    (8, 0, 'const double dq0 = -q1*w2 + q2*w1;')
    >>> print_batch(lower_system(builtin("four_pendula")))
    {}
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Kernel, Module
from s2gen.methods import explicit_tableaus
from s2gen.parts.batch import BATCH_LANES, BATCH_PART
from s2gen.printing.c import c_inline

__all__ = ["batch_work", "print_batch"]

#: The buffers of the lane region, VI then Runge-Kutta (they share the region), with their
#: sizes in (N3, n, NS, stages) units per lane.
_VI = ("x", "v", "gx", "xn", "vn", "gn")


def batch_work(module: Module, lanes: int = BATCH_LANES) -> dict[str, int]:
    """Offsets (doubles) of integrate_batch()'s workspace: each lane's own workspace
    (`lane_work`, WORK_SIZE each: its per-call context and the scratch of the one-member
    gradient and energy), each lane's parameters (`params`), each lane's contiguous copies
    of one member's q, w and g (`scratch`, 4 N3 each), then the lane arrays (lane
    innermost), aligned to 64 bytes inside `size` doubles (`slack` to spare).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> w = batch_work(lower_system(builtin("three_bodies").with_batch()), lanes=2)
        >>> w["params"], w["scratch"], w["lanes"]
        (2 * WORK_SIZE, ...)
    """
    n3, n = 3 * module.n, module.n
    ns = 2 * n3
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    off: dict[str, int] = {"lane_work": 0}
    at = lanes * module.work_size
    off["params"] = at
    at += lanes * max(1, len(module.parameter_names))
    off["scratch"] = at
    at += lanes * 4 * n3
    off["lanes"] = at
    rel = 0
    for name in _VI:
        off[name] = rel
        rel += n3 * lanes
    off["sv"], off["mi"], off["chk"] = rel, rel + n * lanes, rel + 2 * n * lanes
    vi_end = rel + 2 * n * lanes + lanes
    # Runge-Kutta: y0, yn, the stages k, g, then the same mi and chk after them
    rk = {"y0": 0, "yn": ns * lanes, "k": 2 * ns * lanes, "g": (2 + stages) * ns * lanes}
    rk_end = rk["g"] + n3 * lanes
    off.update({f"rk_{k}": v for k, v in rk.items()})
    off["rk_mi"], off["rk_chk"] = rk_end, rk_end + n * lanes
    rk_end += n * lanes + lanes
    off["slack"] = 7
    off["size"] = at + max(vi_end, rk_end) + off["slack"]
    return off


def print_batch(module: Module) -> dict[str, Any]:
    """The batch part's record: lane count, lane-array sizes, workspace offsets, the rhs_diag
    kernel inline (outputs dq0.., dw0..) and the stage arrays' names; `{}` without the part."""
    if BATCH_PART not in module.parts:
        return {}
    lanes, n3 = BATCH_LANES, 3 * module.n
    kernel = module.kernel("rhs_diag")
    assert isinstance(kernel, Kernel), "the passes lowered every kernel"
    shared, rhs = c_inline(kernel, scalars=("q", "w", "g"))
    assert not shared and [a.name for a in kernel.inputs] == ["mi", "q", "w", "g"]
    for name in ("vi_pos", "vi_vel"):
        k = module.kernel(name)
        scalars = [a.name for a in k.inputs if a.scalar]
        assert scalars == ["h", "mi"], f"{name}: the batch loads h and mi only, not {scalars}"
    return {
        "lanes": lanes,
        "nl3": n3 * lanes,
        "nsl": 2 * n3 * lanes,
        "work": batch_work(module, lanes),
        "rhs": rhs,
    }
