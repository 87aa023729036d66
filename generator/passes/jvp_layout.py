"""The workspace of step_jvp() (part of the `workspace` pass).

Input: a sphere `Module` with the ``jvp`` part and the size of its field's workspace. Output:
its ``jvp`` `Layout`, offsets from 0; the `workspace` pass places it after the per-call
context (as the step Jacobians' layout), so that WORK_SIZE stays as it is and the header's
JVP_WORK_SIZE is its end. Every buffer is O(n).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> lay = lower_system(builtin("four_pendula").with_jacobians()).layout("jvp")
    >>> [b.name for b in lay.buffers][:4]
    ['ys', 'k', 'dys', 'dk']
"""

from __future__ import annotations

from s2gen.inertia import InertiaKind
from s2gen.ir import Buffer, Layout, Module
from s2gen.methods import explicit_tableaus

__all__ = ["jvp_layout"]


def jvp_layout(module: Module, field: int, vi: int) -> Layout:
    """The stage state ys and its tangent dys (NS each), the stages' fields k and tangents dk
    (stages x NS each), dg = H dq (N3); with a coupled M the tangent's pair sums and products
    with M_off (du, dz, ka = K a, dka, zy, dzy: N3 each); then the field's own workspace
    (`field` doubles); the VI's: its substep's workspace (`vi` doubles), the gradients at
    both ends, Cayley parameters and dg+ = H(q+) dq+; with a coupled M the known side's,
    residual's and velocity side's tangents and Newton's blocks at the converged parameters
    (e2, hb2, kb2: 9n each), with a diagonal M the half-step velocity and its tangent."""
    n3, ns = 3 * module.n, 6 * module.n
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    coupled = module.solver is not InertiaKind.DIAGONAL
    sizes = [("ys", ns), ("k", stages * ns), ("dys", ns), ("dk", stages * ns), ("dg", n3)]
    sizes += [(b, n3) for b in ("du", "dz", "ka", "dka", "zy", "dzy") if coupled]
    sizes.append(("field", field))
    # the VI's substep (`vi` doubles: the step's own workspace) and its tangent
    sizes += [("vi", vi), *((b, n3) for b in ("g", "gn", "f", "dgn"))]
    if coupled:
        more = ("v", "dv", "z", "dz", "dd", "u", "duq", "r", "df", "dc")
        sizes += [(b, n3) for b in more]
        sizes += [(b, 3 * n3) for b in ("e2", "hb2", "kb2")]
    else:
        sizes += [("wh", n3), ("dwh", n3)]
    buffers, offset = [], 0
    for name, size in sizes:
        buffers.append(Buffer(name, size, offset))
        offset += size
    return Layout("jvp", tuple(buffers))
