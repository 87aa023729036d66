"""The Python API is one shape whichever door a run comes through: parameters by name in
`simulate` as in `Model.integrate`, the angular momentum filled by every path, a trajectory
that rebuilds its own system (built-in or user TOML, also after save and load), `to_xarray`
carrying J, `metadata` an attribute, and `plot` drawing the motion beside the errors.

J is checked against the emitted C's own angular-momentum routine (`Model.angular_momentum`,
one state at a time), which the NumPy computation in `Trajectory` does not use.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import s2gen

USER_SPEC = """
name = "tethered"
bodies = 2
[parameters]
m = 1.3
k = 4.0
g = 9.81
[inertia]
M = [["2*m", "m/2"], ["m/2", "m"]]
[potential]
V = "m*g*(q1[2] + q2[2]) + k/2*dot(q1 - q2, q1 - q2)"
[initial]
q = [[0.6, 0.0, 0.8], [0.0, 0.6, -0.8]]
omega = [[0.0, 1.0, 0.0], [0.5, 0.0, 0.0]]
[run]
h = 0.01
T = 0.5
"""


def _c_momentum(model: s2gen.Model, tr: s2gen.Trajectory, params: dict[str, float]) -> np.ndarray:
    return np.array(
        [model.angular_momentum(q, w, params) for q, w in zip(tr.q, tr.omega, strict=True)]
    )


def test_simulate_takes_parameters_by_name_as_integrate_does() -> None:
    system = s2gen.load("double_pendulum")
    by_name = s2gen.simulate(system, h=0.01, T=0.5, params={"g": 1.62})
    model = s2gen.compile(system)
    via_model = model.integrate(h=0.01, T=0.5, params={"g": 1.62})
    in_order = s2gen.simulate(system, h=0.01, T=0.5, params=[1.0, 1.0, 9.81, 9.81, 1.62])
    for tr in (via_model, in_order):
        assert tr.q.tobytes() == by_name.q.tobytes()
    assert by_name.params == {**system.parameters, "g": 1.62}
    with pytest.raises(ValueError, match="unknown parameter 'G'"):
        s2gen.simulate(system, h=0.01, T=0.5, params={"G": 1.62})


def test_every_path_fills_the_angular_momentum_at_the_run_parameters() -> None:
    system = s2gen.load("double_pendulum")
    model = s2gen.compile(system)
    params = {"m2": 3.0}
    runs = [
        s2gen.simulate(system, h=0.01, T=0.3, params=params),
        model.integrate(h=0.01, T=0.3, params=params),
        s2gen.compile(system, "numpy").integrate(h=0.01, T=0.3, params=params),
    ]
    expected = _c_momentum(model, runs[0], params)
    for tr in runs:
        assert tr.momentum is not None
        np.testing.assert_allclose(
            tr.momentum, _c_momentum(model, tr, params), rtol=1e-12, atol=1e-12
        )
    np.testing.assert_allclose(runs[0].momentum, expected, rtol=1e-12, atol=1e-12)


def test_a_user_toml_trajectory_rebuilds_its_system_after_save_and_load(tmp_path: Path) -> None:
    spec = tmp_path / "tethered.toml"
    spec.write_text(USER_SPEC)
    system = s2gen.load(spec)
    tr = s2gen.simulate(system, params={"m": 2.0})
    back = s2gen.Trajectory.load(tr.save(tmp_path / "t.npz"))
    spec.unlink()  # the trajectory file alone is enough
    assert back.rebuild().spec_hash() == system.spec_hash()
    J = back.angular_momentum()
    np.testing.assert_allclose(J, _c_momentum(s2gen.compile(system), tr, {"m": 2.0}), rtol=1e-12)
    assert J.tobytes() == back.momentum.tobytes()
    with pytest.raises(AssertionError):  # at the spec's m the momentum differs: params count
        np.testing.assert_allclose(back.angular_momentum(params={"m": 1.3}), J)


def test_a_builtin_with_options_is_rebuilt_with_them() -> None:
    tr = s2gen.simulate(s2gen.load("rope:n=5,kappa=0.3"), h=0.001, T=0.01)
    assert tr.spec == "rope:n=5,kappa=0.3"
    assert tr.rebuild().n == 5 and tr.rebuild().parameters["kappa"] == 0.3


def test_a_system_defined_in_python_asks_for_the_system() -> None:
    system = s2gen.define(
        name="spin",
        bodies=1,
        parameters={"m": 1.0},
        diagonal=["m"],
        potential="0",
        initial_q=[[1.0, 0.0, 0.0]],
        initial_omega=[[0.0, 0.0, 1.0]],
    )
    tr = s2gen.simulate(system, h=0.1, T=1.0)
    with pytest.raises(ValueError, match="does not record its spec .* pass the System"):
        tr.angular_momentum()
    assert tr.angular_momentum(system) == pytest.approx(tr.momentum)


def test_to_xarray_carries_the_angular_momentum_and_metadata_is_an_attribute(
    tmp_path: Path,
) -> None:
    tr = s2gen.simulate(s2gen.load("double_pendulum"), h=0.01, T=0.2, params={"g": 2.0})
    ds = tr.to_xarray()
    assert ds["angular_momentum"].dims == ("t", "component")
    np.testing.assert_array_equal(ds["angular_momentum"].values, tr.momentum)
    assert ds.attrs["param_g"] == 2.0 and ds.attrs["spec"] == "double_pendulum"
    assert isinstance(tr.metadata, dict) and tr.metadata["params"]["g"] == 2.0
    arrays = dict(np.load(tr.save(tmp_path / "t.npz")))  # a file without J: rebuilt from spec
    del arrays["angular_momentum"]
    np.savez(tmp_path / "bare.npz", **arrays)
    bare = s2gen.Trajectory.load(tmp_path / "bare.npz")
    assert bare.momentum is None
    np.testing.assert_allclose(bare.to_xarray()["angular_momentum"].values, tr.momentum)


def test_plot_draws_the_motion_beside_the_errors(tmp_path: Path) -> None:
    tr = s2gen.simulate(s2gen.load("double_pendulum"), h=0.01, T=1.0)
    fig = tr.plot(tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 10_000
    top, side, heights, energy, unit = fig.axes
    for i in range(2):  # each body's tip path, from above and from the side
        path_xy = top.lines[1 + 2 * i].get_xydata()
        np.testing.assert_array_equal(path_xy, tr.q[:, i, :2])
        np.testing.assert_array_equal(side.lines[1 + 2 * i].get_xydata(), tr.q[:, i, ::2])
        np.testing.assert_array_equal(heights.lines[i].get_ydata(), tr.q[:, i, 2])
    dE = energy.lines[0].get_ydata()
    np.testing.assert_allclose(dE[1:], np.abs(tr.energy - tr.energy[0])[1:])
    assert unit.get_yscale() == "log" and energy.get_yscale() == "log"
