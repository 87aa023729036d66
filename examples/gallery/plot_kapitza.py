"""
Kapitza's pendulum: upright on a vibrating support
==================================================

A spherical pendulum whose support vibrates vertically, z_s(t) = a cos(W t), is a driven
system: written in the support's frame its potential m l (g - a W^2 cos(W t)) e3.q depends
on time (the built-in ``kapitza``, e3 up). Kapitza found that the inverted state q = e3 is
stable when a^2 W^2 > 2 g l. Here the pendulum starts 0.05 rad from the top, at rest, and
the emitted forced variational integrator runs it for 200 periods of the support on both
sides of the threshold.
"""

import matplotlib.pyplot as plt
import numpy as np

import s2gen

kapitza = s2gen.load("kapitza")
p = kapitza.parameters
print(f"threshold: W > sqrt(2 g l) / a = {np.sqrt(2 * p['g'] * p['l']) / p['a']:.1f} rad/s")

# %%
# Above the threshold (W = 60 rad/s) the pendulum swings slowly about the top; below it
# (W = 30 rad/s) it falls. The work W(t) the support does, and the energy-balance error
# E - E0 - W, come with each run.
fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
for rate in (60.0, 30.0):
    system = s2gen.load(f"kapitza:W={rate}")
    T = round(200 * 2 * np.pi / rate, 2)
    tr = s2gen.simulate(system, "vi", h=1e-3, T=T, every=5)
    angle = np.arctan2(np.hypot(tr.q[:, 0, 0], tr.q[:, 0, 1]), tr.q[:, 0, 2])
    ax1.plot(tr.t, angle, label=f"W = {rate:g} rad/s (a W = {p['a'] * rate:g} m/s)")
    ax2.plot(tr.t, np.abs(tr.balance) + 1e-16, label=f"W = {rate:g} rad/s")
    print(f"W = {rate:g}: largest angle from the top {angle.max():.3f} rad; "
          f"work done by the support {tr.work[-1]:.3g} J; max |E - E0 - W| "
          f"{np.abs(tr.balance).max():.2e} J")
ax1.set_ylabel("angle from the top [rad]")
ax1.legend()
ax2.set_yscale("log")
ax2.set_ylabel("|E - E0 - W| [J]")
ax2.set_xlabel("t [s]")
ax2.legend()
fig.tight_layout()
plt.show()
