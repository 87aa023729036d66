"""Sizes are checked against their stated limits before anything is built: the issue's command
lines (each ran past a minute before failing) now end at once in one line with status 2, and
a run whose members all fail still writes its store, its summary and its figures."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import s2gen
from s2gen.cli import main
from s2gen.ensemble import EnsembleError, EnsembleStore, ensemble, initial_state, member_table
from s2gen.ensemble.figures import energy_plot
from s2gen.ensemble.members import MAX_MEMBERS, MAX_PERTURBATION, sweep_values
from s2gen.ensemble.store import MAX_STORE_BYTES
from s2gen.methods import Status
from s2gen.runtime import IntegrationError
from s2gen.system import MAX_BODIES, SpecError
from s2gen.systems.meshes import MAX_SUBDIVISIONS, icosphere, icosphere_vertices

pytest.importorskip("zarr")


def _one_error_line(capsys: Any) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


# ------------------------------------------------------------------ the issue's command lines
@pytest.mark.timeout(20)
@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (
            [
                "ensemble",
                "double_pendulum",
                "--members",
                "1000000000000",
                "--perturb",
                "omega=1e-10",
            ],
            f"1000000000000 members is more than the limit of {MAX_MEMBERS} members",
        ),
        (
            ["ensemble", "double_pendulum", "--sweep", "g=1:2:1000000000"],
            f"1000000000 values is more than the limit of {MAX_MEMBERS}",
        ),
        (
            ["simulate", "molecular:subdivisions=12"],
            f"{10 * 4**12 + 2} vertices, more than the limit of {MAX_BODIES} bodies",
        ),
        (
            ["ensemble", "double_pendulum", "--perturb", "omega=1e300"],
            f"perturbation size of omega is relative and at most {MAX_PERTURBATION:g}",
        ),
    ],
)
def test_the_issues_command_lines_end_at_once(
    argv: list[str], expected: str, capsys: Any, tmp_path: Path, monkeypatch: Any
) -> None:
    """Exactly the issue's command lines (run in an empty folder, so that the default --out
    would show up): one error line naming the limit, status 2, nothing written."""
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    assert expected in _one_error_line(capsys)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.timeout(20)
def test_a_grid_of_sweeps_is_counted_before_it_is_made(capsys: Any, tmp_path: Path) -> None:
    """Two sweeps each within the limit whose grid, times the replicas, is not."""
    argv = ["ensemble", "double_pendulum", "--sweep", "g=1:2:1000", "--sweep", "l1=1:2:1000"]
    argv += ["--members", "2", "--perturb", "q=1e-13", "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    assert "2 members x 1000000 sweep points = 2000000 members" in _one_error_line(capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.timeout(20)
def test_a_store_larger_than_its_limit_is_refused_before_it_is_made(
    capsys: Any, tmp_path: Path
) -> None:
    """10^5 members of 10^6 + 1 stored samples of 2 bodies: q, omega, energy, t are
    8 * (6 * 2 + 2) bytes a sample, 1.1e13 bytes in all, ten times the limit."""
    members, samples = 10**5, 10**6 + 1
    need = 8 * members * samples * (6 * 2 + 2)
    assert need > MAX_STORE_BYTES
    out = tmp_path / "o"
    argv = ["ensemble", "double_pendulum", "--members", str(members), "--perturb", "q=1e-13"]
    argv += ["--h", "0.0001", "--T", "1000", "--every", "10", "--out", str(out)]
    assert main(argv) == 2
    line = _one_error_line(capsys)
    assert f"{members} members x {samples} samples x 2 bodies" in line
    assert f"would hold {need / 1e12:.3g} TB" in line
    assert not out.exists()


@pytest.mark.timeout(20)
def test_the_python_api_raises_one_line_errors_before_building() -> None:
    s = s2gen.load("double_pendulum")
    with pytest.raises(EnsembleError, match="more than the limit"):
        ensemble(s, members=10**12, perturb={"omega": 1e-10}, workers=0)
    with pytest.raises(EnsembleError, match="more than the limit"):
        member_table(s, sweep={"g": "1:2:1000000000"})
    with pytest.raises(EnsembleError, match="at most 1"):
        member_table(s, 4, perturb={"q": 1.5})
    with pytest.raises(SpecError, match="subdivisions at most 8"):
        s2gen.load("molecular:subdivisions=12")


@pytest.mark.timeout(20)
@pytest.mark.parametrize("spec", ["rope:n=100000000", "elastic_rod:n=100000000"])
def test_built_ins_sized_by_n_check_it_before_building(
    spec: str, capsys: Any, tmp_path: Path, monkeypatch: Any
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["simulate", spec]) == 2
    line = _one_error_line(capsys)
    assert f"n=100000000 bodies is more than the limit of {MAX_BODIES}" in line
    assert line.count(spec.split(":")[0]) == 1
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------- the limits themselves
def test_limits_are_where_they_say() -> None:
    """Each limit admits its own value and refuses the next one."""
    assert len(sweep_values(f"1:2:{MAX_MEMBERS}")) == MAX_MEMBERS
    with pytest.raises(EnsembleError):
        sweep_values(f"1:2:{MAX_MEMBERS + 1}")
    s = s2gen.load("double_pendulum")
    assert member_table(s, 2, perturb={"omega": MAX_PERTURBATION}).size("omega") == 1.0
    with pytest.raises(EnsembleError):
        member_table(s, 2, perturb={"omega": np.nextafter(MAX_PERTURBATION, 2.0)})
    # the icosphere's vertex count in closed form against the built mesh, then the limit
    for k in range(4):
        assert icosphere(k)[0].shape == (icosphere_vertices(k), 3)
    assert icosphere_vertices(MAX_SUBDIVISIONS) <= MAX_BODIES < icosphere_vertices(9)
    assert MAX_SUBDIVISIONS == 8
    with pytest.raises(ValueError, match="subdivisions at most 8"):
        icosphere(MAX_SUBDIVISIONS + 1)


# -------------------------------------------------------------------- every member failing
@pytest.mark.timeout(300)
@pytest.mark.parametrize(
    ("spec", "extra"),
    [
        ("three_bodies", ["--sweep", "gamma=30,40"]),  # the sweep figure
        ("three_bodies:gamma=30", ["--members", "3", "--perturb", "omega=1e-13"]),  # divergence
    ],
)
def test_a_run_whose_members_all_fail_writes_its_store_summary_and_figures(
    spec: str, extra: list[str], tmp_path: Path
) -> None:
    """gamma >= 30 makes the explicit VI step of three bodies infeasible before T = 0.5:
    every member fails, and the run still ends normally with everything written; the store's
    statuses and sample counts are those of each member integrated on its own."""
    out = tmp_path / "o"
    argv = ["ensemble", spec, *extra, "--h", "0.01", "--T", "0.5", "--workers", "0"]
    assert main([*argv, "--out", str(out)]) == 0
    store = EnsembleStore.open(out)
    per = store.per_member()
    assert (per["status"] == int(Status.INFEASIBLE)).all()
    system = s2gen.load(spec)
    model = s2gen.compile(system)
    table = member_table(
        system,
        int(extra[1]) if extra[0] == "--members" else None,
        {"omega": 1e-13} if "--perturb" in extra else None,
        {"gamma": "30,40"} if "--sweep" in extra else None,
        h=0.01,
        T=0.5,
    )
    for m in table.members:
        q0, w0 = initial_state(system, table, m)
        with pytest.raises(IntegrationError) as info:
            model.integrate("vi", 0.01, 0.5, q0=q0, omega0=w0, params=dict(m.params))
        assert info.value.status == Status.INFEASIBLE
        assert per["samples"][m.index] == len(info.value.partial.t)
    summary = (out / "summary.md").read_text()
    assert "**No member reached T**" in summary
    assert f"{len(table)} of {len(table)} members written" in summary
    fig = energy_plot(per, store.attrs)  # the figure itself says so
    assert f"all {len(table)} members failed: none reached T (see summary.md)" in [
        t.get_text() for t in fig.axes[0].texts
    ]
    figures = {"energy.png", "sweep.png" if "--sweep" in extra else "divergence.png"}
    for name in figures:
        assert (out / name).stat().st_size > 0
        assert f"![{name[:-4]}]({name})" in summary
