"""RATTLE on (S^2)^n: Cartesian positions x_i in R^3 with the constraints |x_i|^2 = 1.

Input: nothing system-specific. Output: `KernelDef`s of the per-body steps for diagonal M (the
constrained position update has a closed form there); the coupled case uses the same kernels'
building blocks inside a Newton iteration on the multipliers, laid out by the templates.

RATTLE (the standard constrained Stormer-Verlet) with velocities v_i = qdot_i:
    v+1/2 = v - h/2 M^-1 (g(x) + lambda x),     x+ = x + h v+1/2,     |x_i+|^2 = 1,
    v+    = v+1/2 - h/2 M^-1 (g(x+) + mu x+),   x_i+ . v_i+ = 0.
For diagonal M write y = x + h v - h^2/(2m) g and s = h^2 lambda/(2m); then x+ = y - s x and
|y - s x|^2 = 1 is a quadratic in s whose root nearest 0 is taken in the cancellation-free form
s = (|y|^2 - 1) / ((x.y) + sqrt((x.y)^2 - |x|^2 (|y|^2 - 1))), exact to round-off; the step is
infeasible (reported) when the discriminant is negative. The velocity projection is linear.

Example:
    >>> [k.name for k in rattle_kernels()]
    ['rattle_pos', 'rattle_vel']
"""

from __future__ import annotations

import sympy as sp

from s2gen.equations.geometry import dot
from s2gen.ir import Argument, KernelDef, Output
from s2gen.symbols import vector

__all__ = ["rattle_kernels"]

H = sp.Symbol("h", positive=True)
M_II = sp.Symbol("m", positive=True)


def rattle_kernels() -> list[KernelDef]:
    """Closed-form RATTLE position and velocity updates of one body (diagonal M)."""
    x, v, g, xn, vh, gn = (vector(s) for s in ("x", "v", "g", "xn", "vh", "gn"))
    y = x + H * v - H**2 / (2 * M_II) * g
    xy, xx, c = dot(x, y), dot(x, x), dot(y, y) - 1
    disc = xy**2 - xx * c
    s = c / (xy + sp.sqrt(disc))
    x_new = y - s * x
    v_half = v - H / (2 * M_II) * g - s / H * x
    u = vh - H / (2 * M_II) * gn
    v_new = u - dot(xn, u) / dot(xn, xn) * xn
    scal = lambda sym: Argument(sym.name, (sym,), scalar=True)
    arr = lambda name, m: Argument(name, tuple(m))
    return [
        KernelDef(
            "rattle_pos",
            "RATTLE position step of one body: x+ on |x+| = 1 (closed form), v+1/2, and the "
            "discriminant (must be >= 0)",
            (scal(H), scal(M_II), arr("x", x), arr("v", v), arr("g", g)),
            (
                Output("xn", tuple(x_new)),
                Output("vh", tuple(v_half)),
                Output("disc", (disc,), scalar=True),
            ),
        ),
        KernelDef(
            "rattle_vel",
            "RATTLE velocity step of one body: v+ = u - (x+.u)/(x+.x+) x+, u = v+1/2 - h/(2m) g+",
            (scal(H), scal(M_II), arr("xn", xn), arr("vh", vh), arr("gn", gn)),
            (Output("vn", tuple(v_new)),),
        ),
    ]
