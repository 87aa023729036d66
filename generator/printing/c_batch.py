"""The batch part's record for c/_batch.jinja: lanes, lane-array sizes, workspace offsets.

Input: a lowered sphere module with the ``batch`` part (`s2gen.parts.batch`). Output: a dict
(empty without the part), read by the template as `m.batch`. The VI's position and velocity
updates in the lane loops are the module's own inline lines (`m.inline`, the C printer's), so
that a lane performs the very operations of the one-member loop over bodies.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> b = print_batch(lower_system(builtin("four_pendula").with_batch()))
    >>> b["lanes"], b["nsl"], b["work"]["lane_work"]
    (8, 192, 0)
    >>> print_batch(lower_system(builtin("four_pendula")))["lanes"]
    0
"""

from __future__ import annotations

from typing import Any

import sympy as sp

from s2gen.bindings import BodyDatum, ContextArray, Local, MemberSlot, TermDatum, TermTable
from s2gen.ir import Call, Kernel, Module
from s2gen.methods import explicit_tableaus
from s2gen.parts.batch import BATCH_LANES, BATCH_PART, has_chain_lanes
from s2gen.printing.c import CPrinter, c_inline, c_loop
from s2gen.printing.c_batch_chain import chain_lane_work, chain_lanes, chain_vi_work
from s2gen.printing.c_batch_newton import newton_lane_work, newton_lanes
from s2gen.printing.c_batch_quadratic import quadratic_lanes
from s2gen.printing.c_batch_rattle import rattle_batch, rattle_dense_work
from s2gen.printing.c_calls import c_binding
from s2gen.tableaus import DOP853

__all__ = ["batch_work", "coupled_field", "newton_work", "print_batch"]

#: Stage arrays of the adaptive methods' lanes: rk45's 7, DOP853's stages and extension.
_ADAPTIVE = max(7, DOP853.stages + 1 + len(DOP853.dense_a))

#: The explicit VI's lane arrays of N3 doubles per lane (then sv, mi and chk); the
#: Runge-Kutta arrays share the region with them.
_VI = ("x", "v", "gx", "xn", "vn", "gn")


def batch_work(module: Module, lanes: int = BATCH_LANES) -> dict[str, int]:
    """Offsets (doubles) of integrate_batch()'s workspace: each lane's own workspace
    (`lane_work`, WORK_SIZE each: its per-call context and the scratch of the one-member
    gradient and energy), each lane's parameters (`params`), each lane's contiguous copies
    of one member's q, w and g (`scratch`, 4 N3 each), then the lane arrays (lane
    innermost; their offsets from `lanes`, which is aligned to 64 bytes inside `size`
    doubles, `slack` to spare): the VI's x, v, gx, xn, vn, gn, sv, mi, chk or Runge-Kutta's
    rk_y0, rk_yn, rk_k, rk_chk, rk_mi, rk_xc, rk_gs (the same region), then the lanes'
    constants `cc`, parameters `pl`, member tables `t<k>` and gradient `g`, the field's,
    Newton's and RATTLE's arrays, and the adaptive methods' stages `ad_k` and trial state
    `ad_yt`.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> m = lower_system(builtin("three_bodies").with_batch())
        >>> w = batch_work(m, lanes=2)
        >>> w["params"] == 2 * m.work_size, w["scratch"] - w["params"], w["x"], w["v"]
        (True, 4, 0, 18)
    """
    n3, n = 3 * module.n, module.n
    ns = 2 * n3
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    off: dict[str, int] = {"lane_work": 0}
    at = lanes * module.work_size
    off["params"] = at
    at += lanes * max(1, len(module.parameter_names))
    off["scratch"] = at
    at += lanes * 4 * n3
    off["lanes"] = at
    rel = 0
    for name in _VI:
        off[name] = rel
        rel += n3 * lanes
    off["sv"], off["mi"], off["chk"] = rel, rel + n * lanes, rel + 2 * n * lanes
    vi_end = rel + 2 * n * lanes + lanes
    # Runge-Kutta: y0, yn, the stages k and chk
    rk = {"y0": 0, "yn": ns * lanes, "k": 2 * ns * lanes, "chk": (2 + stages) * ns * lanes}
    rk["mi"] = rk["chk"] + lanes
    rk["xc"] = rk["mi"] + n * lanes  # the lanes' positions component-major, for dV/dq
    rk["gs"] = rk["xc"] + n3 * lanes  # (the component-major gradient, unread)
    rk_end = rk["gs"] + n3 * lanes
    off.update({f"rk_{k}": v for k, v in rk.items()})
    # the lanes' constants, parameters and member tables (lane innermost), the lane gradient
    off["cc"] = max(vi_end, rk_end)
    off["pl"] = off["cc"] + max(1, module.constants) * lanes
    at2 = off["pl"] + max(1, len(module.parameter_names)) * lanes
    for t in module.terms:
        off[f"t{t.index}"] = at2
        at2 += t.table * t.loop.count * lanes
    off["g"] = at2
    at2 += n3 * lanes
    if module.quadratic:  # the accumulator of Kx (one component block: n per lane)
        off["qa"] = at2
        at2 += n * lanes
    if "field_coupled" in module.parts:  # a dense M's field in lane loops: M's entries, A(q)
        off["md"] = at2
        off["mp"] = off["md"] + n * lanes
        off["a"] = off["mp"] + max(1, len(module.pairs)) * lanes
        at2 = off["a"] + n3 * n3 * lanes
        if "vi_newton" in module.parts:  # and its Newton VI
            off.update(newton_lane_work(module, at2, lanes))
            at2 = off.pop("end")
        if "rattle_newton" in module.parts:  # and its RATTLE
            off.update(rattle_dense_work(module, at2, lanes))
            at2 = off.pop("end")
    if has_chain_lanes(module):  # a max-index M's VI block solves in the lanes
        off.update(chain_lane_work(module, at2, lanes))
        at2 = off.pop("end")
    # the adaptive methods' stages and trial state (their y and yn: rk_y0 and rk_yn)
    off["ad_k"], off["ad_yt"] = at2, at2 + _ADAPTIVE * ns * lanes
    at2 = off["ad_yt"] + ns * lanes
    off["slack"] = 7
    off["size"] = at + at2 + off["slack"]
    return off


#: The gradient record where dV/dq runs lane by lane (no loops over the lanes).
_NO_LANES: dict[str, Any] = {"general": False, "parts": (), "quadratic": False, "field_g": ()}


def print_batch(module: Module) -> dict[str, Any]:
    """The batch part's record: lane count, the flat size of an NS-per-lane array and the
    workspace offsets (`batch_work`), dV/dq in loops over the lanes (`lane_gradient`; no
    parts where it runs lane by lane, or with a coupled M), the field's kernel inline, the
    member tables the lanes copy, whether the lanes start component-major (`soa`, a C
    condition: the explicit VI's), with a coupled M where a lane's Newton VI steps keep
    their buffers (`newton_work`) and with a dense M its Newton VI's kernels inline for the
    lane loops (`newton_lanes`), with a max-index M the one-member vi_advance's buffers its
    lanes use (`chain`) and its Newton kernels inline (`chain_lanes`), RATTLE's step
    (`s2gen.printing.c_batch_rattle`); every key empty (or 0) without the part."""
    if BATCH_PART not in module.parts:
        return {
            "lanes": 0,
            "nsl": 0,
            "nl3": 0,
            "work": {},
            "gradient": _NO_LANES,
            "rhs": (),
            "tables": (),
            "soa": "0",
            "newton": {},
            "field": {},
            "newton_lanes": {},
            "chain": {},
            "chain_lanes": {},
            "rattle": {},
        }
    explicit = "vi_explicit" in module.parts  # else a coupled M: the Newton VI
    for name in ("vi_pos", "vi_vel") if explicit else ():
        scalars = [a.name for a in module.kernel(name).inputs if a.scalar]
        assert scalars == ["h", "mi"], f"{name}: the batch loads h and mi only, not {scalars}"
    field = None if explicit else coupled_field(module)
    gradient = lane_gradient(module) if explicit or field else None
    work = batch_work(module, BATCH_LANES)
    return {
        "lanes": BATCH_LANES,
        "nsl": 6 * module.n * BATCH_LANES,
        "nl3": 3 * module.n * BATCH_LANES,
        "work": work,
        "gradient": gradient or _NO_LANES,
        "rhs": _rhs(module) if gradient and explicit else (),
        "tables": tuple(
            {"index": t.index, "size": t.table * t.loop.count} for t in module.terms if t.table
        ),
        # whether a block's lane arrays start component-major (the explicit VI's), in C
        "soa": "scheme != NULL && !scheme->rattle" if explicit else "0",
        "newton": {} if explicit else newton_work(module),
        "field": field or {},
        "newton_lanes": newton_lanes(module) if field else {},
        "chain": chain_vi_work(module),
        "chain_lanes": chain_lanes(module),
        "rattle": rattle_batch(
            module, work, BATCH_LANES, field is not None and "rattle_newton" in module.parts
        ),
    }


#: The buffers of integrate_geometric()'s workspace a lane's Newton VI step uses.
_NEWTON = ("g", "gn", "a", "b", "vc", "vd", "qk", "wk", "q1", "w1", "f", "step")


def newton_work(module: Module) -> dict[str, int]:
    """Offsets (doubles), in a lane's own workspace (WORK_SIZE), of the buffers its VI steps
    use with a coupled M: integrate()'s, inside its run region (integrate_geometric's
    layout), so that a lane's step is the one-member step on its own buffers.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> w = newton_work(lower_system(builtin("double_pendulum").with_batch()))
        >>> w["f"] - w["g"] > 0, w["qk"] != w["q1"]
        (True, True)
    """
    layouts = {lay.name: lay for lay in module.layouts}
    run = layouts["integrate"].offset("run")
    return {name: run + layouts["geometric"].offset(name) for name in _NEWTON}


def _lane_loads(n3: int, scalars: dict[str, tuple[str, str, int]]) -> tuple[str, ...]:
    """Loads of a kernel's 3-vectors from body-major lane arrays in a loop over lanes l: name
    -> (array, C index of its body, offset of the array's block in the state)."""
    lines = []
    for name, (array, body, block) in scalars.items():
        base = f"{block} + 3 * {body}" if block else f"3 * {body}"
        lines.append(
            f"const double {name}0 = {array}[({base}) * L + l], "
            f"{name}1 = {array}[({base} + 1) * L + l], {name}2 = {array}[({base} + 2) * L + l];"
        )
    return tuple(lines)


def coupled_field(module: Module) -> dict[str, Any] | None:
    """The field with a dense M in loops over the lanes (rhs_cx of the coupled field): the
    rhs_body, rhs_pair and a_pair kernels inline with their loads from the lanes' state y
    (body-major, q then w) and gradient g, and the stores of their outputs (dw += b_i, b_j;
    A's blocks, A_ij and A_ji = A_ij^T); None for another M or where dV/dq does not run in
    loops over the lanes.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> f = coupled_field(lower_system(builtin("double_pendulum").with_batch()))
        >>> f["a_stores"][0]
        'a[((3 * i0 + 0) * 6 + 3 * j0 + 0) * L + l] = a0;'
    """
    if "field_coupled" not in module.parts or lane_gradient(module) is None:
        return None
    n3 = 3 * module.n
    inline = {}
    for name, scalars in (
        ("rhs_body", ("q", "w", "g")),
        ("rhs_pair", ("qi", "wi", "qj", "wj")),
        ("a_pair", ("qi", "qj")),
    ):
        kernel = module.kernel(name)
        assert isinstance(kernel, Kernel), "the passes lowered every kernel"
        assert [a.name for a in kernel.inputs if a.scalar] == (
            [] if name == "rhs_body" else ["mij"]
        )
        shared, lines = c_inline(kernel, scalars=scalars)
        if shared:
            return None
        inline[name] = lines
    outputs = [o.name for o in module.kernel("rhs_body").outputs]
    assert len(outputs) == 2, outputs
    dw = [
        f"dw[(3 * {b} + {c}) * L + l] += b{s}{c};"
        for c in range(3)
        for b, s in (("i0", "i"), ("j0", "j"))
    ]
    a_stores = []
    for r in range(3):
        for c in range(3):
            a_stores.append(f"a[((3 * i0 + {r}) * {n3} + 3 * j0 + {c}) * L + l] = a{3 * r + c};")
            a_stores.append(f"a[((3 * j0 + {c}) * {n3} + 3 * i0 + {r}) * L + l] = a{3 * r + c};")
    return {
        "body_loads": _lane_loads(
            n3, {"q": ("y", "i", 0), "w": ("y", "i", n3), "g": ("g", "i", 0)}
        ),
        "body": inline["rhs_body"],
        "body_stores": tuple(
            f"{array}[(3 * i + {c}) * L + l] = {out}{c};"
            for out, array in zip(outputs, ("dy", "dw"))
            for c in range(3)
        ),
        "pair_loads": _lane_loads(
            n3,
            {
                "qi": ("y", "i0", 0),
                "wi": ("y", "i0", n3),
                "qj": ("y", "j0", 0),
                "wj": ("y", "j0", n3),
            },
        ),
        "pair": inline["rhs_pair"],
        "pair_stores": tuple(dw),
        "a_loads": _lane_loads(n3, {"qi": ("x", "i0", 0), "qj": ("x", "j0", 0)}),
        "a_pair": inline["a_pair"],
        "a_stores": tuple(a_stores),
    }


def _rhs(module: Module) -> tuple[str, ...]:
    """The uncoupled field's kernel (rhs_diag) inline: scalars q0.., w0.., g0.. and mi in,
    dq0.., dw0.. out (the same printer as the one-member kernel's body)."""
    kernel = module.kernel("rhs_diag")
    assert isinstance(kernel, Kernel), "the passes lowered every kernel"
    assert [a.name for a in kernel.inputs] == ["mi", "q", "w", "g"]
    shared, lines = c_inline(kernel, scalars=("q", "w", "g"))
    assert not shared
    return lines


def _lane_names(
    module: Module, call: Call, kernel: Kernel
) -> tuple[dict[sp.Symbol, str], list[str]] | None:
    """C names, in a loop over lanes l inside a term's member loop (m, i, j), of a gradient
    kernel's inputs, and the loads they need; None for a binding the lanes do not hold."""
    n = module.n
    names: dict[sp.Symbol, str] = {}
    loads: list[str] = []
    for arg, bound in zip(kernel.inputs, call.inputs):
        if isinstance(bound, MemberSlot):
            for c, s in enumerate(arg.symbols):
                names[s] = f"{arg.name}{c}"
                loads.append(f"const double {arg.name}{c} = xs[({c * n} + {bound.body}) * L + l];")
        elif isinstance(bound, ContextArray) and bound.name == "cc":
            names.update({s: f"cc[{k} * L + l]" for k, s in enumerate(arg.symbols)})
        elif isinstance(bound, TermTable) and not bound.row:
            width = module.terms[call_term(call)].table
            names.update(
                {s: f"tab[(m * {width} + {k}) * L + l]" for k, s in enumerate(arg.symbols)}
            )
        elif isinstance(bound, Local) and bound.name == "p" and not bound.address:
            names.update({s: f"pl[{k} * L + l]" for k, s in enumerate(arg.symbols)})
        elif isinstance(bound, Local) and bound.name == "q" and not bound.address:
            names.update(
                {s: f"xs[({(k % 3) * n + k // 3}) * L + l]" for k, s in enumerate(arg.symbols)}
            )
        elif isinstance(bound, (TermDatum, BodyDatum)):
            at = c_binding(module.name, bound)
            if arg.scalar:
                names[arg.symbols[0]] = at
            else:
                names.update({s: f"({at})[{k}]" for k, s in enumerate(arg.symbols)})
        else:
            return None
    return names, loads


def call_term(call: Call) -> int:
    """The term of a term's call site (``t<k>_gradient``)."""
    return int(call.site[1:].split("_", 1)[0])


def lane_gradient(module: Module) -> dict[str, Any] | None:
    """dV/dq in loops over lanes, for the explicit VI: the general kernel or the terms' member
    loops (their own loop heads, `c_open`), each member's kernel inline with its inputs read
    from the lanes (positions, constants, member tables, parameters) and its outputs added
    into the body-major lane gradient in the one-member code's order; None when some part of
    the gradient is not a member loop over fixed members (rows, cutoffs) or reads what the
    lanes do not hold (the batch then calls gradient_soa lane by lane); `field_g`: the lines
    that load a body's dV/dq for the uncoupled field's kernel.

    When every term is in the quadratic matrix K, Kx + b runs in loops over the lanes instead
    (`quadratic`: see `s2gen.printing.c_batch_quadratic.quadratic_lanes`).

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> g = lane_gradient(lower_system(builtin("dipoles").with_batch()))
        >>> g["quadratic"], g["parts"]
        (True, ())
    """
    general = dict(module.facts).get("general", False)
    lanes = f"{module.name.upper()}_BATCH_LANES"
    if module.quadratic:  # Kx + b alone, every term in K, or lane by lane
        return quadratic_lanes(module)
    if any(t.rows or t.sorted_cells or not t.loop.kind.fixed for t in module.terms):
        return None
    if bool(general) == bool(module.terms):
        return None  # a general kernel alone, or terms alone
    pr_calls = {c.site: c for c in module.calls}
    off = batch_work(module)
    parts: list[dict[str, Any]] = []
    sites = ["gradient"] if general else [f"t{t.index}_gradient" for t in module.terms]
    for site in sites:
        call = pr_calls[site]
        kernel = module.kernel(call.kernel)
        assert isinstance(kernel, Kernel), "the passes lowered every kernel"
        named = _lane_names(module, call, kernel)
        if named is None:
            return None
        names, loads = named
        used: set[str] = set()
        for a in kernel.assignments:
            used |= {names.get(x, "") for x in a.expr.free_symbols}  # type: ignore[call-overload]
        loads = [line for line in loads if line.split(" = ")[0].split()[-1] in used]
        pr = CPrinter(names)
        lines = []
        for a in kernel.assignments:
            out = a.output or ("", 0)
            target = a.temp if a.temp is not None else f"{out[0]}{out[1]}"
            lines.append(f"const double {target} = {pr.doprint(a.expr)};")
        if general:
            (out,) = kernel.outputs
            stores = [f"g[{e} * L + l] = {out.name}{e};" for e in range(out.size)]
        else:
            bodies = ("i", "j")
            stores = [
                f"g[(3 * {bodies[o]} + {c}) * L + l] += {out.name}{c};"
                for o, out in enumerate(kernel.outputs)
                for c in range(out.size)
            ]
        head: tuple[str, ...] = ()
        tail: tuple[str, ...] = ()
        if not general:
            head, tail = c_loop(module.name, module.terms[call_term(call)], module.n)
        term = None if general else module.terms[call_term(call)]
        parts.append(
            {
                "table": off[f"t{term.index}"] if term is not None and term.table else 0,
                "open": head,
                "close": tail,
                "loads": tuple(loads),
                "lines": tuple(lines),
                "stores": tuple(stores),
            }
        )
    field_g = (
        (
            f"const double g0 = g[(3 * i) * {lanes} + l], g1 = g[(3 * i + 1) * {lanes} + l], "
            f"g2 = g[(3 * i + 2) * {lanes} + l];"
        ),
    )
    return {
        "general": bool(general),
        "parts": tuple(parts),
        "quadratic": False,
        "field_g": field_g,
    }
