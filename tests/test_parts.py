"""Declared vs read: the printed module and the templates agree on every name.

Every module kind (sphere with diagonal, dense, banded and max-index M, with and without
structured terms, quadratic terms, member tables and cutoffs, and the angle form) is rendered in
both languages with its `PrintedModule` wrapped in a recording proxy that logs every attribute
and key read (recursively through the dicts `call`, `work`, `inline`, `band`, ...). Then:

(a) every name a template can read is declared: the templates' syntax trees are walked for
    every chain rooted at the module (`m.x`, `m.call.x`, `m.work.x.y`, ...), rendered branch
    or not, and each must be a field of `PrintedModule` or a key some module declares; the
    renders fail on any other read (StrictUndefined);
(b) every declaration is read: each field of the record, each call site `call[...]`, each
    optional section (`c_sections`, `py_sections`) and each workspace buffer
    `work[layout][buffer]` of a module is read by that module's templates;
(c) part by part (`s2gen.parts`): the partial of each part the module selects, in each of its
    languages and with the partials it includes, rendered alone, reads only the call sites
    and workspace buffers its own part declares, and reads every one of them that the module
    has (a site whose kernel the module lacks, a buffer its layout lacks, is not there).
Every template is laid out by some case, so that (b) sees every reader, and every part is
selected by some case, so that (c) sees every part.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Iterator
from importlib import resources
from pathlib import Path
from typing import Any

import jinja2
import numpy as np
import pytest
from jinja2 import nodes

from s2gen.equations.angles import derive_angles
from s2gen.ir import Module
from s2gen.parts import PARTS, Part, selected
from s2gen.passes import lower_angles, lower_system
from s2gen.printing import PrintedModule, print_module
from s2gen.render import TEMPLATES, environment
from s2gen.spec import define_system, load_spec_text
from s2gen.system import System
from s2gen.systems import builtin, resolve

ROOT = Path(__file__).parent.parent
SPECS = Path(__file__).parent / "specs"

#: Fields of the record read by Python rather than by a template (with the reason).
READ_BY_PYTHON = {
    "kind": "render.py chooses the top-level templates of a module by its kind",
}

#: Call sites declared where no template reads them (with the reason).
UNREAD_SITES: dict[str, str] = {}

#: Templates no module lays out (with the reason).
NOT_LAID_OUT = {
    "numpy/_band.jinja": "C only (Module.c_only): NumPy solves with scipy; mirrors C's folder",
    "numpy/_cholesky.jinja": "C only (Module.c_only): NumPy solves with numpy.linalg",
}

#: Template folders of other outputs than the emitted modules, with their own tests: the FMI
#: wrapper (s2gen.fmi.wrapper; tests/test_fmu.py renders each and checks what it reads).
OTHER_OUTPUTS = {"fmu/": "the FMI wrapper of an FMU"}

#: Layout entries that describe a layout rather than name one of its buffers.
LAYOUT_FACTS = {"doc", "size"}

Path_ = tuple[str, ...]


class Recorder:
    """A read-only view of a printed module (or one of its dicts) that logs every read."""

    def __init__(self, target: Any, path: Path_, log: set[Path_]) -> None:
        self._target, self._path, self._log = target, path, log

    def _wrap(self, key: str, value: Any) -> Any:
        self._log.add((*self._path, key))
        return Recorder(value, (*self._path, key), self._log) if isinstance(value, dict) else value

    def __getattr__(self, name: str) -> Any:
        if isinstance(self._target, dict):
            if name in self._target:
                raise AttributeError(name)  # jinja then reads it as a key
            return getattr(self._target, name)  # a dict method
        return self._wrap(name, getattr(self._target, name))

    def __getitem__(self, key: str) -> Any:
        if not isinstance(self._target, dict):
            raise TypeError(f"{'.'.join(self._path) or 'm'} is not a dict")
        return self._wrap(key, self._target[key])

    def __iter__(self) -> Iterator[Any]:
        return iter(self._target)

    def __len__(self) -> int:
        return len(self._target)

    def __bool__(self) -> bool:
        return bool(self._target)

    def __contains__(self, key: object) -> bool:
        return key in self._target


def banded_chain(n: int = 9) -> System:
    """n bodies whose M couples neighbours (banded), with chain springs and a body term."""
    inertia = [["0"] * n for _ in range(n)]
    for i in range(n):
        inertia[i][i] = f"m*(2 + {i % 3})"
        if i + 1 < n:
            inertia[i][i + 1] = inertia[i + 1][i] = "c*m"
    q = np.zeros((n, 3))
    q[:, 2] = 1.0
    return define_system(
        name="banded",
        bodies=n,
        parameters={"m": 1.0, "c": 0.3, "k": 2.0},
        inertia=inertia,
        pair_terms=[{"V": "k*(1 - dot(qi, qj))", "pairs": "chain"}],
        body_terms=[{"V": "q[2]"}],
        initial_q=q.tolist(),
        initial_omega=np.zeros((n, 3)).tolist(),
        run={"h": 0.01, "T": 1.0},
    )


def per_body_diagonal() -> System:
    """A diagonal M given as one expression per body: evaluated body by body; no parameters
    and no initial state (initial_state() reports that it has none)."""
    return define_system(
        name="beads",
        bodies=3,
        parameters={},
        diagonal="1 + i/n",
        body_terms=[{"V": "q[2]"}],
    )


def lopsided_cutoff() -> System:
    """A cutoff term that is not symmetric in its two bodies (it reads ci alone): its gradient
    keeps the linked cell list, where a symmetric one is laid out on sorted cells."""
    return define_system(
        name="lopsided",
        bodies=4,
        parameters={},
        diagonal="1",
        data={"c": [1.0, 2.0, 3.0, 4.0]},
        pair_terms=[{"V": "ci/dot(qi - qj, qi - qj)", "pairs": "all", "cutoff": 0.5}],
    )


def screened_rows() -> System:
    """All pairs laid out as rows whose gradient calls exp: the partner loop split at the call
    (`s2gen.passes.fission`)."""
    return define_system(
        name="screened",
        bodies=4,
        parameters={"k": 2.0},
        diagonal="1",
        pair_terms=[{"V": "exp(-k*norm(qi - qj))/norm(qi - qj)", "pairs": "all"}],
    )


def coupled_field() -> System:
    """Every pair of 8 bodies coupled bilinearly, with a linear part (a field on each body of
    the pair): the quadratic terms' K and b, in loops over the lanes of a batch."""
    pairs = [[i, j] for i in range(1, 9) for j in range(i + 1, 9)]
    return define_system(
        name="coupled_field",
        bodies=8,
        parameters={"k": 0.05, "f": 0.3},
        diagonal="1",
        pair_terms=[{"V": "k*(dot(qi, qj) + 2*qi[0]*qj[1]) + f*qi[2]", "pairs": pairs}],
    ).with_batch()


def double_pendulum_monitor() -> System:
    """The double pendulum with a monitor given as [run] g: the time-transformed driver of a
    coupled M (Newton VI)."""
    text = (resources.files("s2gen.systems.examples") / "double_pendulum.toml").read_text()
    return load_spec_text(text + 'g = "3 + dot(q1, q2)"\n')


def chain4_structured() -> System:
    """The chain of tests/specs with its max-index M solved by the structured solvers, M's
    generators from one system kernel (not per body)."""
    text = (SPECS / "chain4.toml").read_text()
    return load_spec_text(text.replace("[inertia]\n", '[inertia]\nsolver = "structured"\n'))


#: One system per module kind: what it exercises.
SYSTEMS = {
    "double_pendulum": lambda: builtin("double_pendulum"),  # dense M, general V
    "pendulum_chain": lambda: builtin("pendulum_chain"),  # dense M, terms with tables
    "banded": banded_chain,  # banded M, chain and body terms
    "elastic_rod": lambda: builtin("elastic_rod"),  # max-index M (one kernel), tables
    "chain4": chain4_structured,  # max-index M from its matrix, general V
    "rope": lambda: builtin("rope"),  # max-index M per body, with per-body data
    "rope_dense": lambda: builtin("rope", n=8, solver="dense"),  # per-body M, dense solves
    "beads": per_body_diagonal,  # per-body diagonal M, no parameters, no initial state
    "springs4": lambda: resolve(str(SPECS / "springs4.toml")),  # diagonal M, general V only
    "springs4_terms": lambda: resolve(str(SPECS / "springs4_terms.toml")),  # listed terms
    "three_bodies": lambda: builtin("three_bodies"),  # pair terms laid out as rows, the
    # time-transformed driver on the explicit VI's arrays; with a coupled M on the Newton VI's
    "double_pendulum_g": double_pendulum_monitor,
    "screened": screened_rows,  # rows split at their calls
    "dipoles": lambda: builtin("dipoles"),  # quadratic terms (K)
    "lj_cutoff": lambda: builtin("lj_cutoff"),  # cutoff: sorted cell lists
    "lopsided": lopsided_cutoff,  # cutoff, not symmetric: linked cell lists
    # driven: dense M with velocity-dependent forces, time and an input; diagonal M with
    # velocity-dependent forces and a force term; diagonal M with time only (no forces)
    "driven_double": lambda: resolve(str(SPECS / "driven_double.toml")),
    "driven_ring": lambda: resolve(str(SPECS / "driven_ring.toml")),
    "driven_timed": lambda: resolve(str(SPECS / "driven_timed.toml")),
    # the step Jacobians: Runge-Kutta and the VI (dense M, Newton), forces and an input
    "driven_double_jacobians": lambda: resolve(str(SPECS / "driven_double.toml")).with_jacobians(),
    # and RATTLE's of a driven module (diagonal M, forces reading w, inputs)
    "driven_ring_jacobians": lambda: resolve(str(SPECS / "driven_ring.toml")).with_jacobians(),
    # closed: RATTLE's too (dense M, Newton on the multipliers)
    "double_pendulum_jacobians": lambda: builtin("double_pendulum").with_jacobians(),
    # step_jvp(): the structured field's tangent (max-index M, chain terms, beyond the dense
    # Jacobians' 32 bodies), the banded one's and the diagonal one's
    "rope_jvp": lambda: builtin("rope", n=40).with_jacobians(),
    "banded_jvp": lambda: banded_chain(5).with_jacobians(),
    "four_pendula_jvp": lambda: builtin("four_pendula").with_jacobians(),
    # integrate_batch(): diagonal M, listed and body terms with member tables
    "four_pendula_batch": lambda: builtin("four_pendula").with_batch(),
    # integrate_batch() with dV/dq lane by lane (pair rows)
    "three_bodies_batch": lambda: builtin("three_bodies").with_batch(),
    # integrate_batch() with a dense M: the Newton VI and the field in loops over the lanes
    "double_pendulum_batch": lambda: builtin("double_pendulum").with_batch(),
    # integrate_batch() with a max-index M: the VI's block solves in loops over the lanes
    "rope_batch": lambda: resolve("rope:n=10").with_batch(),
    # integrate_batch() with a banded M: the Newton VI and the field lane by lane
    "banded_batch": lambda: banded_chain(5).with_batch(),
    # integrate_batch() with the quadratic terms' Kx + b in loops over the lanes sharing K
    "dipoles_batch": lambda: builtin("dipoles").with_batch(),
    # the same with a linear part (b read by the products)
    "coupled_field_batch": coupled_field,
    # a driven system's integrate_batch(): members one after the other through the driven step
    "forced_double_pendulum_batch": lambda: builtin("forced_double_pendulum").with_batch(),
}


@functools.cache
def lowered() -> dict[str, Module]:
    """The lowered modules of every case, the angle form of the double pendulum included."""
    out = {name: lower_system(make()) for name, make in SYSTEMS.items()}
    out["double_pendulum_angles"] = lower_angles(derive_angles(builtin("double_pendulum"), False))
    return out


@functools.cache
def modules() -> dict[str, PrintedModule]:
    """The printed modules of every case."""
    return {name: print_module(module) for name, module in lowered().items()}


@functools.cache
def reads() -> dict[str, set[Path_]]:
    """Per case: every path read while rendering every file of both languages."""
    env = environment()
    out: dict[str, set[Path_]] = {}
    for name, module in modules().items():
        log: set[Path_] = set()
        for files in TEMPLATES[module.kind].values():
            for template, _ in files:
                env.get_template(template).render(m=Recorder(module, (), log))
        out[name] = log
    return out


# ------------------------------------------------------------------ (a) reads are declared
def _chain(node: nodes.Node) -> Path_ | None:
    """The names of an attribute/constant-key chain rooted at the variable `m`, or None."""
    names: list[str] = []
    while True:
        if isinstance(node, nodes.Getattr):
            names.append(node.attr)
            node = node.node
        elif isinstance(node, nodes.Getitem) and isinstance(node.arg, nodes.Const):
            names.append(str(node.arg.value))
            node = node.node
        elif isinstance(node, nodes.Name) and node.name == "m":
            return tuple(reversed(names))
        else:
            return None


def template_chains() -> dict[Path_, set[str]]:
    """Every chain rooted at `m` in every template (longest only), with the templates it is in."""
    env = environment()
    root = ROOT / "templates"
    out: dict[Path_, set[str]] = {}
    for path in sorted(root.rglob("*.jinja")):
        name = path.relative_to(root).as_posix()
        tree = env.parse(path.read_text(), name=name)
        inner: set[int] = set()
        for node in tree.find_all((nodes.Getattr, nodes.Getitem)):
            chain = _chain(node)
            if chain is None or id(node) in inner:
                continue
            inner.update(id(n) for n in node.find_all((nodes.Getattr, nodes.Getitem)))
            out.setdefault(chain, set()).add(name)
    return out


def declared(module: Any, chain: Path_) -> bool:
    """Whether the record (or the dict in it) declares the chain's names, in order."""
    for name in chain:
        if isinstance(module, dict):
            if name not in module:
                return False
            module = module[name]
        elif dataclasses.is_dataclass(module) and not isinstance(module, type):
            if name not in {f.name for f in dataclasses.fields(module)}:
                return False
            module = getattr(module, name)
        else:
            return False  # a read into a value that is not a record
    return True


def test_every_name_a_template_reads_is_declared() -> None:
    """Rendered or not, each `m.` chain of every template names a field of the record and
    keys that some module declares."""
    chains = template_chains()
    assert chains, "the templates read the module"
    undeclared = {
        ".".join(chain): sorted(where)
        for chain, where in chains.items()
        if not any(declared(module, chain) for module in modules().values())
    }
    assert not undeclared, f"templates read names no module declares: {undeclared}"


def loop_reads() -> dict[tuple[Path_, str], set[str]]:
    """Every attribute or constant key read from the variable of a `for` over an `m.` chain
    (`{% for t in m.terms %}... t.count`), with the templates it is in."""
    env = environment()
    root = ROOT / "templates"
    out: dict[tuple[Path_, str], set[str]] = {}
    for path in sorted(root.rglob("*.jinja")):
        name = path.relative_to(root).as_posix()
        for loop in env.parse(path.read_text(), name=name).find_all(nodes.For):
            chain = _chain(loop.iter)
            if chain is None or not isinstance(loop.target, nodes.Name):
                continue
            for node in loop.find_all((nodes.Getattr, nodes.Getitem)):
                if isinstance(node.node, nodes.Name) and node.node.name == loop.target.name:
                    key = node.attr if isinstance(node, nodes.Getattr) else node.arg
                    if isinstance(key, nodes.Const):
                        key = key.value
                    if isinstance(key, str):
                        out.setdefault((chain, key), set()).add(name)
    return out


def test_every_name_read_in_a_loop_is_declared() -> None:
    """Each name read from a loop's items (terms, kernels, tables, ...) is a field or key of
    those items in some module."""
    reads_ = loop_reads()
    assert reads_, "the templates loop over the module's records"

    def item_declares(module: PrintedModule, chain: Path_, key: str) -> bool:
        items = module
        for name in chain:
            items = items[name] if isinstance(items, dict) else getattr(items, name)
        return any(declared(item, (key,)) for item in items)

    undeclared = {
        f"{'.'.join(chain)}[*].{key}": sorted(where)
        for (chain, key), where in reads_.items()
        if not any(item_declares(m, chain, key) for m in modules().values())
    }
    assert not undeclared, f"templates read names their loop's items do not declare: {undeclared}"


def test_every_template_is_rendered() -> None:
    """The cases lay out every partial of both languages (so (b) sees every reader): the
    top-level templates, the partials the records name, and what those include or import."""
    env = environment()
    loaded: set[str] = set()
    for module in modules().values():
        pending = [t for files in TEMPLATES[module.kind].values() for t, _ in files]
        pending += [*module.c_parts, *module.py_parts, module.c_masses, module.py_masses]
        for t in module.terms:
            pending += [t.c_value_part, t.c_gradient_part, t.py_value_part, t.py_gradient_part]
            pending.append(t.c_rows_partners_part)
        for chosen in (*module.c_sections.values(), *module.py_sections.values()):
            pending += chosen
        while pending:
            name = pending.pop()
            if name in loaded:
                continue
            loaded.add(name)
            source = (ROOT / "templates" / name).read_text()
            for node in env.parse(source).find_all((nodes.Include, nodes.FromImport)):
                if isinstance(node.template, nodes.Const):
                    pending.append(node.template.value)
    root = ROOT / "templates"
    every = {p.relative_to(root).as_posix() for p in root.rglob("*.jinja")}
    every = {name for name in every if not name.startswith(tuple(OTHER_OUTPUTS))}
    missing = every - loaded - set(NOT_LAID_OUT)
    assert not missing, f"no case lays out {sorted(missing)}"
    assert set(NOT_LAID_OUT) <= every - loaded, "a template listed as not laid out is"


# ------------------------------------------------------------------ (b) declarations are read
def test_every_field_is_read() -> None:
    """Each field of PrintedModule is read by some template of some module kind."""
    read = {path[0] for log in reads().values() for path in log}
    fields = {f.name for f in dataclasses.fields(PrintedModule)}
    unread = fields - read - set(READ_BY_PYTHON)
    assert not unread, f"fields no template reads (remove them): {sorted(unread)}"
    assert not set(READ_BY_PYTHON) & read, "a field listed as read by Python only is read"


def test_every_call_site_is_read() -> None:
    """Each call site a module declares is read by that module's templates."""
    unread = {
        name: sorted(
            set(module.call) - {p[1] for p in reads()[name] if p[0] == "call" and len(p) > 1}
        )
        for name, module in modules().items()
    }
    listed = {s for sites in unread.values() for s in sites} & set(UNREAD_SITES)
    assert listed == set(UNREAD_SITES), "a call site listed as unread is read everywhere"
    unread = {name: [s for s in sites if s not in UNREAD_SITES] for name, sites in unread.items()}
    unread = {name: sites for name, sites in unread.items() if sites}
    assert not unread, f"call sites no template reads: {unread}"


def test_every_section_is_read() -> None:
    """Each optional section a module declares (C and NumPy) is laid out by its templates."""
    unread = {
        f"{name}.{field}": sorted(
            set(getattr(module, field)) - {p[1] for p in reads()[name] if p[0] == field and p[1:]}
        )
        for name, module in modules().items()
        for field in ("c_sections", "py_sections")
    }
    unread = {where: keys for where, keys in unread.items() if keys}
    assert not unread, f"sections no template lays out: {unread}"


def test_every_workspace_buffer_is_read() -> None:
    """Each buffer of each workspace layout a module declares is read by its templates."""
    unread: dict[str, list[str]] = {}
    for name, module in modules().items():
        read = {p[1:3] for p in reads()[name] if p[0] == "work" and len(p) == 3}
        for layout, entry in module.work.items():
            for buffer in set(entry) - LAYOUT_FACTS:
                if (layout, buffer) not in read:
                    unread.setdefault(name, []).append(f"{layout}.{buffer}")
    assert not unread, f"workspace buffers no template reads: {unread}"


@pytest.mark.parametrize("case", ["double_pendulum", "springs4"])
def test_recorder_fails_on_an_undeclared_read(case: str) -> None:
    """The proxy lets no undeclared name through: the strict environment raises."""
    template = environment().from_string("{{ m.call.no_such_site.c }}")
    with pytest.raises(jinja2.UndefinedError):
        template.render(m=Recorder(modules()[case], (), set()))


def test_recorder_logs_attribute_and_key_reads() -> None:
    """Reads through attributes, keys and nested dicts are logged with their full path."""
    log: set[Path_] = set()
    module = modules()["double_pendulum"]
    text = (
        environment()
        .from_string("{{ m.name }} {{ m.call.kin_body.c }} {{ m.work['field']['g'] }}")
        .render(m=Recorder(module, (), log))
    )
    assert text == f"{module.name} {module.call['kin_body']['c']} {module.work['field']['g']}"
    assert {("name",), ("call", "kin_body", "c"), ("work", "field", "g")} <= log


# ------------------------------------------------------------------ (c) part by part
def _languages(module: Module, part: Part) -> tuple[str, ...]:
    """A part's languages: C alone where the part (or the one a variant stands for) is C only."""
    stands_for = {partial: name for name, partial in module.variants}
    only = stands_for.get(part.name, part.name) in module.c_only
    return ("c",) if only else ("c", "numpy")


@functools.cache
def part_reads() -> dict[tuple[str, str], set[Path_]]:
    """Per (case, part): every path its partials read, each rendered alone for the module."""
    env = environment()
    out: dict[tuple[str, str], set[Path_]] = {}
    for name, module in lowered().items():
        printed_ = modules()[name]
        for part in selected(module):
            log: set[Path_] = set()
            for lang in _languages(module, part):
                env.get_template(part.partial(lang)).render(m=Recorder(printed_, (), log))
            out[name, part.name] = log
    return out


def _sites_read(log: set[Path_]) -> set[str]:
    return {p[1] for p in log if p[0] == "call" and len(p) > 1}


def _buffers_read(log: set[Path_]) -> set[tuple[str, str]]:
    return {
        (p[1], p[2]) for p in log if p[0] == "work" and len(p) == 3 and p[2] not in LAYOUT_FACTS
    }


def test_every_part_is_selected_by_some_case() -> None:
    """The cases select every part of `s2gen.parts`, so that (c) checks each one."""
    chosen = {part for _, part in part_reads()}
    assert set(PARTS) == chosen, set(PARTS) - chosen


def test_each_part_reads_only_what_it_declares() -> None:
    """A part's partials read no call site and no workspace buffer its part did not declare."""
    stray: dict[str, list[str]] = {}
    for (name, part_name), log in part_reads().items():
        part = PARTS[part_name]
        sites = {s.name for s in part.sites_of(lowered()[name])}
        for site in sorted(_sites_read(log) - sites):
            stray.setdefault(part_name, []).append(f"{name}: call.{site}")
        for layout, buffer in sorted(_buffers_read(log) - set(part.reads)):
            stray.setdefault(part_name, []).append(f"{name}: work.{layout}.{buffer}")
    assert not stray, f"parts read what they do not declare: {stray}"


def test_each_part_reads_everything_it_declares() -> None:
    """Every call site and buffer a part declares, where the module has it, is read by that
    part's partials; every declared buffer is a buffer of some module's layout."""
    unread: dict[str, list[str]] = {}
    for (name, part_name), log in part_reads().items():
        part, printed_ = PARTS[part_name], modules()[name]
        sites = {s.name for s in part.sites_of(lowered()[name])} & set(printed_.call)
        for site in sorted(sites - _sites_read(log)):
            unread.setdefault(part_name, []).append(f"{name}: call.{site}")
        present = {(lay, b) for lay, entry in printed_.work.items() for b in entry}
        for layout, buffer in sorted((set(part.reads) & present) - _buffers_read(log)):
            unread.setdefault(part_name, []).append(f"{name}: work.{layout}.{buffer}")
    assert not unread, f"parts declare what their partials do not read: {unread}"
    every = {(lay, b) for m in modules().values() for lay, entry in m.work.items() for b in entry}
    unknown = {(p.name, r) for p in PARTS.values() for r in p.reads if r not in every}
    assert not unknown, f"declared buffers no layout has: {sorted(unknown)}"
