"""Pass `opcount`: operation counts of each lowered kernel, shown in the emitted files.

Input: a `Module` of lowered kernels. Output: the same module with each kernel's `ops_after`
set to SymPy's count of its assignments (as they will be printed).

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.equations.assemble import sphere_module
    >>> from s2gen.passes.cse import cse_pass
    >>> m = opcount_pass(cse_pass(sphere_module(builtin("double_pendulum"))))
    >>> m.kernel("cayley").ops_after > 0
    True
"""

from __future__ import annotations

import functools
from dataclasses import replace

from s2gen.ir import Kernel, Module
from s2gen.passes.cse import count_ops

__all__ = ["kernel_ops", "module_ops", "opcount_pass"]


@functools.lru_cache(maxsize=2048)
def kernel_ops(kernel: Kernel) -> int:
    """Operations of a lowered kernel's assignments."""
    return count_ops([a.expr for a in kernel.assignments])


def module_ops(module: Module) -> int:
    """Operations of all lowered kernels of a module (0 for kernels not yet lowered)."""
    return sum(kernel_ops(k) for k in module.kernels if isinstance(k, Kernel))


def opcount_pass(module: Module) -> Module:
    """Attach `ops_after` to every lowered kernel."""
    kernels = tuple(
        replace(k, ops_after=kernel_ops(k)) if isinstance(k, Kernel) else k for k in module.kernels
    )
    return replace(module, kernels=kernels)
