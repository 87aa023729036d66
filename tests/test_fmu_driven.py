"""FMUs of driven systems (forces, inputs or time t), checked through FMPy as the importer.

A driven FMU (Co-Simulation, and Model Exchange through the driven field): its inputs are FMI inputs held over each communication
step, its time is the FMU's, and its output `work` is the work done since the start. FMPy
drives it with a piecewise-constant input table; s2gen's own run with the same inputs, step
and method is the comparison, and the energy balance E - E0 - W closes the work.
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import s2gen
from s2gen.build import STRICT_FLAGS, compiler
from s2gen.fmi import export
from s2gen.fmi.archive import fmi_headers
from s2gen.fmi.model import describe
from s2gen.fmi.wrapper import wrapper_files
from s2gen.methods import driven_methods

fmpy = pytest.importorskip("fmpy")  # a test dependency: .ci/run installs it (".[test]")
from fmpy.validation import validate_fmu

ROOT = Path(__file__).resolve().parents[1]
#: communication interval of the FMPy runs, and the length of each constant piece of input
DT, PIECE = 0.05, 0.1


@pytest.fixture(scope="module")
def double() -> s2gen.System:
    """Damped double pendulum, a periodic term in V and the input force `push`."""
    return s2gen.load(ROOT / "tests/specs/driven_double.toml")


@pytest.fixture(scope="module")
def inverted() -> s2gen.System:
    """Inverted pendulum whose potential depends on its three inputs."""
    return s2gen.load(ROOT / "examples/control/inverted_pendulum.toml")


def _outputs(n: int) -> list[str]:
    return [f"{g}{i}_{a}" for g in "qw" for i in range(1, n + 1) for a in "xyz"]


def _state(result: np.ndarray, n: int) -> np.ndarray:
    return np.stack([result[name] for name in _outputs(n)], axis=1)


def _reference(tr: Any) -> np.ndarray:
    k = len(tr.t)
    return np.concatenate([tr.q.reshape(k, -1), tr.omega.reshape(k, -1)], axis=1)


def _pieces(names: tuple[str, ...], T: float) -> np.ndarray:
    """One value per input and piece of length PIECE: smooth in the piece index, distinct."""
    k = np.arange(round(T / PIECE))[:, None]
    j = np.arange(len(names))[None, :]
    return 0.3 + np.sin(1.7 * k + j) * (1.0 + 0.5 * j)


def _signal(names: tuple[str, ...], values: np.ndarray) -> np.ndarray:
    """FMPy's input table of the pieces: each value from its piece's start to its end (a step
    at every switch: the same time twice)."""
    rows = []
    for k, row in enumerate(values):
        rows.append((k * PIECE, *row))
        rows.append(((k + 1) * PIECE, *row))
    return np.array(rows, dtype=[("time", float)] + [(n, float) for n in names])


# ------------------------------------------------------------------ the model description
@pytest.mark.parametrize("fmi", [2, 3])
def test_description_lists_the_inputs_and_the_work(tmp_path: Path, double, fmi: int) -> None:
    path = export(double, tmp_path / "dd.fmu", fmi=fmi, h=0.01)
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    assert md.coSimulation is not None and md.modelExchange is None
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    assert [(v.name, v.variability, float(v.start)) for v in inputs] == [
        ("push", "continuous", 0.2)
    ]
    work = next(v for v in md.modelVariables if v.name == "work")
    assert (work.causality, work.variability) == ("output", "continuous")
    assert "work" in [v.variable.name for v in md.outputs]


@pytest.mark.parametrize("name", ["kapitza", "forced_double_pendulum"])
def test_driven_builtins_validate(tmp_path: Path, name: str) -> None:
    for fmi in (2, 3):
        path = export(s2gen.load(name), tmp_path / f"{name}{fmi}.fmu", fmi=fmi, kind="both")
        assert validate_fmu(str(path)) == [], (name, fmi)


@pytest.mark.parametrize(
    ("kind", "method", "words"),
    [
        ("cs", "rattle", "takes forces only with a diagonal inertia yet"),
        ("cs", "rk2-proj", "does not integrate driven systems"),
    ],
)
def test_methods_that_do_not_drive_are_refused(double, kind, method, words) -> None:
    with pytest.raises(ValueError, match=words) as info:
        describe(double, 2, kind, method, h=0.01)
    assert "\n" not in str(info.value)


# ------------------------------------------------------------------ Co-Simulation
@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize(
    ("which", "method", "h"),
    [("double", "vi", 0.01), ("inverted", "rk4", 0.005), ("inverted", "rattle4", 0.005)],
)
def test_co_simulation_with_an_input_table_is_s2gen_simulate(
    tmp_path: Path, request: pytest.FixtureRequest, which: str, method: str, h: float, fmi: int
) -> None:
    """FMPy with a piecewise-constant input gives s2gen's trajectory with the same inputs, h
    and method, its energy, and its work: the inverted pendulum's inputs are in V, so its work
    is all the jumps of V where they switch."""
    system = request.getfixturevalue(which)
    T = 1.0
    names = system.inputs.names
    values = _pieces(names, T)
    path = export(system, tmp_path / f"{which}.fmu", fmi=fmi, method=method, h=h)
    r = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=DT,
                          input=_signal(names, values),
                          output=[*_outputs(system.n), "energy", "work"])  # fmt: skip
    per_piece = round(PIECE / h)
    tr = s2gen.simulate(system, method=method, h=h, T=T, inputs=np.repeat(values, per_piece, 0))
    sampled = round(DT / h)
    assert np.allclose(r["time"], tr.t[::sampled], rtol=0, atol=1e-12)
    assert np.abs(_state(r, system.n) - _reference(tr)[::sampled]).max() <= 1e-10
    assert np.abs(r["energy"] - tr.energy[::sampled]).max() <= 1e-10
    assert np.abs(r["work"] - tr.work[::sampled]).max() <= 1e-10
    assert np.abs(r["work"]).max() > 0.1  # the inputs did work


def test_work_closes_the_energy_balance(tmp_path: Path, inverted) -> None:
    """Without forces or t in V, the inverted pendulum's energy changes only where an input
    switches, by the jump of V there, and the VI keeps E close between switches: so
    E - E0 - work stays at the VI's energy error while E itself moves by order one."""
    T = 1.0
    names = inverted.inputs.names
    path = export(inverted, tmp_path / "ip.fmu", fmi=2, method="vi", h=0.001)
    r = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=DT,
                          input=_signal(names, _pieces(names, T)),
                          output=["energy", "work"])  # fmt: skip
    balance = r["energy"] - r["energy"][0] - r["work"]
    assert np.abs(r["energy"] - r["energy"][0]).max() > 0.1
    assert np.abs(balance).max() <= 1e-4


def test_a_parameter_set_between_steps_is_work(tmp_path: Path, inverted) -> None:
    """Setting g between two steps moves V = m l (g + az) q_z by m l (g' - g) q_z at that
    state: the work output takes exactly that jump (no force, no t in V: the steps do no
    work), and the energy balance stays closed across it."""
    from fmpy.fmi2 import FMU2Slave

    path = export(inverted, tmp_path / "ip.fmu", fmi=2, method="rk4", h=0.001)
    md = fmpy.read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(str(path), str(tmp_path / "u")),
                    modelIdentifier="inverted_pendulum", instanceName="ip")  # fmt: skip
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    names = ["q1_z", "energy", "work"]

    def read() -> dict[str, float]:
        return dict(zip(names, fmu.getReal([vr[n] for n in names])))

    start = read()
    for k in range(4):
        fmu.doStep(currentCommunicationPoint=k * DT, communicationStepSize=DT)
    before = read()
    fmu.setReal([vr["g"]], [5.0])
    fmu.doStep(currentCommunicationPoint=4 * DT, communicationStepSize=DT)
    after = read()
    fmu.terminate()
    fmu.freeInstance()
    m, l = 1.0, 0.5  # the spec's
    assert abs(before["work"]) <= 1e-12
    assert abs(after["work"] - m * l * (5.0 - 9.81) * before["q1_z"]) <= 1e-12
    assert abs(after["energy"] - start["energy"]) > 1.0
    assert abs(after["energy"] - start["energy"] - after["work"]) <= 1e-9


def test_time_is_the_fmus(tmp_path: Path) -> None:
    """Kapitza's potential depends on t: started at t0 = 0.3 by FMPy it follows s2gen's run
    from t0 = 0.3, not the one from 0."""
    kapitza = s2gen.load("kapitza")
    path = export(kapitza, tmp_path / "kapitza.fmu", fmi=3, method="vi4")
    t0, T = 0.3, 0.2
    r = fmpy.simulate_fmu(str(path), start_time=t0, stop_time=t0 + T, output_interval=0.01,
                          output=_outputs(1))  # fmt: skip
    tr = s2gen.simulate(kapitza, method="vi4", T=T, t0=t0)
    from_zero = s2gen.simulate(kapitza, method="vi4", T=T)
    got = _state(r, 1)
    assert np.abs(got - _reference(tr)[::10]).max() <= 1e-10
    assert np.abs(got - _reference(from_zero)[::10]).max() > 1e-3


@pytest.mark.skipif(shutil.which("cmake") is None, reason="FMPy compiles source FMUs with CMake")
@pytest.mark.parametrize("fmi", [2, 3])
def test_source_fmu_compiles_with_fmpy_and_matches_the_binary(tmp_path: Path, double, fmi):
    from fmpy.build import build_platform_binary

    shipped = export(double, tmp_path / "dd.fmu", fmi=fmi, h=0.01)
    unzipped = tmp_path / "unzipped"
    with zipfile.ZipFile(shipped) as z:
        z.extractall(unzipped)
    shutil.rmtree(unzipped / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(unzipped, build_dir=tmp_path / "build")
    assert list((unzipped / "binaries").rglob("*.so"))
    signal = _signal(("push",), _pieces(("push",), 0.5))
    kwargs = {"stop_time": 0.5, "output_interval": DT, "input": signal}
    built = fmpy.simulate_fmu(str(unzipped), **kwargs)
    ours = fmpy.simulate_fmu(str(shipped), **kwargs)
    assert np.abs(_state(built, 2) - _state(ours, 2)).max() <= 1e-12
    assert np.abs(built["work"] - ours["work"]).max() <= 1e-12


# ------------------------------------------------------------------ failures
@pytest.mark.parametrize("fmi", [2, 3])
def test_a_non_finite_input_is_an_error_with_a_message(tmp_path: Path, double, fmi: int) -> None:
    path = export(double, tmp_path / "dd.fmu", fmi=fmi, h=0.01)
    signal = _signal(("push",), np.array([[0.2], [np.nan], [0.3]]))
    messages: list[str] = []

    def logger(*args: Any) -> None:
        messages.append(args[-1].decode())

    with pytest.raises(Exception, match="SetReal|SetFloat64"):
        fmpy.simulate_fmu(str(path), stop_time=0.3, output_interval=DT, input=signal,
                          logger=logger)  # fmt: skip
    assert any("input push = nan at t = 0.1" in m and "is not finite" in m for m in messages)


@pytest.mark.parametrize("fmi", [2, 3])
def test_a_failing_step_reaches_fmpy_with_the_status_message(tmp_path, double, fmi) -> None:
    """h = 2 is far too large for the driven VI's Newton iteration."""
    path = export(double, tmp_path / "dd.fmu", fmi=fmi, h=2.0)
    messages: list[str] = []

    def logger(*args: Any) -> None:
        messages.append(args[-1].decode())

    with pytest.raises(Exception, match="DoStep"):
        fmpy.simulate_fmu(str(path), stop_time=4.0, output_interval=2.0, logger=logger)
    assert any("doStep from t = 0: vi substep 1 of 1" in m for m in messages), messages


# ------------------------------------------------------------------ the wrapper
@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name", ["kapitza", "tests/specs/driven_double.toml"])
def test_driven_wrapper_is_strict_c99_and_cxx(tmp_path: Path, name: str, fmi: int) -> None:
    system = s2gen.load(name if "/" not in name else ROOT / name)
    files = {
        **s2gen.generate(system, "c"),
        **wrapper_files(describe(system, fmi, "cs", "vi", 0.01)),
    }
    for file, text in files.items():
        (tmp_path / file).write_text(text)
    wrapper = tmp_path / f"{system.name}_fmi{fmi}.c"
    include = f"-I{fmi_headers()}"
    for cmd in (
        [compiler()[0], *STRICT_FLAGS, include, "-fsyntax-only", str(wrapper)],
        ["g++", "-x", "c++", "-Wall", "-Wextra", "-Werror", include, "-fsyntax-only", str(wrapper)],
    ):
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        assert proc.returncode == 0, proc.stderr


def test_every_driven_method_is_offered(double, inverted) -> None:
    """Every method of s2gen's driven runs (RATTLE's with forces for a diagonal M only)."""
    for method in driven_methods(rattle=False):
        assert describe(double, 3, "cs", method, 0.01).method == method
    for method in driven_methods():
        assert describe(inverted, 3, "cs", method).method == method


def test_command_line_exports_a_driven_system(tmp_path: Path, capsys) -> None:
    from s2gen.cli import main

    out = tmp_path / "kapitza.fmu"
    assert main(["fmu", "kapitza", "--out", str(out), "--fmi", "3"]) == 0
    assert "FMI 3 FMU (cs, vi)" in capsys.readouterr().out
    assert main(["fmu", "kapitza", "--out", str(out), "--kind", "me"]) == 0
    assert "FMI 2 FMU (me" in capsys.readouterr().out
    assert main(["fmu", "kapitza", "--out", str(out), "--method", "rk2-proj"]) == 2
    err = capsys.readouterr().err
    assert "does not integrate driven systems" in err and len(err.strip().splitlines()) == 1


# ------------------------------------------------------------------ Model Exchange
@pytest.mark.parametrize("fmi", [2, 3])
def test_model_exchange_of_a_driven_system_with_cvode(tmp_path: Path, double, fmi: int) -> None:
    """The driven field (forces, time and the input held by FMPy's input table) integrated by
    FMPy's CVODE at rtol 1e-10 against s2gen's DOP853 at 1e-12 with the same inputs held over
    the same pieces; the energy output is E(q, w, t, u) at the importer's state."""
    path = export(double, tmp_path / f"me{fmi}.fmu", fmi=fmi, kind="me", h=0.01)
    T = 1.0
    values = _pieces(double.inputs.names, T)
    r = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=PIECE, fmi_type="ModelExchange",
                          solver="CVode", relative_tolerance=1e-10,
                          input=_signal(double.inputs.names, values),
                          output=[*_outputs(double.n), "energy"])  # fmt: skip
    tight = s2gen.Options(rtol=1e-12, atol=1e-12)
    tr = s2gen.simulate(double, "dop853", h=PIECE, T=T, inputs=values, options=tight)
    # FMPy records the output grid and each input switch (twice: before and after): the state
    # is continuous there, so the last row at each grid time is the sample
    rows = [int(np.flatnonzero(np.abs(r["time"] - t) < 1e-9)[-1]) for t in tr.t]
    assert np.abs(_state(r, double.n)[rows] - _reference(tr)).max() <= 1e-6
    # the energy at T with the inputs held over the last piece (the trajectory's sample there)
    assert abs(r["energy"][-1] - tr.energy[-1]) <= 1e-6 * max(1.0, abs(tr.energy[-1]))
