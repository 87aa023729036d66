"""Pass `calls`: every kernel call site, its arguments resolved from the kernel's signature.

Input: a `Module` with lowered kernels. Output: the same module with one `Call` per call site
the templates lay out. A site names its kernel and its context (a whole-system call, one body
of a loop over bodies, one coupled pair of a loop over pairs, or one member of a term's loop);
each argument is bound by the context's rule for its name, unless the site overrides it, so the
argument order always follows the kernel as derived and no template spells it out.

Binding rules, C (loop variables: i the body; k the pair, i0 and j0 its bodies; m the member
of a term, i and j its bodies):
- body: `h` -> h, `m` -> md[i], `mi` -> cx->mi[i] (inverse masses), any other array `x` -> x + 3 * i, a scalar output `s` -> &s;
- pair: `h` -> h, `mij` -> mp[k], an array `xi` / `xj` -> x + 3 * i0 / x + 3 * j0, outputs
  are the site's local arrays (named as the outputs);
- system: arrays by name, a scalar output `s` -> &s;
- term: `q`, `qi` -> q + 3 * i, `qj` -> q + 3 * j, data from the term's tables at member m;
- the structured solvers' per-body kernels (`s2gen.equations.operators`) write their blocks
  at 9 (3 x 3) or 16 (4 x 4) doubles per body, the per-body inertia kernel reads the
  inertia's data tables at body i.
NumPy calls take the inputs only and vectorize: body arrays whole, `m` -> md, `mi` -> 1/md, pair arrays
indexed by PAIR_I / PAIR_J, `mij` -> mp, term positions indexed by the term's index arrays.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> [c.c_args for c in lower_system(builtin("double_pendulum")).calls if c.site == "kin_body"]
    [('md[i]', 'q + 3 * i', 'w + 3 * i', '&t')]
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace

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
    c: dict[str, str] = field(default_factory=dict)
    py: dict[str, str] = field(default_factory=dict)


def _c_default(arg: Argument | Output, output: bool, context: Context) -> str:
    name, scalar = arg.name, arg.scalar
    if context is Context.SYSTEM:
        return f"&{name}" if output and scalar else name
    if context is Context.BODY:
        if name == "h":
            return "h"
        if name == "m":
            return "md[i]"
        if name == "mi":
            return "cx->mi[i]"
        return f"&{name}" if scalar else f"{name} + 3 * i"
    if name == "h":
        return "h"
    if name == "mij":
        return "mp[k]"
    if output:
        return f"&{name}" if scalar else name
    if name[-1] in "ij" and len(name) > 1:
        return f"{name[:-1]} + 3 * {name[-1]}0"
    raise ValueError(f"no pair binding for argument {name!r}")


def _py_default(arg: Argument, context: Context) -> str:
    name = arg.name
    if context is Context.BODY:
        return {"m": "md", "mi": "(1.0 / md)"}.get(name, name)
    if context is Context.PAIR:
        if name == "mij":
            return "mp"
        if name[-1] in "ij" and len(name) > 1 and name != "h":
            return f"{name[:-1]}[PAIR_{name[-1].upper()}]"
    return name


def resolve(site: Site, kernel: Kernel | KernelDef) -> Call:
    """The call of `kernel` at `site`: arguments in the kernel's order, per language."""
    c_args = [site.c.get(a.name) or _c_default(a, False, site.context) for a in kernel.inputs]
    c_args += [site.c.get(o.name) or _c_default(o, True, site.context) for o in kernel.outputs]
    py_args = [site.py.get(a.name) or _py_default(a, site.context) for a in kernel.inputs]
    return Call(site.name, kernel.name, tuple(c_args), tuple(py_args))


_B, _P, _S = Context.BODY, Context.PAIR, Context.SYSTEM
#: Sites reading the masses from the context (their functions keep no local copy)
_MASSES = {"m": "cx->md[i]"}

#: Call sites of the (S^2)^n module; a site whose kernel the module lacks is skipped.
SPHERE_SITES = (
    Site("context", "context", _S, {"cc": "cx->cc"}),
    Site("potential", "potential", _S, {"v": "&total", "cc": "cx->cc"}),
    Site("gradient", "gradient", _S, {"cc": "cx->cc"}),
    Site("kin_body", "kin_body", _B),
    Site("kin_pair", "kin_pair", _P),
    Site("mom_body", "mom_body", _B, {"j": "t"}),
    Site("mom_pair", "mom_pair", _P, {"j": "t"}),
    Site("rhs_diag", "rhs_diag", _B, _MASSES),
    Site("rhs_body", "rhs_body", _B, {"b": "dw + 3 * i"}),
    Site("rhs_pair", "rhs_pair", _P),
    Site("a_pair", "a_pair", _P, {"a": "blk"}),
    Site("d_body", "d_body", _B),
    Site("d_pair", "d_pair", _P),
    Site("res_body", "res_body", _B, {"jac": "jac"}),
    Site("res_pair", "res_pair", _P),
    Site("cayley", "cayley", _B),
    Site("c_body", "c_body", _B, {"c": "wn + 3 * i"}),
    Site("c_pair", "c_pair", _P),
    Site("a_body", "a_body", _B, {"q": "qn + 3 * i", "a": "&cx->adiag[i]"}, {"q": "qn"}),
    Site("vi_pos", "vi_pos", _B, _MASSES),
    Site("vi_vel", "vi_vel", _B, _MASSES),
    Site("rattle_pos", "rattle_pos", _B, _MASSES),
    Site("rattle_vel", "rattle_vel", _B, _MASSES),
    # the structured solvers (banded or max-index M)
    Site("vel", "vel", _B, {"v": "u + 3 * i"}),
    Site("d_coupled", "d_coupled", _B),
    Site("disp", "disp", _B, {"kd": "kb + 9 * i"}),
    Site("res_coupled", "res_coupled", _B, {"e": "e + 9 * i", "hq": "hb + 9 * i"}),
    Site("c_coupled", "c_coupled", _B, {"c": "wn + 3 * i"}),
    Site(
        "a_blocks_vi",
        "a_blocks",
        _B,
        {
            "a": "cx->adiag[i]",
            "q": "qn + 3 * i",
            "e": "e + 9 * i",
            "hq": "hb + 9 * i",
            "kq": "kb + 9 * i",
        },
        {"a": "adiag", "q": "qn"},
    ),
    Site(
        "a_blocks_field",
        "a_blocks",
        _B,
        {"a": "md[i]", "e": "e + 9 * i", "hq": "hb + 9 * i", "kq": "kb + 9 * i"},
        {"a": "md"},
    ),
    Site("src_rhs", "src_rhs", _B),
    Site("rhs_coupled", "rhs_coupled", _B, {"b": "dw + 3 * i"}),
    Site("rattle_pos_blocks", "rattle_pos_blocks", _B, {"e": "e + 16 * i"}),
    Site("rattle_vel_blocks", "rattle_vel_blocks", _B, {"e": "e + 16 * i"}),
    Site("vel_sweep", "vel", _B, {"v": "v"}),
    Site("kin_sweep", "kin_sweep", _B, {"ac": "sa[i] * sc[i]", "pv": "pv"}, {"ac": "sa * sc"}),
    Site(
        "mom_sweep",
        "mom_sweep",
        _B,
        {"ac": "sa[i] * sc[i]", "pq": "pq", "pv": "pv", "j": "t"},
        {"ac": "sa * sc"},
    ),
)

#: Call sites of the angle-form module.
ANGLE_SITES = (
    Site(
        "to_sphere",
        "to_sphere",
        _B,
        {"a": "x + 2 * e", "ad": "xd + 2 * e", "q": "q + 3 * e", "w": "w + 3 * e"},
        {"a": "xa", "ad": "xda"},
    ),
    Site("energy", "energy", _S, {"e": "&e"}),
    Site("dynamics", "dynamics", _S, {"m": "mm", "f": "xdd"}),
)


def _term_sites(module: Module, t: TermLoop) -> list[Site]:
    """The value, gradient and table sites of one term loop (data read at member m; the
    member's table row at `tab`, the context constants at cx->cc)."""
    pre, up = f"{module.name}_t{t.index}", f"T{t.index}"
    kind = t.loop.kind.kind
    c = {role: f"q + 3 * {i}" for role, i in zip(kind.roles, kind.indices)}
    c.update({"v": "&v", "g": "gb", "cc": "cx->cc", "tab": "tab"})
    py = {role: f"q[{up}_{i.upper()}]" for role, i in zip(kind.roles, kind.indices)}
    py["tab"] = f"tab{t.index}"
    for name, width, _ in t.data:
        c[f"d_{name}"] = f"{pre}_{name}[m]" if width == 1 else f"{pre}_{name} + 3 * m"
        py[f"d_{name}"] = f"{up}_{name.upper()}"
    sites = [
        Site(f"t{t.index}_value", t.value, _S, c, py),
        Site(f"t{t.index}_gradient", t.gradient, _S, c, py),
    ]
    if t.table:
        sites.append(Site(f"t{t.index}_table", f"t{t.index}_table", _S, {**c, "tab": "row"}, py))
    if t.quadratic:
        sites.append(Site(f"t{t.index}_quad", f"t{t.index}_quad", _S, {**c, "coef": "row"}, py))
    return sites


def _inertia_sites(module: Module) -> list[Site]:
    """The inertia kernel: the diagonal into md, the coupled entries into mp, or the
    max-index generators a and c into mp[0..n) and mp[n..2n); per body (at body i, data from
    the inertia's tables) or for the whole system."""
    n = module.n
    whole = {"mdiag": "md", "mpair": "mp", "sa": "mp", "sc": f"mp + {n}"}
    c = {"p": "p", "i": "(double)(i + 1)", "md": "&md[i]", "sa": "&mp[i]", "sc": f"&mp[{n} + i]"}
    py = {"i": "INDEX"}
    for name, _ in module.inertia_data:
        c[f"d_{name}"] = f"{module.name}_inertia_{name}[i]"
        py[f"d_{name}"] = f"INERTIA_{name.upper()}"
    return [
        Site("inertia", "inertia", Context.SYSTEM, whole),
        Site("inertia_body", "inertia_body", Context.BODY, c, py),
    ]


def calls_pass(module: Module) -> Module:
    """Resolve every call site of the module's templates."""
    sites = SPHERE_SITES if module.kind is ModuleKind.SPHERE else ANGLE_SITES
    names = {k.name for k in module.kernels}
    if module.kind is ModuleKind.SPHERE:
        sites = (*_inertia_sites(module), *sites)
    all_sites = [s for s in sites if s.kernel in names]
    for t in module.terms:
        all_sites += _term_sites(module, t)
    return replace(module, calls=tuple(resolve(s, module.kernel(s.kernel)) for s in all_sites))
