"""The parts of step_jvp(): O(n) Jacobian-vector products of a fixed Runge-Kutta step (C only).

A sphere module with `s2gen.equations.jvp.has_jvp` selects, after its other parts:

- ``jvp_hvp``: dg = H dq, the Hessian of V times a tangent of the positions, member by member
  in each term's loop (``t<k>_hvp``);
- ``jvp_diagonal`` or ``jvp_structured``: the field and its tangent at a state along a
  tangent direction (``jvp_diag``; or ``jvp_src``, ``jvp_ka``, ``jvp_rhs``, the products with
  M_off and the field's structured solve on its own blocks);
- ``jvp_vi`` (structured M): one VI step and its tangent by the implicit function theorem on
  the step's converged equations (Newton's own Jacobian in the Cayley parameters, the
  velocity equations' A(q+)), each solved by the structured solve; or ``jvp_vi_diagonal``
  (diagonal M): the explicit VI step and its tangent, body by body;
- ``jvp_vi_steps``: the VI family's methods, their substeps in turn;
- ``jvp``: step_jvp(), the tableau's stages with their tangents.

Example:
    >>> [p.name for p in JVP_PARTS]
    ['jvp_hvp', 'jvp_diagonal', 'jvp_structured', 'jvp_vi', 'jvp_vi_diagonal', 'jvp_vi_steps', 'jvp']
"""

from __future__ import annotations

from s2gen.bindings import Binding, Element, Index, Local, Slot
from s2gen.ir import Module
from s2gen.parts.records import Context, Part, Site

__all__ = ["JVP_C_ONLY", "JVP_PART", "JVP_PARTS", "jvp_parts"]

#: The name of the part that emits step_jvp() (its partial: c/_jvp.jinja)
JVP_PART = "jvp"


def _hvp_sites(module: Module) -> tuple[Site, ...]:
    """Each term's Hessian-vector product at member m of its loop: the member's data as its
    gradient reads them, the tangents of its positions in the locals t_<role>, into hv."""
    from s2gen.parts import term_sites

    sites = []
    for t in module.terms:
        roles = t.loop.kind.kind.roles
        bind: dict[str, Binding] = {**term_sites(t)[1].bind, "hv": Local("hv")}
        bind.update({f"t_{role}": Local(f"t_{role}") for role in roles})
        sites.append(Site(f"t{t.index}_hvp", f"t{t.index}_hvp", Context.SYSTEM, bind))
    return tuple(sites)


_B = Context.BODY

#: The parts, in the order a module lays them out
JVP_PARTS = (
    Part("jvp_hvp", module_sites=_hvp_sites),
    Part(
        "jvp_diagonal",
        sites=(Site("jvp_diag", "jvp_diag", _B, {"m": Element("md", Index.BODY, context=True)}),),
        buffers=(("field", ("g",)), ("jvp", ("dg", "field"))),
    ),
    Part(
        "jvp_structured",
        sites=(
            Site("jvp_src", "jvp_src", _B),
            Site("jvp_ka", "jvp_ka", _B),
            Site("jvp_rhs", "jvp_rhs", _B),
        ),
        buffers=(
            ("field", ("g", "z", "e", "hb", "kb", "solve")),
            ("jvp", ("dg", "field", "du", "dz", "ka", "dka", "zy", "dzy")),
        ),
    ),
    Part(
        "jvp_vi",
        sites=(
            Site("jvp_vel", "jvp_vel", _B),
            Site("jvp_d", "jvp_d", _B),
            Site("jvp_vi_disp", "disp", _B, {"kd": Slot("kb2", 9, Index.BODY)}),
            Site("jvp_dispq", "jvp_dispq", _B),
            Site(
                "jvp_vi_res",
                "res_coupled",
                _B,
                {"e": Slot("e2", 9, Index.BODY), "hq": Slot("hb2", 9, Index.BODY)},
            ),
            Site("jvp_res", "jvp_res", _B, {"dr": Slot("df", 3, Index.BODY)}),
            Site("jvp_cay", "jvp_cay", _B),
            Site("jvp_disp", "jvp_disp", _B),
            Site("jvp_c", "jvp_c", _B),
            Site(
                "jvp_ka_vi",
                "jvp_ka",
                _B,
                {
                    "q": Slot("qn", 3, Index.BODY),
                    "a": Slot("wn", 3, Index.BODY),
                    "dq": Slot("dqn", 3, Index.BODY),
                },
            ),
            Site("jvp_vrhs", "jvp_vrhs", _B, {"tb": Slot("dwn", 3, Index.BODY)}),
        ),
        buffers=(
            ("vi_advance", ("d", "e", "hb", "kb", "solve")),
            ("jvp", ("vi", "g", "gn", "f", "dg", "dgn", "v", "dv", "z", "dz", "dd", "u")),
            ("jvp", ("duq", "r", "df", "dc", "e2", "hb2", "kb2", "ka", "dka", "zy", "dzy")),
        ),
    ),
    Part(
        "jvp_vi_diagonal",
        sites=(
            Site("jvp_vpos", "jvp_vpos", _B),
            Site("jvp_vvel", "jvp_vvel", _B),
        ),
        buffers=(("jvp", ("vi", "g", "gn", "f", "dg", "dgn", "wh", "dwh")),),
    ),
    Part("jvp_vi_steps"),
    Part(JVP_PART, buffers=(("jvp", ("ys", "k", "dys", "dk")),)),
)

#: The parts have no NumPy partial (step_jvp() is C only)
JVP_C_ONLY = tuple(p.name for p in JVP_PARTS)


def jvp_parts(diagonal: bool) -> tuple[str, ...]:
    """The names of the parts a module with step_jvp() selects (diagonal M or not).

    Example:
        >>> jvp_parts(True)
        ('jvp_hvp', 'jvp_diagonal', 'jvp_vi_diagonal', 'jvp_vi_steps', 'jvp')
    """
    if diagonal:
        return ("jvp_hvp", "jvp_diagonal", "jvp_vi_diagonal", "jvp_vi_steps", JVP_PART)
    return ("jvp_hvp", "jvp_structured", "jvp_vi", "jvp_vi_steps", JVP_PART)
