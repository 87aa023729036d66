"""The package's import rules, read from its source with `ast` (nothing is imported to check
them, so an import hidden in a function counts as much as one at the top of a module):

- the core (every module but `s2gen.experiments` and the command line, `s2gen.cli`) never
  imports an experiment;
- an experiment imports from s2gen only the public API (`s2gen`, the names of its
  `__all__`, and `s2gen.ensemble`, the names of its `__all__`), the inspection module
  `s2gen.inspect`, and other experiments;
- the modules' top-level imports form no cycle; nor do any of the imports among the ensemble's
  and the experiments' modules, those inside functions included;
- every import of an s2gen module names a module of the package (a moved module leaves no
  import behind that would fail only when its function runs).

Each rule is also run on a small made-up package that breaks it, so that a rule which could
never fail would be noticed.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

import s2gen
import s2gen.ensemble

ROOT = Path(s2gen.__file__).resolve().parent
PUBLIC = {"s2gen": set(s2gen.__all__), "s2gen.ensemble": set(s2gen.ensemble.__all__)}
INSPECTION = "s2gen.inspect"
EXPERIMENTS = "s2gen.experiments"


@dataclass(frozen=True)
class Import:
    """One import by `module`: the module it loads (`target`; for ``from package import
    submodule``, the submodule), what it was written as (``from origin import name``, or
    ``import origin`` with no name), where, and whether it runs when the module loads."""

    module: str
    target: str
    origin: str
    name: str
    line: int
    top_level: bool


def module_name(root: Path, path: Path) -> str:
    """s2gen.a.b for root/a/b.py and root/a/b/__init__.py."""
    parts = ["s2gen", *path.relative_to(root).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def sources(root: Path) -> dict[str, Path]:
    return {module_name(root, p): p for p in sorted(root.rglob("*.py"))}


def _type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _walk(node: ast.AST, top: bool) -> Iterator[tuple[ast.AST, bool]]:
    """Every import node under `node`, and whether it runs at import time (not in a function,
    not under `if TYPE_CHECKING:`)."""
    for child in ast.iter_child_nodes(node):
        if isinstance(child, ast.Import | ast.ImportFrom):
            yield child, top
        inner = top and not isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
        if isinstance(child, ast.If) and _type_checking(child):
            for part in child.body:
                yield from _walk_one(part, False)
            for part in child.orelse:
                yield from _walk_one(part, inner)
            continue
        yield from _walk(child, inner)


def _walk_one(node: ast.AST, top: bool) -> Iterator[tuple[ast.AST, bool]]:
    if isinstance(node, ast.Import | ast.ImportFrom):
        yield node, top
    yield from _walk(node, top and not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef))


def imports(root: Path) -> list[Import]:
    """Every import of an s2gen module in the package under `root`; relative imports resolved,
    and `from package import submodule` recorded as an import of the submodule."""
    known = sources(root)
    found = []
    for name, path in known.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        for node, top in _walk(tree, True):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    found.append(Import(name, alias.name, alias.name, "", node.lineno, top))
                continue
            assert isinstance(node, ast.ImportFrom)
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                parts = parts[: len(parts) - node.level + 1]
                base = ".".join(parts + ([node.module] if node.module else []))
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                target = sub if sub in known else base
                found.append(Import(name, target, base, alias.name, node.lineno, top))
    return [i for i in found if i.target == "s2gen" or i.target.startswith("s2gen.")]


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def core_imports_of_experiments(found: Iterable[Import]) -> list[str]:
    return [
        f"{i.module}:{i.line} imports {i.target}"
        for i in found
        if not _inside(i.module, EXPERIMENTS)
        and i.module != "s2gen.cli"
        and _inside(i.target, EXPERIMENTS)
    ]


def private_imports_of_experiments(found: Iterable[Import]) -> list[str]:
    bad = []
    for i in found:
        if not _inside(i.module, EXPERIMENTS) or _inside(i.target, EXPERIMENTS):
            continue
        if i.target == INSPECTION:
            continue
        if i.origin in PUBLIC and (not i.name or i.name in PUBLIC[i.origin]):
            continue
        what = f"{i.name} from {i.origin}" if i.name else i.origin
        bad.append(f"{i.module}:{i.line} imports {what}")
    return bad


def missing_modules(found: Iterable[Import], known: Iterable[str]) -> list[str]:
    names = set(known)
    return [f"{i.module}:{i.line} imports {i.target}" for i in found if i.target not in names]


def cycles(
    found: Iterable[Import], within: str = "s2gen", top_only: bool = True
) -> list[list[str]]:
    """The import cycles (strongly connected components of two or more modules, or a module
    importing itself) among modules inside `within`."""
    graph: dict[str, set[str]] = {}
    for i in found:
        if (
            (i.top_level or not top_only)
            and _inside(i.module, within)
            and _inside(i.target, within)
        ):
            graph.setdefault(i.module, set()).add(i.target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


FOUND = imports(ROOT)


def test_the_scan_sees_the_package() -> None:
    """The scan finds known imports of each kind (else the rules below would pass vacuously)."""
    assert len(sources(ROOT)) > 100
    pairs = {(i.module, i.target, i.top_level) for i in FOUND}
    assert ("s2gen.cli", "s2gen.methods", True) in pairs
    assert ("s2gen.ensemble.summary", "s2gen.ensemble.store", True) in pairs  # relative
    assert ("s2gen.cli", "s2gen.experiments.bench.command", False) in pairs  # in a function


def test_the_core_never_imports_an_experiment() -> None:
    assert core_imports_of_experiments(FOUND) == []


def test_experiments_use_only_the_public_api_and_the_inspection_module() -> None:
    assert private_imports_of_experiments(FOUND) == []


def test_every_import_names_a_module_of_the_package() -> None:
    assert missing_modules(FOUND, sources(ROOT)) == []


def test_no_import_cycle_at_module_level() -> None:
    assert cycles(FOUND) == []


@pytest.mark.parametrize("package", ["s2gen.ensemble", EXPERIMENTS])
def test_no_import_cycle_in_ensembles_and_experiments_even_inside_functions(package: str) -> None:
    assert cycles(FOUND, within=package, top_only=False) == []


# ------------------------------------------------------------- the rules catch what they should
def _package(tmp_path: Path, files: dict[str, str]) -> list[Import]:
    for name, text in files.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return imports(tmp_path)


def test_the_rules_flag_a_package_that_breaks_them(tmp_path: Path) -> None:
    found = _package(
        tmp_path,
        {
            "__init__.py": "",
            "a.py": "from s2gen import b\n",
            "b.py": "import s2gen.a\n\ndef f():\n    from s2gen.experiments import x\n",
            "experiments/__init__.py": "",
            "experiments/x.py": (
                "from s2gen import load, not_public\nfrom s2gen.inspect import lowered\n"
                "from s2gen.passes import lower_system\nfrom . import y\n"
            ),
            "experiments/y.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from . import x\n\ndef g():\n    from .x import h\n",
        },
    )
    assert core_imports_of_experiments(found) == ["s2gen.b:4 imports s2gen.experiments.x"]
    assert private_imports_of_experiments(found) == [
        "s2gen.experiments.x:1 imports not_public from s2gen",
        "s2gen.experiments.x:3 imports lower_system from s2gen.passes",
    ]
    assert missing_modules(found, sources(tmp_path)) == [
        "s2gen.experiments.x:2 imports s2gen.inspect",
        "s2gen.experiments.x:3 imports s2gen.passes",
    ]
    assert cycles(found) == [["s2gen.a", "s2gen.b"]]  # y -> x is not at module level
    assert cycles(found, within=EXPERIMENTS, top_only=False) == [
        ["s2gen.experiments.x", "s2gen.experiments.y"]
    ]


def test_the_package_ships_no_c_source() -> None:
    """Hand-written C programs live in benchmarks/, beside the package, not in it."""
    assert sorted(p.relative_to(ROOT) for p in ROOT.rglob("*.c")) == []
