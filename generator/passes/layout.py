"""Pass `layout`: loops over every pair i < j are laid out as rows the compiler can vectorise.

Input: a `Module`. Output: the same module with every term over all pairs (no cutoff, not in
the quadratic matrix) marked `rows`: its emitted loop runs over rows i with a contiguous inner
loop over the partners j > i, on structure-of-arrays copies of q (and of g for the gradient)
kept in the workspace, with the term's kernel written inline and the row's sums as OpenMP SIMD
reductions; per-body data are read from their tables by body index (body i once per row, the
partners j in order: contiguous for numbers, every third double for a 3-vector's component). Each pair is still evaluated once, and every operation stays an IEEE operation
(only the order of the sums changes with vectorisation). Functions that run without a
workspace keep the member loop.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> [t.rows for t in lower_system(builtin("molecular")).terms]
    [True]
"""

from __future__ import annotations

from dataclasses import replace

from s2gen.ir import LoopKind, Module, TermLoop

__all__ = ["contiguous", "layout_pass"]


def contiguous(t: TermLoop) -> bool:
    """Whether the term's member loop can run as rows (all pairs, no per-member data), unless
    its members go into the quadratic matrix instead.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.equations.assemble import sphere_module
        >>> [contiguous(t) for t in sphere_module(builtin("dipoles")).terms]  # a listed term
        [False]
    """
    return t.loop.kind is LoopKind.ALL_PAIRS and not t.data


def layout_pass(module: Module) -> Module:
    """Mark the all-pairs terms that loop over rows."""
    terms = tuple(
        replace(
            t,
            rows=contiguous(t) and not t.quadratic,
        )
        for t in module.terms
    )
    return replace(module, terms=terms)
