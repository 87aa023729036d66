"""The batch part's record for c/_batch.jinja: lanes, lane-array sizes, workspace offsets.

Input: a lowered sphere module with the ``batch`` part (`s2gen.parts.batch`). Output: a dict
(empty without the part), read by the template as `m.batch`. The VI's position and velocity
updates in the lane loops are the module's own inline lines (`m.inline`, the C printer's), so
that a lane performs the very operations of the one-member loop over bodies.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> b = print_batch(lower_system(builtin("four_pendula").with_batch()))
    >>> b["lanes"], b["nsl"], b["work"]["lane_work"]
    (8, 192, 0)
    >>> print_batch(lower_system(builtin("four_pendula")))
    {}
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Module
from s2gen.methods import explicit_tableaus
from s2gen.parts.batch import BATCH_LANES, BATCH_PART

__all__ = ["batch_work", "print_batch"]

#: The explicit VI's lane arrays of N3 doubles per lane (then sv, mi and chk); the
#: Runge-Kutta arrays share the region with them.
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
        >>> m = lower_system(builtin("three_bodies").with_batch())
        >>> w = batch_work(m, lanes=2)
        >>> w["params"] == 2 * m.work_size, w["scratch"] - w["params"], w["x"], w["v"]
        (True, 4, 0, 18)
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
    # Runge-Kutta: y0, yn, the stages k and chk
    rk = {"y0": 0, "yn": ns * lanes, "k": 2 * ns * lanes, "chk": (2 + stages) * ns * lanes}
    rk_end = rk["chk"] + lanes
    off.update({f"rk_{k}": v for k, v in rk.items()})
    off["slack"] = 7
    off["size"] = at + max(vi_end, rk_end) + off["slack"]
    return off


def print_batch(module: Module) -> dict[str, Any]:
    """The batch part's record: lane count, the flat size of an NS-per-lane array and the
    workspace offsets (`batch_work`); `{}` without the part."""
    if BATCH_PART not in module.parts:
        return {}
    for name in ("vi_pos", "vi_vel"):
        scalars = [a.name for a in module.kernel(name).inputs if a.scalar]
        assert scalars == ["h", "mi"], f"{name}: the batch loads h and mi only, not {scalars}"
    return {
        "lanes": BATCH_LANES,
        "nsl": 6 * module.n * BATCH_LANES,
        "work": batch_work(module, BATCH_LANES),
    }
