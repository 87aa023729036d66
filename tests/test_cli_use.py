"""The command line in everyday use: the counts `simulate` prints are the integrator's, the file
it names is the file it wrote, bad output paths are refused before integrating, `regen` only
runs in a checkout, `bench` takes TOML specs, and a progress bar shows on request."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import s2gen.runtime
from s2gen import cli
from s2gen.cli import main
from s2gen.methods import method as method_info
from s2gen.runtime import Options, simulate
from s2gen.runtime.trajectory import Trajectory
from s2gen.systems import builtin

SPECS = Path(__file__).parent / "specs"


def _counts(stdout: str) -> dict[str, int]:
    m = re.search(
        r"(\d+) steps(?: \(\+(\d+) rejected\))?, (\d+|uncounted) gradient evaluations, "
        r"(\d+) Newton iterations",
        stdout,
    )
    assert m, stdout
    grads = -1 if m[3] == "uncounted" else int(m[3])
    return {"steps": int(m[1]), "rejected": int(m[2] or 0), "grads": grads, "newton": int(m[4])}


def test_simulate_reports_the_integrators_steps_not_the_samples(tmp_path, capsys) -> None:
    """RK45 takes far fewer steps than the 10^4 output samples; the count printed must be the
    accepted and rejected steps, as the independent reference integrator counts them."""
    out = tmp_path / "rk45.npz"
    assert main(["simulate", "double_pendulum", "--method", "rk45", "--out", str(out)]) == 0
    printed = _counts(capsys.readouterr().out)
    ref = simulate(builtin("double_pendulum"), "rk45", "reference", h=0.01, T=100.0).stats
    assert printed["steps"] == ref["steps"] and printed["rejected"] == ref["rejected"]
    assert printed["grads"] == ref["rhs_evaluations"]
    assert printed["steps"] < 10_000 // 5  # not the sample count
    assert len(np.load(out)["t"]) == 10_001


@pytest.mark.parametrize("backend", ["c", "reference"])
def test_fixed_step_counts_follow_the_method_table(tmp_path, capsys, backend: str) -> None:
    """RK4 takes T/h steps of 4 gradient evaluations (reference: its own key names)."""
    out = tmp_path / "rk4.npz"
    argv = ["simulate", "double_pendulum", "--method", "rk4", "--backend", backend]
    assert main([*argv, "--T", "0.5", "--out", str(out)]) == 0
    printed = _counts(capsys.readouterr().out)
    assert printed["steps"] == 50 and printed["rejected"] == 0
    assert printed["grads"] == method_info("rk4").evals * 50
    assert printed["newton"] == 0


def test_reference_vi_does_not_claim_a_gradient_count(tmp_path, capsys) -> None:
    out = tmp_path / "vi.npz"
    args = ["simulate", "double_pendulum", "--backend", "reference", "--T", "0.05"]
    assert main([*args, "--out", str(out)]) == 0
    printed = _counts(capsys.readouterr().out)
    assert printed["grads"] == -1 and printed["steps"] == 5 and printed["newton"] > 0


def test_the_file_named_is_the_file_written(tmp_path, capsys) -> None:
    """np.savez appended .npz to a path without it while the report named the path given."""
    out = tmp_path / "traj"
    assert main(["simulate", "double_pendulum", "--T", "0.1", "--out", str(out)]) == 0
    stdout = capsys.readouterr().out
    saved = re.search(r"saved (\S+)", stdout)
    assert saved and Path(saved[1]) == out
    assert out.is_file() and not Path(str(out) + ".npz").exists()
    tr = Trajectory.load(out)
    assert tr.system == "double_pendulum" and tr.method == "vi" and len(tr.t) == 11
    assert tr.momentum is not None and tr.momentum.shape == (11, 3)


def test_saved_trajectory_matches_the_api_run(tmp_path) -> None:
    out = tmp_path / "t.npz"
    args = ["simulate", "double_pendulum", "--method", "rk45", "--rtol", "1e-6"]
    assert main([*args, "--T", "1", "--out", str(out)]) == 0
    api = simulate(builtin("double_pendulum"), "rk45", "c", 0.01, 1.0, Options(rtol=1e-6))
    saved = Trajectory.load(out)
    assert saved.q.tobytes() == api.q.tobytes()
    assert (saved.rtol, saved.atol, saved.control) == (1e-6, 1e-6, "matlab")


def _bad_paths(tmp_path: Path) -> dict[str, Path]:
    regular = tmp_path / "regular.txt"
    regular.write_text("x")
    outside = tmp_path / "outside.txt"
    outside.write_text("keep")
    (tmp_path / "out").mkdir()
    link = tmp_path / "out" / "traj.npz"
    link.symlink_to(outside)
    return {
        "a directory": tmp_path,
        "a file inside a regular file": regular / "traj.npz",
        "a symlink inside --out": link,
        "a dangling symlink": _dangling(tmp_path),
        "an unwritable folder": Path("/proc/traj.npz"),
    }


def _dangling(tmp_path: Path) -> Path:
    link = tmp_path / "dangling.npz"
    link.symlink_to(tmp_path / "nowhere" / "x.npz")
    return link


def test_bad_output_paths_are_refused_before_integrating(tmp_path, capsys, monkeypatch) -> None:
    """A long run must not be lost to a path that cannot be written: refuse it first."""

    def no_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("integrated before checking the output path")

    monkeypatch.setattr(s2gen.runtime, "run", no_run)
    monkeypatch.setattr(s2gen.runtime, "simulate", no_run)
    for what, path in _bad_paths(tmp_path).items():
        code = main(["simulate", "double_pendulum", "--out", str(path)])
        err = capsys.readouterr().err
        assert code == 2, what
        assert err.count("\n") == 1 and "--out" in err and str(path) in err, (what, err)
    assert (tmp_path / "outside.txt").read_text() == "keep"


def test_generate_refuses_a_symlink_inside_out(tmp_path, capsys) -> None:
    outside = tmp_path / "outside.c"
    outside.write_text("keep")
    out = tmp_path / "gen"
    out.mkdir()
    (out / "double_pendulum.c").symlink_to(outside)
    assert main(["generate", "double_pendulum", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "symbolic link" in err and "double_pendulum.c" in err
    assert outside.read_text() == "keep"
    assert not (out / "double_pendulum.h").exists()  # nothing half-written


def test_regen_runs_only_in_a_checkout(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["regen"]) == 2  # no generated/ here
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "checkout" in err
    (tmp_path / "generated").mkdir()
    assert main(["regen"]) == 2  # generated/ but no s2gen pyproject.toml beside it
    capsys.readouterr()
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "s2gen"\n')
    assert main(["regen"]) == 0
    assert {p.name for p in (tmp_path / "generated").rglob("*.*")} >= {"double_pendulum.h"}


def test_bench_takes_a_toml_spec() -> None:
    from s2gen.experiments.bench.common import example_system
    from s2gen.systems import resolve

    path = str(SPECS / "chain4.toml")
    assert example_system(path) == resolve(path)
    assert example_system("double_pendulum").name == "double_pendulum"


def test_progress_bar_on_request_and_only_then(tmp_path, capsys, monkeypatch) -> None:
    monkeypatch.setattr(cli, "PROGRESS_DELAY", 0.0)
    base = ["simulate", "double_pendulum", "--T", "20", "--out", str(tmp_path / "p.npz")]
    assert main(base) == 0  # stderr is not a terminal here: no bar
    assert capsys.readouterr().err == ""
    assert main([*base, "--progress"]) == 0
    err = capsys.readouterr().err
    assert "double_pendulum vi" in err and "step/s" in err and "%|" in err
    assert main([*base, "--method", "rk45", "--progress"]) == 0  # RK45 too: time reached
    assert "step/s" in capsys.readouterr().err


def test_progress_does_not_change_the_result(tmp_path) -> None:
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    base = ["simulate", "double_pendulum", "--T", "5"]
    assert main([*base, "--out", str(a)]) == 0
    assert main([*base, "--progress", "--out", str(b)]) == 0
    assert np.load(a)["q"].tobytes() == np.load(b)["q"].tobytes()


def test_every_keeps_every_kth_sample_of_the_same_run(tmp_path) -> None:
    """--every K saves samples 0, K, 2K, ... of the run with every step kept, with their
    energies, and the integrator's statistics are those of all the steps."""
    full, thin = tmp_path / "full.npz", tmp_path / "thin.npz"
    args = ["simulate", "double_pendulum", "--h", "0.01", "--T", "2"]
    assert main([*args, "--out", str(full)]) == 0
    assert main([*args, "--every", "25", "--out", str(thin)]) == 0
    a, b = Trajectory.load(full), Trajectory.load(thin)
    assert len(b.t) == 200 // 25 + 1
    assert np.array_equal(b.q, a.q[::25]) and np.array_equal(b.energy, a.energy[::25])
    assert b.stats["steps"] == a.stats["steps"] == 200


def test_every_must_divide_the_steps(capsys) -> None:
    args = ["simulate", "double_pendulum", "--h", "0.01", "--T", "1", "--every", "3"]
    assert main([*args, "--out", "x.npz"]) == 2
    assert "every" in capsys.readouterr().err
