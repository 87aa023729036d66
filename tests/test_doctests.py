"""The examples in the package's docstrings run as written (every module, its doctests), and
those of the benchmarks beside it.

A docstring example that no longer runs misleads the next reader more than none at all; the
suite runs them all, one test per module, with the expected output compared as doctest does.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

import s2gen

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


def _modules() -> list[str]:
    names = ["s2gen"]
    for info in pkgutil.walk_packages(s2gen.__path__, "s2gen."):
        if info.name.endswith("__main__"):
            continue  # running it would parse this process's arguments
        names.append(info.name)
    return sorted(names)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("name", _modules())
def test_docstring_examples_run(name: str, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)  # examples that write files write them here
    module = importlib.import_module(name)
    result = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False
    )
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("name", sorted(p.stem for p in BENCHMARKS.glob("*.py")))
def test_benchmark_examples_run(name: str, tmp_path, monkeypatch) -> None:
    """The benchmarks' examples (they run from a checkout, importing each other by name)."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    result = doctest.testmod(
        module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False
    )
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"
