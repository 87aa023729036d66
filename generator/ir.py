"""Frozen, typed intermediate representation between the equations and the printers.

Two levels:
- `KernelDef` is what the equation stages (`continuous.py`, `discrete.py`, `model.py`) produce:
  named inputs (each a tuple of SymPy symbols, a scalar or an array slot per symbol) and named
  outputs (tuples of SymPy expressions in those symbols).
- `Kernel` is what `lowering.py` makes of it: common subexpressions eliminated into named
  temporaries (deterministic names), small integer powers expanded, operation counts attached.

A `Module` gathers the kernels of one system with the structural facts the templates lay out
(body count, coupling pairs, parameter names, workspace size). The printers turn a `Module` into
text records (`printing.PrintedModule`); templates never see SymPy objects.

Example:
    >>> import sympy as sp
    >>> x = sp.Symbol("x")
    >>> k = KernelDef("square", "x squared", (Argument("x", (x,), scalar=True),),
    ...               (Output("y", (x**2,), scalar=True),))
    >>> k.inputs[0].size, k.outputs[0].size
    (1, 1)
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

__all__ = ["Argument", "Assignment", "Kernel", "KernelDef", "Module", "Output"]


@dataclass(frozen=True)
class Argument:
    """A kernel input: `scalar` (one symbol, passed by value) or an array of `symbols`."""

    name: str
    symbols: tuple[sp.Symbol, ...]
    scalar: bool = False

    @property
    def size(self) -> int:
        return len(self.symbols)


@dataclass(frozen=True)
class Output:
    """A kernel output: one expression per slot (`scalar`: a single value)."""

    name: str
    exprs: tuple[sp.Expr, ...]
    scalar: bool = False

    @property
    def size(self) -> int:
        return len(self.exprs)


@dataclass(frozen=True)
class KernelDef:
    """A kernel before lowering: inputs and output expressions, with a one-line doc."""

    name: str
    doc: str
    inputs: tuple[Argument, ...]
    outputs: tuple[Output, ...]


@dataclass(frozen=True)
class Assignment:
    """`target = expr`; `target` is a temporary symbol or (output name, slot index)."""

    temp: sp.Symbol | None
    output: tuple[str, int] | None
    expr: sp.Expr


@dataclass(frozen=True)
class Kernel:
    """A lowered kernel: inputs, ordered assignments (temporaries first), op counts."""

    name: str
    doc: str
    inputs: tuple[Argument, ...]
    outputs: tuple[Output, ...]
    assignments: tuple[Assignment, ...]
    ops_before: int
    ops_after: int


@dataclass(frozen=True)
class Module:
    """Everything the templates of one system need, still language-neutral."""

    name: str
    spec_hash: str
    origin: str
    n: int
    parameter_names: tuple[str, ...]
    parameter_values: tuple[float, ...]
    coupled: bool
    pairs: tuple[tuple[int, int], ...]  # 0-based (i, j), i < j, M_ij not identically zero
    system_kernels: tuple[Kernel, ...]  # potential, gradient, inertia
    body_kernels: tuple[Kernel, ...]  # generic per-body / per-pair kernels
    work_size: int
