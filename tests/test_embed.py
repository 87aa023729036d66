"""examples/embed: the C program built from the emitted files with make and with CMake (alone
and as the C guide's parent project's subdirectory, from a C-only and a C++-only project) prints the same final state as `s2gen simulate`'s
saved trajectory, to 1e-12, through the header's public API only."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from docs_text import code_blocks, page

from s2gen.systems import builtin

EMBED = Path(__file__).resolve().parent.parent / "examples" / "embed"
S2GEN = [sys.executable, "-m", "s2gen"]
RUNS = (("vi", 0.01, 300), ("rk45", 0.01, 300))


def _env() -> dict[str, str]:
    """This process's s2gen (PYTHONPATH) and build cache for every command the builds run."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    return env


def _sh(cmd: list[str], cwd: Path) -> str:
    proc = subprocess.run(cmd, cwd=cwd, env=_env(), capture_output=True, text=True, check=False)
    assert proc.returncode == 0, f"{' '.join(cmd)}\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def _final_state(
    program: Path, cwd: Path, method: str, h: float, n: int, initial: str = "double_pendulum.init"
) -> dict[str, np.ndarray]:
    out = _sh([str(program), initial, method, repr(h), str(n)], cwd)
    rows = {}
    for line in out.splitlines():
        key, *values = line.split()
        if key in ("t", "q", "omega", "energy"):
            rows[key] = np.array([float(v) for v in values])
    assert re.search(r"^steps \d+", out, re.MULTILINE), out
    return rows


def _simulated(tmp: Path, method: str, h: float, n: int) -> dict[str, np.ndarray]:
    out = tmp / f"sim_{method}.npz"
    _sh([*S2GEN, "simulate", "double_pendulum", "--method", method, "--h", repr(h),
         "--T", repr(h * n), "--out", str(out)], tmp)  # fmt: skip
    data = np.load(out)
    return {k: data[k][-1].ravel() for k in ("t", "q", "omega", "energy")}


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    dest = tmp_path_factory.mktemp("embed") / "embed"
    shutil.copytree(EMBED, dest, ignore=shutil.ignore_patterns("build", "build-*"))
    return dest


@pytest.fixture(scope="module")
def expected(folder: Path) -> dict[str, dict[str, np.ndarray]]:
    return {m: _simulated(folder.parent, m, h, n) for m, h, n in RUNS}


def _check(program: Path, cwd: Path, expected: dict[str, dict[str, np.ndarray]]) -> None:
    for method, h, n in RUNS:
        got = _final_state(program, cwd, method, h, n)
        from_spec = _final_state(program, cwd, method, h, n, "spec")  # NAME_initial_state
        for key in got:
            assert np.array_equal(got[key], from_spec[key]), key
        want = expected[method]
        assert got["t"][0] == pytest.approx(h * n, rel=1e-14)
        for key in ("q", "omega", "energy"):
            np.testing.assert_allclose(got[key], want[key], rtol=0, atol=1e-12, err_msg=key)


def test_shipped_initial_state_is_the_specs() -> None:
    """The program reads the state from double_pendulum.init: the spec's doubles exactly."""
    values = [float(v) for v in (EMBED / "double_pendulum.init").read_text().split()]
    s = builtin("double_pendulum")
    assert values == [*s.q0.ravel().tolist(), *s.omega0.ravel().tolist()]


def test_program_uses_the_public_header_api_only() -> None:
    """Every system name the program uses is declared in the emitted header's comment-free
    text (no internal helper is reached)."""
    from s2gen import generate

    header = generate(builtin("double_pendulum"), "c")["double_pendulum.h"]
    code = (EMBED / "main.c").read_text()
    used = set(re.findall(r"SYS(?:_MACRO)?\((_\w+)\)", code))
    assert used, "the program names no system symbol"
    for suffix in used:
        name = ("DOUBLE_PENDULUM" if suffix.isupper() else "double_pendulum") + suffix
        assert re.search(rf"\b{name}\b", header), name


@pytest.mark.skipif(shutil.which("make") is None, reason="make not installed")
def test_make_build_matches_simulate(folder: Path, expected) -> None:
    _sh(["make", f"S2GEN={' '.join(S2GEN)}", "BUILD=build-make"], folder)
    _check(folder / "build-make" / "integrate", folder, expected)


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
def test_cmake_build_matches_simulate(folder: Path, expected) -> None:
    build = folder / "build-cmake"
    _sh(["cmake", "-S", ".", "-B", str(build), f"-DS2GEN_EXECUTABLE={';'.join(S2GEN)}"], folder)
    _sh(["cmake", "--build", str(build)], folder)
    _check(build / "integrate", folder, expected)


def _readme_cmake_snippets() -> list[str]:
    """Every cmake block that calls add_subdirectory, in the C guide of the documentation
    (docs/user_guide/c_code.rst, which holds the README's former section) and in the kit's
    README."""
    found = [
        b for b in code_blocks(page("user_guide/c_code.rst"), "cmake") if "add_subdirectory(" in b
    ]
    blocks = re.findall(
        r"^```cmake\n(.*?)^```", (EMBED / "README.md").read_text(), re.MULTILINE | re.DOTALL
    )
    return found + [b for b in blocks if "add_subdirectory(" in b]


def test_readmes_show_one_add_subdirectory_snippet() -> None:
    """The C guide and the kit's README quote the parent project the next test builds, word
    for word."""
    snippets = _readme_cmake_snippets()
    assert len(snippets) == 2, snippets
    assert snippets[0] == snippets[1]


@pytest.mark.skipif(shutil.which("cmake") is None, reason="cmake not installed")
@pytest.mark.parametrize("language", ["CXX", "C"])
def test_readme_parent_project_links_s2gen_system(folder: Path, language: str) -> None:
    """The C guide's parent project, C++-only as quoted and C-only with its two C++ words
    replaced, laid out as it reads (the kit under third_party/, a spec under specs/): it
    configures, builds the emitted source into s2gen_system and links the example program
    (C99 that also compiles as C++) against it; the final state equals `s2gen simulate`'s of
    the same spec to 1e-12."""
    text = _readme_cmake_snippets()[0]
    source = "my_program.cpp"
    if language == "C":
        assert "LANGUAGES CXX)" in text and "my_program.cpp" in text
        text = text.replace("LANGUAGES CXX)", "LANGUAGES C)").replace(".cpp", ".c")
        source = "my_program.c"
    parent = folder.parent / f"parent_{language}"
    kit = parent / "third_party" / "s2gen" / "examples" / "embed"
    shutil.copytree(folder, kit, ignore=shutil.ignore_patterns("build", "build-*"))
    (parent / "specs").mkdir()
    spec = EMBED.parent.parent / "generator" / "systems" / "examples" / "double_pendulum.toml"
    named = re.sub(r'^name = "double_pendulum"', 'name = "my_system"', spec.read_text(), 1,
                   flags=re.MULTILINE)  # fmt: skip
    assert 'name = "my_system"' in named
    (parent / "specs" / "my_system.toml").write_text(named)
    shutil.copy(folder / "main.c", parent / source)
    shutil.copy(folder / "double_pendulum.init", parent)
    (parent / "CMakeLists.txt").write_text(text)
    build = parent / "build"
    args = [f"-DS2GEN_EXECUTABLE={';'.join(S2GEN)}", "-DCMAKE_BUILD_TYPE=Release"]
    _sh(["cmake", "-S", ".", "-B", str(build), *args], parent)
    _sh(["cmake", "--build", str(build)], parent)
    assert not (build / "s2gen_embed" / "integrate").exists()  # the example program stays out
    for method, h, n in RUNS:
        out = parent / f"sim_{method}.npz"
        _sh([*S2GEN, "simulate", "specs/my_system.toml", "--method", method, "--h", repr(h),
             "--T", repr(h * n), "--out", str(out)], parent)  # fmt: skip
        data = np.load(out)
        got = _final_state(build / "my_program", parent, method, h, n)
        for key in ("q", "omega", "energy"):
            np.testing.assert_allclose(got[key], data[key][-1].ravel(), rtol=0, atol=1e-12,
                                       err_msg=key)  # fmt: skip
