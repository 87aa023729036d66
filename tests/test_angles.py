"""The spherical-angle form (angles.py) and its comparison with the S^2 form (compare_angles.py).

Checks against things independent of the emitted angle code: the hand-derived spherical
pendulum, the emitted S^2 module (same trajectory away from the poles), the strict compiler,
and the geometry of the chart (a body at a pole is an error naming it; a singular mass matrix
during a run is an error naming the body and the time).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from s2gen.build import STRICT_FLAGS
from s2gen.equations.angles import derive_angles
from s2gen.experiments import compare_angles as ca
from s2gen.runtime import Options, get_backend, simulate
from s2gen.runtime.angles import (
    AngleIntegrationError,
    PoleError,
    angle_backend,
    emit_angles,
    simulate_angles,
    to_angles,
)
from s2gen.spec import define_system
from s2gen.system import System
from s2gen.systems import builtin

M, L, G = 1.5, 2.0, 9.81


def pendulum() -> System:
    """A single spherical pendulum, hanging along +e3 (its rest position is the pole)."""
    return define_system(
        name="pendulum",
        bodies=1,
        parameters={"m": M, "l": L, "g": G},
        inertia=[["m*l**2"]],
        potential="-m*g*l*q1[2]",
    )


def angle_state(th: list[float], ph: list[float], thd: list[float], phd: list[float]):
    """(q, omega) of the given angles and rates."""
    th_, ph_, thd_, phd_ = (np.asarray(v, float) for v in (th, ph, thd, phd))
    q = np.stack([np.sin(th_) * np.cos(ph_), np.sin(th_) * np.sin(ph_), np.cos(th_)], axis=1)
    e_th = np.stack([np.cos(th_) * np.cos(ph_), np.cos(th_) * np.sin(ph_), -np.sin(th_)], axis=1)
    e_ph = np.stack([-np.sin(ph_), np.cos(ph_), np.zeros_like(ph_)], axis=1)
    qdot = thd_[:, None] * e_th + (np.sin(th_) * phd_)[:, None] * e_ph
    return q, np.cross(q, qdot)


AWAY = {  # states well away from the poles
    "pendulum": ([0.9], [0.3], [0.4], [0.7]),
    "double_pendulum": ([0.7, 1.1], [0.3, -0.5], [0.2, -0.3], [0.6, 0.4]),
}


def test_derived_equations_match_the_hand_derived_pendulum() -> None:
    eq = derive_angles(pendulum())
    th = eq.x[0]
    thd, phd = eq.xd
    m, l, g = sp.symbols("m l g", real=True)
    assert sp.simplify(eq.mass - sp.diag(m * l**2, m * l**2 * sp.sin(th) ** 2)) == sp.zeros(2)
    f_th = m * l**2 * sp.sin(th) * sp.cos(th) * phd**2 - m * g * l * sp.sin(th)
    f_ph = -2 * m * l**2 * sp.sin(th) * sp.cos(th) * thd * phd
    assert sp.simplify(eq.force[0] - f_th) == 0
    assert sp.simplify(eq.force[1] - f_ph) == 0


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_emitted_rhs_matches_the_hand_derived_pendulum(backend: str) -> None:
    be = angle_backend(pendulum(), backend)
    p = np.array([M, L, G])
    for th, thd, phd in [(0.9, 0.4, 0.7), (2.5, -1.2, 0.3), (0.05, 0.0, 3.0)]:
        status, xdd = be.rhs(np.array([th, 0.3]), np.array([thd, phd]), p)
        assert status == 0
        expect_th = np.sin(th) * np.cos(th) * phd**2 - G / L * np.sin(th)
        expect_ph = -2.0 * np.cos(th) / np.sin(th) * thd * phd
        assert xdd == pytest.approx([expect_th, expect_ph], rel=1e-13, abs=1e-13)


@pytest.mark.parametrize("name", sorted(AWAY))
def test_forms_agree_away_from_the_poles(name: str) -> None:
    """RK4 at a small step: the angle and S^2 forms follow the same trajectory to 1e-8."""
    system = pendulum() if name == "pendulum" else builtin(name)
    q0, w0 = angle_state(*AWAY[name])
    ang = simulate_angles(system, "rk4", "c", h=1e-3, T=1.0, q0=q0, omega0=w0)
    s2 = simulate(system, "rk4", "c", h=1e-3, T=1.0, q0=q0, omega0=w0)
    assert np.max(np.abs(ang.q - s2.q)) < 1e-8
    assert np.max(np.abs(ang.omega - s2.omega)) < 1e-8
    e2 = get_backend(system, "c")
    p = np.array(system.parameter_values)
    assert ang.energy[-1] == pytest.approx(e2.energy(ang.q[-1], ang.omega[-1], p), rel=1e-12)


def test_forms_agree_with_rk45_at_tight_tolerance() -> None:
    system = builtin("double_pendulum")
    q0, w0 = angle_state(*AWAY["double_pendulum"])
    opts = Options(rtol=1e-10, atol=1e-12)
    ang = simulate_angles(system, "rk45", "c", h=0.01, T=1.0, options=opts, q0=q0, omega0=w0)
    s2 = simulate(system, "rk45", "c", h=0.01, T=1.0, options=opts, q0=q0, omega0=w0)
    assert np.max(np.abs(ang.q - s2.q)) < 1e-8
    assert ang.counts[-1, 0] == ang.stats["steps"] > 0


@pytest.mark.parametrize("method", ["rk4", "rk45"])
def test_c_and_numpy_angle_modules_agree(method: str) -> None:
    system = builtin("double_pendulum")
    q0, w0 = angle_state(*AWAY["double_pendulum"])
    opts = Options(rtol=1e-7, atol=1e-9)
    h = 0.01
    c = simulate_angles(system, method, "c", h=h, T=0.5, options=opts, q0=q0, omega0=w0)
    n = simulate_angles(system, method, "numpy", h=h, T=0.5, options=opts, q0=q0, omega0=w0)
    assert np.max(np.abs(c.x - n.x)) < 1e-12
    assert np.max(np.abs(c.q - n.q)) < 1e-12
    assert np.array_equal(c.counts, n.counts)
    assert c.stats["rhs_evals"] == n.stats["rhs_evals"]


def test_to_angles_and_to_sphere_are_inverse() -> None:
    system = builtin("double_pendulum")
    q0, w0 = angle_state(*AWAY["double_pendulum"])
    for backend in ("c", "numpy"):
        be = angle_backend(system, backend)
        x, xd = to_angles(system, q0, w0, backend)
        assert x == pytest.approx([0.7, 0.3, 1.1, -0.5], abs=1e-14)
        assert xd == pytest.approx([0.2, 0.6, -0.3, 0.4], abs=1e-14)
        q, w = be.to_sphere(x, xd)
        assert np.max(np.abs(q - q0)) < 1e-15 and np.max(np.abs(w - w0)) < 1e-14


@pytest.mark.parametrize("name", ["double_pendulum", "chain3"])
def test_emitted_angle_c_compiles_strictly(name: str, tmp_path: Path) -> None:
    system = builtin(name) if name == "double_pendulum" else ca.chain_system(3)
    files = emit_angles(system, "c")
    for fname, text in files.items():
        (tmp_path / fname).write_text(text)
    c_file = next(f for f in files if f.endswith(".c"))
    subprocess.run(["gcc", *STRICT_FLAGS, "-O2", "-c", c_file], cwd=tmp_path, check=True)
    if shutil.which("g++"):
        header = next(f for f in files if f.endswith(".h"))
        cmd = ["g++", "-fsyntax-only", "-Wall", "-Werror", "-x", "c++", header]
        subprocess.run(cmd, cwd=tmp_path, check=True)


def test_emitted_angle_code_is_reproducible() -> None:
    system = builtin("double_pendulum")
    from s2gen.emit import clear_caches

    clear_caches()
    first = {lang: emit_angles(system, lang, cache=False) for lang in ("c", "numpy")}
    clear_caches()
    assert {lang: emit_angles(system, lang, cache=False) for lang in ("c", "numpy")} == first
    assert "do not edit" in first["c"]["double_pendulum_angles.c"].splitlines()[0]


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_body_at_a_pole_is_an_error_naming_it(backend: str) -> None:
    """The double pendulum starts with q2 = e3: phi_2 is undefined, reported, not a NaN."""
    with pytest.raises(PoleError, match="body 2 is at a pole at t = 0") as info:
        simulate_angles(builtin("double_pendulum"), "rk45", backend, h=0.01, T=0.1)
    assert info.value.body == 2 and info.value.time == 0.0


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_run_through_a_pole_is_an_error_naming_body_and_time(backend: str) -> None:
    """A free particle on a meridian reaches theta = 0 exactly at t = 0.5 (RK4, h = 0.25):
    M(x) is singular there; the run stops with the body, the step's time and valid samples."""
    free = define_system(
        name="free", bodies=1, parameters={"m": 1.0}, inertia=[["m"]], potential="0"
    )
    q0, w0 = angle_state([0.5], [0.0], [-1.0], [0.0])
    with pytest.raises(AngleIntegrationError, match=r"step from t = 0\.25.*body 1") as info:
        simulate_angles(free, "rk4", backend, h=0.25, T=1.0, q0=q0, omega0=w0)
    err = info.value
    assert (err.body, err.time, err.status) == (1, 0.25, 6)
    assert len(err.partial.t) == 2 and np.all(np.isfinite(err.partial.q))


def test_tilted_state_passes_beta_from_the_pole() -> None:
    """For a free body (great circle) the tilt beta is the distance of the pass from e3."""
    q0, w0 = np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 2.0, 0.0]])
    for beta in (0.1, 1e-3):
        q, w = ca.tilted_state(q0, w0, 0, 0.5, beta)
        assert np.linalg.norm(q[0]) == pytest.approx(1.0) and abs(q[0] @ w[0]) < 1e-15
        assert np.linalg.norm(w[0]) == pytest.approx(2.0)
        normal = w[0] / np.linalg.norm(w[0])
        assert np.arcsin(abs(normal[2])) == pytest.approx(beta, rel=1e-12)
        assert np.arccos(q[0, 2]) == pytest.approx(np.hypot(0.5, beta), rel=0.01)


def test_through_tilt_sends_the_double_pendulum_through_the_pole() -> None:
    system = builtin("double_pendulum")
    s = ca.Settings(T=1.0)
    star = ca.through_tilt(system, s, 1)
    state = ca.tilted_state(system.q0, system.omega0, 1, s.alpha, star)
    passage, when = ca._passage(system, s, state, 1, 1.0)
    assert abs(passage) < 1e-9 and 0.2 < when < 0.6
    state = ca.tilted_state(system.q0, system.omega0, 1, s.alpha, star + 1e-3)
    assert 5e-4 < abs(ca._passage(system, s, state, 1, 1.0)[0]) < 2e-3


def test_derivation_budget_stops_the_subprocess() -> None:
    assert ca.derive_with_budget(ca.chain_system(6), "angles-simplified", 0.5) is None


def test_cost_of_both_forms_of_a_pendulum() -> None:
    system = pendulum()
    costs = {c.form: c for c in ca.costs(system, ("s2", "angles"), 60.0, 2)}
    for c in costs.values():
        assert c.status == "ok" and c.ops > 0 and c.c_bytes > 0 and 0 < c.rhs_ns < 1e5
    assert costs["s2"].ops < costs["angles"].ops


def test_chain_system_inertia() -> None:
    s = ca.chain_system(3)
    assert s.inertia_numeric().tolist() == [[3.0, 2.0, 1.0], [2.0, 2.0, 1.0], [1.0, 1.0, 1.0]]


def test_cli_settings() -> None:
    p = argparse.ArgumentParser()
    ca.add_parser(p.add_subparsers(dest="command"))
    args = p.parse_args(["compare-angles", "double_pendulum", "--quick", "--tilts", "1e-3"])
    s = ca.settings_from_args(args)
    assert (s.T, s.chain_max, s.tilts) == (2.0, 3, (1e-3,))


@pytest.mark.slow
def test_compare_writes_report_and_figures(tmp_path: Path) -> None:
    s = ca.Settings(T=1.0, budget=60.0, tilts=(1e-3,), chain_max=2, repeats=1, windows=5)
    result = ca.compare(builtin("double_pendulum"), s, tmp_path, log=lambda _: None)
    names = sorted(p.name for p in result.files)
    assert "compare_angles.md" in names and "pole_steps.png" in names
    text = (tmp_path / "compare_angles.md").read_text()
    assert "cannot start (body at a pole)" in text
