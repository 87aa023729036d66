"""Print the records of RATTLE's step Jacobians (``m.rattle_jac``, read by the ``jacobian_rattle``
sections of ``c/_jacobian.jinja`` and ``numpy/_jacobian.jinja``).

Input: a lowered sphere `Module` with the ``rattle_jacobian`` kernels
(`s2gen.equations.rattle_jacobian`). Output: the RATTLE family's methods (their substeps' step
fractions), the C and the NumPy lines that recover the multipliers of a converged step and
assemble its equations' derivatives from the generic body's and pair's blocks at their rows
and columns (the unknowns y = (v+1/2, lambda, x+, v+, mu) of body i at 3i, 3n + i,
4n + 3i, 7n + 3i, 10n + i, each block of rows at its unknown's), and the C line that hands
a RATTLE method from step_jacobian() to its own function. Empty without those kernels.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> r = print_rattle_jacobian(lower_system(builtin("four_pendula").with_jacobians()))
    >>> [x["name"] for x in r["methods"]], r["ny"]
    (['rattle', 'rattle4', 'rattle6', 'rattle8'], '44')
"""

from __future__ import annotations

from typing import Any

from s2gen.ir import Call, Module
from s2gen.methods import METHODS, Family
from s2gen.printing.c_calls import c_call
from s2gen.printing.jacobian import composition_record
from s2gen.printing.numpy import py_call

__all__ = ["RATTLE_SITES", "print_rattle_jacobian"]

#: The call sites whose text this record writes into its lines
RATTLE_SITES = frozenset({"rattle_jacobian", "rattle_jacobian_pair"})

_KEYS = (
    "methods",
    "py_correction",
    "count",
    "max_sub",
    "ny",
    "c_equations",
    "py_equations",
    "c_other",
    "py_dispatch",
)

#: Per local row r of a body's 11 (and per unknown of the body): the block's first row (in
#: units of n), its stride per body and the offset within it
_BASE = (0, 0, 0, 3, 4, 4, 4, 7, 7, 7, 10)
_STRIDE = (3, 3, 3, 1, 3, 3, 3, 3, 3, 3, 1)
_OFFSET = (0, 1, 2, 0, 0, 1, 2, 0, 1, 2, 0)
#: Where a vector unknown's or input's columns start (matrix, first column in units of n)
_VECTORS = {
    "vh": ("ey", 0),
    "xn": ("ey", 4),
    "vn": ("ey", 7),
    "x": ("ex", 0),
    "v": ("ex", 3),
    "g": ("eg", 0),
    "gn": ("egn", 0),
}


def _call(module: Module, site: str) -> Call | None:
    return next((c for c in module.calls if c.site == site), None)


def print_rattle_jacobian(module: Module) -> dict[str, Any]:
    """The ``m.rattle_jac`` record of a module (every key empty without RATTLE's Jacobian)."""
    body, pair = _call(module, "rattle_jacobian"), _call(module, "rattle_jacobian_pair")
    if body is None or pair is None:
        return dict.fromkeys(_KEYS, ())
    name = module.name
    methods = tuple(
        composition_record(m)
        for m in METHODS
        if m.family is Family.RATTLE and m.composition is not None
    )
    drive = module.drive
    # a driven module's (C: _jacobian_rattle_driven) with the forces' end velocity correction
    correction: tuple[str, ...] = ()
    if drive is not None and drive.forces:
        correction = (
            "status, wd, _, its = _end_velocity(p, cc, hs, xd, wd, tu, newton_tol, newton_maxiter)",
            "if status != OK:",
            "    return status, None, None, None",
        )
    call = (
        "_jac_rattle(p, cc, method, h, q, w, newton_tol, newton_maxiter)"
        if drive is None
        else "_jac_rattle_driven(p, cc, method, t, h, q, w, tu, newton_tol, newton_maxiter)"
    )
    return {
        "methods": methods,
        "py_correction": correction,
        "count": str(len(methods)),
        "max_sub": str(max(int(m["count"]) for m in methods)),
        "ny": str(11 * module.n),
        "c_equations": _c_lines(module, body, pair),
        "py_equations": _py_lines(module, body, pair),
        "py_dispatch": ("else:", f"    status, qn, wn, d = {call}"),
        "c_other": (
            f"if ({name}_jac_rattle_method_of(method)) {{",
            (
                f"    return {name}_jac_rattle_step(p, opt, method, t, h, u, q, w, qn, wn, A, B, P, "
                "work);"
            ),
            "}",
        ),
    }


def _c_lines(module: Module, body: Call, pair: Call) -> tuple[str, ...]:
    """C: every matrix zeroed, v+1/2 and the multipliers from the converged step, then each
    body's blocks and each coupled pair's (i0 < j0 with M_ij != 0 or dM_ij/dp != 0) added."""
    n, npar, name = module.n, len(module.parameter_names), module.name
    n3, ns, ny = 3 * n, 6 * n, 11 * n
    lay = module.layout("jacobian")
    mass = _call(module, "jac_mass")
    assert mass is not None, "the step Jacobians read M's entries"
    sizes = (("ey", ny * ny), ("ex", ny * ns), ("eg", ny * n3), ("egn", ny * n3))
    lines = [
        f"double *mm = work + {lay.offset('mm')}, *mp = work + {lay.offset('mp')};",
        f"double {', '.join(f'r_{v}[33]' for v in _VECTORS)}, r_lam[11], r_mu[11], r_m[11];",
        "double p_vhi[66], p_vhj[66], p_vni[66], p_vnj[66], p_vi[66], p_vj[66], p_m[22];",
        f"static const long base[11] = {{{', '.join(str(b * n) for b in _BASE)}}};",
        f"static const long stride[11] = {{{', '.join(map(str, _STRIDE))}}};",
        f"static const long off[11] = {{{', '.join(map(str, _OFFSET))}}};",
        "long i, i0, j0, r, c;",
        "(void)mp;",
    ]
    for buffer, size in (*sizes, ("ep", ny * npar)):
        lines += [f"for (r = 0; r < {size}; ++r) {{", f"    {buffer}[r] = 0.0;", "}"]
    lines += [
        f"{c_call(name, mass)};",
        f"for (r = 0; r < {n3}; ++r) {{",
        "    vh[r] = (xn[r] - x[r]) / h;",
        "}",
        "/* lambda_i and mu_i from the first and fourth rows of body i */",
        f"for (i = 0; i < {n}; ++i) {{",
        "    double s1[3], s4[3], d1 = 0.0, d4 = 0.0, xx = 0.0, nn = 0.0;",
        "    for (c = 0; c < 3; ++c) {",
        "        s1[c] = 0.5 * h * g[3 * i + c];",
        "        s4[c] = 0.5 * h * gn[3 * i + c];",
        f"        for (r = 0; r < {n}; ++r) {{",
        f"            s1[c] += mm[i * {n} + r] * (vh[3 * r + c] - v[3 * r + c]);",
        f"            s4[c] += mm[i * {n} + r] * (vn[3 * r + c] - vh[3 * r + c]);",
        "        }",
        "        d1 += x[3 * i + c] * s1[c];",
        "        d4 += xn[3 * i + c] * s4[c];",
        "        xx += x[3 * i + c] * x[3 * i + c];",
        "        nn += xn[3 * i + c] * xn[3 * i + c];",
        "    }",
        "    lam[i] = -2.0 * d1 / (h * xx);",
        "    mu[i] = -2.0 * d4 / (h * nn);",
        "}",
        f"for (i = 0; i < {n}; ++i) {{",
        f"    const double mii = mm[i * {n} + i];",
        f"    {c_call(name, body)};",
        "    for (r = 0; r < 11; ++r) {",
        "        const long row = base[r] + stride[r] * i + off[r];",
        "        for (c = 0; c < 3; ++c) {",
    ]
    for v, (mat, start) in _VECTORS.items():
        width = {"ey": ny, "ex": ns, "eg": n3, "egn": n3}[mat]
        lines.append(
            f"            {mat}[row * {width} + {start * n} + 3 * i + c] += r_{v}[3 * r + c];"
        )
    lines += [
        "        }",
        f"        ey[row * {ny} + {3 * n} + i] += r_lam[r];",
        f"        ey[row * {ny} + {10 * n} + i] += r_mu[r];",
        f"        for (c = 0; c < {npar}; ++c) {{",
        f"            ep[row * {npar} + c] += r_m[r] * mp[(i * {n} + i) * {npar} + c];",
        "        }",
        "    }",
        "}",
        f"for (i0 = 0; i0 < {n}; ++i0) {{",
        f"    for (j0 = i0 + 1; j0 < {n}; ++j0) {{",
        f"        const double mij = mm[i0 * {n} + j0];",
        "        int idle = mij == 0.0;",
        f"        for (c = 0; c < {npar} && idle; ++c) {{",
        f"            idle = mp[(i0 * {n} + j0) * {npar} + c] == 0.0;",
        "        }",
        "        if (idle) {",
        "            continue;",
        "        }",
        f"        {c_call(name, pair)};",
        "        for (r = 0; r < 22; ++r) {",
        "            const long b = r < 11 ? i0 : j0, lr = r % 11;",
        "            const long row = base[lr] + stride[lr] * b + off[lr];",
        "            for (c = 0; c < 3; ++c) {",
    ]
    for v in ("vh", "vn", "v"):
        mat, start = _VECTORS[v]
        width = ny if mat == "ey" else ns
        for k, at in (("i", "i0"), ("j", "j0")):
            lines.append(
                f"                {mat}[row * {width} + {start * n} + 3 * {at} + c] += "
                f"p_{v}{k}[3 * r + c];"
            )
    lines += [
        "            }",
        f"            for (c = 0; c < {npar}; ++c) {{",
        f"                ep[row * {npar} + c] += p_m[r] * mp[(i0 * {n} + j0) * {npar} + c];",
        "            }",
        "        }",
        "    }",
        "}",
    ]
    return tuple(lines)


def _py_lines(module: Module, body: Call, pair: Call) -> tuple[str, ...]:
    """NumPy: the same, each kernel called once on all bodies (pairs), blocks scattered with
    numpy.add.at."""
    lines = [
        "vh = (xn - x) / h",
        "mv = mm @ (vh - v)",
        "mn = mm @ (vn - vh)",
        "# lambda_i and mu_i from the first and fourth rows of body i",
        "lam = -2.0 * numpy.sum(x * (mv + 0.5 * h * g), axis=1) / (h * numpy.sum(x * x, axis=1))",
        "mu = -2.0 * numpy.sum(xn * (mn + 0.5 * h * gn), axis=1) / (h * numpy.sum(xn * xn, axis=1))",
        "mii = numpy.diag(mm)",
        f"{', '.join(f'r_{v}' for v in _VECTORS)}, r_lam, r_mu, r_m = {py_call(body)}",
        "index = numpy.arange(NBODIES)",
        f"base = numpy.array({list(_BASE)}) * NBODIES",
        f"stride = numpy.array({list(_STRIDE)})",
        f"off = numpy.array({list(_OFFSET)})",
        "rows = base[None, :] + stride[None, :] * index[:, None] + off[None, :]",
        "cols = 3 * index[:, None] + numpy.arange(3)",
    ]
    for v, (mat, start) in _VECTORS.items():
        lines.append(
            f"numpy.add.at({mat}, (rows[:, :, None], {start} * NBODIES + cols[:, None, :]), "
            f"r_{v}.reshape(-1, 11, 3))"
        )
    lines += [
        "numpy.add.at(ey, (rows, 3 * NBODIES + index[:, None]), r_lam.reshape(-1, 11))",
        "numpy.add.at(ey, (rows, 10 * NBODIES + index[:, None]), r_mu.reshape(-1, 11))",
        "numpy.add.at(ep, rows, r_m.reshape(-1, 11, 1) * mp[index, index][:, None, :])",
        "# the pairs i < j M couples (or whose M_ij the parameters move)",
        (
            "PAIR_I, PAIR_J = numpy.nonzero(numpy.triu((mm != 0.0) | "
            "numpy.any(mp != 0.0, axis=2), 1))"
        ),
        "mij = mm[PAIR_I, PAIR_J]",
        f"p_vhi, p_vhj, p_vni, p_vnj, p_vi, p_vj, p_m = {py_call(pair)}",
        "local = numpy.arange(22) % 11",
        (
            "rows = (base[local] + off[local])[None, :] + stride[local][None, :] * numpy.where("
            "numpy.arange(22) < 11, PAIR_I[:, None], PAIR_J[:, None])"
        ),
        "cols_i = 3 * PAIR_I[:, None] + numpy.arange(3)",
        "cols_j = 3 * PAIR_J[:, None] + numpy.arange(3)",
    ]
    for v in ("vh", "vn", "v"):
        mat, start = _VECTORS[v]
        for k in "ij":
            lines.append(
                f"numpy.add.at({mat}, (rows[:, :, None], {start} * NBODIES + cols_{k}[:, None, :]),"
                f" p_{v}{k}.reshape(-1, 22, 3))"
            )
    lines.append("numpy.add.at(ep, rows, p_m.reshape(-1, 22, 1) * mp[PAIR_I, PAIR_J][:, None, :])")
    return tuple(lines)
