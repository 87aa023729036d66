"""Pass `workspace`: the caller's workspace laid out, function by function.

Input: a `Module`. Output: the same module with one `Layout` per function that takes scratch
memory, for each layout a selected part declares it reads (`s2gen.parts`): named buffers, sizes
and offsets (a buffer that hands memory on to a callee has the callee's size, so a layout's
builder asks for the layouts it holds), `work_base` (the most any entry point uses) and
`work_size` (plus the per-call context kept after `work_base`). Templates read every offset
from these records; the header's WORK_SIZE is `work_size`. Modules with structured solvers
(BANDED or MAX_INDEX inertia) also get their `Band` systems (`bands`): the bandwidths and
storage of each coupled solve.

Example:
    >>> from s2gen.systems import builtin
    >>> from s2gen.passes import lower_system
    >>> m = lower_system(builtin("double_pendulum"))
    >>> m.layout("field").buffers
    (Buffer(name='g', size=6, offset=0), Buffer(name='a', size=48, offset=6))
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from s2gen.inertia import InertiaKind
from s2gen.ir import Band, Buffer, Layout, LoopKind, Module, ModuleKind, TermLoop
from s2gen.methods import METHODS, explicit_tableaus
from s2gen.parts import selected
from s2gen.passes.jacobian_layout import jacobian_layout
from s2gen.passes.jvp_layout import jvp_layout
from s2gen.tableaus import DOP853, DOPRI5

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


def _structured(module: Module) -> tuple[Layout, Layout, Layout]:
    """Layouts of the structured field, VI and RATTLE: sources u, sums z = M_off u, the
    blocks E, H, K of each body (9 or 16 doubles) and the band solve's storage."""
    n, m3 = module.n, 3 * module.n
    size = {b.name: b.size for b in bands(module)}
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


class _Layouts:
    """The layouts of one module built on demand by name, each once: a layout's size may
    hold another's (a buffer that hands memory on to a callee), so a builder asks for the
    layouts it needs. A builder returns None where the module has no such function."""

    def __init__(self, module: Module, builders: dict[str, _Builder]) -> None:
        self.module, self._builders = module, builders
        self._built: dict[str, Layout | None] = {}

    def get(self, name: str) -> Layout | None:
        if name not in self._built:
            self._built[name] = self._builders[name](self.module, self)
        return self._built[name]

    def __getitem__(self, name: str) -> Layout:
        lay = self.get(name)
        assert lay is not None, f"layout {name} is needed but the module has none"
        return lay

    def size(self, name: str) -> int:
        lay = self.get(name)
        return lay.size if lay is not None else 0


_Builder = Callable[[Module, _Layouts], Layout | None]


def _ns(module: Module) -> int:
    """Doubles of the state: (q, omega) or (x, xd)."""
    return 6 * module.n if module.kind is ModuleKind.SPHERE else 4 * module.n


def _m3(module: Module) -> int:
    return 3 * module.n


def _coupled(module: Module) -> bool:
    return module.solver is not InertiaKind.DIAGONAL


def _soa(module: Module) -> list[tuple[str, int]]:
    """The explicit step's component-major (SoA) copies, so that its loops over bodies
    vectorise; "bridge" holds body-major q and g for terms without an SoA gradient."""
    m3 = _m3(module)
    bridge = ("bridge", 2 * m3 if module.body_major_terms else 0)
    return [*((b, m3) for b in ("x", "v", "gx", "xn", "vn", "gn")), ("s", module.n), bridge]


def _field(module: Module, _: _Layouts) -> Layout:
    """The field's gradient; with a coupled M the dense A(q) of A omegadot = b."""
    if module.solver in _STRUCTURED:
        return _structured(module)[0]
    m3 = _m3(module)
    return layout("field", ("g", m3), *((("a", m3 * padded(m3)),) if _coupled(module) else ()))


def _vi(module: Module, _: _Layouts) -> Layout:
    m3 = _m3(module)
    if module.solver in _STRUCTURED:
        return _structured(module)[1]
    if _coupled(module):
        return layout("vi_advance", ("d", m3), ("r", m3), ("jm", m3 * padded(m3)))
    return layout("vi_advance", *_soa(module))


def _explicit(module: Module, _: _Layouts) -> Layout | None:
    """The explicit VI's own driver (diagonal M only): its buffers from the first 64-byte
    boundary of the workspace (`KQ_SLACK` doubles to spare), each a whole number of 64-byte
    lines, so that the vector loops over bodies never read across a cache line when n is a
    multiple of 8 (see templates/c/sections/_integrate_explicit.jinja); qs and ws take the
    body-major state of the substeps whose state is not stored."""
    if _coupled(module):
        return None
    m3 = _m3(module)
    lines = [(name, -(-size // 8) * 8) for name, size in (*_soa(module), ("qs", m3), ("ws", m3))]
    return layout("explicit", *lines, ("slack", KQ_SLACK))


def _rattle(module: Module, _: _Layouts) -> Layout:
    n, m3 = module.n, _m3(module)
    if module.solver in _STRUCTURED:
        return _structured(module)[2]
    if _coupled(module):
        return layout(
            "rattle_advance",
            ("wi", n * n),
            ("jm", n * padded(n)),
            ("y", m3),
            ("gw", m3),
            ("u", m3),
            ("r", n),
        )
    return layout("rattle_advance", ("vh", m3))


def _rk_fixed(module: Module, lays: _Layouts) -> Layout:
    """The stages of the longest fixed-step tableau of the module's kind, and the field's."""
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    return layout("rk_fixed", ("k", stages * _ns(module)), ("field", lays.size("field")))


def _rk_step(module: Module, lays: _Layouts) -> Layout:
    """One fixed step; the angle form keeps the state where a step failed."""
    ns = _ns(module)
    fail = (("fail", ns),) if module.kind is ModuleKind.ANGLES else ()
    return layout("rk_step", ("y0", ns), ("yt", ns), *fail, ("rk", lays.size("rk_fixed")))


def _rk45(module: Module, lays: _Layouts) -> Layout:
    ns = _ns(module)
    field = lays.size("field")
    return layout("rk45", ("k", 7 * ns), ("y", ns), ("yn", ns), ("ys", ns), ("field", field))


def _dop853(module: Module, lays: _Layouts) -> Layout:
    """DOP853: its stages, the field at the new state and the stages of its dense output."""
    ns = _ns(module)
    return layout(
        "dop853",
        ("k", (DOP853.stages + 1 + len(DOP853.dense_a)) * ns),
        ("y", ns),
        ("yt", ns),
        ("yn", ns),
        ("ys", ns),
        ("field", lays.size("field")),
    )


def _state(module: Module) -> list[tuple[str, int]]:
    """The current and the next state."""
    return [(b, _m3(module)) for b in ("qk", "wk", "q1", "w1")]


def _starts(module: Module) -> list[tuple[str, int]]:
    """Newton's starting points: each substep's Cayley parameters (VI) or multipliers
    (RATTLE) from the previous step, for the longest composition."""
    coupled = _coupled(module)
    subs = max(len(m.composition.fractions) for m in METHODS if m.composition is not None)
    f = (("f", subs * _m3(module)),) if coupled else ()
    return [*f, ("s", subs * module.n if coupled else 0)]


def _geometric(module: Module, lays: _Layouts) -> Layout:
    """Substeps alternate between (a, vc) and (b, vd); va, vb carry RATTLE's velocities;
    uncoupled, the geometric driver runs RATTLE only (the VI has its own: "explicit")."""
    step = lays.size("rattle_advance")
    if _coupled(module):
        step = max(lays.size("vi_advance"), step)
    return layout(
        "geometric",
        *((b, _m3(module)) for b in ("g", "gn", "a", "b", "va", "vb", "vc", "vd")),
        *_state(module),
        *_starts(module),
        ("step", step),
    )


def _transformed(module: Module, lays: _Layouts) -> Layout | None:
    """The time-transformed driver: g at the state, g1 at the next, ga and gb within a
    composed step, whose substeps alternate between (a, vc) and (b, vd); the state, the next
    and a sample's (qs, ws); the Newton starts (f: the VI's, RATTLE's multipliers) and the VI
    or RATTLE step's own workspace. With a diagonal M, the explicit VI's
    (`_transformed_explicit`)."""
    if "transformed" not in module.parts:
        return None
    if not _coupled(module):
        return _transformed_explicit(module, lays)
    m3 = _m3(module)
    return layout(
        "transformed",
        *((b, m3) for b in ("g", "g1", "ga", "gb", "a", "b", "vc", "vd")),
        *_state(module),
        ("qs", m3),
        ("ws", m3),
        _starts(module)[0],
        ("step", max(lays.size("vi_advance"), lays.size("rattle_advance"))),
    )


def _transformed_explicit(module: Module, lays: _Layouts) -> Layout:
    """The time-transformed driver of a diagonal M, on the explicit VI's component-major
    arrays (RATTLE's body-major ones in the same places): the state (x, v, gx), the substeps'
    (xa, va, ga) and (xb, vb, gb), the step's scratch (s, bridge), the body-major state
    (qk, wk) the monitor reads and RATTLE's step's workspace (step); placed as the explicit
    driver's buffers (whole 64-byte lines from the first boundary, `KQ_SLACK` doubles to
    spare)."""
    m3, soa = _m3(module), dict(_soa(module))
    state = [(b, m3) for b in ("x", "v", "gx", "xa", "va", "ga", "xb", "vb", "gb")]
    scratch = (("s", soa["s"]), ("bridge", soa["bridge"]), ("qk", m3), ("wk", m3))
    sized = (*state, *scratch, ("step", lays.size("rattle_advance")))
    lines = [(name, -(-size // 8) * 8) for name, size in sized]
    return layout("transformed", *lines, ("slack", KQ_SLACK))


def _fixed(module: Module, lays: _Layouts) -> Layout:
    return layout("fixed", *_state(module), ("step", lays.size("rk_step")))


def _vi_step(module: Module, lays: _Layouts) -> Layout:
    m3 = _m3(module)
    return layout("vi_step", ("g", m3), ("gn", m3), ("f", m3), ("step", lays.size("vi_advance")))


def _integrate(module: Module, lays: _Layouts) -> Layout:
    """A whole run: the driver's workspace and the initial state."""
    ns = _ns(module)
    if module.kind is ModuleKind.ANGLES:
        run = max(lays.size("rk45"), lays.size("rk_step"))
        return layout("integrate", ("run", run), ("y0", ns), ("fail", ns))
    drivers = ("geometric", "rk45", "dop853", "fixed", "explicit", "transformed")
    return layout("integrate", ("run", max(lays.size(d) for d in drivers)), ("y0", ns))


def _one_step(module: Module, lays: _Layouts) -> Layout:
    """step(): one step of a fixed-step method, its substeps alternating as in "geometric"."""
    basic = max(lays.size("vi_advance"), lays.size("rattle_advance"))
    subs = [(b, _m3(module)) for b in ("g", "gn", "a", "b", "vb", "vc", "vd")]
    return layout("step", *subs, ("step", max(basic, lays.size("rk_step"))))


def _carry(module: Module, _: _Layouts) -> Layout:
    """The caller's carry of step(), kept between steps (not workspace): the last state
    returned and its gradient, RATTLE's velocities and each substep's last Newton solution."""
    return layout("carry", *((b, _m3(module)) for b in ("q", "w", "g", "v")), *_starts(module))


def _driven(module: Module, lays: _Layouts) -> Layout:
    """A driven module's driver, one layout for integrate(), step() and the functions they
    call, all reading the same `work`: the state and the next (qk, wk, q1, w1), the
    substeps' alternating buffers (a, vc) and (b, vd), g and gn, the forces F and dF/dw,
    the velocity equations' terms c, Jacobian jc and matrix jm and their start w0, the VI's
    Newton start f, the Runge-Kutta stages k (DOP853's thirteen at least), the stage state ys,
    the adaptive methods' accepted state yk and DOP853's trial state yd, the inputs a feedback
    writes
    (ub), RATTLE's velocities v and vr and its multipliers' start ss, and the field's and the
    VI or RATTLE step's own workspace."""
    assert module.drive is not None
    m3, ns = _m3(module), _ns(module)
    forces, velocity = module.drive.forces, module.drive.velocity
    stages = max(t.stages for t in explicit_tableaus(module.kind.value))
    return layout(
        "driven",
        *((b, m3) for b in ("qk", "wk", "q1", "w1", "a", "b", "vc", "vd", "g", "gn", "F")),
        ("Fw", m3 * m3 if velocity else 0),
        # the velocity equations of forced steps (the force terms of the field reuse c, jm)
        *(
            (("c", m3), ("jc", m3 * m3 if velocity else 0), ("jm", m3 * padded(m3)), ("w0", m3))
            if forces
            else ()
        ),
        ("f", m3 if _coupled(module) else 0),
        ("k", max(stages, DOPRI5.stages, DOP853.stages + 1) * ns),
        ("ys", ns),
        ("yk", ns),
        ("yd", ns),
        ("ub", len(module.drive.inputs)),
        ("v", m3),
        ("vr", m3),
        ("ss", module.n if _coupled(module) else 0),
        ("field", lays.size("field")),
        ("step", max(lays.size("vi_advance"), lays.size("rattle_advance"))),
    )


#: The builder of each layout a part of the sphere module may declare
_SPHERE: dict[str, _Builder] = {
    "field": _field,
    "vi_advance": _vi,
    "explicit": _explicit,
    "rattle_advance": _rattle,
    "rk_fixed": _rk_fixed,
    "rk_step": _rk_step,
    "rk45": _rk45,
    "dop853": _dop853,
    "geometric": _geometric,
    "fixed": _fixed,
    "transformed": _transformed,
    "vi_step": _vi_step,
    "integrate": _integrate,
    "step": _one_step,
    "carry": _carry,
    "driven": _driven,
    "jacobian": lambda module, _: jacobian_layout(module),
    "jvp": lambda module, lays: jvp_layout(module, lays.size("field"), lays.size("vi_advance")),
}


def _angle_field(module: Module, _: _Layouts) -> Layout:
    """The angle form's mass matrix and its LU factors."""
    nx = 2 * module.n
    return layout("field", ("m", nx * nx), ("lu", nx * padded(nx)))


#: The builder of each layout a part of the angle-form module may declare
_ANGLES: dict[str, _Builder] = {
    "field": _angle_field,
    "rk_fixed": _rk_fixed,
    "rk_step": _rk_step,
    "rk45": _rk45,
    "integrate": _integrate,
}

#: Layouts that are not workspace (kept by the caller between calls)
_NOT_WORKSPACE = ("carry",)
#: Layouts placed after the per-call context (their offsets count from the workspace's start)
_TAIL = ("jacobian", "jvp")


#: Name of the layout of the per-call context kept at the tail of the workspace.
CONTEXT = "context"
#: Doubles of K's buffer beyond (3n)^2: K starts at the buffer's first 64-byte boundary (its
#: rows are read as whole vectors; see templates/c/sections/_build_quadratic.jinja).
KQ_SLACK = 7


def _cell_storage(t: TermLoop, n: int) -> int:
    """Doubles of a cutoff term's cell lists: the linked list (each cell's first body, each
    body's next), or for `sorted_cells` each cell's start (cells + 1), each sorted place's body
    and each body's cell, the sorted q and g (component-major) and one sorted copy per datum.

    Example:
        >>> from s2gen.ir import Loop, LoopKind, TermLoop
        >>> t = TermLoop(0, Loop(LoopKind.CUTOFF_PAIRS, 45, cutoff=0.5, cells=4), (), "v", "g")
        >>> _cell_storage(t, 10), _cell_storage(replace(t, sorted_cells=True), 10)
        (74, 145)
    """
    if not t.sorted_cells:
        return t.loop.cells**3 + n
    data = len({name for name, _, _ in t.body_data})
    return t.loop.cells**3 + 1 + (8 + data) * n


def _context(module: Module) -> Layout:
    """Per-call context after `work_base`: masses and their inverses, coupled entries, A's
    diagonal in the VI,
    neighbour-list cells (the largest grid of the cutoff terms)."""
    if module.kind is not ModuleKind.SPHERE:
        return layout(CONTEXT)
    n = module.n
    cells = [_cell_storage(t, n) for t in module.terms if t.loop.kind is LoopKind.CUTOFF_PAIRS]
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
        *(
            (("kq", module.quadratic**2 + KQ_SLACK), ("kb", module.quadratic + 10))
            if module.quadratic
            else ()
        ),
        *((f"t{t.index}", t.table * t.loop.count) for t in module.terms if t.table),
    )


def workspace_pass(module: Module) -> Module:
    """Lay out the workspace of every function the module's parts declare (`s2gen.parts`):
    each layout a selected part reads, then the per-call context."""
    lays = _Layouts(module, _SPHERE if module.kind is ModuleKind.SPHERE else _ANGLES)
    names = dict.fromkeys(lay for part in selected(module) for lay, _ in part.buffers)
    layouts = [lay for lay in map(lays.get, names) if lay is not None]
    base = max((lay.size for lay in layouts if lay.name not in _NOT_WORKSPACE + _TAIL), default=0)
    context = _context(module)
    tail = base + context.size
    layouts = [
        Layout(lay.name, tuple(replace(b, offset=b.offset + tail) for b in lay.buffers))
        if lay.name in _TAIL
        else lay
        for lay in layouts
    ]
    return replace(
        module,
        layouts=(*layouts, context),
        work_base=base,
        work_size=base + context.size,
        bands=bands(module),
    )
