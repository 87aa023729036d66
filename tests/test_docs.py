"""The documentation covers the public API: every name of `s2gen.__all__` is documented and
appears in the API reference, and the C API page lists every function, enum constant and
struct field of a header the generator actually emits (no Sphinx build needed)."""

from __future__ import annotations

import importlib.util
import inspect
import re
from pathlib import Path
from types import ModuleType

import pytest

import s2gen
from s2gen.interface import interface
from s2gen.ir import ModuleKind

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
API = DOCS / "api.rst"
DIRECTIVE = re.compile(
    r"^\.\. auto(function|class|exception|data|module):: +(?:s2gen\.)?(\S+)", re.MULTILINE
)


def _extension(name: str) -> ModuleType:
    """A module of docs/_ext, loaded from its file (it is not part of the package)."""
    spec = importlib.util.spec_from_file_location(name, DOCS / "_ext" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _documented() -> dict[str, str]:
    """{name: the text of its autodoc directive's block} for each directive of api.rst."""
    text = API.read_text(encoding="utf-8")
    blocks = {}
    for match in DIRECTIVE.finditer(text):
        rest = text[match.end() :]
        end = re.search(r"^\S", rest, re.MULTILINE)
        blocks[match.group(2)] = rest[: end.start() if end else len(rest)]
    return blocks


@pytest.mark.parametrize("name", s2gen.__all__)
def test_public_name_is_in_the_api_reference(name: str) -> None:
    assert name in _documented(), f"docs/api.rst has no autodoc directive for s2gen.{name}"


@pytest.mark.parametrize("name", s2gen.__all__)
def test_public_name_has_a_docstring(name: str) -> None:
    obj = getattr(s2gen, name)
    if inspect.isclass(obj):
        # a dataclass without a docstring gets its signature as __doc__: not documentation
        own = vars(obj).get("__doc__") or ""
        assert own.strip() and not own.startswith(f"{obj.__name__}("), name
    elif callable(obj) or inspect.ismodule(obj):
        assert (obj.__doc__ or "").strip(), name
    else:
        # data (a tuple, a string) has no docstring of its own: the reference must say what
        # it is in the directive's body
        body = _documented()[name]
        prose = [line for line in body.splitlines() if line.strip() and ":" not in line[:8]]
        assert prose, f"docs/api.rst says nothing about s2gen.{name}"


_AUTOMODULE = re.compile(r"^\.\. automodule:: +(\S+)\n((?:   .*\n|\n)*)", re.MULTILINE)


def _public_modules() -> dict[str, tuple[str, ...] | None]:
    """{module: the members its automodule directive names} for each module api.rst documents
    (None: a bare ``:members:``, which documents what autodoc finds defined in the module; ():
    no ``:members:``, each name then needs a directive of its own)."""
    text = API.read_text(encoding="utf-8")
    found: dict[str, tuple[str, ...] | None] = {}
    for match in _AUTOMODULE.finditer(text):
        options = re.search(r":members:(.*(?:\n {13}.*)*)", match.group(2))
        if options is None:
            continue
        names = tuple(
            n.strip() for n in options.group(1).replace("\n", " ").split(",") if n.strip()
        )
        found[match.group(1)] = names or None
    for module in re.findall(r"^\.\. automodule:: +(\S+)\n(?!   :members:)", text, re.MULTILINE):
        found.setdefault(module, ())
    return found


def _module(dotted: str) -> ModuleType:
    """A public module by its documented name (``s2gen.paper`` is an attribute of s2gen)."""
    found: object = s2gen
    for part in dotted.split(".")[1:]:
        found = getattr(found, part)
    assert inspect.ismodule(found), dotted
    return found


def _module_names() -> list[tuple[str, str]]:
    return [(m, n) for m in _public_modules() for n in _module(m).__all__]


def test_api_reference_documents_the_public_modules() -> None:
    assert set(_public_modules()) == {"s2gen.ensemble", "s2gen.metrics", "s2gen.paper"}


@pytest.mark.parametrize(("module", "name"), _module_names())
def test_public_module_name_is_documented_in_the_reference(module: str, name: str) -> None:
    """Every name in the `__all__` of a public module that api.rst documents (`s2gen.ensemble`,
    `s2gen.metrics`, `s2gen.paper`) appears in the reference with its documentation: a
    function or class has its own docstring and is a member autodoc renders (named in the
    directive's ``:members:`` list, or defined in the module itself under a bare
    ``:members:``, since autodoc skips imported ones); a constant or type alias has an
    ``autodata`` directive whose body says what it is."""
    obj = getattr(_module(module), name)
    real = _module(module).__name__
    if inspect.isclass(obj) or inspect.isfunction(obj):
        own = vars(obj).get("__doc__") if inspect.isclass(obj) else obj.__doc__
        assert (own or "").strip() and not own.startswith(f"{name}("), f"{module}.{name}"
        # automodule's :members: renders only what dir() of the module shows (a lazily
        # imported name needs a directive of its own), and a bare :members: only what the
        # module defines itself
        members = _public_modules()[module]
        seen = name in dir(_module(module))
        listed = seen and (name in members if members is not None else obj.__module__ == real)
        own = f"{module.removeprefix('s2gen.')}.{name}" in _documented()
        assert listed or own, f"docs/api.rst does not render {module}.{name}"
    else:
        body = _documented().get(f"{module.removeprefix('s2gen.')}.{name}")
        assert body is not None, f"docs/api.rst has no autodata directive for {module}.{name}"
        prose = [line for line in body.splitlines() if line.strip() and ":" not in line[:8]]
        assert prose, f"docs/api.rst says nothing about {module}.{name}"


def test_every_header_function_is_in_the_c_api_page() -> None:
    page = _extension("s2gen_capi").c_api_rst(ModuleKind.SPHERE)
    for f in interface(ModuleKind.SPHERE).functions:
        assert re.search(rf"^\.\. c:function:: .*\bNAME_{f.name}\(", page, re.MULTILINE), f.name


def test_the_c_api_page_matches_an_emitted_header() -> None:
    """Every function, enum constant and struct field of the double pendulum's emitted header,
    read from the header text itself, is on the page (with NAME for the system's name)."""
    page = _extension("s2gen_capi").c_api_rst(ModuleKind.SPHERE)
    header = s2gen.generate(s2gen.load("double_pendulum"), "c")["double_pendulum.h"]
    functions = re.findall(r"^\w[\w ]*?\bdouble_pendulum_(\w+)\(", header, re.MULTILINE)
    constants = re.findall(r"(?:^    |[{,] )DOUBLE_PENDULUM_(\w+) = \d+", header, re.MULTILINE)
    fields = re.findall(r"^    (?:const )?\w+ \**(\w+)(?:\[\d+\])?; /\*", header, re.MULTILINE)
    assert len(functions) == len(interface(ModuleKind.SPHERE).functions)
    assert "OK" in constants and "METHOD_DOP853" in constants and "CONTROL_HAIRER" in constants
    assert "newton_tol" in fields and "fail_body" in fields
    for name in functions:
        assert f"NAME_{name}(" in page, name
    for name in constants:
        assert f"``NAME_{name}``" in page, name
    for name in fields:
        assert re.search(rf"c:member:: [\w ]+\**\b{name}\b", page), name
    # and nothing the header lacks: the page's functions are exactly the header's
    assert sorted(re.findall(r"c:function:: [\w ]*?\bNAME_(\w+)\(", page)) == sorted(functions)


def test_the_angle_module_page_matches_its_records() -> None:
    page = _extension("s2gen_capi").c_api_rst(ModuleKind.ANGLES)
    names = re.findall(r"c:function:: [\w ]*?\bNAME_angles_(\w+)\(", page)
    assert names == [f.name for f in interface(ModuleKind.ANGLES).functions]
    assert "``NAME_ANGLES_ERR_POLE``" in page and "``NAME_ANGLES_ERR_NEWTON``" not in page


def test_every_spec_key_is_described() -> None:
    """The spec page's key table is written from the reader's own key tables; a key the
    reader accepts without a description would fail the build (KeyError here)."""
    from s2gen import spec
    from s2gen.terms import TermKind

    page = _extension("s2gen_tables").spec_keys_rst()
    keys = set(spec._TOP_KEYS) | {k for keys in spec._TABLE_KEYS.values() for k in keys or ()}
    keys |= {kind.select_key for kind in TermKind} | {"cutoff"}
    for key in keys:
        assert f"* - ``{key}``" in page, key


@pytest.mark.parametrize("name", ["s2gen_capi", "s2gen_docstrings", "s2gen_tables"])
def test_extension_examples_run(name: str) -> None:
    """The docstring examples of the site's own extensions (those that need no Sphinx)."""
    import doctest

    result = doctest.testmod(_extension(name))
    assert result.attempted > 0 and result.failed == 0, result


def test_every_file_the_developer_guide_names_exists() -> None:
    """The guide's walk-throughs (adding a method, a term kind, a language; parts) name the
    files a change touches: each must be a file of the checkout (under generator/, the
    checkout's root, or a subpackage's own folder), so the guide cannot point at a file that
    moved."""
    text = (DOCS / "developer.rst").read_text(encoding="utf-8")
    names = set(re.findall(r"``([\w/{},.]+\.(?:py|jinja))``", text)) - {".py"}
    assert len(names) > 20
    package = ROOT / "generator"
    missing = []
    for name in sorted(names):
        variants = [name]
        if "{c,numpy}" in name:
            variants = [name.replace("{c,numpy}", lang) for lang in ("c", "numpy")]
        for variant in variants:
            places = [ROOT / variant, package / variant, *package.glob(f"*/{variant}")]
            if not any(p.is_file() for p in places):
                missing.append(variant)
    assert not missing, f"docs/developer.rst names files that do not exist: {missing}"
