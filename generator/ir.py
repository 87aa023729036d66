"""Frozen, typed intermediate representation between the equations and the printers.

Kernels:
- `KernelDef` is what the equation stages (`s2gen.equations`) produce: named inputs (each a
  tuple of SymPy symbols, a scalar or an array slot per symbol) and named outputs (tuples of
  SymPy expressions in those symbols).
- `Kernel` is what the lowering passes (`s2gen.passes`) make of it: common subexpressions
  eliminated into named temporaries (deterministic names), small integer powers expanded,
  operation counts attached.

Structure:
- `Loop` is a loop over the members of a structured term or over the coupled pairs of M
  (`LoopKind` says how members are enumerated; list kinds read member tables).
- `Call` is one call site of a kernel, its arguments bound in Python from the kernel's own
  signature (`s2gen.passes.calls`) to typed bindings (`s2gen.bindings`), not to text.
- `Layout` is the workspace of one function: named buffers with sizes and offsets
  (`s2gen.passes.workspace`).
- `Band` is one coupled linear system of the structured solvers as the band elimination lays
  it out: unknowns per body, rows, bandwidths and the doubles its storage takes.
- `Module` gathers one emitted module: its kind, kernels, loops, calls, layouts, the partial
  templates that lay it out (chosen in Python: the algorithm variants) and the passes that ran.

Templates never see SymPy objects: `s2gen.printing` turns a `Module` into text records.

Example:
    >>> import sympy as sp
    >>> x = sp.Symbol("x")
    >>> k = KernelDef("square", "x squared", (Argument("x", (x,), scalar=True),),
    ...               (Output("y", (x**2,), scalar=True),))
    >>> k.inputs[0].size, k.outputs[0].size
    (1, 1)
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import sympy as sp

from s2gen.bindings import Binding
from s2gen.inertia import InertiaKind
from s2gen.terms import Selection

__all__ = [
    "Argument",
    "Assignment",
    "Band",
    "Buffer",
    "Call",
    "Drive",
    "Fission",
    "Kernel",
    "KernelDef",
    "Layout",
    "Loop",
    "LoopKind",
    "Module",
    "ModuleKind",
    "Output",
    "PassRecord",
    "TermLoop",
]


@dataclass(frozen=True)
class Argument:
    """A kernel input: `scalar` (one symbol, passed by value) or an array of `symbols`."""

    name: str
    symbols: tuple[sp.Symbol, ...]
    scalar: bool = False
    shared: bool = False  # one array for all members (not vectorized over them in NumPy)

    @property
    def size(self) -> int:
        return len(self.symbols)


@dataclass(frozen=True)
class Output:
    """A kernel output: one expression per slot (`scalar`: a single value)."""

    name: str
    exprs: tuple[sp.Expr, ...]
    scalar: bool = False

    @property
    def size(self) -> int:
        return len(self.exprs)


@dataclass(frozen=True)
class KernelDef:
    """A kernel before lowering: inputs and output expressions, with a one-line doc.

    `system` kernels index the global positions (q of all bodies: `q[3*i + c]` in C, `q[i, c]`
    in NumPy); the others take one body's or one pair's vectors (and vectorize in NumPy).
    """

    name: str
    doc: str
    inputs: tuple[Argument, ...]
    outputs: tuple[Output, ...]
    system: bool = False
    #: (input name, stage) of the inputs that are constant per call: 0 parameters, 1 a member's
    #: data; the `hoist` pass computes what depends only on them once per call. None: the
    #: kernel does not take part (the generic kernels of the equations).
    stages: tuple[tuple[str, int], ...] | None = None


@dataclass(frozen=True)
class Assignment:
    """`target = expr`; `target` is a temporary symbol or (output name, slot index)."""

    temp: sp.Symbol | None
    output: tuple[str, int] | None
    expr: sp.Expr


@dataclass(frozen=True)
class Kernel:
    """A lowered kernel: inputs, ordered assignments (temporaries first), op counts."""

    name: str
    doc: str
    inputs: tuple[Argument, ...]
    outputs: tuple[Output, ...]
    assignments: tuple[Assignment, ...]
    ops_before: int
    ops_after: int
    system: bool = False
    stages: tuple[tuple[str, int], ...] | None = None

    @property
    def temporaries(self) -> int:
        return sum(1 for a in self.assignments if a.temp is not None)


class ModuleKind(enum.Enum):
    """The kinds of emitted module: the (S^2)^n equations and integrators, or the classical
    spherical-angle form of the same system (for comparison)."""

    SPHERE = "sphere"
    ANGLES = "angles"


#: How a loop enumerates its members: a term selection of `s2gen.terms` (every body, listed
#: bodies, the chain, listed pairs, every pair i < j, the pairs within a cutoff) or the coupled
#: pairs of M.
LoopKind = Selection


@dataclass(frozen=True)
class Loop:
    """A loop over `count` members of one kind; list kinds read `members` (0-based bodies)."""

    kind: Selection
    count: int
    members: tuple[tuple[int, ...], ...] = ()
    cutoff: float | None = None  # CUTOFF_PAIRS: chord distance; pairs farther apart are skipped
    cells: int = 0  # CUTOFF_PAIRS: neighbour-list grid cells per axis over [-1, 1]


@dataclass(frozen=True)
class Fission:
    """A pair kernel's inline loop split at its calls of libm functions (`s2gen.passes.fission`).

    Three loops over the same partners: `first` computes the call-free temporaries that
    `stores` need and writes buffer k := stores[k][1] (a call's argument, or a temporary worth
    keeping); the calls then set buffer k := calls[k](buffer k) for each k with a call; `last`
    computes the outputs, reading buffer k as the symbol stores[k][0]. A call in `calls` is
    applied to the symbol `ARG`.
    """

    first: tuple[Assignment, ...]
    stores: tuple[tuple[sp.Symbol, sp.Expr], ...]
    calls: tuple[sp.Expr | None, ...]
    last: tuple[Assignment, ...]

    ARG = sp.Symbol("fission_arg", real=True)


@dataclass(frozen=True)
class TermLoop:
    """One structured potential term: its loop, kernels and per-member data tables.

    `data` holds (name, width, values) tables, one entry (width values) per member.
    """

    index: int
    loop: Loop
    data: tuple[tuple[str, int, tuple[float, ...]], ...]
    value: str  # kernel names
    gradient: str
    table: int = 0  # slots per member of the term's table (see the `hoist` pass)
    #: (slot, row, column) of the member's coefficients in the term's quadratic form, when the
    #: `quadratic` pass put it into the module's matrix (column -1: linear; row -1: constant)
    quadratic: tuple[tuple[int, int, int], ...] = ()
    rows: bool = False  # all pairs as vectorisable rows on structure-of-arrays copies (`layout`)
    #: cutoff pairs from cell lists sorted into structure-of-arrays copies, the gradient
    #: kernel inline in a masked SIMD loop (`layout`)
    sorted_cells: bool = False
    #: (datum, width, body of the member (0 or 1)) of each per-body array the kernels read,
    #: in their argument order (kernel argument b_<datum><i or j>, or b_<datum> in body terms)
    body_data: tuple[tuple[str, int, int], ...] = ()
    #: the rows gradient loop split at its calls so that the call-free parts vectorise
    #: (`layout`; None: one loop)
    fission: Fission | None = None


@dataclass(frozen=True)
class Call:
    """One call site of a kernel: what each argument is bound to (`s2gen.bindings`), in the
    kernel's parameter order. The printers render them: C passes the inputs then the outputs
    (by address), NumPy passes the inputs and takes the outputs as returned values.
    """

    site: str
    kernel: str
    inputs: tuple[Binding, ...]
    outputs: tuple[Binding, ...]


@dataclass(frozen=True)
class Buffer:
    """A named part of a workspace: `size` doubles at `offset`."""

    name: str
    size: int
    offset: int


@dataclass(frozen=True)
class Layout:
    """The workspace of one function: its buffers in order and its total size (doubles)."""

    name: str
    buffers: tuple[Buffer, ...]

    @property
    def size(self) -> int:
        return max((b.offset + b.size for b in self.buffers), default=0)

    def offset(self, name: str) -> int:
        """The offset of buffer `name` (KeyError if absent)."""
        for b in self.buffers:
            if b.name == name:
                return b.offset
        raise KeyError(f"layout {self.name} has no buffer {name!r}")


@dataclass(frozen=True)
class Band:
    """One coupled system L x = b, L = E + H (M_off (x) I_r) K, as a band matrix.

    `p` unknowns per body (`r` of them coupled through M), `nrhs` right-hand sides; `block`
    unknowns per body in the band (p + r for MAX_INDEX, whose y_i join x_i; p for BANDED),
    `rows` = n block, `kl` and `ku` sub- and superdiagonals. Storage: rows (2 kl + ku + 1)
    doubles for the matrix, then rows nrhs for the right-hand sides when they are laid out
    apart from b (MAX_INDEX).

    Example:
        >>> Band("field", 3, 3, 1, 6, 60, 6, 6, True).size
        1200
    """

    name: str
    p: int
    r: int
    nrhs: int
    block: int
    rows: int
    kl: int
    ku: int
    separate_rhs: bool

    @property
    def size(self) -> int:
        """Doubles of workspace the solve takes."""
        return self.rows * (2 * self.kl + self.ku + 1) + (
            self.rows * self.nrhs if self.separate_rhs else 0
        )


@dataclass(frozen=True)
class PassRecord:
    """A lowering pass that ran, with the operations of all kernels after it (total, and by
    kind as `passes.opcount.Ops` prints them)."""

    name: str
    ops: int
    profile: str = ""


@dataclass(frozen=True)
class Drive:
    """The driven part of a module: the inputs (names and defaults, in the order of ``u``),
    whether it has forces and whether they depend on the angular velocities."""

    inputs: tuple[str, ...]
    defaults: tuple[float, ...]
    forces: bool
    velocity: bool

    @property
    def width(self) -> int:
        """Doubles of ``tu``: the time, then the inputs."""
        return 1 + len(self.inputs)


@dataclass(frozen=True)
class Module:
    """Everything the printers need for one emitted module, still language-neutral.

    `kernels` are `KernelDef`s before the lowering passes and `Kernel`s after; `parts` names the
    parts in the order they are laid out, each by the partial template of its name or by the
    variant `variants` names for it (e.g. the energy of a coupled M), whose record in
    `s2gen.parts` declares its call sites and workspace buffers; `facts`
    are the few other values the templates show (flags and sizes, decided in Python).
    """

    kind: ModuleKind
    name: str
    spec_hash: str
    origin: str
    n: int
    parameter_names: tuple[str, ...]
    parameter_values: tuple[float, ...]
    kernels: tuple[KernelDef | Kernel, ...]
    parts: tuple[str, ...]
    c_only: tuple[str, ...] = ()  # parts the NumPy module does by library calls instead
    variants: tuple[tuple[str, str], ...] = ()  # (part, the partial that lays it out)
    pairs: tuple[tuple[int, int], ...] = ()  # 0-based (i, j), i < j, M_ij not identically zero
    terms: tuple[TermLoop, ...] = ()
    coupling: Loop | None = None
    calls: tuple[Call, ...] = ()
    layouts: tuple[Layout, ...] = ()
    work_base: int = 0  # doubles used by the functions; the per-call context follows
    work_size: int = 0
    constants: int = 0  # context constants (see the `hoist` pass)
    quadratic: int = 0  # order of the quadratic terms' matrix K (3n, or 0 without one)
    facts: tuple[tuple[str, bool | int | float | str], ...] = ()
    field_calls: tuple[tuple[str, int], ...] = ()  # (kernel, calls) per vector-field evaluation
    passes: tuple[PassRecord, ...] = ()
    solver: InertiaKind = InertiaKind.DIAGONAL  # how the coupled solves are done
    bands: tuple[Band, ...] = ()  # structured solvers: their systems (workspace pass)
    inertia_data: tuple[tuple[str, tuple[float, ...]], ...] = ()  # per-body data of M
    #: per-body arrays the terms read (name, width, n * width values), one table each
    body_data: tuple[tuple[str, int, tuple[float, ...]], ...] = ()
    initial_state: tuple[float, ...] = ()  # the spec's q then omega, body-major (or none)
    drive: Drive | None = None  # a driven system's inputs and forces (None: closed)

    def band(self, name: str) -> Band:
        """The band system `name` (KeyError if absent)."""
        for b in self.bands:
            if b.name == name:
                return b
        raise KeyError(f"module {self.name} has no band system {name!r}")

    def kernel(self, name: str) -> KernelDef | Kernel:
        """The kernel called `name` (KeyError if absent)."""
        for k in self.kernels:
            if k.name == name:
                return k
        raise KeyError(f"module {self.name} has no kernel {name!r}")

    def fact(self, name: str) -> bool | int | float | str:
        """The value of fact `name` (KeyError if absent)."""
        return dict(self.facts)[name]

    @property
    def body_major_terms(self) -> bool:
        """True when part of the potential has only a body-major gradient (q[3 i + c]): a
        general potential, or a term neither in K nor laid out as rows. The component-major
        gradient of the explicit VI then passes through body-major copies for that part."""
        general = bool(dict(self.facts).get("general", False))
        return general or any(not (t.quadratic or t.rows) for t in self.terms)

    def layout(self, name: str) -> Layout:
        """The workspace layout of function `name` (KeyError if absent)."""
        for lay in self.layouts:
            if lay.name == name:
                return lay
        raise KeyError(f"module {self.name} has no layout {name!r}")
