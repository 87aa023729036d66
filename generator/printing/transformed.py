"""The time-transformed methods' records for the drivers (`templates/c/_transformed.jinja`,
`templates/numpy/_transformed.jinja`).

Input: a lowered `Module` and a language. Output: one record per time-transformed method of
`s2gen.methods` that the language's backend has (its enum constant, whether its basic step is
RATTLE's, as C's 0 or 1 and NumPy's False or True, the length and the table of its composition, the tables
the geometric driver prints), or none when the module has no monitor (no `transformed` part).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> print_transformed(lower_system(builtin("three_bodies")))[1]
    {'c_name': 'METHOD_VI4_ADAPTIVE', 'rattle': 0, 'py_rattle': 'False', 'count': 3, 'table': 'triple_jump'}
    >>> [r["c_name"] for r in print_transformed(lower_system(builtin("three_bodies")), "numpy")][4:6]
    ['METHOD_RATTLE_ADAPTIVE', 'METHOD_RATTLE4_ADAPTIVE']
    >>> print_transformed(lower_system(builtin("double_pendulum")))
    ()
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Module
from s2gen.methods import METHODS, Driver, Family

__all__ = ["print_transformed"]


def print_transformed(module: Module, language: str = "c") -> tuple[dict[str, Any], ...]:
    """Per time-transformed method of the backend `language` ("c" or "numpy"): c_name,
    rattle, py_rattle, count and table (the composition's name)."""
    if "transformed" not in module.parts:
        return ()
    return tuple(
        {
            "c_name": m.c_name,
            "rattle": int(m.family is Family.TIME_RATTLE),
            "py_rattle": repr(m.family is Family.TIME_RATTLE),
            "count": len(m.transformed.fractions),
            "table": m.transformed.name,
        }
        for m in METHODS
        if m.driver is Driver.TIME_TRANSFORMED
        and m.transformed is not None
        and language in m.backends
    )
