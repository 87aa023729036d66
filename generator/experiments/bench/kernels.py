"""Operations per kernel before and after the lowering passes, for ``bench.md``.

Input: a system. Output: one row per emitted kernel: its operations as derived (the kernel
definitions the equations give, before any pass) and after the passes (as printed; see
`s2gen.passes.opcount`), with the total saved. Kernels the passes create (the per-call
context, per-member tables, the quadratic terms' coefficients) have no "as derived" count.

Example:
    >>> import s2gen
    >>> rows = {r["kernel"]: r for r in kernel_rows(s2gen.load("double_pendulum"))}
    >>> rows["context"]["before"] is None, rows["d_body"]["after"].total < rows["d_body"]["before"].total
    (True, True)
"""

from __future__ import annotations

from typing import Any

from s2gen import System
from s2gen.inspect import Kernel, KernelDef, definition_profile, derived, kernel_profile, lowered

from .common import _table

__all__ = ["kernel_rows", "md_kernel_ops"]


def kernel_rows(system: System) -> list[dict[str, Any]]:
    """Per kernel: operations as derived ("before", None for kernels the passes add) and as
    printed after the passes ("after")."""
    as_derived = {k.name: k for k in derived(system).kernels if isinstance(k, KernelDef)}
    rows = []
    for k in lowered(system).kernels:
        if not isinstance(k, Kernel):
            continue
        before = as_derived.get(k.name)
        rows.append(
            {
                "kernel": k.name,
                "before": definition_profile(before) if before is not None else None,
                "after": kernel_profile(k),
            }
        )
    return rows


def md_kernel_ops(system: System) -> list[str]:
    """The Markdown table of `kernel_rows`."""
    rows = kernel_rows(system)
    body = [
        [
            r["kernel"],
            str(r["before"]) if r["before"] is not None else "(added by the passes)",
            str(r["after"]),
        ]
        for r in rows
    ]
    before = sum(r["before"].total for r in rows if r["before"] is not None)
    after = sum(r["after"].total for r in rows if r["before"] is not None)
    title = (
        "Operations per kernel, as derived and after the lowering passes (as printed: +, *, /, "
        f"sqrt, calls of pow and other functions). Kernels present in both: {before} → {after} "
        "operations per evaluation of each:"
    )
    return [title, "", *_table(("kernel", "as derived", "after the passes"), body)]
