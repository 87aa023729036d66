"""The workspace of step_jacobian() (part of the `workspace` pass).

Input: a sphere `Module` with the ``jacobian`` part. Output: its ``jacobian`` `Layout`, with
offsets from 0; the `workspace` pass places it after the per-call context, so that WORK_SIZE,
which every other function reads, stays as it is, and the header's JACOBIAN_WORK_SIZE is its
end.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> lay = lower_system(builtin("double_pendulum").with_jacobians()).layout("jacobian")
    >>> [b.name for b in lay.buffers][:4]
    ['ys', 'k', 'dy', 'kd']
"""

from __future__ import annotations

from s2gen.inertia import InertiaKind
from s2gen.ir import Buffer, Layout, Module
from s2gen.methods import explicit_tableaus

__all__ = ["jacobian_layout"]


def jacobian_layout(module: Module) -> Layout:
    """The stage state ys and fields k, the derivatives of the stage state (dy), of each stage
    (kd) and of the step (d), all with the state's 6n columns, then the inputs' and the
    parameters', the field's Jacobian jx and its parts (jq, jr, am, ju), the Hessian of V (H),
    the derivative of G = g - F in (q, w, u, p) (gx), G, F and the forces' derivatives (fq,
    fw, fu), M's entries (mm) and the derivatives in the parameters (mp of M, gp of
    g = dV/dq in the inputs and the parameters, fp of F); with the VI's Jacobian, its substeps' states (qs, ws) -> (qd, wd),
    gradients and Cayley parameters, the derivatives of their equations (ey, ex: ny = 9n
    unknowns (f, q+, w+) for a coupled M, 6n for a diagonal one), the product of the
    substeps' so far (sd), the kernel's parts (ex0 = dE/dx, eg, egn, efn = dE/d(G, g+, F+),
    ep = dE/dp) and, at the end of a substep, the Hessian (hn), d(g+ - F+)/d(q+, w+, u, p)
    (gxn), g+ - F+ (Gn) and F+ (Fn)."""
    n = module.n
    m3, ns = 3 * n, 6 * n
    ni = len(module.drive.inputs) if module.drive is not None else 0
    npar = len(module.parameter_names)
    cols = ns + ni + npar
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    sizes = [
        ("ys", ns),
        ("k", stages * ns),
        ("dy", ns * cols),
        ("kd", stages * ns * cols),
        ("d", ns * cols),
        ("jx", ns * cols),
        ("jq", m3 * ns),
        ("jr", m3 * ns),
        ("am", m3 * m3),
        ("ju", m3 * (cols - ns)),
        ("H", m3 * m3),
        ("gx", m3 * cols),
        ("G", m3),
        ("F", m3),
        ("fq", m3 * m3),
        ("fw", m3 * m3),
        ("fu", m3 * (cols - ns)),
        ("mm", n * n),
        ("mp", n * n * npar),
        ("gp", m3 * (ni + npar)),
        ("fp", m3 * npar),
    ]
    if any(k.name == "vi_jacobian" for k in module.kernels):
        ny = (6 if module.solver is InertiaKind.DIAGONAL else 9) * n
        sizes += [(b, m3) for b in ("qs", "ws", "qd", "wd", "g", "gn", "f")]
        sizes += [("ey", ny * ny), ("ex", ny * cols), ("sd", ns * cols)]
        sizes += [("ex0", ny * ns), ("eg", ny * m3), ("egn", ny * m3), ("efn", ny * m3)]
        sizes += [("ep", ny * npar)]
        sizes += [("hn", m3 * m3), ("gxn", m3 * cols), ("Gn", m3), ("Fn", m3)]
    if any(k.name == "rattle_jacobian" for k in module.kernels):
        # RATTLE's equations: 11n unknowns (v+1/2, lambda, x+, v+, mu), their derivatives
        # (rey, rex, rex0 = dE/dx, reg, regn, rep), v+1/2, the multipliers, Newton's start
        # (a closed module's: a driven one's step keeps its own)
        ny = 11 * n
        sizes += [("rey", ny * ny), ("rex", ny * cols), ("rex0", ny * ns), ("reg", ny * m3)]
        sizes += [("regn", ny * m3), ("rep", ny * npar), ("rvh", m3)]
        sizes += [("rlam", n), ("rmu", n), *((("rsv", n),) if module.drive is None else ())]
    buffers, offset = [], 0
    for name, size in sizes:
        buffers.append(Buffer(name, size, offset))
        offset += size
    return Layout("jacobian", tuple(buffers))
