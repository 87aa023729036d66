"""Print the record of step_jvp() (``m.jvp``, read by the ``c/_jvp*.jinja`` partials).

Input: a lowered sphere `Module` whose parts include ``jvp`` (`s2gen.parts.jvp`). Output:
the fixed-step explicit methods step_jvp() takes, each with its tableau as round-trip
literals (a zero-padded to stages x stages, b) and whether q_i is normalized after the
step, and the VI family's substeps; the C lines of dg = H dq (each term's member loop calling its ``t<k>_hvp`` and adding
the member's blocks at its bodies); the field's structured solve's arguments. Every key is
empty for a module without it.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> jvp = print_jvp(lower_system(builtin("four_pendula").with_jacobians()))
    >>> [x["name"] for x in jvp["methods"]], jvp["max_stages"]
    (['rk2', 'rk2-proj', 'rk4', 'rk3'], '4')
"""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from s2gen.ir import Module
from s2gen.methods import METHODS, Family, fixed_methods
from s2gen.parts.jvp import JVP_PART
from s2gen.printing.c import c_loop
from s2gen.printing.c_calls import c_call
from s2gen.printing.jacobian import composition_record, tableau_record

__all__ = ["print_jvp"]

_KEYS = ("methods", "count", "max_stages", "hvp", "vi_methods", "vi_count", "max_sub", "other")


def _lits(values: list[Fraction]) -> str:
    return ", ".join(repr(float(v)) for v in values)


def print_jvp(module: Module) -> dict[str, Any]:
    """The ``m.jvp`` record of a module (every key empty without the ``jvp`` part)."""
    if JVP_PART not in module.parts:
        return dict.fromkeys(_KEYS, ())
    methods = [tableau_record(m) for m in fixed_methods(module.kind.value)]
    return {
        "methods": tuple(methods),
        "count": str(len(methods)),
        "max_stages": str(max(int(m["stages"]) for m in methods)),
        "hvp": hvp_lines(module),
        **_vi(module),
    }


def _vi(module: Module) -> dict[str, Any]:
    """The VI family's entries: each method's substeps (fractions of h) and the lines that
    step_jvp() runs for a method without a tableau (the VI's substeps where the module has
    the ``jvp_vi`` part, else ERR_ARGUMENT)."""
    name, upper = module.name, module.name.upper()
    if "jvp_vi_steps" not in module.parts:
        return {
            "vi_methods": (),
            "vi_count": "0",
            "max_sub": "1",
            "other": (f"return {upper}_ERR_ARGUMENT;",),
        }
    methods = tuple(
        composition_record(m)
        for m in METHODS
        if m.family is Family.VI and m.composition is not None
    )
    copies = [("ys", "q"), ("ys + n3", "w"), ("dys", "dq"), ("dys + n3", "dw")]
    return {
        "vi_methods": methods,
        "vi_count": str(len(methods)),
        "max_sub": str(max(int(m["count"]) for m in methods)),
        "other": (
            *(f"{name}_copy({to}, {src}, n3);" for to, src in copies),
            f"return {name}_jvp_vi_step(&cx, opt, method, h, ys, dys, qn, wn, dqn, dwn, work);",
        ),
    }


def hvp_lines(module: Module) -> tuple[str, ...]:
    """The C lines that set dg (N3) to H dq, H the Hessian of V at q: zeros, then each term
    with a Hessian (a ``t<k>_hvp`` kernel) member by member, its blocks added at the member's
    bodies.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> lines = hvp_lines(lower_system(builtin("four_pendula").with_jacobians()))
        >>> lines[1], any("four_pendula_k_t1_hvp(" in line for line in lines)
        ('    dg[r] = 0.0;', True)
    """
    name, upper = module.name, module.name.upper()
    calls = {c.site: c for c in module.calls}
    lines = [f"for (r = 0; r < {upper}_N3; ++r) {{", "    dg[r] = 0.0;", "}"]
    for t in module.terms:
        call = calls.get(f"t{t.index}_hvp")
        if call is None:  # a term linear in the positions
            continue
        kind = t.loop.kind.kind
        head, tail = c_loop(name, t, module.n)
        tangents = ", ".join(
            f"*t_{role} = dq + 3 * {index}" for role, index in zip(kind.roles, kind.indices)
        )
        inner = [
            f"const double {tangents};",
            f"double hv[{3 * len(kind.indices)}];",
            f"{c_call(name, call)};",
            *(
                f"dg[3 * {index} + {c}] += hv[{3 * r + c}];"
                for r, index in enumerate(kind.indices)
                for c in range(3)
            ),
        ]
        lines += [line[4:] for line in head]
        lines += [f"        {line}" for line in inner]
        lines += [line[4:] for line in tail]
    return tuple(lines)
