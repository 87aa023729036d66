"""The public Python API, the method table, the import graph and the cache of emitted files."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from docs_text import code_blocks, list_table_rows, page, section

import s2gen
from s2gen import methods
from s2gen.build import cache_dir
from s2gen.emit import emit, emit_key
from s2gen.reference import METHODS as REFERENCE_METHODS
from s2gen.systems import builtin
from s2gen.version import __version__

TOML = """
name = "pendulum"
bodies = 1
[parameters]
m = 2.0
g = 9.81
[inertia]
diagonal = ["m"]
[potential]
V = "-m*g*q1[2]"
[initial]
q = [[1, 0, 0]]
omega = [[0, 0, 1]]
[run]
h = 0.01
T = 0.1
"""


def _python(code: str) -> str:
    env = {**os.environ}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env
    )
    return out.stdout


def test_notebook_example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The Python API block of docs/user_guide/python_api.rst (the README's "Python API" section
    before it moved), run as it stands, against independent checks: the VI
    keeps the double pendulum's energy and unit length, the model's energy function agrees
    with the samples, the spring's RATTLE run keeps its energy and (the potential being
    invariant under rotations) its angular momentum, and the files written are the files returned."""
    code = code_blocks(section(page("user_guide/python_api.rst"), "Python API"), "python")[0]
    monkeypatch.chdir(tmp_path)
    ns: dict[str, object] = {}
    exec(compile(code, "python_api.rst", "exec"), ns)  # noqa: S102 (the page's own example)
    tr, model, run = ns["tr"], ns["model"], ns["run"]
    assert isinstance(tr, s2gen.Trajectory) and isinstance(run, s2gen.Trajectory)
    assert isinstance(model, s2gen.Model)
    assert tr.q.shape == (1001, 2, 3)
    assert np.max(np.abs(np.linalg.norm(tr.q, axis=2) - 1.0)) < 1e-13
    assert ns["drift"] == np.max(np.abs(tr.energy - tr.energy[0]))
    assert 0.0 < float(ns["drift"]) < 1e-2 * np.max(np.abs(tr.energy))  # type: ignore[arg-type]
    e = model.energy(tr.q[-1], tr.omega[-1], params={"g": 9.81})
    assert e == pytest.approx(tr.energy[-1], rel=1e-13)
    assert np.max(np.abs(run.energy - run.energy[0])) < 1e-3 * abs(run.energy[0])
    J = run.angular_momentum(ns["spring"])  # type: ignore[attr-defined]
    assert np.max(np.abs(J - J[0])) < 1e-12 * np.max(np.abs(J[0]))
    files = ns["files"]
    assert sorted(p.name for p in (tmp_path / "spring_c").iterdir()) == sorted(files)  # type: ignore[arg-type]


def test_load_accepts_text_path_and_name(tmp_path: Path) -> None:
    spec = tmp_path / "p.toml"
    spec.write_text(TOML)
    assert s2gen.load(TOML).name == "pendulum"
    assert s2gen.load(spec).name == "pendulum"
    assert s2gen.load(str(spec)).n == 1
    with pytest.raises(s2gen.SpecError, match="built-ins are"):
        s2gen.load("no_such_system")


def test_parameters_by_name_change_the_physics() -> None:
    """g by name: a pendulum released from the horizontal falls faster under larger g
    (V = -m g q_z puts gravity along +e3; at small t, q_z ~ g t^2 / 2 for unit length)."""
    model = s2gen.compile(s2gen.load(TOML), "numpy")
    q0, w0 = np.array([[1.0, 0, 0]]), np.zeros((1, 3))
    h = 1e-4
    for g in (1.0, 4.0):
        q, _ = model.step(q0, w0, h, "rk4", params={"g": g})
        assert q[0, 2] == pytest.approx(g * h * h / 2, rel=1e-6)
    with pytest.raises(ValueError, match="unknown parameter 'k'.*m, g"):
        model.params({"k": 1.0})


def test_model_agrees_across_backends() -> None:
    system = builtin("double_pendulum")
    grads = [s2gen.compile(system, b).gradient(system.q0) for b in methods.BACKENDS]
    for g in grads[1:]:
        np.testing.assert_allclose(g, grads[0], rtol=1e-14, atol=1e-14)
    moms = [
        s2gen.compile(system, b).angular_momentum(system.q0, system.omega0)
        for b in ("c", "numpy", "reference")
    ]
    for j in moms[1:]:
        np.testing.assert_allclose(j, moms[0], rtol=1e-13, atol=1e-14)


def test_method_table_backends_match_the_reference() -> None:
    """The table says which backends have a method; the reference implements exactly those."""
    listed = {m.name for m in methods.METHODS if "reference" in m.backends}
    assert listed == set(REFERENCE_METHODS)
    assert [m.code for m in methods.METHODS] == list(range(len(methods.METHODS)))


def test_a_method_a_backend_lacks_is_refused_before_running() -> None:
    with pytest.raises(
        ValueError, match="not available on the reference backend; backends that have it: c, numpy"
    ):
        s2gen.simulate(builtin("double_pendulum"), "vi4", "reference", h=0.01, T=0.01)


def test_cli_imports_no_experiment_scipy_or_matplotlib() -> None:
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import s2gen.cli"],
        capture_output=True,
        text=True,
        check=True,
    ).stderr
    loaded = {line.rsplit("|", 1)[-1].strip() for line in out.splitlines() if "|" in line}
    heavy = sorted(
        m
        for m in loaded
        if m.startswith(
            ("s2gen.experiments", "scipy", "matplotlib", "sympy", "dask", "distributed", "zarr")
        )
    )
    assert heavy == []


def test_version_flag() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "s2gen", "--version"], capture_output=True, text=True, check=False
    )
    assert out.returncode == 0 and out.stdout.strip() == f"s2gen {__version__}"
    assert s2gen.__version__ == __version__  # the package attribute, as users look for it
    from importlib.metadata import version

    assert __version__ == version("s2gen")  # the version pyproject.toml declares


def test_emitted_files_are_read_back_without_sympy_work() -> None:
    """A second process emitting an unchanged system derives nothing (the lowering passes are
    never imported), and gets the same bytes."""
    system = builtin("double_pendulum")
    first = emit(system, "c")
    code = (
        "import sys, json, s2gen; s = s2gen.load('double_pendulum'); "
        "f = s2gen.generate(s, 'c'); "
        "print(json.dumps({'passes': 's2gen.passes' in sys.modules, 'files': f}))"
    )
    result = json.loads(_python(code))
    assert result["passes"] is False
    assert result["files"] == first


def test_a_damaged_cache_entry_is_derived_again() -> None:
    system = builtin("double_pendulum")
    good = emit(system, "c")
    folder = cache_dir() / "emitted" / emit_key(system, "c")
    victim = folder / "double_pendulum.c"
    victim.write_text(victim.read_text()[:100])
    assert emit(system, "c") == good
    assert victim.read_text() == good["double_pendulum.c"]


def test_native_flags_give_the_same_motion() -> None:
    """compile(..., opt="native") builds with -O3 -march=native: the same trajectory as the
    portable library to round-off (no fused multiply-adds under -std=c99); opt is refused off
    the C backend."""
    system = s2gen.load("double_pendulum")
    portable = s2gen.compile(system).integrate("vi", h=0.01, T=1.0)
    native = s2gen.compile(system, opt="native").integrate("vi", h=0.01, T=1.0)
    assert np.max(np.abs(native.q - portable.q)) < 1e-12
    with pytest.raises(ValueError, match="C backend"):
        s2gen.compile(system, "numpy", opt="native")


def test_docs_method_table_is_the_methods_table() -> None:
    """docs/user_guide/methods.rst shows the method table through the ``s2gen-methods``
    directive; the table it writes has the cells of `s2gen.methods.markdown_table()`, row by
    row (two renderings of `s2gen.METHODS` that must agree)."""
    import importlib.util

    from s2gen.methods import markdown_table

    assert ".. s2gen-methods::" in page("user_guide/methods.rst")
    where = Path(__file__).parent.parent / "docs" / "_ext" / "s2gen_tables.py"
    spec = importlib.util.spec_from_file_location("s2gen_tables", where)
    assert spec is not None and spec.loader is not None
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    shown = [[cell.replace("``", "`").replace("\\|", "|") for cell in row]
             for row in list_table_rows(tables.methods_rst())]  # fmt: skip
    markdown = [
        [cell.strip().replace("\\|", "|") for cell in re.split(r"(?<!\\)\|", line)[1:-1]]
        for line in markdown_table().splitlines()
        if not line.startswith("|---")
    ]
    assert len(shown) == len(markdown) == len(methods.METHODS) + 1
    assert shown == markdown
