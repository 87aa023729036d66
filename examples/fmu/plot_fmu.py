"""Simulate the double pendulum's FMU with FMPy from Python and plot it.

Usage: ``python examples/fmu/plot_fmu.py [FMU] [--out PNG]`` (default: export
double_pendulum.fmu here first). Runs the FMU's Co-Simulation (the VI, h = 0.01) and its
Model Exchange under FMPy's CVODE, once on the Earth and once on the Moon (the parameter g set
through FMPy), and plots q2_z and the energy's drift of each run.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import fmpy
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import s2gen


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("fmu", nargs="?", default="double_pendulum.fmu")
    p.add_argument("--out", default="double_pendulum_fmu.png")
    p.add_argument("--stop-time", type=float, default=10.0)
    args = p.parse_args()
    path = Path(args.fmu)
    if not path.exists():
        s2gen.fmu(s2gen.load("double_pendulum"), path)
    fig, (ax_q, ax_e) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    for g in (9.81, 1.62):
        for kind, style in (("CoSimulation", "-"), ("ModelExchange", "--")):
            r = fmpy.simulate_fmu(str(path), stop_time=args.stop_time, output_interval=0.01,
                                  fmi_type=kind, relative_tolerance=1e-10,
                                  start_values={"g": g})  # fmt: skip
            label = f"{kind}, g = {g}"
            ax_q.plot(r["time"], r["q2_z"], style, label=label)
            ax_e.plot(r["time"], (r["energy"] - r["energy"][0]) / abs(r["energy"][0]), style,
                      label=label)  # fmt: skip
    ax_q.set_ylabel("q2_z")
    ax_e.set_ylabel("relative energy error")
    ax_e.set_xlabel("t")
    ax_q.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
