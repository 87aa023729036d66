"""
Work against precision on the double pendulum
=============================================

The error of the final state against the time a run takes, for a few methods on the emitted C:
the variational integrator and RATTLE (order 2), their compositions of orders 4 and 8, the
classical RK4, and the adaptive RK45 and DOP853 over their tolerances. Each run keeps only
the final state and evaluates no energy, so storage costs no method anything; each time is the
best of three runs. The reference is DOP853 at tolerance 1e-13.
"""

import time

import matplotlib.pyplot as plt
import numpy as np

import s2gen

model = s2gen.compile(s2gen.load("double_pendulum"))
T = 10.0
reference = model.integrate("dop853", h=T, T=T, options=s2gen.Options(rtol=1e-13, atol=1e-13))
q_ref = reference.q[-1]


def measure(method, h, options=None):
    """(seconds, error of the final q) of one run, the best time of three."""
    best = np.inf
    for _ in range(3):
        start = time.perf_counter()
        tr = model.integrate(method, h=h, T=T, options=options, every=round(T / h), energy=False)
        best = min(best, time.perf_counter() - start)
    return best, float(np.max(np.abs(tr.q[-1] - q_ref)))


steps = [0.05, 0.02, 0.01, 0.005, 0.002, 0.001]
fine = [*steps, 5e-4, 2e-4]
fixed = {"vi": fine, "rattle": fine, "vi4": steps, "rattle8": steps[:4], "rk4": steps}
results = {m: [measure(m, h) for h in hs] for m, hs in fixed.items()}
tolerances = [1e-4, 1e-6, 1e-8, 1e-10, 1e-12]
for m in ("rk45", "dop853"):
    results[m] = [measure(m, T, s2gen.Options(rtol=tol, atol=tol)) for tol in tolerances]

for m, points in results.items():
    cheapest = min((t for t, e in points if e < 1e-6), default=None)
    shown = "none of these runs" if cheapest is None else f"{1e3 * cheapest:.3f} ms"
    print(f"{m:8s} fastest run with error < 1e-6: {shown}")

# %%
# Lower left is better. The geometric methods' errors fall with slope equal to their order;
# the adaptive methods' are set by the tolerance. Errors near 1e-12 meet round-off (and the
# reference's own error), where smaller steps stop helping.
fig, ax = plt.subplots(figsize=(7, 5))
for (m, points), marker in zip(results.items(), "os^vDxP"):
    seconds, errors = np.array(points).T
    ax.loglog(errors, seconds, marker=marker, label=m)
ax.set_xlabel(r"error of the final state, max $|q - q_{ref}|$ at T = 10")
ax.set_ylabel("wall time (s)")
ax.grid(True, which="major", alpha=0.3)
ax.legend()
fig.tight_layout()
plt.show()
