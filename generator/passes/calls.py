"""Pass `calls`: every kernel call site, its arguments bound from the kernel's signature.

Input: a `Module` with lowered kernels. Output: the same module with one `Call` per call site
its parts declare (`s2gen.parts`: each selected part's sites, then each term loop's). A site
names its kernel and its context (a whole-system call, one body of a loop over bodies, one
coupled pair of a loop over pairs, or one member of a term's loop); each argument is bound
(`s2gen.bindings`) by the context's rule for its name, unless the site overrides it, so the
argument order always follows the kernel as derived and no template spells it out. The bindings
say what an argument is; the printers say how each language writes it.

Binding rules:
- body (loop variable: body i): `h` by value, `m` the body's mass, `mi` its inverse mass
  from the context, a scalar by address, any other array the body's slot (3 doubles);
- pair (pair k of bodies i0, j0): `h` by value, `mij` the pair's entry of M, an array `xi` /
  `xj` the slot of x at the pair's first / second body, outputs are the site's locals;
- system: variables by name, a scalar output by address;
- term (member m): `q`, `qi`, `qj` the member's bodies' positions, data from the term's
  tables at member m;
- the structured solvers' per-body kernels (`s2gen.equations.operators`) write their blocks
  at 9 (3 x 3) or 16 (4 x 4) doubles per body, the per-body inertia kernel reads the
  inertia's data tables at body i.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> calls = lower_system(builtin("double_pendulum")).calls
    >>> call = next(c for c in calls if c.site == "kin_body")
    >>> call.inputs[0], call.outputs
    (Element(array='md', index=<Index.BODY: 'body'>, offset=0, address=False, context=False), \
(Local(name='t', address=True, vector=None),))
"""

from __future__ import annotations

from dataclasses import replace

from s2gen.bindings import Binding, Element, Index, Local, Slot
from s2gen.ir import Argument, Call, Kernel, KernelDef, Module, Output
from s2gen.parts import Context, Site, selected, term_sites

__all__ = ["calls_pass", "resolve"]


def _default(arg: Argument | Output, output: bool, context: Context) -> Binding:
    """The context's binding of an argument the site does not override."""
    name, scalar = arg.name, arg.scalar
    if context is Context.SYSTEM:
        return Local(name, address=output and scalar)
    if context is Context.BODY:
        if name == "h":
            return Local("h")
        if name == "m":
            return Element("md", Index.BODY)
        if name == "mi":
            return Element("mi", Index.BODY, context=True)
        return Local(name, address=True) if scalar else Slot(name, 3, Index.BODY)
    if name == "h":
        return Local("h")
    if name == "mij":
        return Element("mp", Index.PAIR)
    if output:
        return Local(name, address=scalar)
    if name[-1] in "ij" and len(name) > 1:
        return Slot(name[:-1], 3, Index.FIRST if name[-1] == "i" else Index.SECOND)
    raise ValueError(f"no pair binding for argument {name!r}")


def resolve(site: Site, kernel: Kernel | KernelDef) -> Call:
    """The call of `kernel` at `site`: each argument's binding, in the kernel's order."""
    inputs = tuple(site.bind.get(a.name) or _default(a, False, site.context) for a in kernel.inputs)
    outputs = tuple(
        site.bind.get(o.name) or _default(o, True, site.context) for o in kernel.outputs
    )
    return Call(site.name, kernel.name, inputs, outputs)


def calls_pass(module: Module) -> Module:
    """Resolve the call sites of the module's parts (`s2gen.parts`) and of its terms' loops,
    each once, skipping a site whose kernel the module lacks."""
    names = {k.name for k in module.kernels}
    sites: dict[str, Site] = {}
    for part in selected(module):
        for site in part.sites_of(module):
            if site.kernel in names:
                sites.setdefault(site.name, site)
    for t in module.terms:
        sites.update((s.name, s) for s in term_sites(t))
    return replace(module, calls=tuple(resolve(s, module.kernel(s.kernel)) for s in sites.values()))
