"""
The sphere against spherical angles near the pole
=================================================

The same double pendulum written in spherical angles (theta_i, phi_i) has a chart
singularity at the poles, where phi_i is undefined and the angle form's mass matrix is
singular. s2gen can emit the angle form from the same spec (the runtime's angle backend, also
used by ``s2gen compare-angles``): here both forms integrate states in which body 2 passes
closer and closer to the pole, against a tight S² reference.
"""

import matplotlib.pyplot as plt
import numpy as np

import s2gen
from s2gen.runtime.angles import AngleIntegrationError, PoleError, simulate_angles

pendulum = s2gen.load("double_pendulum")
model = s2gen.compile(pendulum)

# %%
# The spec's own initial state has body 2 exactly on the pole: the angle form refuses it.
try:
    simulate_angles(pendulum, "rk4", h=0.01, T=1.0)
except PoleError as exc:
    print("angle form:", exc)

# %%
# Body 2 moved back along its motion by alpha = 0.39 rad and tilted by beta about its
# direction of motion passes near the pole at t of about 0.32 (body 1 pulls it aside, so the
# miss is not beta itself). `miss(beta)` measures on a tight S² run (DOP853, tolerance 1e-12)
# the signed distance from the pole as body 2 crosses over it; bisection finds the tilt
# beta* that sends it through the pole, and beta* + delta passes about delta away.
alpha, h, T = 0.39, 0.01, 1.0
tight = s2gen.Options(rtol=1e-12, atol=1e-12)
loose = s2gen.Options(rtol=1e-6, atol=1e-9)


def tilted(beta):
    q, w = pendulum.q0.copy(), pendulum.omega0.copy()
    q[1] = [-np.sin(alpha), -np.cos(alpha) * np.sin(beta), np.cos(alpha) * np.cos(beta)]
    w[1] = [0.0, np.cos(beta), np.sin(beta)]
    return q, w


def miss(beta):
    q0, w0 = tilted(beta)
    ref = model.integrate("dop853", h=1e-4, T=0.5, q0=q0, omega0=w0, options=tight)
    x, y = ref.q[:, 1, 0], ref.q[:, 1, 1]
    k = int(np.argmax(x > 0))  # first sample past the pole's meridian plane x = 0
    return y[k - 1] + x[k - 1] / (x[k - 1] - x[k]) * (y[k] - y[k - 1])


lo, hi = 0.0, 0.03  # miss(lo) > 0 > miss(hi)
for _ in range(40):
    mid = 0.5 * (lo + hi)
    lo, hi = (mid, hi) if miss(mid) > 0 else (lo, mid)
through = 0.5 * (lo + hi)
print(f"beta* = {through:.6f} rad passes {abs(miss(through)):.1e} from the pole")


def error(q, ref):
    """Largest distance of any q_i from the reference over the run."""
    return float(np.max(np.linalg.norm(q - ref.q, axis=2)))


rows = []
for delta in (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 0.0):
    q0, w0 = tilted(through + delta)
    ref = model.integrate("dop853", h=h, T=T, q0=q0, omega0=w0, options=tight)
    s2_rk4 = model.integrate("rk4", h=h, T=T, q0=q0, omega0=w0)
    s2_rk45 = model.integrate("rk45", h=h, T=T, q0=q0, omega0=w0, options=loose)
    row = {
        "pass": abs(miss(through + delta)),
        "S2 rk4": error(s2_rk4.q, ref),
        "S2 rk45": error(s2_rk45.q, ref),
        "S2 rk45 steps": s2_rk45.stats["steps"],
    }
    for method in ("rk4", "rk45"):
        try:
            ang = simulate_angles(pendulum, method, h=h, T=T, q0=q0, omega0=w0, options=loose)
            row[f"angles {method}"] = error(ang.q, ref)
            row[f"angles {method} steps"] = ang.stats["steps"]
        except (AngleIntegrationError, PoleError) as exc:  # the failure, named by the runtime
            row[f"angles {method}"] = row[f"angles {method} steps"] = np.nan
            print(f"pass {row['pass']:.1e}: {exc}".split("; body")[0])
    rows.append(row)

print(
    f"{'pass':>8} {'S2 rk4':>9} {'ang rk4':>9} {'S2 rk45':>9} {'ang rk45':>9} "
    f"{'steps S2':>8} {'steps ang':>9}"
)
for r in rows:
    print(
        f"{r['pass']:8.1e} {r['S2 rk4']:9.1e} {r['angles rk4']:9.1e} {r['S2 rk45']:9.1e} "
        f"{r['angles rk45']:9.1e} {r['S2 rk45 steps']:8d} {r['angles rk45 steps']:9.0f}"
    )

# %%
# The S² form's error does not depend on where the motion goes; the angle form's grows as the
# pass nears the pole (fixed steps), or costs ever more steps (adaptive).
rows = [r for r in rows if r["pass"] > 1e-6]  # the pass through the pole has no place on a log axis
passes = np.array([r["pass"] for r in rows])
fig, (ax_err, ax_steps) = plt.subplots(1, 2, figsize=(10, 4))
for key, style in (
    ("S2 rk4", "o-C0"),
    ("angles rk4", "s--C3"),
    ("S2 rk45", "o-C2"),
    ("angles rk45", "s--C1"),
):
    ax_err.loglog(passes, [r[key] for r in rows], style[:-2], color=style[-2:], label=key)
ax_err.set_xlabel("closest approach of body 2 to the pole")
ax_err.set_ylabel(r"max $\|q - q_{ref}\|$ over $t \leq 1$")
ax_err.legend(fontsize=8)
ax_steps.semilogx(passes, [r["S2 rk45 steps"] for r in rows], "o-", color="C2", label="S2 rk45")
ax_steps.semilogx(
    passes, [r["angles rk45 steps"] for r in rows], "s--", color="C1", label="angles rk45"
)
ax_steps.set_xlabel("closest approach of body 2 to the pole")
ax_steps.set_ylabel("accepted RK45 steps (rtol 1e-6)")
ax_steps.legend(fontsize=8)
for ax in (ax_err, ax_steps):
    ax.invert_xaxis()
fig.tight_layout()
plt.show()
