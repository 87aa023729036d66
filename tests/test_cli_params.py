"""The command line's everyday use: parameter values after a colon on every spec (built-in or
TOML) or as --param, a run without --out, and a missing C compiler in one line.

That a parameter reached the run is checked against the reference backend's energy of the
initial state at that value (independent of the emitted code), and the three ways of giving
it against each other, bit for bit.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

import s2gen
from s2gen.cli import main
from s2gen.runtime import get_backend

RUN = ["--h", "0.01", "--T", "0.3"]


def _reference_energy(params: dict[str, float]) -> float:
    system = s2gen.load("double_pendulum")
    p = np.array([{**system.parameters, **params}[n] for n in system.parameter_names])
    return float(get_backend(system, "reference").energy(system.q0, system.omega0, p))


def test_a_parameter_after_the_colon_or_as_param_reaches_the_run(tmp_path: Path, capsys) -> None:
    toml = tmp_path / "dp.toml"
    toml.write_text(files("s2gen.systems.examples").joinpath("double_pendulum.toml").read_text())
    ways = {
        "builtin": ["double_pendulum:g=5"],
        "param": ["double_pendulum", "--param", "g=5"],
        "toml": [f"{toml}:g=5"],
        "toml-param": [str(toml), "--param", "g=5", "--param", "m2=1"],
    }
    runs = {}
    for name, spec in ways.items():
        out = tmp_path / f"{name}.npz"
        assert main(["simulate", *spec, *RUN, "--out", str(out)]) == 0, capsys.readouterr().err
        runs[name] = s2gen.Trajectory.load(out)
    assert runs["builtin"].energy[0] == pytest.approx(_reference_energy({"g": 5.0}), rel=1e-14)
    assert runs["builtin"].energy[0] != pytest.approx(_reference_energy({}), rel=1e-3)
    for tr in runs.values():
        assert tr.q.tobytes() == runs["builtin"].q.tobytes() and tr.params["g"] == 5.0
    assert runs["toml"].rebuild().parameters["g"] == 9.81  # the file's text, the run's values


def test_simulate_without_out_prints_the_statistics_and_writes_nothing(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", "double_pendulum", *RUN]) == 0
    out = capsys.readouterr().out
    assert "|E - E0|" in out and "not saved (31 samples; give --out FILE" in out
    assert list(tmp_path.iterdir()) == []


def test_no_c_compiler_is_one_line_with_the_status_reproduce_gives(
    tmp_path: Path, monkeypatch, capsys, request
) -> None:
    """Status 1, as `s2gen reproduce` reports an example it cannot build (systems not built in
    this process before, so that a compiler is needed)."""
    from s2gen.build import compiler

    monkeypatch.setenv("CC", str(tmp_path / "no" / "gcc"))
    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path / "cache"))  # nothing built before
    compiler.cache_clear()  # the compiler is looked up once per process
    request.addfinalizer(compiler.cache_clear)
    for argv in (
        ["simulate", "double_pendulum:g=3.25", *RUN, "--out", str(tmp_path / "t.npz")],
        [
            "ensemble",
            "double_pendulum:g=3.5",
            "--T",
            "0.1",
            "--workers",
            "0",
            "--out",
            str(tmp_path / "e"),
        ],
    ):
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 1, (argv, err)
        assert err.count("\n") == 1 and "C compiler" in err and "not found" in err, err
        assert "Traceback" not in err
    assert not (tmp_path / "t.npz").exists() and not (tmp_path / "e").exists()


def test_ensemble_takes_param_as_simulate_does(tmp_path: Path) -> None:
    import zarr

    argv = ["ensemble", "double_pendulum", "--param", "g=5", "--T", "0.1", "--workers", "0"]
    assert main([*argv, "--out", str(tmp_path / "e"), "--no-figures"]) == 0
    group = zarr.open_group(str(tmp_path / "e" / "ensemble.zarr"), mode="r")
    assert group["energy"][0, 0] == pytest.approx(_reference_energy({"g": 5.0}), rel=1e-14)
    assert "--param g=5" in group.attrs["s2gen"]["command"]
