"""The energy check around a run: a state where V is infinite is refused before integrating,
and a run whose relative energy error passes `Options.energy_warn` warns, names the first
sample, records it and keeps its numbers (status 0 on the command line).

The yardsticks are independent of the check: the energy scale is recomputed here from the
reference backend's energy and gradient (or is a closed form), the first sample from the
trajectory's own energies, and a tight DOP853 run of the same motion stays silent.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import s2gen
from s2gen.cli import main
from s2gen.runtime import get_backend

BLOW_UP = {"h": 0.1, "T": 10.0}  # three_bodies' VI at 100 times its spec's step


def _reference_scale(system: s2gen.System) -> float:
    """K0 + |V0| + sum_i |tangential grad_i V(q0)|, from the reference backend."""
    ref = get_backend(system, "reference")
    p = np.array(system.parameter_values)
    q, w = system.q0, system.omega0
    V = ref.energy(q, np.zeros_like(w), p)
    K = ref.energy(q, w, p) - V
    g = ref.gradient(q, p).reshape(-1, 3)
    g_tan = g - np.sum(g * q, axis=1)[:, None] * q
    return float(K + abs(V) + np.linalg.norm(g_tan, axis=1).sum())


def test_a_blow_up_warns_once_naming_the_first_sample_past_the_threshold() -> None:
    system = s2gen.load("three_bodies")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tr = s2gen.simulate(system, "vi", **BLOW_UP)
    drift = [w for w in caught if issubclass(w.category, s2gen.EnergyDriftWarning)]
    assert len(drift) == 1 and "\n" not in str(drift[0].message)
    scale = _reference_scale(system)
    rel = np.abs(tr.energy - tr.energy[0]) / scale
    assert rel.max() > 1.0  # an honest blow-up: the error exceeds the whole energy scale
    first = int(np.flatnonzero(rel > 1e-2)[0])
    assert tr.drift_sample == first and tr.energy_warn == 1e-2
    assert tr.energy_scale == pytest.approx(scale, rel=1e-12)
    assert f"at sample {first} (t = {tr.t[first]:.6g})" in str(drift[0].message)
    assert np.all(np.isfinite(tr.q))  # the numbers are kept as computed


def test_a_tight_adaptive_run_of_the_same_motion_stays_silent() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", s2gen.EnergyDriftWarning)
        tr = s2gen.simulate(
            s2gen.load("three_bodies"), "dop853", **BLOW_UP, options=s2gen.Options(rtol=1e-10)
        )
    assert tr.drift_sample is None and tr.energy_scale is not None


@pytest.mark.parametrize("threshold", [0.0, np.inf, 1e3])
def test_the_threshold_is_an_option_and_0_or_inf_switch_it_off(threshold: float) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", s2gen.EnergyDriftWarning)
        tr = s2gen.simulate(
            s2gen.load("three_bodies"),
            "vi",
            **BLOW_UP,
            options=s2gen.Options(energy_warn=threshold),
        )
    assert tr.drift_sample is None


def test_a_negative_threshold_is_refused() -> None:
    with pytest.raises(ValueError, match="energy_warn = -1.0: must be >= 0"):
        s2gen.simulate(
            s2gen.load("three_bodies"), "vi", **BLOW_UP, options=s2gen.Options(energy_warn=-1.0)
        )


def test_the_scale_of_a_state_where_the_energy_is_zero_is_m_g_l() -> None:
    """A pendulum released at rest with its rod horizontal has E0 = K0 = V0 = 0; the scale is
    the energy its potential exchanges over one radian, m g l, not 0."""
    from s2gen.runtime.diagnostics import energy_scale

    m, g, l = 2.0, 9.81, 0.7
    pendulum = s2gen.define(
        name="pendulum",
        bodies=1,
        parameters={"m": m, "g": g, "l": l},
        diagonal=["m*l**2"],
        potential="m*g*l*q1[2]",
        initial_q=[[1.0, 0.0, 0.0]],
        initial_omega=[[0.0, 0.0, 0.0]],
    )
    be = get_backend(pendulum, "c")
    S = energy_scale(be, pendulum.q0, pendulum.omega0, np.array([m, g, l]))
    assert S == pytest.approx(m * g * l, rel=1e-15)
    tr = s2gen.simulate(pendulum, "vi", h=0.001, T=2.0)
    assert tr.drift_sample is None  # |E - E0| of the VI stays far below 1e-2 m g l


def test_the_command_line_ends_with_one_warning_line_and_status_0(tmp_path: Path, capsys) -> None:
    out = tmp_path / "t.npz"
    argv = ["simulate", "three_bodies", "--h", "0.1", "--T", "10", "--out", str(out)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warning: three_bodies: vi on c: the relative")
    meta = json.loads(str(np.load(out)["metadata"]))
    tr = s2gen.Trajectory.load(out)
    assert meta["drift_sample"] == tr.drift_sample and f"sample {tr.drift_sample} " in lines[0]
    assert tr.metadata["energy_warn"] == 1e-2
    assert main([*argv, "--energy-warn", "0"]) == 0
    assert capsys.readouterr().err == ""
    assert s2gen.Trajectory.load(out).drift_sample is None


COINCIDENT = """
name = "charges"
bodies = 2
[parameters]
k = 1.0
[inertia]
diagonal = [1.0, 1.0]
[potential]
V = "k/norm(q1 - q2)"
[initial]
q = [[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
omega = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
[run]
h = 0.01
T = 1.0
"""


def test_an_initial_state_where_V_is_infinite_is_refused_before_the_run(
    tmp_path: Path, capsys
) -> None:
    spec = tmp_path / "charges.toml"
    spec.write_text(COINCIDENT)
    out = tmp_path / "t.npz"
    assert main(["simulate", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: charges: at the initial state the ")
    assert "is not finite" in err and not out.exists() and list(tmp_path.iterdir()) == [spec]
    for backend in ("c", "numpy", "reference"):
        with pytest.raises(ValueError, match="at the initial state the gradient of V on body 1"):
            s2gen.simulate(s2gen.load(spec), "vi", backend)
