"""The C text of a rows gradient loop split at its calls (`s2gen.ir.Fission`).

Input: a term's `Fission`, its gradient `Kernel`, the partner's per-body data reads and the
number of bodies. Output: a `SplitRows` of lines for `c/_macros.jinja`'s split rows loop: the row
buffers' declarations and the bodies of the three partner loops, each reading only the
partner's components and per-body data it uses.

Example:
    >>> from s2gen.spec import define_system
    >>> from s2gen.passes import lower_system
    >>> s = define_system(name="screened", bodies=4, parameters={"k": 2.0}, diagonal="1",
    ...                   pair_terms=[{"V": "exp(-k*norm(qi - qj))/norm(qi - qj)", "pairs": "all"}])
    >>> m = lower_system(s)
    >>> t = m.terms[0]
    >>> s = c_split_rows(t.fission, m.kernel(t.gradient), (), m.n)
    >>> s.buffers, s.calls
    (('double rb0[4], rb1[4];',), ('rb1[j] = exp(rb1[j]);',))
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from s2gen.ir import Assignment, Fission, Kernel
from s2gen.printing.c import CPrinter, inline_names

__all__ = ["SplitRows", "c_split_rows"]


@dataclass(frozen=True)
class SplitRows:
    """A split rows loop as lines: buffer declarations, then the partner loops' bodies;
    `prelude`: what precedes the row loop (a comment saying why, then the buffers)."""

    buffers: tuple[str, ...]
    first: tuple[str, ...]
    calls: tuple[str, ...]
    last: tuple[str, ...]

    @property
    def prelude(self) -> tuple[str, ...]:
        return (
            "/* the partner loop split at its calls, so that the rest vectorises: call-free work into",
            " * the row buffers, the calls on them, then the forces */",
            *self.buffers,
        )


def _reads(kernel: Kernel, data: tuple[str, ...], used: set[sp.Basic]) -> list[str]:
    """The partner's component and per-body data reads that the `used` symbols need."""
    lines = []
    for arg in kernel.inputs:
        if arg.name == "qj":
            lines += [
                f"const double qj{c} = {'xyz'[c]}[j];"
                for c, s in enumerate(arg.symbols)
                if s in used
            ]
    for line in data:
        name = line.split(" = ")[0].split()[-1]
        arg = next(a for a in kernel.inputs if a.name == name)
        if any(s in used for s in arg.symbols):
            lines.append(line)
    return lines


def _assign(pr: CPrinter, a: Assignment) -> str:
    target = a.temp if a.temp is not None else f"{a.output[0]}{a.output[1]}"  # type: ignore[index]
    return f"const double {target} = {pr.doprint(a.expr)};"


def c_split_rows(split: Fission, kernel: Kernel, data: tuple[str, ...], n: int) -> SplitRows:
    """The split rows loop `split` of the gradient kernel `kernel` over `n` bodies; `data`: the
    declarations of the partner's per-body data (`s2gen.printing.terms.c_rows_data`)."""
    names = inline_names(kernel)
    buffers = [f"rb{k}" for k in range(len(split.stores))]
    pr = CPrinter(names)
    used: set[sp.Basic] = set()
    for a in split.first:
        used |= a.expr.free_symbols
    for _, value in split.stores:
        used |= value.free_symbols
    first = _reads(kernel, data, used) + [_assign(pr, a) for a in split.first]
    first += [
        f"{b}[j] = {pr.doprint(value)};"
        for b, (_, value) in zip(buffers, split.stores, strict=True)
    ]
    calls = tuple(
        f"{b}[j] = {CPrinter({Fission.ARG: f'{b}[j]'}).doprint(c)};"
        for b, c in zip(buffers, split.calls, strict=True)
        if c is not None
    )
    loads = {load: f"{b}[j]" for b, (load, _) in zip(buffers, split.stores, strict=True)}
    last_pr = CPrinter({**names, **loads})
    used = set()
    for a in split.last:
        used |= a.expr.free_symbols
    last = _reads(kernel, data, used) + [_assign(last_pr, a) for a in split.last]
    return SplitRows(
        buffers=(f"double {', '.join(f'{b}[{n}]' for b in buffers)};",),
        first=tuple(first),
        calls=calls,
        last=tuple(last),
    )
