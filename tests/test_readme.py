"""The README a new user reads, checked against the things it describes: the set-up commands
come first and the introduction before any table, the command table against the command line's
own parser, the dependency table against pyproject.toml, every path it names against the
checkout, the C compiler needed only by the C backend, the all-pairs data limit against the
spec loader, and one name for RK45 everywhere."""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text()


def _section(title: str) -> str:
    """The README's text from the heading `## title` to the next `## ` heading."""
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start : end if end >= 0 else len(README)]


def test_readme_starts_with_the_two_set_up_commands_then_says_what_s2gen_is() -> None:
    first = "# s2gen\n\n```bash\npip install -e . && s2gen reproduce --quick\n"
    assert README.startswith(first + 'pip install -e ".[test]" && python -m pytest -q\n```\n')
    intro = README.index("s2gen turns a mechanical system")
    first_table = README.index("\n|")
    first_heading = README.index("\n## ")
    assert intro < first_heading < first_table, "the introduction comes before any table"
    scope = README[intro:first_heading]
    for words in (
        "constant inertia matrix M",
        "Driven systems",
        "energy balance",
        "--backend numpy",
    ):
        assert words in scope, words


def _subcommands() -> dict[str, argparse.ArgumentParser]:
    from s2gen.cli import _parser

    for action in _parser()._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    raise AssertionError("the command line has no subcommands")


def test_command_table_names_every_subcommand_and_every_simulate_option() -> None:
    rows = [line for line in _section("Command line").splitlines() if line.startswith("| `")]
    firsts = [row.split(" | ")[0] for row in rows]
    for name in _subcommands():
        assert any(re.search(rf"`(s2gen )?{re.escape(name)}\b", f) for f in firsts), name
    simulate = next(row for row in rows if row.startswith("| `s2gen simulate"))
    for action in _subcommands()["simulate"]._actions:
        for option in action.option_strings:
            if option not in ("-h", "--help"):
                assert option in simulate, option


def test_dependency_table_explains_every_dependency_and_extra() -> None:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    section = _section("Dependencies")
    table = {
        name.strip()
        for row in section.splitlines()
        if row.startswith("| ") and not row.startswith("| package")
        for name in row.split(" | ")[0].strip("| ").split(",")
    }
    for requirement in project["dependencies"]:
        assert re.split(r"[<>=!~ \[]", requirement)[0] in table, requirement
    for extra in project["optional-dependencies"]:
        assert f'".[{extra}]"' in section, extra


def test_every_path_the_readme_names_is_in_the_checkout() -> None:
    assert "../" not in README, "a path outside the checkout"
    for target in re.findall(r"\]\(([^)#]+)\)", README):
        if not target.startswith("http"):
            assert (ROOT / target).exists(), target
    for script in re.findall(r"python (?:-m )?(\S+\.py)\b", README):
        assert (ROOT / script).exists(), script


def test_rk45_is_dormand_prince_5_4_everywhere() -> None:
    """One name, 5(4) (fifth order propagated, fourth order for the error), in the README,
    the docs, the emitted code's templates and every string of the package (results.md's
    column definitions among them)."""
    files = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")]
    for folder, pattern in (("generator", "*.py"), ("templates", "*.jinja")):
        files += (ROOT / folder).rglob(pattern)
    stale = [str(f.relative_to(ROOT)) for f in files if "4(5)" in f.read_text()]
    assert stale == []
    assert "Dormand-Prince 5(4)" in README


@pytest.mark.parametrize(("backend", "runs"), [("numpy", True), ("reference", True), ("c", False)])
def test_only_the_c_backend_needs_a_c_compiler(tmp_path: Path, backend: str, runs: bool) -> None:
    """With $CC naming no compiler and an empty build cache, simulate runs on the NumPy and
    reference backends and cannot on the C backend (the README's statement, both ways)."""
    env = dict(os.environ, CC=str(tmp_path / "no-such-gcc"), S2GEN_CACHE=str(tmp_path / "cache"))
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    out = tmp_path / "t.npz"
    cmd = [sys.executable, "-m", "s2gen", "simulate", "double_pendulum", "--backend", backend,
           "--T", "0.05", "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    assert (proc.returncode == 0) == runs, proc.stderr
    assert out.exists() == runs


def test_all_pairs_terms_take_per_body_not_per_member_data_as_the_readme_says() -> None:
    from s2gen.spec import SpecError, load_spec_text

    assert 'need an explicit list of pairs (or bodies), `"chain"` or `"ring"`' in README
    assert "top-level `[data]`" in README and "a pair term as\n`ci` and `cj`" in README
    spec = """
name = "charges"
bodies = 3
[inertia]
diagonal = [1, 1, 1]
[[potential.pair]]
V = "c*dot(qi, qj)"
pairs = "all"
[potential.pair.data]
c = [1, 2, 3]
[initial]
q = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
omega = [[0, 0, 1], [0, 0, 1], [1, 0, 0]]
"""
    with pytest.raises(SpecError, match="explicit list of pairs"):
        load_spec_text(spec)
    per_body = spec.replace('"c*dot(qi, qj)"', '"ci*cj*dot(qi, qj)"')
    per_body = per_body.replace("[potential.pair.data]", "[data]")
    per_body = per_body.replace("[[potential.pair]]", "[potential]\n[[potential.pair]]")
    per_body = per_body.replace("[data]\nc = [1, 2, 3]\n", "") + "[data]\nc = [1, 2, 3]\n"
    assert [d.name for d in load_spec_text(per_body).terms[0].body_data] == ["c"]
