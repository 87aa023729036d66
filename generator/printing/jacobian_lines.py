"""The C lines of the step Jacobians' assembly (part of ``m.jac``, `s2gen.printing.jacobian`).

Input: a lowered sphere `Module` with the ``jacobian`` part. Output: tuples of C lines: the
Hessian of V and dg/dp from V's general part and each term's member loop, the forces' part of
G = g - F and its derivatives, and the VI's equations' derivatives from the generic body's
(and, coupled M, pair's) blocks, placed at their rows and columns. The call sites' C comes
from the C printer (`s2gen.printing.c_calls`), the loops from `s2gen.printing.c.c_loop`.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> lines = hessian_lines(lower_system(builtin("four_pendula").with_jacobians()))
    >>> lines[0], any("four_pendula_k_t1_hessian(" in line for line in lines)
    ('for (r = 0; r < FOUR_PENDULA_N3 * FOUR_PENDULA_N3; ++r) {', True)
"""

from __future__ import annotations

from s2gen.ir import Call, Module
from s2gen.printing.c import c_loop
from s2gen.printing.c_calls import c_call

__all__ = ["call_of", "force_lines", "hessian_lines", "vi_coupled_lines", "vi_diagonal_lines"]


def call_of(module: Module, site: str) -> Call | None:
    """The module's call at `site`, or None.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> call_of(lower_system(builtin("double_pendulum")), "hessian") is None
        True
    """
    return next((c for c in module.calls if c.site == site), None)


def hessian_lines(module: Module) -> tuple[str, ...]:
    """The C lines that set H (N3 x N3) to the Hessian of V at q and gp (N3 x (inputs +
    parameters)) to dg/d(u, p): V's general part (the ``hessian`` kernel, which writes every entry) or zeros, then
    each term's member loop, which calls the term's ``t<k>_hessian`` and adds its blocks at the
    member's bodies."""
    name, upper = module.name, module.name.upper()
    # the columns of dg/d(u, p)
    npar = len(module.parameter_names) + (len(module.drive.inputs) if module.drive else 0)
    general = call_of(module, "hessian")
    if general is not None:
        lines = [f"{c_call(name, general)};"]
    else:
        lines = [f"for (r = 0; r < {upper}_N3 * {upper}_N3; ++r) {{", "    H[r] = 0.0;", "}"]
        lines += [f"for (r = 0; r < {upper}_N3 * {npar}; ++r) {{", "    gp[r] = 0.0;", "}"]
    for t in module.terms:
        call = call_of(module, f"t{t.index}_hessian")
        assert call is not None, "every term of a module with step Jacobians has its Hessian"
        indices = t.loop.kind.kind.indices
        size = 3 * len(indices)
        head, tail = c_loop(name, t, module.n)
        at = "3 * at[r / 3] + r % 3"
        inner = [
            f"double hb[{size * size}];",
            *((f"double gpb[{size * npar}];",) if npar else ()),
            f"const long at[{len(indices)}] = {{{', '.join(indices)}}};",
            f"{c_call(name, call)};",
            f"for (r = 0; r < {size}; ++r) {{",
            f"    for (c = 0; c < {size}; ++c) {{",
            f"        H[({at}) * {upper}_N3 + 3 * at[c / 3] + c % 3] += hb[{size} * r + c];",
            "    }",
            *(
                (
                    f"    for (c = 0; c < {npar}; ++c) {{",
                    f"        gp[({at}) * {npar} + c] += gpb[{npar} * r + c];",
                    "    }",
                )
                if npar
                else ()
            ),
            "}",
        ]
        lines += [line[4:] for line in head]
        lines += [f"        {line}" for line in inner]
        lines += [line[4:] for line in tail]
    return tuple(lines)


def force_lines(module: Module) -> tuple[str, ...]:
    """The C lines that take the forces out of G and gx = dG/d(q, w, u, p)
    (``force_jacobian``: F, fq, fw, fu, fp at q, w and the context's time and inputs); none
    without forces."""
    call = call_of(module, "force_jacobian")
    if call is None:
        return ()
    upper = module.name.upper()
    ni = len(module.drive.inputs) if module.drive is not None else 0
    ns, npar = 6 * module.n, len(module.parameter_names)
    return (
        f"{c_call(module.name, call)};",
        f"for (r = 0; r < {upper}_N3; ++r) {{",
        "    G[r] -= F[r];",
        f"    for (c = 0; c < {upper}_N3; ++c) {{",
        f"        gx[r * nc + c] -= fq[r * {upper}_N3 + c];",
        f"        gx[r * nc + {upper}_N3 + c] = -fw[r * {upper}_N3 + c];",
        "    }",
        f"    for (c = 0; c < {ni}; ++c) {{",
        f"        gx[r * nc + {ns} + c] -= fu[r * {ni} + c];",
        "    }",
        f"    for (c = 0; c < {npar}; ++c) {{",
        f"        gx[r * nc + {ns + ni} + c] -= fp[r * {npar} + c];",
        "    }",
        "}",
    )


def _vi_call(module: Module) -> str:
    call = call_of(module, "vi_jacobian")
    assert call is not None, "a module that differentiates the VI calls vi_jacobian"
    return f"{c_call(module.name, call)};"


def vi_diagonal_lines(module: Module) -> tuple[str, ...]:
    """The C lines of the diagonal M's VI equations' derivatives: every matrix zeroed, then
    each body's blocks from the generic body's kernel (its mass from ``jac_mass``) placed at
    its rows (position 3i, velocity 3n + 3i) and columns, one line per entry not identically
    zero, dE/dp = dE/dm dM_ii/dp."""
    n, npar = module.n, len(module.parameter_names)
    n3, ns = 3 * n, 6 * n
    lay = module.layout("jacobian")
    mass = call_of(module, "jac_mass")
    assert mass is not None, "the step Jacobians read M's entries"
    zero = [("ey", ns * ns), ("ex", ns * ns), ("eg", ns * n3), ("egn", ns * n3)]
    zero += [("efn", ns * n3), ("ep", ns * npar)]
    nonzero = _nonzero(module, "vi_jacobian")
    lines = []  # the entries not identically zero, at body i's rows and columns
    for out, mat, width, cols in (
        ("bey", "ey", ns, 6),
        ("bex", "ex", ns, 6),
        ("beg", "eg", n3, 3),
        ("begn", "egn", n3, 3),
        ("befn", "efn", n3, 3),
    ):
        for k in nonzero[out]:
            r, c = divmod(k, cols)
            at = (r // 3 * n3 + r % 3) * width + (c // 3 * n3 + c % 3 if cols == 6 else c)
            lines.append(f"{mat}[{at} + {3 * (width + 1)} * i] = {out}[{k}];")
    return (
        f"double *mm = work + {lay.offset('mm')}, *mp = work + {lay.offset('mp')};",
        "double bey[36], bex[36], beg[18], begn[18], befn[18], bem[6];",
        "long i, r, c;",
        "(void)mp;",
        *(line for b, size in zero for line in _zero(b, size)),
        f"{c_call(module.name, mass)};",
        f"for (i = 0; i < {n}; ++i) {{",
        f"    const double mii = mm[i * {n} + i];",
        f"    {_vi_call(module)}",
        *(f"    {line}" for line in lines),
        "    for (r = 0; r < 6; ++r) {",
        f"        const long row = r < 3 ? 3 * i + r : {n3} + 3 * i + r - 3;",
        f"        for (c = 0; c < {npar}; ++c) {{",
        f"            ep[row * {npar} + c] = bem[r] * mp[(i * {n} + i) * {npar} + c];",
        "        }",
        "    }",
        "}",
    )


def _nonzero(module: Module, kernel: str) -> dict[str, list[int]]:
    """The entries of each output of the module's kernel `kernel` that are not identically
    zero (the rest need not be added into matrices zeroed beforehand)."""
    k = next(k for k in module.kernels if k.name == kernel)
    return {o.name: [i for i, e in enumerate(o.exprs) if e != 0] for o in k.outputs}


def _zero(buffer: str, size: int) -> tuple[str, ...]:
    return (f"for (r = 0; r < {size}; ++r) {{", f"    {buffer}[r] = 0.0;", "}")


def vi_coupled_lines(module: Module) -> tuple[str, ...]:
    """The C lines of a coupled M's VI equations' derivatives: every matrix zeroed, then each
    body's blocks (``vi_jacobian``) and each coupled pair's (``vi_jacobian_pair``, pairs
    i0 < j0 with M_ij != 0 or dM_ij/dp != 0) added at their rows (residual 0, Cayley update 3n, velocity 6n,
    plus 3 times the body) and columns (y = (f, q+, w+), x = (q, w), G, g+, F+), one line per
    entry not identically zero (about a third of them), and dE/dp = dE/dM_ij dM_ij/dp."""
    n, npar = module.n, len(module.parameter_names)
    n3, ns, ny = 3 * n, 6 * n, 9 * n
    lay = module.layout("jacobian")
    mass = call_of(module, "jac_mass")
    pair = call_of(module, "vi_jacobian_pair")
    assert mass is not None and pair is not None, "the coupled VI's blocks read M's entries"
    zero = [("ey", ny * ny), ("ex", ny * ns), ("eg", ny * n3), ("egn", ny * n3)]
    zero += [("efn", ny * n3), ("ep", ny * npar)]
    body_out = ["b_f", "b_qn", "b_wn", "b_q", "b_w", "b_G", "b_gn", "b_Fn"]
    pair_out = [f"p_{x}{b}" for x in ("f", "qn", "wn", "q", "w") for b in "ij"]
    # (matrix, its row length, the column of the vector's first component at body b)
    target = {
        "f": ("ey", ny, 0),
        "qn": ("ey", ny, n3),
        "wn": ("ey", ny, 2 * n3),
        "q": ("ex", ns, 0),
        "w": ("ex", ns, n3),
        "G": ("eg", n3, 0),
        "gn": ("egn", n3, 0),
        "Fn": ("efn", n3, 0),
    }

    body_nz, pair_nz = _nonzero(module, "vi_jacobian"), _nonzero(module, "vi_jacobian_pair")

    def body_adds(out: str) -> list[str]:
        """`out`'s structurally nonzero entries added at body i's rows and columns."""
        mat, width, col = target[out[2:]]
        lines = []
        for k in body_nz[out]:
            r, c = divmod(k, 3)
            at = ((r // 3) * n3 + r % 3) * width + col + c
            lines.append(f"{mat}[{at} + {3 * (width + 1)} * i] += {out}[{k}];")
        return lines

    def pair_adds(out: str) -> list[str]:
        """Those of the pair's output `out` at the rows of i0 (its first 9) and j0, and the
        columns of the body its name ends with."""
        mat, width, col = target[out[2:-1]]
        lines = []
        for k in pair_nz[out]:
            r, c = divmod(k, 3)
            at = ((r % 9 // 3) * n3 + r % 3) * width + col + c
            rb = "i0" if r < 9 else "j0"
            lines.append(f"{mat}[{at} + {3 * width} * {rb} + 3 * {out[-1]}0] += {out}[{k}];")
        return lines

    lines = [
        f"double *mm = work + {lay.offset('mm')}, *mp = work + {lay.offset('mp')};",
        f"double {', '.join(f'{b}[27]' for b in body_out)}, b_m[9];",
        f"double {', '.join(f'{b}[54]' for b in pair_out)}, p_m[18];",
        "long i, i0, j0, r, c;",
        "(void)mp;",
        *(line for b, size in zero for line in _zero(b, size)),
        f"{c_call(module.name, mass)};",
        f"for (i = 0; i < {n}; ++i) {{",
        f"    const double mii = mm[i * {n} + i];",
        f"    {_vi_call(module)}",
        *(f"    {line}" for out in body_out for line in body_adds(out)),
        "    for (r = 0; r < 9; ++r) {",
        f"        const long row = (r / 3) * {n3} + 3 * i + r % 3;",
        f"        for (c = 0; c < {npar}; ++c) {{",
        f"            ep[row * {npar} + c] += b_m[r] * mp[(i * {n} + i) * {npar} + c];",
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
        f"        {c_call(module.name, pair)};",
        *(f"        {line}" for out in pair_out for line in pair_adds(out)),
        "        for (r = 0; r < 18; ++r) {",
        f"            const long row = (r % 9 / 3) * {n3} + 3 * (r < 9 ? i0 : j0) + r % 3;",
        f"            for (c = 0; c < {npar}; ++c) {{",
        f"                ep[row * {npar} + c] += p_m[r] * mp[(i0 * {n} + j0) * {npar} + c];",
        "            }",
        "        }",
        "    }",
        "}",
    ]
    return tuple(lines)
