"""The figure of the control examples: the tilt of each link against time, on a log scale,
from the C programs' own runs.

    python3 plot_tilt.py build/inverted_pendulum/control \
        build/double_inverted_pendulum/control --out tilt.png

(`make figure` runs this.) Each program runs from its default 0.2 rad tilt with the state
printed after every step (its TRACE argument), and the tilt of link i is the angle of q_i from
e3.
"""

from __future__ import annotations

import argparse
import subprocess

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def run(program: str, steps: int = 2000) -> tuple[str, np.ndarray, np.ndarray]:
    """Run a control program tracing `steps` steps: its system's name, the times (initial
    state first) and the tilts (one column per link)."""
    out = subprocess.run(
        [program, "0.2", str(steps)], capture_output=True, text=True, check=True
    ).stdout
    name = out.split(":", 1)[0]
    rows = np.array([line.split()[2:] for line in out.splitlines() if line.startswith("state ")])
    rows = rows.astype(float)
    t, x = rows[:, 0], rows[:, 1:]
    n = x.shape[1] // 6
    q = x[:, : 3 * n].reshape(len(t), n, 3)
    q0 = np.tile([0.0, 0.0, 1.0], (n, 1))
    q0[0] = [np.sin(0.2) * np.cos(0.5), np.sin(0.2) * np.sin(0.5), np.cos(0.2)]
    q = np.concatenate([q0[None], q])
    tilt = np.arctan2(np.hypot(q[..., 0], q[..., 1]), q[..., 2])
    return name, np.concatenate([[0.0], t]), tilt


def main() -> None:
    """Plot the tilts of the programs given on the command line."""
    parser = argparse.ArgumentParser(description="tilt against time of the control programs")
    parser.add_argument("programs", nargs="+", help="the built control programs")
    parser.add_argument("--out", default="tilt.png", help="the PNG to write")
    args = parser.parse_args()
    fig, ax = plt.subplots(figsize=(7, 4))
    for program in args.programs:
        name, t, tilt = run(program)
        for i in range(tilt.shape[1]):
            label = f"{name}, link {i + 1}" if tilt.shape[1] > 1 else name
            ax.semilogy(t, np.where(tilt[:, i] > 0.0, tilt[:, i], np.nan), label=label)
    ax.axhline(1e-6, color="gray", linestyle=":", linewidth=1)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("tilt from upright [rad]")
    ax.set_title("discrete LQR through the step Jacobians (VI, h = 5 ms)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
