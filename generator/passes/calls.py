"""Pass `calls`: every kernel call site, its arguments bound from the kernel's signature.

Input: a `Module` with lowered kernels. Output: the same module with one `Call` per call site
the templates lay out. A site names its kernel and its context (a whole-system call, one body
of a loop over bodies, one coupled pair of a loop over pairs, or one member of a term's loop);
each argument is bound (`s2gen.bindings`) by the context's rule for its name, unless the site
overrides it, so the argument order always follows the kernel as derived and no template
spells it out. The bindings say what an argument is; the printers say how each language
writes it.

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
    >>> call = next(c for c in lower_system(builtin("double_pendulum")).calls if c.site == "kin_body")
    >>> call.inputs[0], call.outputs
    (Element(array='md', index=<Index.BODY: 'body'>, offset=0, address=False, context=False), \
(Local(name='t', address=True, vector=None),))
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace

from s2gen.bindings import (
    Binding,
    BodyNumber,
    ContextArray,
    Element,
    Index,
    InertiaDatum,
    Local,
    MemberSlot,
    Product,
    Shifted,
    Slot,
    TermDatum,
    TermTable,
)
from s2gen.ir import Argument, Call, Kernel, KernelDef, Module, ModuleKind, Output, TermLoop

__all__ = ["Context", "Site", "calls_pass", "resolve"]


class Context(enum.Enum):
    """Where a kernel is called from (which loop variables are in scope)."""

    SYSTEM = "system"
    BODY = "body"
    PAIR = "pair"


@dataclass(frozen=True)
class Site:
    """A call site: its name in the templates, its kernel, context and argument overrides."""

    name: str
    kernel: str
    context: Context
    bind: dict[str, Binding] = field(default_factory=dict)


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


_B, _P, _S = Context.BODY, Context.PAIR, Context.SYSTEM
_CC = {"cc": ContextArray("cc")}
#: Sites reading the masses from the context (their functions keep no local copy)
_MASSES: dict[str, Binding] = {"m": Element("md", Index.BODY, context=True)}


def _at_body(array: str, stride: int = 3, vector: str | None = None) -> Slot:
    return Slot(array, stride, Index.BODY, vector)


#: The blocks E, H, K of the structured solvers (NumPy names H and K as the kernel does)
_BLOCKS: dict[str, Binding] = {
    "e": _at_body("e", 9),
    "hq": _at_body("hb", 9, "hq"),
    "kq": _at_body("kb", 9, "kq"),
}
#: A max-index M's generator products a_i c_i
_GENERATORS = Product((Element("sa", Index.BODY), Element("sc", Index.BODY)))

#: Call sites of the (S^2)^n module; a site whose kernel the module lacks is skipped.
SPHERE_SITES = (
    Site("context", "context", _S, _CC),
    Site("potential", "potential", _S, {"v": Local("total", address=True), **_CC}),
    Site("gradient", "gradient", _S, _CC),
    Site("kin_body", "kin_body", _B),
    Site("kin_pair", "kin_pair", _P),
    Site("mom_body", "mom_body", _B, {"j": Local("t")}),
    Site("mom_pair", "mom_pair", _P, {"j": Local("t")}),
    Site("rhs_diag", "rhs_diag", _B, _MASSES),
    Site("rhs_body", "rhs_body", _B, {"b": _at_body("dw", vector="b")}),
    Site("rhs_pair", "rhs_pair", _P),
    Site("a_pair", "a_pair", _P, {"a": Local("blk", vector="a")}),
    Site("d_body", "d_body", _B),
    Site("d_pair", "d_pair", _P),
    Site("res_body", "res_body", _B, {"jac": Local("jac")}),
    Site("res_pair", "res_pair", _P),
    Site("cayley", "cayley", _B),
    Site("c_body", "c_body", _B, {"c": _at_body("wn", vector="c")}),
    Site("c_pair", "c_pair", _P),
    Site(
        "a_body",
        "a_body",
        _B,
        {"q": _at_body("qn"), "a": Element("adiag", Index.BODY, address=True, context=True)},
    ),
    Site("vi_pos", "vi_pos", _B, _MASSES),
    Site("vi_vel", "vi_vel", _B, _MASSES),
    Site("rattle_pos", "rattle_pos", _B, _MASSES),
    Site("rattle_vel", "rattle_vel", _B, _MASSES),
    # the structured solvers (banded or max-index M)
    Site("vel", "vel", _B, {"v": _at_body("u", vector="v")}),
    Site("d_coupled", "d_coupled", _B),
    Site("disp", "disp", _B, {"kd": _at_body("kb", 9, "kd")}),
    Site("res_coupled", "res_coupled", _B, {"e": _BLOCKS["e"], "hq": _BLOCKS["hq"]}),
    Site("c_coupled", "c_coupled", _B, {"c": _at_body("wn", vector="c")}),
    Site(
        "a_blocks_vi",
        "a_blocks",
        _B,
        {"a": Element("adiag", Index.BODY, context=True), "q": _at_body("qn"), **_BLOCKS},
    ),
    Site("a_blocks_field", "a_blocks", _B, {"a": Element("md", Index.BODY), **_BLOCKS}),
    Site("src_rhs", "src_rhs", _B),
    Site("rhs_coupled", "rhs_coupled", _B, {"b": _at_body("dw", vector="b")}),
    Site("rattle_pos_blocks", "rattle_pos_blocks", _B, {"e": _at_body("e", 16)}),
    Site("rattle_vel_blocks", "rattle_vel_blocks", _B, {"e": _at_body("e", 16)}),
    Site("vel_sweep", "vel", _B, {"v": Local("v")}),
    Site("kin_sweep", "kin_sweep", _B, {"ac": _GENERATORS, "pv": Local("pv")}),
    Site(
        "mom_sweep",
        "mom_sweep",
        _B,
        {"ac": _GENERATORS, "pq": Local("pq"), "pv": Local("pv"), "j": Local("t")},
    ),
)

#: Call sites of the angle-form module (loop variable: body e of the conversion).
ANGLE_SITES = (
    Site(
        "to_sphere",
        "to_sphere",
        _B,
        {
            "a": Slot("x", 2, Index.ELEMENT, "xa"),
            "ad": Slot("xd", 2, Index.ELEMENT, "xda"),
            "q": Slot("q", 3, Index.ELEMENT),
            "w": Slot("w", 3, Index.ELEMENT),
        },
    ),
    Site("energy", "energy", _S, {"e": Local("e", address=True)}),
    Site("dynamics", "dynamics", _S, {"m": Local("mm", vector="m"), "f": Local("xdd", vector="f")}),
)


def _term_sites(t: TermLoop) -> list[Site]:
    """The value, gradient and table sites of one term loop (data read at member m; the
    member's table row at `tab`, the context constants at cc)."""
    kind = t.loop.kind.kind
    bind: dict[str, Binding] = {
        role: MemberSlot(t.index, i) for role, i in zip(kind.roles, kind.indices)
    }
    bind.update(
        {
            "v": Local("v", address=True),
            "g": Local("gb", vector="g"),
            "tab": TermTable(t.index),
            **_CC,
        }
    )
    for name, width, _ in t.data:
        bind[f"d_{name}"] = TermDatum(t.index, name, width)
    sites = [
        Site(f"t{t.index}_value", t.value, _S, bind),
        Site(f"t{t.index}_gradient", t.gradient, _S, bind),
    ]
    if t.table:
        row = {**bind, "tab": TermTable(t.index, row=True)}
        sites.append(Site(f"t{t.index}_table", f"t{t.index}_table", _S, row))
    if t.quadratic:
        coef = {**bind, "coef": Local("row", vector="coef")}
        sites.append(Site(f"t{t.index}_quad", f"t{t.index}_quad", _S, coef))
    return sites


def _inertia_sites(module: Module) -> list[Site]:
    """The inertia kernel: the diagonal into md, the coupled entries into mp, or the
    max-index generators a and c into mp[0..n) and mp[n..2n); per body (at body i, data from
    the inertia's tables) or for the whole system."""
    n = module.n
    whole: dict[str, Binding] = {
        "mdiag": Local("md", vector="mdiag"),
        "mpair": Local("mp", vector="mpair"),
        "sa": Local("mp", vector="sa"),
        "sc": Shifted("mp", n),
    }
    body: dict[str, Binding] = {
        "p": Local("p"),
        "i": BodyNumber(),
        "md": Element("md", Index.BODY, address=True),
        "sa": Element("mp", Index.BODY, address=True),
        "sc": Element("mp", Index.BODY, offset=n, address=True),
    }
    for name, _ in module.inertia_data:
        body[f"d_{name}"] = InertiaDatum(name)
    return [
        Site("inertia", "inertia", Context.SYSTEM, whole),
        Site("inertia_body", "inertia_body", Context.BODY, body),
    ]


def calls_pass(module: Module) -> Module:
    """Resolve every call site of the module's templates."""
    sites = SPHERE_SITES if module.kind is ModuleKind.SPHERE else ANGLE_SITES
    names = {k.name for k in module.kernels}
    if module.kind is ModuleKind.SPHERE:
        sites = (*_inertia_sites(module), *sites)
    all_sites = [s for s in sites if s.kernel in names]
    for t in module.terms:
        all_sites += _term_sites(t)
    return replace(module, calls=tuple(resolve(s, module.kernel(s.kernel)) for s in all_sites))
