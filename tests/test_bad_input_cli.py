"""Bad input on the command line: every case exits 2 (bad input) or 1 (failed integration) with
exactly one line on stderr that names the option or file at fault, and no traceback.

(The spec parser's and the Python API's bad-input catalog lives in its own file; the cases
here are the command line's options and paths.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from s2gen.cli import main

DP = ["simulate", "double_pendulum"]
RK45 = [*DP, "--method", "rk45"]

# (id, argv with {tmp} for the test's folder, exit status, text stderr must contain)
CASES: list[tuple[str, list[str], int, str]] = [
    # what to run
    ("unknown-system", ["simulate", "nosuch", "--out", "{tmp}/t.npz"], 2, "nosuch"),
    ("missing-spec-file", ["simulate", "{tmp}/no/spec.toml", "--out", "{tmp}/t.npz"], 2, "spec.toml"),
    ("spec-is-a-folder", ["simulate", "{tmp}/folder/", "--out", "{tmp}/t.npz"], 2, "folder"),
    ("spec-bad-toml", ["simulate", "{tmp}/bad.toml", "--out", "{tmp}/t.npz"], 2, "bad.toml"),
    ("unknown-command", ["integrate", "double_pendulum"], 2, "integrate"),
    ("no-command", [], 2, "command"),
    ("unknown-option", [*DP, "--steps", "10", "--out", "{tmp}/t.npz"], 2, "--steps"),
    ("spec-is-the-test-folder", ["simulate", "{tmp}", "--T", "1"], 2, "is a folder, not a spec file"),
    ("unknown-param", [*DP, "--param", "k=1"], 2, "unknown parameter 'k'"),
    ("param-not-a-number", [*DP, "--param", "g=heavy"], 2, "--param g: expected a number"),
    ("spec-param-unknown", ["simulate", "double_pendulum:k=1"], 2, "unknown option or parameter 'k'"),
    ("ensemble-every-not-dividing", ["ensemble", "double_pendulum", "--every", "7", "--T", "1", "--out", "{tmp}/e"], 2, "every=7 must be a positive divisor of the 100 steps"),
    ("unknown-method", [*DP, "--method", "euler", "--out", "{tmp}/t.npz"], 2, "--method"),
    ("vi4-on-reference", [*DP, "--method", "vi4", "--backend", "reference", "--out", "{tmp}/t.npz"], 2, "vi4"),
    ("rattle-on-reference", [*DP, "--method", "rattle", "--backend", "reference", "--out", "{tmp}/t.npz"], 2, "rattle"),
    ("unknown-backend", [*DP, "--backend", "gpu", "--out", "{tmp}/t.npz"], 2, "--backend"),
    ("unknown-control", [*RK45, "--control", "scipy", "--out", "{tmp}/t.npz"], 2, "--control"),
    ("generate-unknown-lang", ["generate", "double_pendulum", "--lang", "fortran", "--out", "{tmp}/g"], 2, "--lang"),
    ("generate-missing-out", ["generate", "double_pendulum"], 2, "--out"),
    ("reproduce-unknown-example", ["reproduce", "nosuch", "--out", "{tmp}/r"], 2, "nosuch"),
    ("bench-steps-not-int", ["bench", "--steps", "many"], 2, "--steps"),
    # step size and horizon
    ("h-negative", [*DP, "--h", "-0.01", "--out", "{tmp}/t.npz"], 2, "h = -0.01"),
    ("h-zero", [*DP, "--h", "0", "--out", "{tmp}/t.npz"], 2, "h = 0"),
    ("h-inf", [*DP, "--h", "inf", "--out", "{tmp}/t.npz"], 2, "h = inf"),
    ("h-nan", [*DP, "--h", "nan", "--out", "{tmp}/t.npz"], 2, "h = nan"),
    ("h-not-a-number", [*DP, "--h", "small", "--out", "{tmp}/t.npz"], 2, "--h"),
    ("h-empty", [*DP, "--h=", "--out", "{tmp}/t.npz"], 2, "--h"),
    ("T-negative", [*DP, "--T", "-1", "--out", "{tmp}/t.npz"], 2, "T = -1"),
    ("T-zero", [*DP, "--T", "0", "--out", "{tmp}/t.npz"], 2, "T = 0"),
    ("T-inf", [*DP, "--T", "inf", "--out", "{tmp}/t.npz"], 2, "T = inf"),
    ("T-nan", [*DP, "--T", "nan", "--out", "{tmp}/t.npz"], 2, "T = nan"),
    ("T-not-a-multiple-of-h", [*DP, "--T", "0.015", "--out", "{tmp}/t.npz"], 2, "T=0.015"),
    ("T-shorter-than-h", [*DP, "--T", "0.001", "--out", "{tmp}/t.npz"], 2, "T = 0.001"),
    ("T-huge", [*DP, "--T", "1e12", "--out", "{tmp}/t.npz"], 2, "2147483648 samples"),
    ("h-tiny-T-huge", [*DP, "--h", "1e-300", "--T", "1e300", "--out", "{tmp}/t.npz"], 2, "T / h"),
    ("T-over-memory", ["simulate", "molecular", "--T", "500000", "--out", "{tmp}/t.npz"], 2, "memory"),
    # tolerances
    ("rtol-zero", [*RK45, "--rtol", "0", "--out", "{tmp}/t.npz"], 2, "rtol"),
    ("rtol-negative", [*RK45, "--rtol", "-1e-3", "--out", "{tmp}/t.npz"], 2, "rtol"),
    ("rtol-below-floor", [*RK45, "--rtol", "1e-300", "--out", "{tmp}/t.npz"], 2, "rtol = 1e-300"),
    ("rtol-nan", [*RK45, "--rtol", "nan", "--out", "{tmp}/t.npz"], 2, "rtol"),
    ("rtol-above-one", [*RK45, "--rtol", "2", "--out", "{tmp}/t.npz"], 2, "rtol = 2"),
    ("atol-zero", [*RK45, "--atol", "0", "--out", "{tmp}/t.npz"], 2, "atol"),
    ("atol-inf", [*RK45, "--atol", "inf", "--out", "{tmp}/t.npz"], 2, "atol"),
    # output paths
    ("out-is-a-folder", [*DP, "--out", "{tmp}"], 2, "--out"),
    ("out-inside-a-file", [*DP, "--out", "{tmp}/regular.txt/t.npz"], 2, "regular.txt"),
    ("out-symlink-inside", [*DP, "--out", "{tmp}/out/link.npz"], 2, "symbolic link"),
    ("out-dangling-symlink", [*DP, "--out", "{tmp}/dangling.npz"], 2, "dangling.npz"),
    ("out-unwritable-folder", [*DP, "--out", "/proc/s2gen-t.npz"], 2, "/proc"),
    ("out-empty", [*DP, "--out", ""], 2, "--out"),
    ("generate-out-is-a-file", ["generate", "double_pendulum", "--out", "{tmp}/regular.txt"], 2, "regular.txt"),
    ("generate-symlink-inside-out", ["generate", "double_pendulum", "--out", "{tmp}/out"], 2, "double_pendulum.c"),
    ("regen-outside-a-checkout", ["regen", "--out", "{tmp}/generated"], 2, "checkout"),
    # failed integrations: status 1, the step named, the partial run saved
    ("vi-infeasible", ["simulate", "three_bodies", "--h", "0.9", "--T", "90", "--out", "{tmp}/f.npz"], 1, "the 1 valid samples are kept"),
    ("rk4-non-finite", [*DP, "--method", "rk4", "--h", "5", "--T", "500", "--out", "{tmp}/f.npz"], 1, "non-finite"),
]  # fmt: skip


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    """A folder with the paths the cases point at."""
    (tmp_path / "regular.txt").write_text("x")
    (tmp_path / "outside.txt").write_text("keep")
    (tmp_path / "folder").mkdir()
    (tmp_path / "bad.toml").write_text("name = \n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "link.npz").symlink_to(tmp_path / "outside.txt")
    (out / "double_pendulum.c").symlink_to(tmp_path / "outside.txt")
    (tmp_path / "dangling.npz").symlink_to(tmp_path / "nowhere" / "x.npz")
    return tmp_path


def test_the_catalog_is_large_and_distinct() -> None:
    assert len(CASES) >= 35
    assert len({c[0] for c in CASES}) == len(CASES)


@pytest.mark.parametrize(
    ("argv", "status", "names"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_bad_input_is_one_line(
    scene: Path, capsys, argv: list[str], status: int, names: str
) -> None:
    args = [a.replace("{tmp}", str(scene)) for a in argv]
    code = main(args)
    err = capsys.readouterr().err
    assert code == status, err
    assert err.count("\n") == 1 and err.startswith("error: "), err
    assert names.replace("{tmp}", str(scene)) in err, err
    assert "Traceback" not in err
    assert (scene / "outside.txt").read_text() == "keep"  # never written through a link
    if status == 1:
        assert str(scene / "f.npz") in err and (scene / "f.npz").is_file()  # partial run saved


def test_unusable_build_cache_is_one_line(scene: Path, capsys, monkeypatch) -> None:
    monkeypatch.setenv("S2GEN_CACHE", str(scene / "regular.txt"))
    assert main([*DP, "--T", "0.1", "--out", str(scene / "t.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "S2GEN_CACHE" in err and "regular.txt" in err


def test_through_the_real_entry_point_no_traceback(scene: Path) -> None:
    """The installed command's path (python -m s2gen): status and one line, no traceback."""
    for argv, status in (
        ([*DP, "--T", "inf", "--out", str(scene / "t.npz")], 2),
        ([*DP, "--out", str(scene / "out" / "link.npz")], 2),
        (["simulate", "nosuch", "--out", str(scene / "t.npz")], 2),
    ):
        proc = subprocess.run(
            [sys.executable, "-m", "s2gen", *argv], capture_output=True, text=True, check=False
        )
        assert proc.returncode == status, proc.stderr
        assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
