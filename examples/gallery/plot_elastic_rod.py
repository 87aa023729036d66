"""
The elastic rod
===============

The paper's fourth example: a clamped rod of n + 1 rigid elements (n = 10 move) joined by
bending springs, kicked at element 5. Its inertia is a chain's (diagonal plus max-index), so
every coupled solve is O(n). The motion is chaotic (perturbations of 1e-13 grow like e^(28 t)),
so only statistics such as the mean energy error are reproducible; the paper gives 1.431e-6
for the VI at h = 1e-4.
"""

import matplotlib.pyplot as plt
import numpy as np

import s2gen

rod = s2gen.load("elastic_rod")
print(rod.n, "moving elements; inertia structure:", rod.structure.kind.name)

model = s2gen.compile(rod)
vi = model.integrate("vi", h=1e-4, T=3.0)
rk45 = model.integrate("rk45", h=1e-4, T=3.0)  # ode45's control, samples every 1e-4
for tr in (vi, rk45):
    dE = np.abs(tr.energy - tr.energy[0])
    print(f"{tr.method:5s} mean |E - E0| = {dE.mean():.4e}, {1e3 * tr.wall_time:.0f} ms")

# %%
# The shape of the rod: the clamped element 0 lies along e1, and each moving element i adds
# its length l / (n + 1) along q_i.
n = rod.n
ell = 1.1 / (n + 1)
fig, (ax_s, ax_e) = plt.subplots(1, 2, figsize=(10, 4))
for k, t in enumerate((0.0, 0.05, 0.1, 0.2, 0.4)):
    j = round(t / vi.h)
    joints = [ell, 0, 0] + ell * np.cumsum(vi.q[j], axis=0)
    points = np.vstack([[0, 0, 0], [ell, 0, 0], joints])
    ax_s.plot(
        points[:, 0], points[:, 1], "o-", ms=3, color=plt.cm.viridis(k / 4), label=f"t = {t:g}"
    )
ax_s.set_xlabel("x (m)")
ax_s.set_ylabel("y (m)")
ax_s.set_aspect("equal")
ax_s.legend(fontsize=8)
ax_s.set_title("top view")
for tr, colour in ((vi, "C0"), (rk45, "C3")):
    ax_e.semilogy(
        tr.t[1:], np.abs(tr.energy - tr.energy[0])[1:], lw=0.6, color=colour, label=tr.method
    )
ax_e.set_xlabel("t (s)")
ax_e.set_ylabel(r"$|E - E_0|$ (J)")
ax_e.legend()
fig.tight_layout()
plt.show()
