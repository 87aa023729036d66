"""Scaling: the cost of every form for chains of n = 1 … `chain_max` spherical pendula.

Input: `Settings` (`chain_max`, `budget`, `repeats`). Output: a `Cost` per form and n
(`scaling`); a form over budget (or failing) is not tried for larger n. `chain_system(n)`
builds the chain.

Example:
    >>> chain_system(3).n
    3
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from s2gen import System, define

from .cost import _cost_line, costs, generic_state
from .model import Cost
from .settings import FORMS, Settings


def chain_system(n: int) -> System:
    """n spherical pendula in a chain: M_ij = (sum_{k>=max(i,j)} m_k) l_i l_j, gravity along e3.

    Example:
        >>> chain_system(2).inertia
        Matrix([
        [l1**2*(m1 + m2), l1*l2*m2],
        [       l1*l2*m2, l2**2*m2]])
    """
    params: dict[str, float] = {}
    for i in range(1, n + 1):
        params[f"m{i}"], params[f"l{i}"] = 1.0, 1.0
    params["g"] = 9.81

    def tail(i: int) -> str:
        return "(" + " + ".join(f"m{k}" for k in range(i, n + 1)) + ")"

    inertia = [[f"{tail(max(i, j))}*l{i}*l{j}" for j in range(1, n + 1)] for i in range(1, n + 1)]
    potential = " + ".join(f"-{tail(i)}*g*l{i}*q{i}[2]" for i in range(1, n + 1))
    q, w = generic_state(n)
    return define(
        name=f"chain{n}",
        bodies=n,
        parameters=params,
        inertia=inertia,
        potential=potential,
        initial_q=q,
        initial_omega=w,
        origin=f"s2gen.compare_angles.chain_system({n})",
    )


def scaling(
    s: Settings, log: Callable[[str], None] = print, forms: Sequence[str] = FORMS
) -> list[Cost]:
    """Cost of every form for chains n = 1..chain_max; a form over budget is not retried."""
    out: list[Cost] = []
    over: dict[str, str] = {}
    for n in range(1, s.chain_max + 1):
        for c in costs(chain_system(n), forms, s.budget, s.repeats, over):
            if c.status != "ok":
                over.setdefault(c.form, c.status)
            log(f"  chain n={n:2d} {c.form:18s} {_cost_line(c)}")
            out.append(c)
    return out
