"""
A rope of 1000 links
====================

A rope of 1000 spherical pendula pinned at the origin (the ``rope`` built-in): total mass
1 kg, length 1 m, bending springs between neighbouring links, released at rest 60 degrees
from the vertical. Its inertia is given per body (diagonal plus max-index), so the generated
code is the same for any n (the tables of n numbers aside) and each step of the implicit VI is
O(n). The step 2e-5 resolves the rope's fastest motion at this n.
"""

import matplotlib.pyplot as plt
import numpy as np

import s2gen

rope = s2gen.load("rope:n=1000")
print(rope.n, "links; inertia:", rope.structure.kind.name, "; default h =", rope.run.h)

model = s2gen.compile(rope)
tr = model.integrate("vi", h=2e-5, T=0.1, every=50)
stats = tr.stats
print(
    f"{stats['steps']} steps in {tr.wall_time:.2f} s "
    f"({1e3 * tr.wall_time / stats['steps']:.2f} ms per step), "
    f"{stats['newton_iters'] / stats['steps']:.2f} Newton iterations per step"
)
print(f"max |E - E0| = {np.max(np.abs(tr.energy - tr.energy[0])):.2e} J")

# %%
# The rope's shape (joints at the partial sums of l_i q_i, l_i = 1 mm) as it starts to fall,
# and the energy error.
fig, (ax_s, ax_e) = plt.subplots(1, 2, figsize=(10, 4.5))
for k, j in enumerate(np.linspace(0, len(tr.t) - 1, 5).astype(int)):
    joints = np.vstack([[0, 0, 0], 1e-3 * np.cumsum(tr.q[j], axis=0)])
    ax_s.plot(joints[:, 0], joints[:, 2], color=plt.cm.viridis(k / 4), label=f"t = {tr.t[j]:.3g}")
ax_s.set_xlabel("x (m)")
ax_s.set_ylabel("z (m)")
ax_s.set_aspect("equal")
ax_s.legend(fontsize=8)
ax_e.plot(tr.t, np.abs(tr.energy - tr.energy[0]))
ax_e.set_xlabel("t (s)")
ax_e.set_ylabel(r"$|E - E_0|$ (J)")
fig.tight_layout()
plt.show()
