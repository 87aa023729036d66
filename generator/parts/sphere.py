"""The parts of the (S^2)^n module: their call sites (with their bindings) and buffers.

Binding overrides name the variables of the partial that makes the call (`dw` for the
right-hand side b, the blocks `e`, `hb`, `kb` of the structured solvers, ...); an argument
without one is bound by its site's context (`s2gen.passes.calls`).

Example:
    >>> [s.name for s in PARTS_BY_NAME["energy_coupled"].sites]
    ['kin_body', 'kin_pair', 'mom_body', 'mom_pair']
"""

from __future__ import annotations

from s2gen.bindings import (
    Binding,
    BodyNumber,
    Element,
    Index,
    InertiaDatum,
    Local,
    Product,
    Shifted,
    Slot,
)
from s2gen.ir import Module
from s2gen.parts.batch import PART as BATCH
from s2gen.parts.batch_driven import PART as DRIVEN_BATCH
from s2gen.parts.jvp import JVP_PARTS
from s2gen.parts.records import CC, Context, Part, Site

__all__ = ["PARTS_BY_NAME", "SPHERE_PARTS"]

_B, _P, _S = Context.BODY, Context.PAIR, Context.SYSTEM
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

_GRADIENT = Site("gradient", "gradient", _S, CC)
_CAYLEY = Site("cayley", "cayley", _B)
#: The monitor R(q) and dR/dt of the time-transformed drivers
_MONITOR = Site(
    "monitor", "monitor", _S, {"r": Local("R", address=True), "dr": Local("dR", address=True)}
)
_A_BODY = Site(
    "a_body",
    "a_body",
    _B,
    {"q": _at_body("qn"), "a": Element("adiag", Index.BODY, address=True, context=True)},
)


def _inertia_sites(module: Module) -> tuple[Site, ...]:
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
    return (
        Site("inertia", "inertia", _S, whole),
        Site("inertia_body", "inertia_body", _B, body),
    )


def _stage_sites(module: Module) -> tuple[Site, ...]:
    """The power at a Runge-Kutta stage: the stage state ys holds q, then w from 3n on (NumPy
    keeps them as qs and ws)."""
    q, w = Local("ys", vector="qs"), Shifted("ys", 3 * module.n, vector="ws")
    at = {"q": q, "w": w, "pw": Local("pw", address=True)}
    return (Site("power_stage", "power", _S, {**CC, **at}),)


#: A driven module's own driver: the power at a step's ends and at each stage, the forces,
#: the forced VI's end-velocity terms and the field's force terms (`s2gen.equations.driven`)
_DRIVEN = Part(
    "driven",
    sites=(
        Site("force", "force", _S, CC),
        Site("power", "power", _S, {**CC, "pw": Local("p0", address=True)}),
        Site(
            "power_end",
            "power",
            _S,
            {**CC, "q": Local("qn"), "w": Local("wn"), "pw": Local("p1", address=True)},
        ),
        Site("fvel", "fvel", _S, {"q": Local("qn")}),
        Site("fstage", "fstage", _S),
    ),
    module_sites=_stage_sites,
    buffers=(
        ("driven", ("qk", "wk", "q1", "w1", "a", "b", "vc", "vd", "g", "gn", "F", "Fw")),
        ("driven", ("c", "jc", "jm", "w0", "f", "k", "ys", "yk", "yd", "ub", "v", "vr", "ss")),
        ("driven", ("field",)),
        ("driven", ("step",)),
    ),
)


#: The step Jacobians: the field's derivatives at each stage, the VI's equations', and the
#: second derivatives of V (per term member) and of the forces
def _vi_jacobian_sites(module: Module) -> tuple[Site, ...]:
    """The VI step's equations' derivatives, where the module differentiates the VI, the
    terms' Hessian blocks (each at member m of its loop, into the local hb), V's general
    Hessian (into H) and the forces' derivatives."""
    from s2gen.parts import term_sites

    sites = [
        Site(f"t{t.index}_hessian", f"t{t.index}_hessian", _S, {**term_sites(t)[1].bind, **HB})
        for t in module.terms
    ]
    sites.append(Site("hessian", "hessian", _S, {**CC, "hv": Local("H"), "gpv": Local("gp")}))
    sites.append(Site("force_jacobian", "force_jacobian", _S, CC))
    if any(k.name == "vi_jacobian" for k in module.kernels):
        # the generic body's kernel at body i, the generic pair's at the pair (i0, j0)
        body = {name: Slot(name, 3, Index.BODY) for name in _VI_BODY}
        sites.append(Site("vi_jacobian", "vi_jacobian", _S, {**body, "m": Local("mii")}))
        pair: dict[str, Binding] = {f"{x}i": Slot(x, 3, Index.FIRST) for x in _VI_BODY}
        pair.update({f"{x}j": Slot(x, 3, Index.SECOND) for x in _VI_BODY})
        sites.append(Site("vi_jacobian_pair", "vi_jacobian_pair", _S, pair))
    if any(k.name == "rattle_jacobian" for k in module.kernels):
        sites += _rattle_jacobian_sites()
    return tuple(sites)


def _rattle_jacobian_sites() -> list[Site]:
    """RATTLE's equations' blocks: the generic body's at body i (its multipliers from the
    arrays lam and mu), the generic pair's at the pair (i0, j0)."""
    body: dict[str, Binding] = {n: Slot(n, 3, Index.BODY) for n in ("vh", "xn", "vn", "x", "v")}
    body.update({"m": Local("mii"), "lam": Element("lam", Index.BODY)})
    body["mu"] = Element("mu", Index.BODY)
    pair: dict[str, Binding] = {f"{n}i": Slot(n, 3, Index.FIRST) for n in ("vh", "vn", "v")}
    pair.update({f"{n}j": Slot(n, 3, Index.SECOND) for n in ("vh", "vn", "v")})
    return [
        Site("rattle_jacobian", "rattle_jacobian", _S, body),
        Site("rattle_jacobian_pair", "rattle_jacobian_pair", _S, pair),
    ]


#: The vectors of the generic body and pair kernels of the VI's equations
_VI_BODY = ("q", "w", "f", "qn", "wn", "G", "gn", "Fn")


#: The Hessian block of a term member and its gradient's derivative in the parameters, into
#: the local arrays hb and gpb
HB: dict[str, Binding] = {"hb": Local("hb"), "gpb": Local("gpb")}


def _vi_jacobian_buffers() -> tuple[str, ...]:
    return ("qs", "ws", "qd", "wd", "g", "gn", "f", "ey", "ex", "sd", *_VI_MORE)


#: The buffers of RATTLE's step Jacobian (`s2gen.passes.jacobian_layout`)
RATTLE_JACOBIAN_BUFFERS = ("rey", "rex", "rex0", "reg", "regn", "rep", "rvh", "rlam", "rmu", "rsv")

#: The buffers of the second derivatives (start and end of a step) and the VI's products
_VI_MORE = ("ex0", "eg", "egn", "efn", "ep", "hn", "gxn", "Gn", "Fn")


#: The field's blocks: body i, and the pair (i0, j0) for row i0 (a the field's wdot)
_FIELD_SITES = (
    Site(
        "jac_body",
        "jac_body",
        _S,
        {n: Slot(n, 3, Index.BODY) for n in ("q", "w", "G")},
    ),
    Site(
        "jac_pair",
        "jac_pair",
        _S,
        {
            "qi": Slot("q", 3, Index.FIRST),
            "qj": Slot("q", 3, Index.SECOND),
            "wj": Slot("w", 3, Index.SECOND),
            "aj": Slot("a", 3, Index.SECOND),
        },
    ),
    Site("jac_mass", "jac_mass", _S, CC),
)

_JACOBIAN = Part(
    "jacobian",
    sites=_FIELD_SITES,
    buffers=(
        ("jacobian", ("ys", "k", "dy", "kd", "d", "jx", "jq", "jr", "am", "ju")),
        ("jacobian", ("H", "gx", "G", "F", "fq", "fw", "fu", "mm", "mp", "gp", "fp")),
        ("jacobian", _vi_jacobian_buffers()),
        ("jacobian", RATTLE_JACOBIAN_BUFFERS),
    ),
    module_sites=_vi_jacobian_sites,
)

#: The parts of the sphere module (each laid out by `c/_<name>.jinja`, `numpy/_<name>.jinja`)
SPHERE_PARTS = (
    Part("tables"),
    Part("neighbours"),
    Part("kernels"),
    Part("helpers"),
    Part(
        "inertia_operator", sites=(Site("a_pair", "a_pair", _P, {"a": Local("blk", vector="a")}),)
    ),
    Part("cholesky"),
    Part("lu"),
    Part("band"),
    Part("coupled_banded"),
    Part("coupled_chain"),
    # the per-call context, with the masses partial it includes (`records.masses_partials`)
    Part("context", sites=(Site("context", "context", _S, CC),), module_sites=_inertia_sites),
    Part("quadratic"),
    Part(
        "potential",
        sites=(
            Site("context", "context", _S, CC),
            Site("potential", "potential", _S, {"v": Local("total", address=True), **CC}),
            _GRADIENT,
        ),
    ),
    Part(
        "energy",
        sites=(
            Site("kin_body", "kin_body", _B),
            Site("mom_body", "mom_body", _B, {"j": Local("t")}),
        ),
    ),
    Part(
        "energy_coupled",
        sites=(
            Site("kin_body", "kin_body", _B),
            Site("kin_pair", "kin_pair", _P),
            Site("mom_body", "mom_body", _B, {"j": Local("t")}),
            Site("mom_pair", "mom_pair", _P, {"j": Local("t")}),
        ),
    ),
    Part(
        "energy_chain",
        sites=(
            Site("kin_sweep", "kin_sweep", _B, {"ac": _GENERATORS, "pv": Local("pv")}),
            Site(
                "mom_sweep",
                "mom_sweep",
                _B,
                {"ac": _GENERATORS, "pq": Local("pq"), "pv": Local("pv"), "j": Local("t")},
            ),
            Site("vel_sweep", "vel", _B, {"v": Local("v")}),
        ),
    ),
    Part(
        "field_diagonal",
        sites=(Site("rhs_diag", "rhs_diag", _B, _MASSES),),
        buffers=(("field", ("g",)),),
    ),
    Part(
        "field_coupled",
        sites=(
            Site("rhs_body", "rhs_body", _B, {"b": _at_body("dw", vector="b")}),
            Site("rhs_pair", "rhs_pair", _P),
        ),
        buffers=(("field", ("g", "a")),),
    ),
    Part(
        "field_structured",
        sites=(
            Site("src_rhs", "src_rhs", _B),
            Site("rhs_coupled", "rhs_coupled", _B, {"b": _at_body("dw", vector="b")}),
            Site("a_blocks_field", "a_blocks", _B, {"a": Element("md", Index.BODY), **_BLOCKS}),
        ),
        buffers=(("field", ("g", "u", "z", "e", "hb", "kb", "solve")),),
    ),
    Part("field"),
    Part(
        "vi_explicit",
        sites=(
            _GRADIENT,
            Site("vi_pos", "vi_pos", _B, _MASSES),
            Site("vi_vel", "vi_vel", _B, _MASSES),
        ),
        buffers=(("vi_advance", ("x", "v", "gx", "xn", "vn", "gn", "s", "bridge")),),
    ),
    Part(
        "vi_newton",
        sites=(
            Site("d_body", "d_body", _B),
            Site("d_pair", "d_pair", _P),
            Site("res_body", "res_body", _B, {"jac": Local("jac")}),
            Site("res_pair", "res_pair", _P),
            _CAYLEY,
            Site("c_body", "c_body", _B, {"c": _at_body("wn", vector="c")}),
            Site("c_pair", "c_pair", _P),
            _A_BODY,
        ),
        buffers=(("vi_advance", ("d", "r", "jm")),),
    ),
    Part(
        "vi_structured",
        sites=(
            _CAYLEY,
            _A_BODY,
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
        ),
        buffers=(("vi_advance", ("d", "r", "u", "z", "e", "hb", "kb", "solve")),),
    ),
    Part("vi_step", buffers=(("vi_step", ("g", "gn", "f", "step")),)),
    Part(
        "rattle_closed",
        sites=(
            Site("rattle_pos", "rattle_pos", _B, _MASSES),
            Site("rattle_vel", "rattle_vel", _B, _MASSES),
        ),
        buffers=(("rattle_advance", ("vh",)),),
    ),
    Part("rattle_newton", buffers=(("rattle_advance", ("wi", "jm", "y", "gw", "u", "r")),)),
    Part(
        "rattle_structured",
        sites=(
            Site("rattle_pos_blocks", "rattle_pos_blocks", _B, {"e": _at_body("e", 16)}),
            Site("rattle_vel_blocks", "rattle_vel_blocks", _B, {"e": _at_body("e", 16)}),
        ),
        buffers=(("rattle_advance", ("gw", "y", "u", "t", "e", "rb", "solve")),),
    ),
    Part("rk", buffers=(("rk_fixed", ("k", "field")),)),
    Part("rk_step", buffers=(("rk_step", ("y0", "yt", "rk")),)),
    Part(
        "transformed",
        sites=(_MONITOR,),
        buffers=(
            ("transformed", ("g", "g1", "ga", "gb", "a", "b", "vc", "vd")),
            ("transformed", ("qk", "wk", "q1", "w1", "qs", "ws", "f", "step")),
        ),
    ),
    Part(
        "transformed_explicit",
        sites=(_MONITOR,),
        buffers=(
            ("transformed", ("x", "v", "gx", "xa", "va", "ga", "xb", "vb", "gb")),
            ("transformed", ("s", "bridge", "qk", "wk", "step", "slack")),
        ),
    ),
    Part(
        "driver",
        buffers=(
            ("rk45", ("k", "y", "yn", "ys", "field")),
            ("dop853", ("k", "y", "yt", "yn", "ys", "field")),
            ("explicit", ("x", "v", "gx", "xn", "vn", "gn", "s", "bridge", "qs", "ws", "slack")),
            ("geometric", ("g", "gn", "a", "b", "va", "vb", "vc", "vd")),
            ("geometric", ("qk", "wk", "q1", "w1", "f", "s", "step")),
            ("fixed", ("qk", "wk", "q1", "w1", "step")),
            ("integrate", ("run", "y0")),
        ),
    ),
    Part(
        "step",
        buffers=(
            ("step", ("g", "gn", "a", "b", "vb", "vc", "vd", "step")),
            ("carry", ("q", "w", "g", "v", "f", "s")),
        ),
    ),
    _DRIVEN,
    _JACOBIAN,
    *JVP_PARTS,
    BATCH,
    DRIVEN_BATCH,
)

#: The sphere module's parts by name
PARTS_BY_NAME = {p.name: p for p in SPHERE_PARTS}
