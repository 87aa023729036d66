"""Discrete LQR gains at the upright equilibrium of an inverted pendulum, written as a C header.

    python3 lqr_gains.py inverted_pendulum.toml build/inverted_pendulum/gains.h

The equilibrium is q_i = e3 for every body, omega = 0 and the inputs (the support's
acceleration) zero. `Model.linearize` gives the exact derivatives of one step of the
variational integrator there, in the tangent basis of T(S^2)^n (4n coordinates z: per body
two for the direction q_i, in rad, and two for omega_i, in rad/s):

    z+ = A z + B u.

SciPy's `solve_discrete_are` solves the discrete algebraic Riccati equation for the cost
sum_k z_k^T Q z_k + u_k^T R u_k, and the optimal feedback is u = -K z with
K = (R + B^T X B)^-1 B^T X A.

Q = I (4n x 4n) and R = I (inputs x inputs). The tangent basis is orthonormal, so z^T z is the
squared length of the displacement of (q, omega) from the equilibrium, angles in rad and
rates in rad/s; that norm does not depend on the frame chosen in the tangent planes, so the
controller treats every direction of tilt alike. R = I prices a support acceleration of
1 m/s^2 like a tilt of 1 rad: from a 0.2 rad tilt the largest |u| (at the start) is
3.9 m/s^2 for the single pendulum and 26 m/s^2 for the double one, and the slowest
closed-loop mode decays at 3.6 /s and 2.7 /s (spectral radius of A - B K 0.9823 and 0.9866
at h = 5 ms), fast enough to bring the tilt under 1e-6 rad well within 10 s.

The header gives the C controller the equilibrium x_eq (the 6n embedding coordinates: the 3n
components of q body-major, then the 3n of omega), the tangent basis E at it (6n x 4n,
`Linearization.basis_in`), the equilibrium inputs and K, so that the controller computes
z = E^T (x - x_eq) and u = u_eq - K z; and the names of the system's C API as LQR_* macros,
so that one control.c serves every system.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.linalg

import s2gen


@dataclass(frozen=True)
class Gains:
    """The LQR design at the upright equilibrium: the step's tangent-basis Jacobians A and B,
    the Riccati solution X, the gain K (u = u_eq - K z), the equilibrium (q, omega, u), the
    tangent basis there (6n x 4n), the step size and the method."""

    A: np.ndarray
    B: np.ndarray
    X: np.ndarray
    K: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    u: np.ndarray
    basis: np.ndarray
    h: float
    method: str


def upright(system: s2gen.System) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The upright equilibrium: every q_i = e3, omega = 0, the inputs zero."""
    q = np.tile([0.0, 0.0, 1.0], (system.n, 1))
    return q, np.zeros((system.n, 3)), np.zeros(len(system.inputs.names))


def lqr(
    system: s2gen.System,
    h: float | None = None,
    method: str = "vi",
    Q: np.ndarray | None = None,
    R: np.ndarray | None = None,
) -> Gains:
    """The discrete LQR gains of one step of `method` (step h, default the spec's) at the
    upright equilibrium, with the weights Q (default I, 4n x 4n) and R (default I)."""
    h = float(system.run.h if h is None else h)
    q, w, u = upright(system)
    lin = s2gen.compile(system).linearize(q, w, h, method, u=u)
    if not np.allclose(lin.q, q, rtol=0.0, atol=1e-14):
        raise ValueError(f"{system.name}: q = e3, omega = 0, u = 0 is not an equilibrium")
    A, B = lin.A, lin.B
    Q = np.eye(A.shape[0]) if Q is None else Q
    R = np.eye(B.shape[1]) if R is None else R
    X = scipy.linalg.solve_discrete_are(A, B, Q, R)
    K = np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A)
    return Gains(A, B, X, K, q, w, u, lin.basis_in, h, method)


def _array(name: str, values: np.ndarray) -> str:
    """A C array of doubles, written so that it reads back bit for bit."""
    dims = "".join(f"[{d}]" for d in values.shape)
    if values.ndim == 1:
        body = ", ".join(repr(float(v)) for v in values)
    else:
        rows = (", ".join(repr(float(v)) for v in row) for row in values)
        body = "\n    " + ",\n    ".join(f"{{{row}}}" for row in rows) + "\n"
    return f"static const double {name}{dims} = {{{body}}};\n"


def header(system: s2gen.System, gains: Gains, source: str) -> str:
    """The text of gains.h for `system` (its C API named after system.name)."""
    name, n = system.name, system.n
    upper = name.upper()
    eigs = np.abs(np.linalg.eigvals(gains.A - gains.B @ gains.K))
    macros = {
        "LQR_NBODIES": f"{upper}_NBODIES",
        "LQR_NSTATE": f"{upper}_NSTATE",
        "LQR_NTANGENT": str(4 * n),
        "LQR_NINPUTS": f"{upper}_NINPUTS",
        "LQR_NPARAMS": f"{upper}_NPARAMS",
        "LQR_WORK_SIZE": f"{upper}_WORK_SIZE",
        "LQR_OK": f"{upper}_OK",
        "LQR_METHOD": f"{upper}_METHOD_{gains.method.upper()}",
        "LQR_H": repr(gains.h),
        "LQR_NAME": f'"{name}"',
        "lqr_default_params": f"{name}_default_params",
        "lqr_step": f"{name}_step",
    }
    x_eq = np.concatenate([gains.q.ravel(), gains.omega.ravel()])
    return (
        f"/* Discrete LQR gains for {name} at its upright equilibrium, written by\n"
        f" * lqr_gains.py from {source}: one {gains.method} step of h = {gains.h!r} s,\n"
        f" * Q = I, R = I, u = LQR_U_EQ - LQR_K z with z = LQR_BASIS^T (x - LQR_X_EQ).\n"
        f" * Spectral radius of A - B K: {eigs.max():.6f} (of A: "
        f"{np.abs(np.linalg.eigvals(gains.A)).max():.6f}). */\n"
        "#ifndef LQR_GAINS_H\n#define LQR_GAINS_H\n\n"
        f'#include "{name}.h"\n\n'
        + "".join(f"#define {k} {v}\n" for k, v in macros.items())
        + "\n/* the equilibrium: q (3n, body-major), then omega (3n); its inputs */\n"
        + _array("LQR_X_EQ", x_eq)
        + _array("LQR_U_EQ", gains.u)
        + "\n/* the orthonormal tangent basis of T(S^2)^n at the equilibrium (6n x 4n) */\n"
        + _array("LQR_BASIS", gains.basis)
        + "\n/* the gain (inputs x 4n) */\n"
        + _array("LQR_K", gains.K)
        + "\n#endif\n"
    )


def main(argv: list[str] | None = None) -> None:
    """Compute the gains of a spec and write its gains.h."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("spec", type=Path, help="the system's TOML spec")
    parser.add_argument("out", type=Path, help="the header to write (gains.h)")
    parser.add_argument("--h", type=float, default=None, help="step size (default: the spec's)")
    args = parser.parse_args(argv)
    system = s2gen.load(args.spec)
    gains = lqr(system, args.h)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(header(system, gains, args.spec.name))
    rho = np.abs(np.linalg.eigvals(gains.A - gains.B @ gains.K)).max()
    print(f"{args.out}: K {gains.K.shape[0]} x {gains.K.shape[1]}, spectral radius {rho:.6f}")


if __name__ == "__main__":
    main()
