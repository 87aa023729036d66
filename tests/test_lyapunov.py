"""Lyapunov spectra (`Model.lyapunov`, `s2gen lyapunov`) against independent answers: the
symplectic pairing and zero sum of a conservative system, the volume contraction rate of a
damped one in closed form, the divergence of two nearby trajectories integrated by
`Model.integrate` with renormalization, exponents near zero for small oscillations, and the
frame's products against `Model.linearize`'s tangent Jacobians multiplied here."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from s2gen import load
from s2gen.cli import main
from s2gen.runtime.linearize import tangent_basis
from s2gen.runtime.lyapunov import tangent_normals
from s2gen.runtime.model import Model
from s2gen.spec import load_spec_text

H = 0.01

#: Two pendula (diagonal M) coupled through their potential, pushed periodically and damped
#: by F_i = -c_i w_i x q_i (see `test_damped_sum_is_the_volume_contraction_rate`)
DAMPED = """
name = "damped_pair"
bodies = 2
[parameters]
m1 = 1.0
m2 = 2.0
g = 9.81
k = 3.0
c1 = 0.3
c2 = 0.5
a = 4.0
[inertia]
diagonal = ["m1", "m2"]
[potential]
V = "g*(m1*q1[2] + m2*q2[2]) + k*dot(q1, q2) + a*cos(1.7*t)*q1[0]"
[forces]
F1 = "-c1*cross(w1, q1)"
F2 = "-c2*cross(w2, q2)"
[initial]
q = [[0.6, 0.0, 0.8], [0.0, 0.6, -0.8]]
omega = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]
"""


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _tangent(q: np.ndarray, w: np.ndarray) -> np.ndarray:
    return w - np.sum(w * q, axis=1, keepdims=True) * q


#: A chaotic state of the double pendulum (both bodies high, fast)
CHAOTIC_Q = _unit(np.array([[1.0, 0.0, 1.0], [0.0, 1.0, -1.0]]))
CHAOTIC_W = _tangent(CHAOTIC_Q, np.array([[0.0, 1.5, 0.0], [1.0, 0.0, 0.0]]))


@pytest.fixture(scope="module")
def chaotic(double: Model):  # type: ignore[no-untyped-def]
    return double.lyapunov(CHAOTIC_Q, CHAOTIC_W, H, 200.0, "vi", transient=10.0)


def test_conservative_spectrum_pairs_and_sums_to_zero(chaotic) -> None:  # type: ignore[no-untyped-def]
    """The VI is symplectic: its exponents come in +- pairs, lambda_k + lambda_(9-k) = 0, and
    sum to zero, each within three of its block errors (the sum's finite-time part, the log
    of the ratio of the symplectic volume to the tangent coordinates' at the two ends, over T,
    is far below them); the spectrum is decreasing, with a positive largest exponent well
    above its error and four near zero (energy, time, the vertical angular momentum and its
    angle)."""
    ls = chaotic
    assert ls.exponents.shape == (8,) and ls.pair_sums.shape == (4,)
    assert np.all(np.abs(ls.pair_sums) <= 3 * ls.pair_error + 1e-3), (ls.pair_sums, ls.pair_error)
    assert abs(ls.total) <= 3 * ls.total_error + 1e-3, (ls.total, ls.total_error)
    assert ls.exponents[0] > 5 * ls.error[0]
    assert np.all(np.abs(ls.exponents[2:6]) < 0.05), ls.exponents
    assert ls.exponents[0] >= ls.exponents[1] >= max(ls.exponents[2:6])
    assert ls.running.shape == (400, 8) and np.isclose(ls.times[-1], 200.0)
    assert np.allclose(ls.running[-1], ls.exponents, 0, 1e-12)


def _two_trajectories(model: Model, q, w, T: float, transient: float, tau: float = 1.0) -> float:  # type: ignore[no-untyped-def]
    """The largest exponent from two nearby trajectories of `Model.integrate` (VI), their
    separation renormalized to d0 every tau (Benettin's two-trajectory method)."""
    d0 = 1e-8
    rng = np.random.default_rng(0)
    tr = model.integrate("vi", H, transient, q, w, energy=False)
    q, w = tr.q[-1], tr.omega[-1]

    def near(dq: np.ndarray, dw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = np.sqrt(np.sum(dq**2) + np.sum(dw**2))
        q2 = _unit(q + d0 * dq / d)
        return q2, _tangent(q2, w + d0 * dw / d)

    q2, w2 = near(rng.normal(size=q.shape), rng.normal(size=w.shape))
    logs = 0.0
    for _ in range(round(T / tau)):
        a = model.integrate("vi", H, tau, q, w, energy=False)
        b = model.integrate("vi", H, tau, q2, w2, energy=False)
        q, w = a.q[-1], a.omega[-1]
        dq, dw = b.q[-1] - q, b.omega[-1] - w
        logs += np.log(np.sqrt(np.sum(dq**2) + np.sum(dw**2)) / d0)
        q2, w2 = near(dq, dw)
    return float(logs / T)


def test_largest_exponent_matches_two_trajectories(double: Model, chaotic) -> None:  # type: ignore[no-untyped-def]
    """lambda_1 against the divergence of two trajectories 1e-8 apart (Model.integrate, no
    Jacobian), over the same time from the same state: within three block errors."""
    two = _two_trajectories(double, CHAOTIC_Q, CHAOTIC_W, 200.0, 10.0)
    assert abs(chaotic.exponents[0] - two) <= 3 * chaotic.error[0], (chaotic.exponents[0], two)


def test_small_oscillations_have_exponents_near_zero(double: Model) -> None:
    """Small oscillations about the hanging equilibrium (q_i = e_z) are (nearly) linear and regular:
    tangent vectors grow at most linearly, so every exponent is O(log(T)/T), here below 0.05
    over T = 200 (the chaotic state's largest is about 0.35)."""
    q = _unit(np.array([[0.03, 0.0, 1.0], [0.0, 0.02, 1.0]]))  # e_z points down
    w = _tangent(q, np.array([[0.0, 0.01, 0.0], [0.02, 0.0, 0.0]]))
    ls = double.lyapunov(q, w, H, 200.0, "vi", transient=10.0)
    assert np.all(np.abs(ls.exponents) < 0.05), ls.exponents


def test_damped_sum_is_the_volume_contraction_rate() -> None:
    """For F_i = -c_i w_i x q_i and diagonal M, q_i x F_i = -c_i w_i: each body's two
    tangential velocity components decay at the rate c_i / M_ii, and the potential (time
    dependent or not) moves no volume (Liouville), so the phase-space volume contracts at the
    constant rate sum_i 2 c_i / M_ii and the exponents sum to -2 (c1/m1 + c2/m2) = -1.1 here
    (the symplectic volume and the tangent coordinates' differ by a bounded factor, which
    averages away). Checked within three block errors plus 1 %, with the forced VI and RK4."""
    model = Model(load_spec_text(DAMPED))
    s = model.system
    rate = -2 * (0.3 / 1.0 + 0.5 / 2.0)
    for name in ("vi", "rk4"):
        ls = model.lyapunov(s.q0, s.omega0, H, 60.0, name, transient=5.0)
        assert abs(ls.total - rate) <= 3 * ls.total_error + 0.01 * abs(rate), (name, ls.total)


def test_frame_products_are_linearize_tangent_jacobians(double: Model) -> None:
    """The run's frame, projected in the embedding, against QR of the tangent A of
    `Model.linearize` multiplied here step by step: the same exponents to 1e-10 (vi and rk4,
    whose steps leave T(S^2)^n and are projected); and `tangent_normals` completes the
    tangent basis to an orthonormal basis of the embedding."""
    s = double.system
    steps = 60
    for name in ("vi", "rk4"):
        q, w = s.q0, s.omega0
        Q, logs = np.eye(8), np.zeros(8)
        for _ in range(steps):
            lin = double.linearize(q, w, H, name)
            Q, R = np.linalg.qr(lin.A @ Q)
            logs += np.log(np.abs(np.diag(R)))
            q, w = lin.q, lin.omega
        ls = double.lyapunov(s.q0, s.omega0, H, steps * H, name, blocks=2, samples=1)
        assert np.allclose(ls.exponents, logs / (steps * H), 0, 1e-10), name
    full = np.hstack([tangent_basis(q, w), tangent_normals(q, w)])
    assert np.allclose(full.T @ full, np.eye(12), 0, 1e-14)


def test_lyapunov_command_prints_the_spectrum_and_writes_csv_and_plot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The command's numbers are Model.lyapunov's; the CSV holds the running estimates, the
    last row the spectrum printed."""
    out = tmp_path / "ly"
    args = ["lyapunov", "double_pendulum", "--T", "2", "--transient", "0.5", "--out", str(out)]
    assert main([*args, "--no-progress"]) == 0
    text = capsys.readouterr().out
    s = load("double_pendulum")
    ls = Model(s).lyapunov(s.q0, s.omega0, 0.01, 2.0, "vi", transient=0.5)
    assert f"lambda_1   {ls.exponents[0]:+.6f} +- {ls.error[0]:.6f}" in text
    assert f"lambda_1 + lambda_8 = {ls.pair_sums[0]:+.6f}" in text
    table = np.loadtxt(out / "lyapunov.csv", delimiter=",", skiprows=1)
    assert table.shape == (200, 9) and np.allclose(table[-1, 1:], ls.exponents, 0, 1e-12)
    assert (out / "lyapunov.png").stat().st_size > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["double_pendulum", "--h", "0"], "h = 0.0: must be positive"),
        (["double_pendulum", "--T", "0.05", "--blocks", "10"], "fewer than 10 blocks"),
        (["double_pendulum", "--method", "rk45"], "method 'rk45' has no step Jacobian"),
        (["rope:n=40"], "at most 32 bodies"),
        (["no_such_system"], "no_such_system"),
    ],
)
def test_lyapunov_command_bad_input_is_one_line(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["lyapunov", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_lyapunov_command_checks_out_before_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["lyapunov", "double_pendulum", "--T", "1", "--out", str(blocker)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --out") and err.count("\n") == 1, err


@pytest.mark.slow
def test_paper_state_spectrum_over_a_long_run(double: Model) -> None:
    """The double pendulum from the paper's initial state over T = 1000 (10^5 VI steps, the
    spectrum the docs report): pairs and total zero within three block errors, four
    exponents within 0.01 of zero, and lambda_1 against two trajectories over the same time."""
    s = double.system
    ls = double.lyapunov(s.q0, s.omega0, H, 1000.0, "vi", transient=10.0)
    assert np.all(np.abs(ls.pair_sums) <= 3 * ls.pair_error), (ls.pair_sums, ls.pair_error)
    assert abs(ls.total) <= 3 * ls.total_error, (ls.total, ls.total_error)
    assert np.all(np.abs(ls.exponents[2:6]) < 0.01), ls.exponents
    two = _two_trajectories(double, s.q0, s.omega0, 1000.0, 10.0)
    assert abs(ls.exponents[0] - two) <= 3 * ls.error[0], (ls.exponents[0], two)
