"""The quadratic terms' Kx + b of integrate_batch() in loops over the lanes.

Input: a lowered sphere module with the ``batch`` part whose potential is the quadratic
matrix K alone (every term in K, no general kernel). Output: the gradient record of
`s2gen.printing.c_batch.lane_gradient` for it (no member loops; `quadratic` set; `field_g`:
the lines that load a body's dV/dq for the uncoupled field), laid out by
c/sections/_batch_quadratic_lanes.jinja, where each lane performs the one-member
quadratic_soa's operations in its order: the same four-column passes and parenthesisation,
the same 3 x 3 component blocks skipped, the same final add of b, so that its results are
quadratic_soa's bit for bit.

How lanes get their K: K depends on the member's parameters, so the lanes share one K, each
entry read once for all lanes, only where every lane's K and b (with its zero-block flags)
are lane 0's bit for bit: integrate_batch() compares them when it starts a block of lanes
(c/sections/_batch_quadratic_share.jinja). That holds for the usual ensemble of perturbed
initial states, and for parameters K does not depend on (the dipoles' mass m: each lane its
own M, one K). Where they differ, the block's dV/dq runs lane by lane through gradient_soa,
each lane with its own K: a K per lane would stream 8 (3n)^2 doubles per evaluation instead
of (3n)^2, and its zero blocks could differ between lanes.

With terms both in K and in member loops the one-member code sums the two in one order for
the VI (gradient_soa: Kx + b, then the member loops' sum added) and in another for the field
(gradient_cx: the member loops added one by one to Kx + b), so such a gradient runs lane by
lane (None).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> g = quadratic_lanes(lower_system(builtin("dipoles").with_batch()))
    >>> g["quadratic"], g["parts"], g["field_g"][0]
    (True, (), '(void)g;')
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Module

__all__ = ["quadratic_lanes"]


def quadratic_lanes(module: Module) -> dict[str, Any] | None:
    """The gradient record of a module whose dV/dq is Kx + b alone; None where some term is
    not in K or a general kernel adds to it."""
    general = dict(module.facts).get("general", False)
    if not module.quadratic or general or not all(t.quadratic for t in module.terms):
        return None
    n, lanes = module.n, f"{module.name.upper()}_BATCH_LANES"
    return {
        "general": False,
        "parts": (),
        "quadratic": True,
        # the field's dV/dq body-major, as gradient_cx leaves it: 0.0 + (Kx + b)
        "field_g": (
            "(void)g;",
            (
                f"const double g0 = 0.0 + gs[i * {lanes} + l], "
                f"g1 = 0.0 + gs[({n} + i) * {lanes} + l], "
                f"g2 = 0.0 + gs[({2 * n} + i) * {lanes} + l];"
            ),
        ),
    }
