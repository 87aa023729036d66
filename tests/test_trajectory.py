"""Trajectory as a result: saved and loaded bit for bit with its metadata, its angular momentum
(against the emitted C's, sample by sample, and a conservation law), xarray and plot views,
and the progress reports of a running integration (which leave the run bit for bit alone)."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from s2gen.runtime import Options, get_backend, run, simulate
from s2gen.runtime.model import Model
from s2gen.runtime.trajectory import Trajectory
from s2gen.systems import builtin
from s2gen.version import __version__


@pytest.fixture(scope="module")
def rk45_run() -> Trajectory:
    opts = Options(rtol=1e-6, atol=1e-8, control="hairer")
    return simulate(builtin("double_pendulum"), "rk45", "c", h=0.01, T=2.0, options=opts)


def _same_arrays(a: Trajectory, b: Trajectory) -> None:
    for key in ("t", "q", "omega", "energy"):
        x, y = getattr(a, key), getattr(b, key)
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes(), key


def test_run_records_what_produced_it(rk45_run: Trajectory) -> None:
    s = builtin("double_pendulum")
    assert (rk45_run.system, rk45_run.spec_hash) == ("double_pendulum", s.spec_hash())
    assert (rk45_run.rtol, rk45_run.atol, rk45_run.control) == (1e-6, 1e-8, "hairer")
    assert rk45_run.version == __version__
    vi = simulate(s, "vi", "c", h=0.01, T=0.1)
    assert vi.rtol is None and vi.control is None  # a fixed-step run has no tolerances


def test_save_load_round_trip_is_bit_identical(tmp_path, rk45_run: Trajectory) -> None:
    tr = rk45_run.with_momentum(rk45_run.angular_momentum(builtin("double_pendulum")))
    path = tr.save(tmp_path / "run.npz")
    back = Trajectory.load(path)
    _same_arrays(tr, back)
    assert back.momentum is not None and tr.momentum is not None
    assert back.momentum.tobytes() == tr.momentum.tobytes()
    assert back.metadata == tr.metadata
    assert back.stats == tr.stats and back.stats["rejected"] >= 0
    # an old-style file with the arrays alone still loads
    np.savez(tmp_path / "old.npz", t=tr.t, q=tr.q, omega=tr.omega, energy=tr.energy)
    old = Trajectory.load(tmp_path / "old.npz")
    _same_arrays(tr, old)
    assert old.h == pytest.approx(0.01) and old.method == "unknown"


def test_save_writes_exactly_the_path_given_and_refuses_symlinks(tmp_path, rk45_run) -> None:
    path = rk45_run.save(tmp_path / "no_suffix")
    assert path == tmp_path / "no_suffix" and path.is_file()
    assert not (tmp_path / "no_suffix.npz").exists()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    (tmp_path / "link.npz").symlink_to(victim)
    with pytest.raises(ValueError, match="symbolic link"):
        rk45_run.save(tmp_path / "link.npz")
    assert victim.read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.npz", "no_suffix", "victim.txt"]


def test_angular_momentum_matches_the_emitted_code_sample_by_sample(rk45_run) -> None:
    """NumPy from M's entries here, the emitted C's NAME_angular_momentum there."""
    model = Model(builtin("double_pendulum"))
    J = rk45_run.angular_momentum(model)
    ref = np.array([model.angular_momentum(q, w) for q, w in zip(rk45_run.q, rk45_run.omega)])
    assert J.shape == (len(rk45_run.t), 3)
    np.testing.assert_allclose(J, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
    # parameters by name change M (m2 scales the coupling and the second body)
    J2 = rk45_run.angular_momentum(model, params={"m2": 2.0})
    ref2 = np.array(
        [model.angular_momentum(q, w, {"m2": 2.0}) for q, w in zip(rk45_run.q, rk45_run.omega)]
    )
    np.testing.assert_allclose(J2, ref2, rtol=0, atol=1e-12 * np.abs(ref2).max())


def test_angular_momentum_is_conserved_where_it_must_be() -> None:
    """Three bodies on a sphere: V depends on q_i . q_j only, so every component of J is
    conserved, and the VI keeps it to round-off."""
    s = builtin("three_bodies")
    J = simulate(s, "vi", "c", h=1e-3, T=2.0).angular_momentum(s)
    assert np.abs(J - J[0]).max() < 1e-12 * np.abs(J[0]).max()
    assert np.abs(J[0]).max() > 0.1


def test_plot_writes_a_png(tmp_path, rk45_run: Trajectory) -> None:
    pytest.importorskip("matplotlib")
    path = tmp_path / "errors.png"
    rk45_run.plot(path)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    assert width > 400 and height > 300


def test_to_xarray_carries_arrays_and_metadata(rk45_run: Trajectory) -> None:
    pytest.importorskip("xarray")
    tr = rk45_run.with_momentum(rk45_run.angular_momentum(builtin("double_pendulum")))
    ds = tr.to_xarray()
    assert ds["q"].dims == ("t", "body", "component")
    np.testing.assert_array_equal(ds["q"].values, tr.q)
    np.testing.assert_array_equal(ds["angular_momentum"].values, tr.momentum)
    np.testing.assert_array_equal(ds["t"].values, tr.t)
    assert ds.attrs["system"] == "double_pendulum" and ds.attrs["rtol"] == 1e-6
    assert ds.attrs["stats_steps"] == tr.stats["steps"]


def test_to_xarray_without_xarray_names_the_extra(monkeypatch, rk45_run) -> None:
    monkeypatch.setitem(sys.modules, "xarray", None)  # import xarray now raises ImportError
    with pytest.raises(ImportError, match=r"s2gen\[xarray\]") as info:
        rk45_run.to_xarray()
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("method", ["vi", "rattle", "rk4", "rk45"])
def test_progress_reports_without_changing_the_run(method: str, monkeypatch) -> None:
    """The progress callback reads how far the running C has come; the run is the same call,
    bit for bit, and the fractions it sees grow to 1."""
    monkeypatch.setattr("s2gen.runtime.c.POLL_SECONDS", 1e-3)
    be = get_backend(builtin("double_pendulum"), "c")
    one = run(be, method, 0.01, 30.0)
    seen: list[float] = []
    watched = run(be, method, 0.01, 30.0, progress=seen.append)
    _same_arrays(one, watched)
    assert seen == sorted(seen) and seen[-1] == 1.0 and 0 <= seen[0] <= 1
    assert watched.stats == one.stats


def test_progress_of_a_failed_run_keeps_every_valid_sample() -> None:
    """Three bodies with too large a step: the explicit VI becomes infeasible; with progress
    reports, the partial run equals the one without, and the last report is short of 1."""
    from s2gen.runtime import IntegrationError

    be = get_backend(builtin("three_bodies"), "c")
    with pytest.raises(IntegrationError) as one:
        run(be, "vi", 0.05, 200.0)
    seen: list[float] = []
    with pytest.raises(IntegrationError) as watched:
        run(be, "vi", 0.05, 200.0, progress=seen.append)
    assert watched.value.step == one.value.step and watched.value.status == one.value.status
    _same_arrays(one.value.partial, watched.value.partial)
    assert seen and seen[-1] < 1.0
