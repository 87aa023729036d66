"""The records of a part: `Context`, `Site` (a call site and its bindings) and `Part`.

Example:
    >>> Part("vi_step", buffers=(("vi_step", ("g", "gn")),)).reads
    (('vi_step', 'g'), ('vi_step', 'gn'))
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, field

from s2gen.bindings import Binding, ContextArray, Local  # noqa: F401 - in the examples
from s2gen.ir import Module

__all__ = ["CC", "Context", "Part", "Site"]


class Context(enum.Enum):
    """Where a kernel is called from (which loop variables are in scope).

    Example:
        >>> Context("pair").name
        'PAIR'
    """

    SYSTEM = "system"
    BODY = "body"
    PAIR = "pair"


@dataclass(frozen=True)
class Site:
    """A call site: its name in the templates (`m.call.<name>`), its kernel, context and
    argument overrides (argument name -> binding).

    Example:
        >>> Site("energy", "energy", Context.SYSTEM, {"e": Local("e", address=True)}).kernel
        'energy'
    """

    name: str
    kernel: str
    context: Context
    bind: dict[str, Binding] = field(default_factory=dict)


@dataclass(frozen=True)
class Part:
    """One algorithmic part: its partial per language, its call sites (and so the kernels it
    calls) and the workspace buffers it reads, as (layout, buffer names) pairs
    (`m.work.<layout>.<buffer>`). `module_sites` declares the sites that depend on the module
    (e.g. the inertia's data).

    Example:
        >>> p = Part("rk", buffers=(("rk_fixed", ("k", "field")),))
        >>> p.partial("numpy"), p.reads
        ('numpy/_rk.jinja', (('rk_fixed', 'k'), ('rk_fixed', 'field')))
    """

    name: str
    sites: tuple[Site, ...] = ()
    buffers: tuple[tuple[str, tuple[str, ...]], ...] = ()
    module_sites: Callable[[Module], tuple[Site, ...]] | None = None

    def partial(self, lang: str) -> str:
        """The partial template that lays the part out in `lang` ("c" or "numpy")."""
        return f"{lang}/_{self.name}.jinja"

    @property
    def kernels(self) -> tuple[str, ...]:
        """The kernels the part calls (at its fixed sites), each once.

        Example:
            >>> sites = (Site("a", "k", Context.BODY), Site("b", "k", Context.PAIR))
            >>> Part("p", sites=sites).kernels
            ('k',)
        """
        return tuple(dict.fromkeys(s.kernel for s in self.sites))

    @property
    def reads(self) -> tuple[tuple[str, str], ...]:
        """Every (layout, buffer) the part reads."""
        return tuple((lay, b) for lay, names in self.buffers for b in names)

    def sites_of(self, module: Module) -> tuple[Site, ...]:
        """The part's sites in `module` (the fixed ones, then those of the module)."""
        more = self.module_sites(module) if self.module_sites is not None else ()
        return (*self.sites, *more)


#: The context's constants, as the kernels that read hoisted parameter terms take them, and a
#: driven system's time and held inputs (``tu``), as the kernels that read them take them
CC: dict[str, Binding] = {"cc": ContextArray("cc"), "tu": ContextArray("tu")}
