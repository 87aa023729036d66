"""FMI export checked by a third party, FMPy: its validator, its Co-Simulation master and its
CVODE Model Exchange solver, and its own compilation of the source FMU.

Independent yardsticks: `s2gen simulate` (the same VI steps, run by the runtime's
integrate()), s2gen's DOP853 at tight tolerances (a different solver from FMPy's CVODE),
the initial state of the spec, and the status messages of the method table.
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
from s2gen.fmi import export, fmu_files
from s2gen.fmi.archive import fmi_headers
from s2gen.fmi.model import describe
from s2gen.fmi.wrapper import WrapperSource, wrapper_files
from s2gen.methods import Status
from s2gen.render import environment

fmpy = pytest.importorskip("fmpy")  # a test dependency: .ci/run installs it (".[test]")
from fmpy.validation import validate_fmu

ROOT = Path(__file__).resolve().parents[1]
H, T = 0.01, 1.0


@pytest.fixture(scope="module")
def pendulum() -> s2gen.System:
    return s2gen.load("double_pendulum")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory: pytest.TempPathFactory, pendulum: s2gen.System) -> dict[int, Path]:
    """The double pendulum's FMU (Co-Simulation and Model Exchange), FMI 2 and 3."""
    folder = tmp_path_factory.mktemp("fmu")
    return {fmi: export(pendulum, folder / f"dp{fmi}.fmu", fmi=fmi) for fmi in (2, 3)}


def _state(result: np.ndarray, n: int) -> np.ndarray:
    """q1_x .. qn_z, w1_x .. wn_z of an FMPy result, one row per output time."""
    names = [f"{g}{i}_{a}" for g in "qw" for i in range(1, n + 1) for a in "xyz"]
    return np.stack([result[name] for name in names], axis=1)


def _reference(tr: Any) -> np.ndarray:
    k = len(tr.t)
    return np.concatenate([tr.q.reshape(k, -1), tr.omega.reshape(k, -1)], axis=1)


# ------------------------------------------------------------------ the model description
@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name", ["double_pendulum", "four_pendula", "elastic_rod"])
def test_fmpy_validates_both_kinds(tmp_path: Path, name: str, fmi: int) -> None:
    path = export(s2gen.load(name), tmp_path / f"{name}.fmu", fmi=fmi, kind="both")
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    assert md.coSimulation is not None and md.modelExchange is not None


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("kind", ["cs", "me"])
def test_fmpy_validates_one_kind(tmp_path: Path, pendulum: s2gen.System, kind: str, fmi: int):
    path = export(pendulum, tmp_path / "dp.fmu", fmi=fmi, kind=kind)
    assert validate_fmu(str(path)) == []
    md = fmpy.read_model_description(str(path))
    assert (md.coSimulation is not None, md.modelExchange is not None) == (
        kind == "cs",
        kind == "me",
    )
    names = {v.name for v in md.modelVariables}
    assert ("stepSize" in names) == (kind == "cs")
    assert ("der(q1_x)" in names) == (kind == "me")


def test_description_declares_the_spec(fmus: dict[int, Path], pendulum: s2gen.System) -> None:
    """Parameters tunable with the spec's values, the state's start values the spec's initial
    state, the default experiment the spec's [run]."""
    for path in fmus.values():
        md = fmpy.read_model_description(str(path))
        by_name = {v.name: v for v in md.modelVariables}
        for name, value in zip(pendulum.parameter_names, pendulum.parameter_values):
            v = by_name[name]
            assert (v.causality, v.variability, float(v.start)) == ("parameter", "tunable", value)
        q0 = [float(by_name[f"q{i}_{a}"].start) for i in (1, 2) for a in "xyz"]
        w0 = [float(by_name[f"w{i}_{a}"].start) for i in (1, 2) for a in "xyz"]
        assert q0 == list(pendulum.q0.ravel()) and w0 == list(pendulum.omega0.ravel())
        assert {"energy", "J_x", "J_y", "J_z"} <= {u.variable.name for u in md.outputs}
        derivatives = [v for v in md.modelVariables if v.name.startswith("der(")]
        assert [v.derivative.name for v in derivatives] == [v.name[4:-1] for v in derivatives]
        assert [u.variable.name for u in md.derivatives] == [v.name for v in derivatives]
        assert len(derivatives) == 12
        e = md.defaultExperiment
        assert (float(e.stopTime), float(e.stepSize)) == (pendulum.run.T, pendulum.run.h)


# ------------------------------------------------------------------ Co-Simulation
@pytest.mark.parametrize("fmi", [2, 3])
def test_co_simulation_is_s2gen_simulate(fmus: dict[int, Path], pendulum: s2gen.System, fmi: int):
    """doStep over 0.01 and over 0.1 (ten sub-steps) gives `s2gen simulate`'s VI trajectory,
    energy and angular momentum."""
    tr = s2gen.simulate(pendulum, method="vi", h=H, T=T)
    ref = _reference(tr)
    for interval, stride in ((H, 1), (10 * H, 10)):
        r = fmpy.simulate_fmu(str(fmus[fmi]), stop_time=T, output_interval=interval,
                              fmi_type="CoSimulation")  # fmt: skip
        assert len(r) == len(tr.t[::stride])
        assert np.abs(_state(r, 2) - ref[::stride]).max() <= 1e-12
        assert np.abs(r["energy"] - tr.energy[::stride]).max() <= 1e-12 * abs(tr.energy[0])
        J = np.stack([r["J_x"], r["J_y"], r["J_z"]], axis=1)
        assert np.abs(J - tr.momentum[::stride]).max() <= 1e-10


def test_parameters_set_through_fmpy_act_as_in_simulate(fmus: dict[int, Path], pendulum):
    params = {"g": 1.62, "l1": 5.0, "m2": 2.0}
    tr = s2gen.simulate(pendulum, method="vi", h=H, T=T, params=params)
    default = s2gen.simulate(pendulum, method="vi", h=H, T=T)
    for path in fmus.values():
        r = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=H, fmi_type="CoSimulation",
                              start_values=params)  # fmt: skip
        assert np.abs(_state(r, 2) - _reference(tr)).max() <= 1e-12
        assert np.abs(_state(r, 2) - _reference(default)).max() > 1e-2  # they did change it


def test_step_size_parameter_sets_the_sub_step(fmus: dict[int, Path], pendulum) -> None:
    tr = s2gen.simulate(pendulum, method="vi", h=0.005, T=T)
    r = fmpy.simulate_fmu(str(fmus[2]), stop_time=T, output_interval=0.05,
                          fmi_type="CoSimulation", start_values={"stepSize": 0.005})  # fmt: skip
    assert np.abs(_state(r, 2) - _reference(tr)[::10]).max() <= 1e-12


def test_adaptive_co_simulation_through_integrate(tmp_path: Path, pendulum) -> None:
    """--method dop853: each communication interval integrated adaptively; agrees with
    s2gen's DOP853 at tight tolerances."""
    path = export(pendulum, tmp_path / "dop.fmu", fmi=3, kind="cs", method="dop853")
    tight = s2gen.Options(rtol=1e-12, atol=1e-12)
    tr = s2gen.simulate(pendulum, method="dop853", h=H, T=T, options=tight)
    r = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=H)
    assert np.abs(_state(r, 2) - _reference(tr)).max() <= 1e-6


# ------------------------------------------------------------------ Model Exchange
@pytest.mark.parametrize("fmi", [2, 3])
def test_model_exchange_with_cvode_agrees_with_dop853(fmus: dict[int, Path], pendulum, fmi: int):
    """The continuous field integrated by FMPy's CVODE (rtol 1e-10) against s2gen's DOP853
    over the paper's 1 s horizon."""
    r = fmpy.simulate_fmu(str(fmus[fmi]), stop_time=T, output_interval=H,
                          fmi_type="ModelExchange", solver="CVode",
                          relative_tolerance=1e-10)  # fmt: skip
    tight = s2gen.Options(rtol=1e-12, atol=1e-12)
    tr = s2gen.simulate(pendulum, method="dop853", h=H, T=T, options=tight)
    assert np.allclose(r["time"], tr.t, rtol=0, atol=1e-12)
    assert np.abs(_state(r, 2) - _reference(tr)).max() <= 1e-6


# ------------------------------------------------------------------ failures
@pytest.mark.parametrize("fmi", [2, 3])
def test_failing_step_reaches_fmpy_with_the_status_message(fmus: dict[int, Path], fmi: int):
    """h = 1 is far too large for the VI's Newton iteration on the double pendulum."""
    messages: list[str] = []

    def logger(*args: Any) -> None:
        messages.append(args[-1].decode())

    with pytest.raises(Exception, match="DoStep"):
        fmpy.simulate_fmu(str(fmus[fmi]), stop_time=2.0, output_interval=1.0,
                          fmi_type="CoSimulation", start_values={"stepSize": 1.0},
                          logger=logger)  # fmt: skip
    assert any(Status.NEWTON.message in m and "doStep from t = 0" in m for m in messages)


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize(
    ("start", "words"),
    [({"q1_x": 2.0}, "is not a unit vector"), ({"w2_z": 1.0}, "is not tangent to q2")],
)
def test_invalid_start_values_are_refused(fmus: dict[int, Path], fmi: int, start, words) -> None:
    messages: list[str] = []

    def logger(*args: Any) -> None:
        messages.append(args[-1].decode())

    with pytest.raises(Exception, match="ExitInitializationMode"):
        fmpy.simulate_fmu(str(fmus[fmi]), stop_time=0.1, output_interval=H, logger=logger,
                          start_values=start, fmi_type="CoSimulation")  # fmt: skip
    assert any(words in m for m in messages), messages


def _fmi2_callbacks(messages: list[str]) -> Any:
    """FMI 2 callbacks whose logger appends to `messages` (FMPy formats the variadic message
    through its logger proxy, which keeps the last logger it was given: each instantiation
    here passes its own, alive while it runs)."""
    from ctypes import byref

    from fmpy import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )
    from fmpy.logging import addLoggerProxy

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda *args: messages.append(args[-1].decode()))
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))
    return callbacks


@pytest.mark.parametrize("fmi", [2, 3])
def test_an_interface_the_fmu_lacks_is_not_instantiated(tmp_path: Path, pendulum, fmi: int):
    """A Co-Simulation-only FMU refuses an importer that instantiates it for Model Exchange,
    with a message; its Co-Simulation instantiates."""
    path = export(pendulum, tmp_path / "cs.fmu", fmi=fmi, kind="cs")
    unzipped = fmpy.extract(str(path), str(tmp_path / "unzipped"))
    md = fmpy.read_model_description(str(path))
    token = md.guid if fmi == 2 else md.instantiationToken
    kwargs = {"guid": token, "unzipDirectory": unzipped, "modelIdentifier": "double_pendulum"}
    messages: list[str] = []
    if fmi == 2:
        callbacks = _fmi2_callbacks(messages)
        me = fmpy.fmi2.FMU2Model(**kwargs)
        with pytest.raises(Exception, match="Failed to instantiate"):
            me.instantiate(callbacks=callbacks)
        cs = fmpy.fmi2.FMU2Slave(**kwargs)
        cs.instantiate(callbacks=callbacks)
    else:

        def log(*args: Any) -> None:
            messages.append(args[-1].decode())

        me = fmpy.fmi3.FMU3Model(**kwargs)
        with pytest.raises(Exception, match="Failed to instantiate"):
            me.instantiate(logMessage=log)
        cs = fmpy.fmi3.FMU3Slave(**kwargs)
        cs.instantiate(logMessage=log)
    assert messages == ["this FMU has no Model Exchange interface"]
    cs.freeInstance()


# ------------------------------------------------------------------ archive and sources
def test_archive_is_byte_reproducible(tmp_path: Path, pendulum: s2gen.System) -> None:
    """Two exports give the same bytes (the binary too, from the build cache); every entry
    has the fixed timestamp, in the fixed order; the sources are the emitted C."""
    a = export(pendulum, tmp_path / "a.fmu", fmi=3).read_bytes()
    b = export(pendulum, tmp_path / "b.fmu", fmi=3).read_bytes()
    assert a == b
    with zipfile.ZipFile(tmp_path / "a.fmu") as z:
        infos = z.infolist()
        assert {i.date_time for i in infos} == {(1980, 1, 1, 0, 0, 0)}  # zip's earliest
        names = [i.filename for i in infos]
        emitted = s2gen.generate(pendulum, "c")
        for name, text in emitted.items():
            assert z.read(f"sources/{name}").decode() == text
    assert names[0] == "modelDescription.xml" and names[-1].startswith("binaries/x86_64-linux/")
    assert names[1:-1] == sorted(names[1:-1])


def test_entries_apart_from_the_binary_do_not_depend_on_the_build(pendulum, monkeypatch, tmp_path):
    """With another build cache (the library compiled afresh), every entry but the binary is
    the same bytes."""
    first = fmu_files(pendulum, fmi=2)
    monkeypatch.setenv("S2GEN_CACHE", str(tmp_path / "cache"))
    second = fmu_files(pendulum, fmi=2)
    assert list(first) == list(second)
    assert {k: v for k, v in first.items() if not k.startswith("binaries/")} == {
        k: v for k, v in second.items() if not k.startswith("binaries/")
    }


@pytest.mark.skipif(shutil.which("cmake") is None, reason="FMPy compiles source FMUs with CMake")
@pytest.mark.parametrize("fmi", [2, 3])
def test_source_fmu_compiles_with_fmpy_and_matches_the_binary(tmp_path: Path, fmus, fmi: int):
    from fmpy.build import build_platform_binary

    unzipped = tmp_path / "unzipped"
    with zipfile.ZipFile(fmus[fmi]) as z:
        z.extractall(unzipped)
    shutil.rmtree(unzipped / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(unzipped, build_dir=tmp_path / "build")
    assert list((unzipped / "binaries").rglob("*.so"))
    kwargs = {"stop_time": T, "output_interval": 0.1, "fmi_type": "CoSimulation"}
    built = fmpy.simulate_fmu(str(unzipped), **kwargs)
    shipped = fmpy.simulate_fmu(str(fmus[fmi]), **kwargs)
    assert np.abs(_state(built, 2) - _state(shipped, 2)).max() <= 1e-12


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("method", ["vi", "rk45"])
def test_wrapper_is_strict_c99_and_cxx(tmp_path: Path, pendulum, fmi: int, method: str) -> None:
    files = {
        **s2gen.generate(pendulum, "c"),
        **wrapper_files(describe(pendulum, fmi, "both", method)),
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    wrapper = tmp_path / f"double_pendulum_fmi{fmi}.c"
    include = f"-I{fmi_headers()}"
    cc = compiler()[0]
    for cmd in (
        [cc, *STRICT_FLAGS, include, "-fsyntax-only", str(wrapper)],
        ["g++", "-x", "c++", "-Wall", "-Wextra", "-Werror", include, "-fsyntax-only", str(wrapper)],
    ):
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        assert proc.returncode == 0, proc.stderr


def test_templates_read_only_the_record_and_are_all_laid_out(pendulum: s2gen.System) -> None:
    """Every `f.NAME` a wrapper template reads is a field of WrapperSource; the six
    combinations (FMI 2/3, fixed/adaptive/driven) lay out every template of templates/fmu/."""
    from jinja2 import meta, nodes

    env = environment()
    fields = set(WrapperSource.__dataclass_fields__)
    every = sorted((ROOT / "templates" / "fmu").glob("*.jinja"))
    for path in every:
        tree = env.parse(path.read_text())
        read = {n.attr for n in tree.find_all(nodes.Getattr) if isinstance(n.node, nodes.Name)
                and n.node.name == "f"}  # fmt: skip
        assert read <= fields, (path.name, read - fields)
        assert meta.find_undeclared_variables(tree) <= {"f"}
    from s2gen.fmi.wrapper import source_record

    laid_out: set[str] = {"fmu/_checks.jinja"}  # included by both instance partials
    kapitza = s2gen.load("kapitza")
    for fmi in (2, 3):
        for system, kind, method in ((pendulum, "both", "vi"), (pendulum, "both", "dop853"),
                                     (kapitza, "cs", "vi")):  # fmt: skip
            record = source_record(describe(system, fmi, kind, method))
            laid_out |= {f"fmu/fmi{fmi}.c.jinja", record.core_part, record.advance_part}
    assert {f"fmu/{p.name}" for p in every} == laid_out


# ------------------------------------------------------------------ command line
def test_command_line_writes_the_fmu(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from s2gen.cli import main

    out = tmp_path / "moon.fmu"
    assert main(["fmu", "double_pendulum:g=1.62", "--out", str(out), "--fmi", "3",
                 "--kind", "cs"]) == 0  # fmt: skip
    assert "FMI 3 FMU" in capsys.readouterr().out
    md = fmpy.read_model_description(str(out))
    assert float(next(v for v in md.modelVariables if v.name == "g").start) == 1.62
    assert main(["fmu", "double_pendulum", "--out", str(out), "--h", "-1"]) == 2
    assert "no step size" in capsys.readouterr().err
    assert main(["fmu", "no_such_system", "--out", str(out)]) == 2


def test_adaptive_co_simulation_takes_the_spec_tolerances(tmp_path: Path, pendulum) -> None:
    """A spec's [run] rtol and atol reach doStep's adaptive integration: with 1e-10 the FMU's
    DOP853 follows a tight reference a hundred times more closely than with the defaults
    (rtol 1e-3, atol 1e-6), and both within their tolerance's reach."""
    tight = s2gen.simulate(pendulum, method="dop853", h=H, T=T,
                           options=s2gen.Options(rtol=1e-13, atol=1e-13))  # fmt: skip
    text = (Path(s2gen.__file__).parent / "systems/examples/double_pendulum.toml").read_text()
    assert "[run]" in text and "rtol" not in text
    precise = s2gen.load(text.replace("[run]\n", "[run]\nrtol = 1e-10\natol = 1e-10\n"))
    errors = []
    for system, name in ((pendulum, "default"), (precise, "precise")):
        path = export(system, tmp_path / f"{name}.fmu", fmi=2, kind="cs", method="dop853")
        # communication intervals of 0.25: long enough for the tolerance to choose the steps
        r = fmpy.simulate_fmu(str(path), stop_time=T, output_interval=0.25)
        errors.append(float(np.abs(_state(r, 2) - _reference(tight)[::25]).max()))
    default, precise_error = errors
    assert precise_error <= 1e-8 and precise_error * 100 <= default, errors


def test_the_command_line_parser_loads_no_fmu_export_module() -> None:
    """`s2gen fmu` is registered through the `s2gen.fmi` package, whose model, wrapper and
    archive (and xml.etree) load on first use: a fresh process that builds the command line's
    parser, as every command does, has none of them, and `s2gen.fmi.KINDS` still reads."""
    import sys

    probe = (
        "import sys\nfrom s2gen import cli\ncli._parser()\n"
        "print(sorted(m for m in sys.modules if m.startswith(('s2gen.fmi.', 'xml.'))))\n"
        "import s2gen.fmi\nprint(s2gen.fmi.KINDS, s2gen.fmi.FMI_VERSIONS)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    loaded, kinds = out.stdout.splitlines()
    assert loaded == "['s2gen.fmi.command']"
    assert kinds == "('cs', 'me', 'both') (2, 3)"
