"""A dense M's Newton VI in loops over the lanes: the kernels of vi_advance inline, per lane.

Input: a lowered sphere module with the ``batch`` part and the dense VI (``vi_newton``) whose
dV/dq and field run in lane loops (`s2gen.printing.c_batch.coupled_field`). Output: the
record `m.batch.newton_lanes` of c/sections/_batch_vi_lanes.jinja: each kernel of the
one-member vi_advance (d_body, d_pair, res_body, res_pair, cayley, c_body, c_pair, a_body)
written inline for a loop over lanes l, its inputs read from body-major lane arrays (element
e of lane l at [e * L + l]) and its outputs stored, or added, where vi_advance puts them, in
the same order; the lanes' workspace for it (`newton_lane_work`).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> r = newton_lanes(lower_system(builtin("double_pendulum").with_batch()))
    >>> r["d_body_stores"][0]
    'dd[(3 * i + 0) * L + l] = d0;'
    >>> newton_lanes(lower_system(builtin("four_pendula").with_batch()))
    {}
"""

from __future__ import annotations

from typing import Any

import sympy as sp

from s2gen.ir import Kernel, Module
from s2gen.printing.c import CPrinter

__all__ = ["lane_inline", "newton_lane_work", "newton_lanes"]

#: Each VI kernel's 3-vector inputs: name -> (lane array, body index in the loop).
_BODY = {"q": ("qs", "i"), "w": ("ws", "i"), "g": ("gs", "i"), "f": ("ff", "i"), "d": ("dd", "i")}
_VECTORS: dict[str, dict[str, tuple[str, str]]] = {
    "d_body": {k: _BODY[k] for k in ("q", "w", "g")},
    "d_pair": {"qi": ("qs", "i0"), "wi": ("ws", "i0"), "qj": ("qs", "j0"), "wj": ("ws", "j0")},
    "res_body": {k: _BODY[k] for k in ("q", "f", "d")},
    "res_pair": {"qi": ("qs", "i0"), "fi": ("ff", "i0"), "qj": ("qs", "j0"), "fj": ("ff", "j0")},
    "cayley": {k: _BODY[k] for k in ("q", "f")},
    "c_body": {**{k: _BODY[k] for k in ("q", "f")}, "qn": ("qn", "i"), "gn": ("gn", "i")},
    "c_pair": {
        "qi": ("qs", "i0"),
        "fi": ("ff", "i0"),
        "qni": ("qn", "i0"),
        "qj": ("qs", "j0"),
        "fj": ("ff", "j0"),
        "qnj": ("qn", "j0"),
    },
    "a_body": {"q": ("qn", "i")},
}
#: The scalar inputs: the substep h, M_ii and M_ij of the lane.
_SCALARS = {"h": "h", "m": "md[i * L + l]", "mij": "mp[k * L + l]"}


def lane_inline(
    kernel: Kernel, vectors: dict[str, tuple[str, str]], scalars: dict[str, str]
) -> tuple[str, ...]:
    """`kernel`'s body inline in a loop over lanes l: each 3-vector input read from its lane
    array (`vectors`: name -> (array, body)), each scalar input by its C expression, each
    output slot y[k] the scalar yk (the printer of the one-member kernel's body).

    Example:
        >>> from s2gen.ir import Argument, Output, KernelDef
        >>> from s2gen.passes import lower
        >>> a = sp.symbols("q_0:3", real=True)
        >>> k = lower(KernelDef("k", "", (Argument("q", a),), (Output("g", (2 * a[1],)),)))
        >>> lane_inline(k, {"q": ("x", "i")}, {})
        ('const double g0 = 2*x[(3 * i + 1) * L + l];',)
    """
    names: dict[sp.Symbol, str] = {}
    for arg in kernel.inputs:
        assert not arg.shared, f"{kernel.name}: shared inputs are not read from the lanes"
        if arg.scalar:
            names[arg.symbols[0]] = scalars[arg.name]
        else:
            array, body = vectors[arg.name]
            names.update(
                {s: f"{array}[(3 * {body} + {c}) * L + l]" for c, s in enumerate(arg.symbols)}
            )
    pr = CPrinter(names)
    lines = []
    for a in kernel.assignments:
        target = a.temp if a.temp is not None else f"{a.output[0]}{a.output[1]}"  # type: ignore[index]
        lines.append(f"const double {target} = {pr.doprint(a.expr)};")
    return tuple(lines)


def _pair_adds(array: str, i: str, j: str) -> tuple[str, ...]:
    """vi_advance's accumulation of a pair's two 3-vectors: for c, array[3 i0 + c] += i_c,
    then array[3 j0 + c] += j_c."""
    return tuple(
        f"{array}[(3 * {b} + {c}) * L + l] += {out}{c};"
        for c in range(3)
        for b, out in (("i0", i), ("j0", j))
    )


def newton_lanes(module: Module) -> dict[str, Any]:
    """The inline kernels of a dense M's vi_advance for loops over lanes and the stores of
    their outputs (empty for another module): d (assigned per body, pairs added), the
    residual r and the Jacobian's blocks (diagonal blocks assigned, pair blocks added onto
    zeros, as vi_advance does), the Cayley map, c and A(q+)'s diagonal.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> r = newton_lanes(lower_system(builtin("double_pendulum").with_batch()))
        >>> r["a_body_stores"], r["c_pair_stores"][:2]
        (('adiag[i * L + l] = a0;',), ('wn[(3 * i0 + 0) * L + l] += ci0;', 'wn[(3 * j0 + 0) * L + l] += cj0;'))
    """
    if "vi_newton" not in module.parts or "batch" not in module.parts:
        return {}
    n3 = 3 * module.n
    out: dict[str, Any] = {}
    for name, vectors in _VECTORS.items():
        kernel = module.kernel(name)
        assert isinstance(kernel, Kernel), "the passes lowered every kernel"
        out[name] = lane_inline(kernel, vectors, _SCALARS)
    jm = "jm[((3 * {r} + {a}) * {n3} + 3 * {c} + {b}) * L + l]"
    out["d_body_stores"] = tuple(f"dd[(3 * i + {c}) * L + l] = d{c};" for c in range(3))
    out["d_pair_stores"] = _pair_adds("dd", "di", "dj")
    out["res_body_stores"] = tuple(f"rr[(3 * i + {c}) * L + l] = r{c};" for c in range(3)) + tuple(
        f"{jm.format(r='i', a=a, n3=n3, c='i', b=b)} = jac{3 * a + b};"
        for a in range(3)
        for b in range(3)
    )
    out["res_pair_stores"] = tuple(
        line
        for a in range(3)
        for line in (
            f"rr[(3 * i0 + {a}) * L + l] += ri{a};",
            f"rr[(3 * j0 + {a}) * L + l] += rj{a};",
            *(
                f"{jm.format(r=r, a=a, n3=n3, c=c, b=b)} += {blk}{3 * a + b};"
                for b in range(3)
                for r, c, blk in (("i0", "j0", "jij"), ("j0", "i0", "jji"))
            ),
        )
    )
    out["cayley_stores"] = tuple(f"qn[(3 * i + {c}) * L + l] = qn{c};" for c in range(3))
    out["c_body_stores"] = tuple(f"wn[(3 * i + {c}) * L + l] = c{c};" for c in range(3))
    out["c_pair_stores"] = _pair_adds("wn", "ci", "cj")
    out["a_body_stores"] = ("adiag[i * L + l] = a0;",)
    return out


def newton_lane_work(module: Module, at: int, lanes: int) -> dict[str, int]:
    """Offsets (doubles, from `at`) of the lane arrays of a dense M's Newton VI: the state's
    gradient g and gn, the substeps' positions and velocities (qa, qb, va, vb, q1, w1), d, r,
    A(q+)'s diagonal, and the Cayley parameters of every substep (f: as many N3 blocks as
    integrate_geometric keeps); `end` past them.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> w = newton_lane_work(lower_system(builtin("double_pendulum").with_batch()), 0, 8)
        >>> w["vgn"], w["vadiag"], w["vf"] - w["vadiag"]
        (48, 480, 16)
    """
    n3 = 3 * module.n
    layouts = {lay.name: lay for lay in module.layouts}
    substeps = next(b.size for b in layouts["geometric"].buffers if b.name == "f") // n3
    off: dict[str, int] = {}
    for name in ("vg", "vgn", "vqa", "vqb", "vva", "vvb", "vq1", "vw1", "vd", "vr"):
        off[name] = at
        at += n3 * lanes
    off["vadiag"] = at
    at += module.n * lanes
    off["vf"] = at
    at += substeps * n3 * lanes
    off["end"] = at
    return off
