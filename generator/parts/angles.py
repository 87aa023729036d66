"""The parts of the angle-form module: their call sites (with their bindings) and buffers.

The conversion loops over the bodies with loop variable e (`Index.ELEMENT`): two angles and
two rates per body, a position and an angular velocity of three.

Example:
    >>> [p.name for p in ANGLE_PARTS]
    ['angles_context', 'angles_convert', 'angles_field', 'angles_driver']
"""

from __future__ import annotations

from s2gen.bindings import Index, Local, Slot
from s2gen.parts.records import Context, Part, Site

__all__ = ["ANGLE_PARTS"]

#: The angle-form module's own parts (it shares kernels, helpers, lu and rk with the sphere's)
ANGLE_PARTS = (
    Part("angles_context"),
    Part(
        "angles_convert",
        sites=(
            Site(
                "to_sphere",
                "to_sphere",
                Context.BODY,
                {
                    "a": Slot("x", 2, Index.ELEMENT, "xa"),
                    "ad": Slot("xd", 2, Index.ELEMENT, "xda"),
                    "q": Slot("q", 3, Index.ELEMENT),
                    "w": Slot("w", 3, Index.ELEMENT),
                },
            ),
            Site("energy", "energy", Context.SYSTEM, {"e": Local("e", address=True)}),
        ),
    ),
    Part(
        "angles_field",
        sites=(
            Site(
                "dynamics",
                "dynamics",
                Context.SYSTEM,
                {"m": Local("mm", vector="m"), "f": Local("xdd", vector="f")},
            ),
        ),
        buffers=(("field", ("m", "lu")),),
    ),
    Part(
        "angles_driver",
        buffers=(
            ("rk_step", ("y0", "yt", "fail", "rk")),
            ("rk45", ("k", "y", "yn", "ys", "field")),
            ("integrate", ("run", "y0", "fail")),
        ),
    ),
)
