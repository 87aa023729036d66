"""
An ensemble: how fast nearby double pendula part
=================================================

The double pendulum is chaotic: two runs that start 1e-10 apart in their angular velocities
part exponentially, so a single run says little about the trajectory and much about the
statistics. ``s2gen.ensemble`` integrates many perturbed members of one system with the emitted
C (here one after another in this process, ``workers=0``; on a Dask cluster with ``workers=K``
or a scheduler's address) and streams them into one Zarr store.
"""

import tempfile

import matplotlib.pyplot as plt
import numpy as np

import s2gen
from s2gen.ensemble import EnsembleStore

out = tempfile.mkdtemp()
run = s2gen.ensemble.ensemble(
    "double_pendulum", members=12, perturb={"omega": 1e-10}, T=100.0, every=20, workers=0, out=out
)
print(f"{run.written} members written in {run.wall_time:.1f} s to {run.path.name}")

# %%
# Member 0 is the unperturbed reference. Each other member's distance from it in q, at every
# stored sample (every 20th step, h = 0.01): straight lines on the log axis are exponential
# separation; the envelope's slope estimates the largest Lyapunov exponent.
store = EnsembleStore.open(run.path)
t = np.asarray(store.array("t")[0])
q = np.asarray(store.array("q"))  # member x sample x body x component
t, distance = t[1:], np.linalg.norm(q[1:, 1:] - q[:1, 1:], axis=(2, 3))  # 0 at t = 0 (q equal)
mean = np.exp(np.mean(np.log(distance), axis=0))  # geometric mean over the members
fig, ax = plt.subplots(figsize=(7, 4))
for d in distance:
    ax.semilogy(t, d, lw=0.6, color="C0", alpha=0.6)
ax.semilogy(t, mean, color="C3", label="geometric mean")
ax.set_xlabel("t")
ax.set_ylabel(r"$\|q^{(k)} - q^{(0)}\|$")
ax.legend()
fig.tight_layout()
window = (t > 2.0) & (t < 80.0)
rate = np.polyfit(t[window], np.log(mean[window]), 1)[0]
print(f"the separation grows like exp({rate:.2f} t) between t = 2 and 80")
plt.show()
