"""
The double pendulum as an FMU, simulated by FMPy
================================================

``s2gen.fmu`` writes a system as a Functional Mock-up Unit (FMI 2 or 3, Co-Simulation and Model
Exchange) that Modelica tools, co-simulation masters and FMPy load. Here FMPy, a third-party
importer, runs its Co-Simulation (the variational integrator inside ``doStep``) and its Model
Exchange under FMPy's own CVODE, on the Earth and on the Moon (the parameter ``g`` set through
FMPy), beside ``s2gen.simulate`` of the same system.
"""

import tempfile
from pathlib import Path

import fmpy
import matplotlib.pyplot as plt
import numpy as np
from fmpy.validation import validate_fmu

import s2gen

pendulum = s2gen.load("double_pendulum")
path = Path(tempfile.mkdtemp()) / "double_pendulum.fmu"
s2gen.fmu(pendulum, path)
print(path.name, f"{path.stat().st_size} bytes;", "problems:", validate_fmu(str(path)))

# %%
# Co-Simulation with the VI (h = 0.01 inside each 0.01 communication interval) gives the very
# steps ``s2gen.simulate`` takes; Model Exchange hands the field to CVODE, which does not keep
# the unit length of q_i by construction.
fig, (ax_q, ax_e) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5))
for g, colour in ((9.81, "C0"), (1.62, "C2")):
    ours = s2gen.simulate(pendulum, "vi", h=0.01, T=10.0, params={"g": g})
    for kind, style in (("CoSimulation", "-"), ("ModelExchange", ":")):
        r = fmpy.simulate_fmu(
            str(path), stop_time=10.0, output_interval=0.01, fmi_type=kind,
            relative_tolerance=1e-10, start_values={"g": g},
        )  # fmt: skip
        if kind == "CoSimulation":
            gap = np.max(np.abs(r["q2_z"] - ours.q[:, 1, 2]))
            print(
                f"g = {g}: Co-Simulation against s2gen.simulate, max |q2_z difference| = {gap:.1e}"
            )
        ax_q.plot(r["time"], r["q2_z"], style, color=colour, lw=0.8, label=f"{kind}, g = {g}")
        drift = np.abs(r["energy"] - r["energy"][0]) / abs(r["energy"][0])
        ax_e.semilogy(r["time"][1:], np.maximum(drift[1:], 1e-17), style, color=colour, lw=0.8)
ax_q.set_ylabel("q2_z")
ax_e.set_ylabel(r"$|E - E_0|\ /\ |E_0|$")
ax_e.set_xlabel("t")
ax_q.legend(fontsize=8)
fig.tight_layout()
plt.show()
