"""The README a new user reads, and the documentation pages its former sections moved to,
checked against the things they describe: the set-up commands come first and the introduction
before any table, the first example runs and prints what the README shows, the times table
names the commands `s2gen.experiments.timings` measures, the dependency table against
pyproject.toml, every documentation page linked from the README, the command table
(docs/user_guide/cli.rst) against the command line's own parser, every path the README and the
pages name against the checkout, the C compiler needed only by the C backend, the all-pairs data
limit (docs/user_guide/terms.rst) against the spec loader, and one name for RK45 everywhere."""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from docs_text import DOCS, list_table_rows, page, section

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
    """docs/user_guide/cli.rst's command table: a row for every subcommand of the parser, and
    the simulate row names every simulate option."""
    rows = list_table_rows(section(page("user_guide/cli.rst"), "Command line"))
    firsts = [row[0] for row in rows if row[0].startswith("``")]
    assert len(firsts) >= 7, firsts
    for name in _subcommands():
        assert any(re.search(rf"``(s2gen )?{re.escape(name)}\b", f) for f in firsts), name
    simulate = next(f for f in firsts if f.startswith("``s2gen simulate"))
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


#: The checkout's own folders: a literal path under one of them names a file or folder of it.
_CHECKOUT_FOLDERS = ("generator", "tests", "benchmarks", "examples", "docs", "templates")


def _pages() -> list[Path]:
    """The documentation's own pages (not those the gallery writes during a build)."""
    skip = {"auto_examples", "_build", "_generated", "sg_execution_times.rst"}
    return [p for p in sorted(DOCS.rglob("*.rst")) if not skip & set(p.relative_to(DOCS).parts)]


def test_every_path_the_documentation_names_is_in_the_checkout() -> None:
    """The pages that hold the README's former sections name files of the checkout
    (``examples/embed/``, ``benchmarks/unseen.py``, ``tests/test_chains.py``, ...) and scripts
    (``python benchmarks/python_step.py``): each must exist, so a page cannot point at a file
    that moved. Patterns (``templates/{c,numpy}/...``, ``<name>``, ``*``) are not paths."""
    missing = []
    checked = 0
    for path in _pages():
        text = path.read_text(encoding="utf-8")
        for literal in re.findall(r"``([^`\s]+)``", text):
            literal = literal.rstrip(".,;:")
            if "/" not in literal or literal.split("/")[0] not in _CHECKOUT_FOLDERS:
                continue
            if re.search(r"[{}<>*]|NAME", literal):
                continue
            checked += 1
            if not (ROOT / literal).exists():
                missing.append(f"{path.relative_to(ROOT)}: {literal}")
        for script in re.findall(r"python (?:-m )?(\S+\.py)\b", text):
            checked += 1
            if not (ROOT / script).exists():
                missing.append(f"{path.relative_to(ROOT)}: python {script}")
    assert checked > 30, checked
    assert not missing, missing


def test_readme_links_every_documentation_page() -> None:
    """The front page's documentation table links each page of the site by its path, so a
    reader finds every former README section from it, and says how the site is built."""
    linked = set(re.findall(r"\]\((docs/[^)#]+\.rst)\)", _section("Documentation")))
    pages = {str(p.relative_to(ROOT)) for p in _pages()}
    unlinked = pages - linked - {"docs/index.rst", "docs/user_guide/index.rst"}
    assert not unlinked, unlinked
    assert "python -m sphinx -W --keep-going -b html docs docs/_build/html" in README


def test_rk45_is_dormand_prince_5_4_everywhere() -> None:
    """One name, 5(4) (fifth order propagated, fourth order for the error), in the README,
    the docs, the emitted code's templates and every string of the package (results.md's
    column definitions among them)."""
    files = [ROOT / "README.md", *DOCS.rglob("*.md"), *_pages()]
    for folder, pattern in (("generator", "*.py"), ("templates", "*.jinja")):
        files += (ROOT / folder).rglob(pattern)
    stale = [str(f.relative_to(ROOT)) for f in files if "4(5)" in f.read_text()]
    assert stale == []
    from s2gen.methods import markdown_table

    methods = " ".join(page("user_guide/methods.rst").split())
    assert "RK45 is Dormand–Prince 5(4)" in methods and ".. s2gen-methods::" in methods
    assert "Dormand-Prince 5(4)" in markdown_table()


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


def test_all_pairs_terms_take_per_body_not_per_member_data_as_the_docs_say() -> None:
    from s2gen.spec import SpecError, load_spec_text

    terms = " ".join(page("user_guide/terms.rst").split())
    assert 'need an explicit list of pairs (or bodies), ``"chain"`` or ``"ring"``' in terms
    assert "top-level ``[data]``" in terms and "a pair term as ``ci`` and ``cj``" in terms
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


def test_readme_first_example_runs_and_prints_what_the_readme_shows(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The front page's example, run as it stands: it prints the lines the README shows
    (numbers to their printed digits), its C run follows the independent reference integrator
    to 1e-10 with unit length kept to 1e-12, and its energy error is the VI's second-order one
    (a quarter of it at half the step)."""
    text = _section("A first system")
    code = text.split("```python\n", 1)[1].split("```", 1)[0]
    shown = text.split("```text\n", 1)[1].split("```", 1)[0].splitlines()
    monkeypatch.chdir(tmp_path)
    ns: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), ns)  # noqa: S102 (the README's own example)
    printed = capsys.readouterr().out.splitlines()
    assert len(printed) == len(shown) == 3
    for got, want in zip(printed, shown, strict=True):
        assert got.split("=")[0] == want.split("=")[0]
    numbers = [[float(x) for x in re.findall(r"-?\d+\.?\d*(?:e[-+]\d+)?", line.split("=")[1])]
               for line in (*printed, *shown)]  # fmt: skip
    q_got, e_got, d_got, q_shown, e_shown, d_shown = numbers
    assert np.allclose(q_got, q_shown, rtol=0, atol=2e-6)
    assert e_got[0] == pytest.approx(e_shown[0], rel=2e-3)
    assert d_got[0] < 1e-10 and d_shown[0] < 1e-10

    import s2gen

    tr, ref, pendula = ns["tr"], ns["ref"], ns["pendula"]
    assert isinstance(tr, s2gen.Trajectory) and isinstance(ref, s2gen.Trajectory)
    assert np.abs(tr.q - ref.q).max() < 1e-10
    assert np.abs(np.linalg.norm(tr.q, axis=2) - 1).max() < 1e-12
    half = s2gen.simulate(pendula, "vi", h=0.005, T=10.0)  # type: ignore[arg-type]
    ratio = np.abs(tr.energy - tr.energy[0]).max() / np.abs(half.energy - half.energy[0]).max()
    assert 3.0 < ratio < 5.0, ratio


def test_times_table_lists_what_the_timings_command_measures() -> None:
    """The "Times" table is what `python -m s2gen.experiments.timings` prints, pasted: the
    writer's columns and a row for each command it measures, in its order."""
    from s2gen.experiments.timings import COMMANDS, table

    rows = [line for line in _section("Times").splitlines() if line.startswith("| ")]
    written = table([], "a machine").splitlines()[0].strip("| ").split(" | ")
    assert rows[0].strip("| ").split(" | ") == written[: len(rows[0].strip("| ").split(" | "))]
    labels = [row.split(" | ")[0].removeprefix("| ") for row in rows[1:]]
    assert [label.split("` (`")[0].strip("`") for label in labels] == [c.label for c in COMMANDS]
    assert "python -m s2gen.experiments.timings" in _section("Times")
