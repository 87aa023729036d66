"""
LQR: a double inverted pendulum held upright through the step Jacobians
========================================================================

Two point masses on massless rods stand on a support that the controller accelerates
horizontally; in the support's frame (e3 up) the masses feel gravity and the inertial force
of the support's acceleration (ax, ay), the potential
V = (m1 + m2) l1 (a + g e3) . q1 + m2 l2 (a + g e3) . q2, which makes (ax, ay) the system's
inputs (``examples/control/double_inverted_pendulum.toml`` derives it). ``Model.linearize``
gives the exact derivatives of one step of the variational integrator at the upright
equilibrium, A and B of z+ = A z + B u in the tangent coordinates z of T(S^2)^2; SciPy's
``solve_discrete_are`` gives the discrete LQR gain, and the closed loop runs through
``Model.integrate`` with the feedback u = -K z computed in Python once per step.
``examples/control/`` runs the same design in C.
"""

import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg

import s2gen

pendulum = s2gen.load("""
name = "double_inverted_pendulum"
bodies = 2

[parameters]
m1 = 1.0
m2 = 1.0
l1 = 0.5
l2 = 0.5
g = 9.81

[inputs]
ax = 0.0
ay = 0.0

[inertia]
M = [["(m1 + m2)*l1**2", "m2*l1*l2"], ["m2*l1*l2", "m2*l2**2"]]

[potential]
V = "(m1 + m2)*l1*(ax*q1[0] + ay*q1[1] + g*q1[2]) + m2*l2*(ax*q2[0] + ay*q2[1] + g*q2[2])"
""")
model = s2gen.compile(pendulum)

# %%
# The linearization at the upright state q1 = q2 = e3, omega = 0, u = 0, for one VI step of
# h = 5 ms: A is 8 x 8 (per body two coordinates for q_i and two for omega_i, in an
# orthonormal basis of the tangent space), B is 8 x 2. The weights Q = I and R = I price a
# displacement of 1 rad (or 1 rad/s) like a support acceleration of 1 m/s^2.
h = 0.005
q_eq, w_eq = np.tile([0.0, 0.0, 1.0], (2, 1)), np.zeros((2, 3))
lin = model.linearize(q_eq, w_eq, h, "vi", u=[0.0, 0.0])
A, B, E = lin.A, lin.B, lin.basis_in
X = scipy.linalg.solve_discrete_are(A, B, np.eye(8), np.eye(2))
K = np.linalg.solve(np.eye(2) + B.T @ X @ B, B.T @ X @ A)
rho_open = np.abs(np.linalg.eigvals(A)).max()
rho_closed = np.abs(np.linalg.eigvals(A - B @ K)).max()
print(f"spectral radius of A: {rho_open:.6f} (unstable), of A - B K: {rho_closed:.6f}")
print(f"slowest closed-loop mode: {np.log(rho_closed) / h:.3f} /s")
x_eq = np.concatenate([q_eq.ravel(), w_eq.ravel()])


def feedback(t, q, w):
    """u = -K z, z = E^T (x - x_eq): the tangent coordinates of the state."""
    z = E.T @ (np.concatenate([q.ravel(), w.ravel()]) - x_eq)
    return -K @ z


# %%
# The closed loop from a 0.2 rad tilt of the first link, 10 s. The support's acceleration
# is the feedback's value at the start of each step, held over it. The tilt falls below
# 1e-6 rad in about 5 s; the support's acceleration (below, its first 2 s) is largest at
# the start.
tilt0 = 0.2
q0 = q_eq.copy()
q0[0] = [np.sin(tilt0) * np.cos(0.5), np.sin(tilt0) * np.sin(0.5), np.cos(tilt0)]
tr = model.integrate("vi", h=h, T=10.0, q0=q0, omega0=w_eq, inputs=feedback)
tilt = np.arctan2(np.hypot(tr.q[..., 0], tr.q[..., 1]), tr.q[..., 2])
u = np.array([feedback(t, q, w) for t, q, w in zip(tr.t, tr.q, tr.omega)])
unit = np.abs(np.linalg.norm(tr.q, axis=2) - 1.0).max()
print(f"tilt after 10 s: {tilt[-1].max():.2e} rad; max ||q_i| - 1| = {unit:.1e}")
print(f"largest |u|: {np.hypot(u[:, 0], u[:, 1]).max():.1f} m/s^2 (at t = 0)")

fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6))
for i in range(2):
    ax1.semilogy(tr.t, np.where(tilt[:, i] > 0, tilt[:, i], np.nan), label=f"link {i + 1}")
ax1.axhline(1e-6, color="gray", linestyle=":", linewidth=1)
ax1.set_ylabel("tilt from upright [rad]")
ax1.set_xlabel("t [s]")
ax1.legend()
ax2.plot(tr.t, u[:, 0], label="ax")
ax2.plot(tr.t, u[:, 1], label="ay")
ax2.set_xlim(0, 2)
ax2.set_ylabel("support acceleration [m/s^2]")
ax2.set_xlabel("t [s]")
ax2.legend()
fig.tight_layout()
plt.show()
