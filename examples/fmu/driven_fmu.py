"""Simulate FMUs of driven systems with FMPy from Python and plot them.

Usage: ``python examples/fmu/driven_fmu.py [--out PNG] [--folder DIR]``. Exports two
Co-Simulation FMUs (FMI 2) into DIR (default: here) and runs them with FMPy:

- ``kapitza.fmu``, the Kapitza pendulum (its potential depends on t): the angle from the top
  with the support's drive above Kapitza's threshold (W = 60, the spec's) and below it
  (W = 30, set through FMPy's start values), where the inverted pendulum falls;
- ``inverted_pendulum.fmu`` (examples/control/), whose input is the support's acceleration
  (ax, ay, az): FMPy holds it at values from an input table, the pendulum released 0.3 rad
  from the top falls, and the FMU's ``work`` output balances its energy.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import fmpy
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import s2gen

HERE = Path(__file__).resolve().parent


def kapitza(folder: Path, ax: plt.Axes) -> None:
    """The angle from the top (q = e3) over 5 s, above and below the threshold."""
    path = s2gen.fmu(s2gen.load("kapitza"), folder / "kapitza.fmu", method="vi")
    for W in (60.0, 30.0):
        r = fmpy.simulate_fmu(str(path), stop_time=5.0, output_interval=0.005,
                              start_values={"W": W})  # fmt: skip
        ax.plot(r["time"], np.degrees(np.arccos(np.clip(r["q1_z"], -1, 1))), label=f"W = {W:g}")
    ax.set_ylabel("Kapitza: angle from the top [deg]")
    ax.legend(fontsize=8)


def inverted(folder: Path, ax_tilt: plt.Axes, ax_energy: plt.Axes) -> None:
    """The support pushed along e1 for 0.4 s, then along -e1: the tilt, and the energy
    against the work the inputs did (their jumps of V)."""
    spec = HERE.parent / "control" / "inverted_pendulum.toml"
    path = s2gen.fmu(s2gen.load(spec), folder / "inverted_pendulum.fmu", method="vi4")
    # a step at each switch: the same time twice (FMPy then applies the new value from it)
    table = [(0.0, 3.0), (0.4, 3.0), (0.4, -4.0), (0.8, -4.0), (0.8, 0.0), (1.5, 0.0)]
    signal = np.array([(t, a, 0.0, 0.0) for t, a in table],
                      dtype=[("time", float), ("ax", float), ("ay", float), ("az", float)])  # fmt: skip
    free = fmpy.simulate_fmu(str(path), stop_time=1.5, output_interval=0.01)
    pushed = fmpy.simulate_fmu(str(path), stop_time=1.5, output_interval=0.01, input=signal)
    for r, label in ((free, "no input"), (pushed, "ax from FMPy's table")):
        ax_tilt.plot(r["time"], np.arccos(np.clip(r["q1_z"], -1, 1)), label=label)
    ax_tilt.set_ylabel("inverted pendulum: tilt [rad]")
    ax_tilt.legend(fontsize=8)
    e = pushed["energy"] - pushed["energy"][0]
    ax_energy.plot(pushed["time"], e, label="E - E0")
    ax_energy.plot(pushed["time"], pushed["work"], "--", label="work (output)")
    ax_energy.set_ylabel("energy [J]")
    ax_energy.legend(fontsize=8)
    print(f"inverted pendulum: max |E - E0 - work| = {np.abs(e - pushed['work']).max():.2e} J")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="driven_fmu.png")
    p.add_argument("--folder", default=".")
    args = p.parse_args()
    folder = Path(args.folder)
    folder.mkdir(parents=True, exist_ok=True)
    fig, (ax_k, ax_t, ax_e) = plt.subplots(3, 1, figsize=(8, 9))
    kapitza(folder, ax_k)
    inverted(folder, ax_t, ax_e)
    for a in (ax_k, ax_t, ax_e):
        a.set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
