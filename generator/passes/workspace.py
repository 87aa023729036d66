"""Pass `workspace`: the caller's workspace laid out, function by function.

Input: a `Module`. Output: the same module with one `Layout` per function that takes scratch
memory (named buffers, sizes and offsets; a buffer that hands memory on to a callee has the
callee's size), `work_base` (the most any entry point uses) and `work_size` (plus the per-call
context kept after `work_base`). Templates read every offset from these records; the header's
WORK_SIZE is `work_size`. Modules with structured solvers (BANDED or MAX_INDEX inertia) also
get their `Band` systems (`bands`): the bandwidths and storage of each coupled solve.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> m = lower_system(builtin("double_pendulum"))
    >>> m.layout("field").buffers
    (Buffer(name='g', size=6, offset=0), Buffer(name='a', size=48, offset=6))
"""

from __future__ import annotations

from dataclasses import replace

from s2gen.inertia import InertiaKind
from s2gen.ir import Band, Buffer, Layout, LoopKind, Module, ModuleKind
from s2gen.methods import METHODS, explicit_tableaus
from s2gen.tableaus import DOP853

__all__ = ["CONTEXT", "band", "bands", "layout", "padded", "workspace_pass"]

_STRUCTURED = (InertiaKind.BANDED, InertiaKind.MAX_INDEX)


def padded(dim: int) -> int:
    """Row stride of a dim x dim matrix for the dense solvers: dim rounded up to a multiple of
    4 doubles (one AVX register), so that their row updates have a fixed vector length."""
    return -(-dim // 4) * 4


def layout(name: str, *buffers: tuple[str, int]) -> Layout:
    """Buffers placed one after the other in the given order."""
    placed, offset = [], 0
    for bname, size in buffers:
        placed.append(Buffer(bname, size, offset))
        offset += size
    return Layout(name, tuple(placed))


def band(module: Module, name: str, p: int, r: int, nrhs: int) -> Band:
    """The band system of an operator with `p` unknowns per body (`r` coupled through M).

    MAX_INDEX: unknowns (x_i, y_i) per body, y_i coupled to y_i-1 and y_i+1: kl = ku = p + r.
    BANDED (bandwidth w): the blocks L_ij of |i - j| <= w: kl = ku = p (w + 1) - 1.

    Example:
        >>> from s2gen.systems import builtin
        >>> from s2gen.passes import lower_system
        >>> b = lower_system(builtin("rope", n=10)).band("newton")
        >>> b.block, b.rows, b.kl, b.ku
        (6, 60, 6, 6)
    """
    n = module.n
    if module.solver is InertiaKind.MAX_INDEX:
        block = p + r
        return Band(name, p, r, nrhs, block, n * block, block, block, True)
    width = max((j - i for i, j in module.pairs), default=0)
    half = p * (width + 1) - 1
    return Band(name, p, r, nrhs, p, n * p, half, half, False)


def bands(module: Module) -> tuple[Band, ...]:
    """The coupled solves of the structured solvers: the VI's Newton step and velocity
    solve, the continuous field (all 3 x 3 blocks coupled by M), RATTLE's multipliers
    ((z_i, lambda_i): 4 per body, z_i coupled) and M itself (three right-hand sides)."""
    if module.kind is not ModuleKind.SPHERE or module.solver not in _STRUCTURED:
        return ()
    return (
        band(module, "newton", 3, 3, 1),
        band(module, "velocity", 3, 3, 1),
        band(module, "field", 3, 3, 1),
        band(module, "rattle", 4, 3, 1),
        band(module, "mass", 1, 1, 3),
    )


def _structured(module: Module, systems: tuple[Band, ...]) -> tuple[Layout, Layout, Layout]:
    """Layouts of the structured field, VI and RATTLE: sources u, sums z = M_off u, the
    blocks E, H, K of each body (9 or 16 doubles) and the band solve's storage."""
    n, m3 = module.n, 3 * module.n
    size = {b.name: b.size for b in systems}
    blocks = [("e", 9 * n), ("hb", 9 * n), ("kb", 9 * n)]
    field = layout("field", ("g", m3), ("u", m3), ("z", m3), *blocks, ("solve", size["field"]))
    vi = layout(
        "vi_advance",
        ("d", m3),
        ("r", m3),
        ("u", m3),
        ("z", m3),
        *blocks,
        ("solve", max(size["newton"], size["velocity"])),
    )
    rattle = layout(
        "rattle_advance",
        ("gw", m3),
        ("y", m3),
        ("u", m3),
        ("t", m3),
        ("e", 16 * n),
        ("rb", 4 * n),
        ("solve", max(size["rattle"], size["mass"])),
    )
    return field, vi, rattle


def _rk_fixed(module: Module, ns: int, field: Layout) -> Layout:
    """The stages of the longest fixed-step tableau of the module's kind, and the field's."""
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    return layout("rk_fixed", ("k", stages * ns), ("field", field.size))


def _sphere(module: Module) -> tuple[list[Layout], int]:
    n, m3 = module.n, 3 * module.n
    ns = 2 * m3
    coupled = module.solver is not InertiaKind.DIAGONAL
    structured = module.solver in _STRUCTURED
    # a coupled M: the dense field solves A(q) omegadot = b in a
    field = layout("field", ("g", m3), *((("a", m3 * padded(m3)),) if coupled else ()))
    extra: list[Layout] = []
    if structured:
        field, vi, rattle = _structured(module, bands(module))
    rk_fixed = _rk_fixed(module, ns, field)
    rk_step = layout("rk_step", ("y0", ns), ("yt", ns), ("rk", rk_fixed.size))
    rk45 = layout("rk45", ("k", 7 * ns), ("y", ns), ("yn", ns), ("ys", ns), ("field", field.size))
    # DOP853: its stages, the field at the new state and the stages of its dense output
    dop853 = layout(
        "dop853",
        ("k", (DOP853.stages + 1 + len(DOP853.dense_a)) * ns),
        ("y", ns),
        ("yt", ns),
        ("yn", ns),
        ("ys", ns),
        ("field", field.size),
    )
    if structured:
        pass  # laid out above
    elif coupled:
        vi = layout("vi_advance", ("d", m3), ("r", m3), ("jm", m3 * padded(m3)))
        rattle = layout(
            "rattle_advance",
            ("wi", n * n),
            ("jm", n * padded(n)),
            ("y", m3),
            ("gw", m3),
            ("u", m3),
            ("r", n),
        )
    else:
        # the explicit step runs on component-major (SoA) copies, so that its loops over bodies
        # vectorise; "bridge" holds body-major q and g for terms without an SoA gradient
        bridge = ("bridge", 2 * m3 if module.body_major_terms else 0)
        soa = [(b, m3) for b in ("x", "v", "gx", "xn", "vn", "gn")]
        vi = layout("vi_advance", *soa, ("s", n), bridge)
        extra = [layout("explicit", *soa, ("s", n), bridge)]
        rattle = layout("rattle_advance", ("vh", m3))
    # uncoupled, the geometric driver runs RATTLE only (the VI has its own: "explicit")
    step = max(vi.size, rattle.size) if coupled else rattle.size
    state = [(b, m3) for b in ("qk", "wk", "q1", "w1")]  # the current and the next state
    # Newton's starting points: each substep's Cayley parameters (VI) or multipliers (RATTLE)
    # from the previous step, for the longest composition
    subs = max(len(m.composition.fractions) for m in METHODS if m.composition is not None)
    starts = [*((("f", subs * m3),) if coupled else ()), ("s", subs * n if coupled else 0)]
    # substeps alternate between (a, vc) and (b, vd); va, vb carry RATTLE's velocities
    geometric = layout(
        "geometric",
        *((b, m3) for b in ("g", "gn", "a", "b", "va", "vb", "vc", "vd")),
        *state,
        *starts,
        ("step", step),
    )
    fixed = layout("fixed", *state, ("step", rk_step.size))
    vi_step = layout("vi_step", ("g", m3), ("gn", m3), ("f", m3), ("step", vi.size))
    run = max(geometric.size, rk45.size, dop853.size, fixed.size, *(lay.size for lay in extra))
    integrate = layout("integrate", ("run", run), ("y0", ns))
    # step(): one step of a fixed-step method, its substeps alternating as in "geometric"
    basic = max(vi.size, rattle.size)
    subs_step = [(b, m3) for b in ("g", "gn", "a", "b", "vb", "vc", "vd")]
    one_step = layout("step", *subs_step, ("step", max(basic, rk_step.size)))
    layouts = [field, rk_fixed, rk_step, rk45, dop853, vi, rattle, geometric, fixed, vi_step]
    layouts += [integrate, one_step]
    layouts += extra
    base = max(lay.size for lay in layouts)
    # the caller's carry of step(), kept between steps (not workspace): the last state returned
    # and its gradient, RATTLE's velocities and each substep's last Newton solution
    carry = layout("carry", *((b, m3) for b in ("q", "w", "g", "v")), *starts)
    return [*layouts, carry], base


def _angles(module: Module) -> tuple[list[Layout], int]:
    nx = 2 * module.n
    ns = 2 * nx
    field = layout("field", ("m", nx * nx), ("lu", nx * padded(nx)))
    rk_fixed = _rk_fixed(module, ns, field)
    rk_step = layout("rk_step", ("y0", ns), ("yt", ns), ("fail", ns), ("rk", rk_fixed.size))
    rk45 = layout("rk45", ("k", 7 * ns), ("y", ns), ("yn", ns), ("ys", ns), ("field", field.size))
    integrate = layout("integrate", ("run", max(rk45.size, rk_step.size)), ("y0", ns), ("fail", ns))
    layouts = [field, rk_fixed, rk_step, rk45, integrate]
    return layouts, max(lay.size for lay in layouts)


#: Name of the layout of the per-call context kept at the tail of the workspace.
CONTEXT = "context"


def _context(module: Module) -> Layout:
    """Per-call context after `work_base`: masses and their inverses, coupled entries, A's
    diagonal in the VI,
    neighbour-list cells (the largest grid of the cutoff terms)."""
    if module.kind is not ModuleKind.SPHERE:
        return layout(CONTEXT)
    n = module.n
    cells = [t.loop.cells**3 + n for t in module.terms if t.loop.kind is LoopKind.CUTOFF_PAIRS]
    coupled = module.solver is not InertiaKind.DIAGONAL
    return layout(
        CONTEXT,
        ("md", n),
        ("mi", n),
        ("mp", 2 * n if module.solver is InertiaKind.MAX_INDEX else len(module.pairs)),
        ("adiag", n if coupled else 0),
        ("nb", max(cells, default=0)),
        ("cc", module.constants),
        ("soa", 6 * n if any(t.rows for t in module.terms) else 0),
        *((("kq", module.quadratic**2), ("kb", module.quadratic + 10)) if module.quadratic else ()),
        *((f"t{t.index}", t.table * t.loop.count) for t in module.terms if t.table),
    )


def workspace_pass(module: Module) -> Module:
    """Lay out the workspace of every function of the module."""
    layouts, base = _sphere(module) if module.kind is ModuleKind.SPHERE else _angles(module)
    context = _context(module)
    return replace(
        module,
        layouts=(*layouts, context),
        work_base=base,
        work_size=base + context.size,
        bands=bands(module),
    )
