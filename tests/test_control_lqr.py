"""examples/control: the discrete LQR through the step Jacobians, built and run with its Makefile.

For each pendulum (about 10 s for the double one with an empty build cache) the C program
must hold it upright (final tilt below 1e-6 rad after 10 s from a 0.2 rad tilt, its
own output, |q_i| = 1 to 1e-12), and the closed loop is checked apart from the program:
- the gain K read back from the generated gains.h makes the step's linearization stable
  (spectral radius of A - B K below 1, A and B from `Model.linearize`), where the open loop
  (K = 0) and the wrong sign (A + B K) are unstable;
- the nonlinear C run, traced step by step, agrees with the linear recursion
  z+ = (A - B K) z in the header's tangent coordinates z = E^T (x - x_eq) to second order in
  the tilt (the error shrinks at least 3.5-fold when the tilt halves), and its tilt decays at
  the rate of the slowest closed-loop mode, ln(rho(A - B K)) / h, over the last 5 s;
- a gains.h with K = 0 builds a program that lets the pendulum fall (exit status 1).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import re
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import s2gen

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "control"
SINGLE, DOUBLE = "inverted_pendulum", "double_inverted_pendulum"
#: The steps traced for the comparison with the linear recursion (0.1 s at h = 5 ms)
TRACE = 20


def _make(build: Path, *targets: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [
            "make",
            "-C",
            str(EXAMPLE),
            *targets,
            f"BUILD={build}",
            f"S2GEN={sys.executable} -m s2gen",
            f"PYTHON={sys.executable}",
        ],
        capture_output=True,
        text=True,
        check=False,
    )


def _array(header: str, name: str) -> np.ndarray:
    """A static const double array of gains.h, as numbers (its shape from its declaration)."""
    match = re.search(rf"{name}((?:\[\d+\])+) = \{{(.*?)\}};", header, re.DOTALL)
    assert match is not None, name
    shape = tuple(int(d) for d in re.findall(r"\d+", match.group(1)))
    numbers = re.findall(r"[-+]?\d+\.?\d*(?:e[-+]?\d+)?", match.group(2))
    return np.array([float(v) for v in numbers]).reshape(shape)


def _gains_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("lqr_gains", EXAMPLE / "lqr_gains.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["lqr_gains"] = module  # its dataclass looks its module up while defined
    spec.loader.exec_module(module)
    return module


def _after(stdout: str) -> tuple[float, float]:
    """The final tilt and the largest | |q_i| - 1 | of a run, from its last line."""
    last = next(line for line in stdout.splitlines() if line.startswith("after "))
    tilt = float(last.split("tilt ")[1].split(" rad")[0])
    return tilt, float(last.split("= ")[1])


def _trace(stdout: str) -> tuple[np.ndarray, np.ndarray]:
    """The traced states of a run: times and the embedding coordinates x = (q, omega)."""
    rows = [line.split()[2:] for line in stdout.splitlines() if line.startswith("state ")]
    data = np.array(rows, dtype=float)
    return data[:, 0], data[:, 1:]


def _table(stdout: str) -> dict[float, float]:
    """The once-per-second rows of a run: t -> the largest tilt of its links."""
    out = {}
    for line in stdout.splitlines():
        fields = line.split()
        if len(fields) >= 3 and re.fullmatch(r"\d+\.\d\d", fields[0]):
            out[float(fields[0])] = max(float(v) for v in fields[1:-1])
    return out


def _start(n: int, tilt: float) -> np.ndarray:
    """The program's initial state (first link `tilt` rad from e3 towards azimuth 0.5)."""
    q = np.tile([0.0, 0.0, 1.0], (n, 1))
    q[0] = [np.sin(tilt) * np.cos(0.5), np.sin(tilt) * np.sin(0.5), np.cos(tilt)]
    return np.concatenate([q.ravel(), np.zeros(3 * n)])


def _check(name: str, build: Path) -> None:
    """Build and run `name`'s program and check it and its closed loop (module docstring)."""
    target = "run" if name == SINGLE else "run-double"
    proc = _make(build, target)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    tilt, unit = _after(proc.stdout)
    assert tilt < 1e-6 and unit < 1e-12, (tilt, unit)

    header = (build / name / "gains.h").read_text()
    K, E, x_eq = _array(header, "LQR_K"), _array(header, "LQR_BASIS"), _array(header, "LQR_X_EQ")
    system = s2gen.load(EXAMPLE / f"{name}.toml")
    n, h = system.n, float(system.run.h)
    ni = len(system.inputs.names)
    lin = s2gen.compile(system).linearize(
        x_eq[: 3 * n].reshape(n, 3), x_eq[3 * n :].reshape(n, 3), h, "vi", u=np.zeros(ni)
    )
    A, B = lin.A, lin.B
    assert np.allclose(lin.basis_in, E, atol=1e-15)

    def radius(M: np.ndarray) -> float:
        return float(np.abs(np.linalg.eigvals(M)).max())

    closed = A - B @ K
    assert radius(closed) < 1.0, radius(closed)
    assert radius(A) > 1.0 and radius(A + B @ K) > 1.0, (radius(A), radius(A + B @ K))

    # the asymptotic decay of the nonlinear run is the slowest closed-loop mode's
    rows = _table(proc.stdout)
    rate = np.log(rows[10.0] / rows[5.0]) / 5.0
    assert rate == pytest.approx(np.log(radius(closed)) / h, rel=0.01), rate

    # the nonlinear run against z+ = (A - B K) z, to second order in the tilt
    errors = []
    for tilt0 in (0.02, 0.01):
        run = subprocess.run(
            [str(build / name / "control"), str(tilt0), str(TRACE)],
            capture_output=True,
            text=True,
            check=True,
        )
        _, x = _trace(run.stdout)
        z = E.T @ (_start(n, tilt0) - x_eq)
        worst = 0.0
        for k in range(TRACE):
            z = closed @ z
            worst = max(worst, float(np.abs(E.T @ (x[k] - x_eq) - z).max()))
        errors.append(worst)
        assert worst < 2.0 * tilt0**2, (tilt0, worst)
    # at least second order (third, in fact: a half turn about e3 maps the system to itself
    # and z, u to -z, -u, so the step's second-order terms vanish at the upright state)
    assert errors[0] / errors[1] > 3.5, errors

    # K = 0 in gains.h: the same program lets the pendulum fall
    broken = build.parent / f"{build.name}-zero"
    made = _make(broken, str(broken / name / f"{name}.c"))
    assert made.returncode == 0, made.stdout[-2000:] + made.stderr[-2000:]
    lqr_gains = _gains_module()
    gains = lqr_gains.lqr(system)
    zero = dataclasses.replace(gains, K=np.zeros_like(gains.K))
    (broken / name / "gains.h").write_text(lqr_gains.header(system, zero, f"{name}.toml"))
    made = _make(broken, str(broken / name / "control"))
    assert made.returncode == 0, made.stdout[-2000:] + made.stderr[-2000:]
    fallen = subprocess.run(
        [str(broken / name / "control")], capture_output=True, text=True, check=False
    )
    assert fallen.returncode == 1, fallen.stdout[-2000:] + fallen.stderr[-2000:]
    # without control the energy holds the largest tilt above 0.16 rad (single: 0.2 rad)
    assert _after(fallen.stdout)[0] > 0.1


def test_lqr_holds_the_inverted_pendulum(tmp_path: Path) -> None:
    _check(SINGLE, tmp_path / "build")


def test_lqr_holds_the_double_inverted_pendulum(tmp_path: Path) -> None:
    _check(DOUBLE, tmp_path / "build")
