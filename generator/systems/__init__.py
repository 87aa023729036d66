"""The built-in systems: the paper's examples, by name.

Input: a name (``double_pendulum``) or a path to a TOML spec file.
Output: a validated `System`.

Built-ins come from two places, merged into one registry of loader callables: the TOML files
shipped in the ``s2gen.systems.examples`` package folder (one system per file, named by the file stem)
and Python factories listed in `_FACTORIES` (for systems whose size is a parameter).

Example:
    >>> "double_pendulum" in builtin_names()
    True
    >>> builtin("double_pendulum").n
    2
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from importlib.resources import files
from pathlib import Path

from s2gen.spec import load_spec, load_spec_text
from s2gen.system import SpecError, System
from s2gen.systems import paper

__all__ = ["builtin", "builtin_names", "resolve"]

_EXAMPLES = "s2gen.systems.examples"

#: Built-ins written in Python, name -> factory. A TOML example of the same name is an error.
_FACTORIES: dict[str, Callable[[], System]] = {
    "three_bodies": paper.three_bodies,
    "four_pendula": paper.four_pendula,
    "elastic_rod": paper.elastic_rod,
    "dipoles": paper.dipoles,
    "molecular": paper.molecular,
}


def _toml_stems() -> list[str]:
    """Stems of the TOML files shipped in the examples package folder."""
    folder = files(_EXAMPLES)
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def _toml_loader(stem: str) -> Callable[[], System]:
    """A loader for a shipped TOML example; its origin is package-relative (reproducible)."""

    def load() -> System:
        text = files(_EXAMPLES).joinpath(f"{stem}.toml").read_text(encoding="utf-8")
        return load_spec_text(text, origin=f"{_EXAMPLES}/{stem}.toml")

    return load


@functools.cache
def _registry() -> dict[str, Callable[[], System]]:
    """Every built-in name mapped to the callable that builds it."""
    registry = {stem: _toml_loader(stem) for stem in _toml_stems()}
    clash = sorted(set(registry) & set(_FACTORIES))
    if clash:
        raise RuntimeError(f"built-in systems defined twice (TOML and Python): {clash}")
    registry.update(_FACTORIES)
    return dict(sorted(registry.items()))


def builtin_names() -> list[str]:
    """The names of the built-in systems, sorted.

    Example:
        >>> "double_pendulum" in builtin_names()
        True
    """
    return list(_registry())


def builtin(name: str) -> System:
    """Build the built-in system `name` (raises SpecError listing the names if unknown).

    Example:
        >>> builtin("double_pendulum").parameter_names
        ('m1', 'm2', 'l1', 'l2', 'g')
    """
    loader = _registry().get(name)
    if loader is None:
        raise SpecError(f"unknown built-in system {name!r}; built-ins are: {_listing()}")
    return loader()


def resolve(spec: str) -> System:
    """A spec file path if one exists, else a built-in name (raises SpecError otherwise).

    Example:
        >>> resolve("double_pendulum").name
        'double_pendulum'
    """
    path = Path(spec)
    if path.is_file():
        return load_spec(path)
    if spec in _registry():
        return builtin(spec)
    if path.suffix == ".toml" or len(path.parts) > 1:
        raise SpecError(f"{spec}: no such spec file (built-ins are: {_listing()})")
    raise SpecError(
        f"{spec!r} is neither a spec file nor a built-in system; built-ins are: {_listing()}"
    )


def _listing() -> str:
    return ", ".join(builtin_names())
