"""Figures of the paper's numerical examples, in the paper's style (PNG, matplotlib Agg).

Input: an `ExampleResult` from `reproduce.py` (runs with trajectories, the system) and an
output folder. Output: PNG files, one per figure of the paper:

- ``<example>.png``: (a) the motion, (b) total energy against time, (c) unit-length error
  against time (log scale), every method on one plot in the paper's colours (RK: blue dotted,
  VI: red solid, RK2 with projection: black dashed);
- ``three_bodies.png``: (a) trajectories on the sphere, (b) energy error and (c) unit-length
  error against step size (log-log; RK2 blue squares, VI red circles; the step-size axis is
  labelled at the measured step sizes only);
- ``molecular_kinetic.png``: the kinetic-energy distribution over a 5120-face icosphere at
  t = 0, 0.25, 0.5, 0.75 and 5 (each face: mean kinetic energy of the molecules within the face
  and the faces sharing a vertex with it; blue, green, yellow, red in ascending order), with a
  caption stating the viewing direction and the x, y, z axes drawn as seen.

The rod's snapshots are coloured by time with a colour bar beside the panel (a legend of nine
times covered the rod).

Figures are drawn on `matplotlib.figure.Figure` objects (no pyplot, no global state).

Example:
    >>> from pathlib import Path
    >>> from s2gen.experiments.reproduce import reproduce
    >>> report = reproduce(["double_pendulum"], "/tmp/s2", quick=True)  # doctest: +SKIP
    >>> sorted(p.name for p in report.examples[0].figures)  # doctest: +SKIP
    ['double_pendulum.png']
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import mpl_toolkits.mplot3d  # noqa: F401  (registers the "3d" projection)
import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.colors import LinearSegmentedColormap, Normalize
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from s2gen import System

    from .records import ExampleResult, RunResult

__all__ = [
    "STYLES",
    "example_figures",
    "face_kinetic_energy",
    "kinetic_energy",
    "plot_kinetic_distribution",
]

#: Line style per method: the paper's colours (RK blue dotted, VI red solid, projection black).
STYLES: dict[str, dict[str, Any]] = {
    "vi": {"color": "red", "linestyle": "-", "label": "VI"},
    "rk45": {"color": "blue", "linestyle": ":", "label": "RK45"},
    "rk2": {"color": "blue", "linestyle": ":", "label": "RK2"},
    "rk2-proj": {"color": "black", "linestyle": "--", "label": "RK2 with projection"},
    "rk4": {"color": "green", "linestyle": "-.", "label": "RK4"},
    "vi4": {"color": "darkorange", "linestyle": "-", "label": "VI (4th order)"},
    "rattle": {"color": "purple", "linestyle": "--", "label": "RATTLE"},
}

#: Marker per method on the step-size plots (RK2 blue squares, VI red circles).
MARKERS = {
    "vi": "o",
    "rk2": "s",
    "rk2-proj": "^",
    "rk4": "D",
    "rk45": "v",
    "vi4": "P",
    "rattle": "X",
}

#: Unit of the printed energies, per example ("" for dimensionless).
ENERGY_UNITS = {"double_pendulum": "m g l", "three_bodies": "", "molecular": ""}

#: Times of the kinetic-energy panels (the paper's figure).
KINETIC_TIMES = (0.0, 0.25, 0.5, 0.75, 5.0)

#: Blue, green, yellow, red in ascending order.
KINETIC_CMAP = LinearSegmentedColormap.from_list("bgyr", ["blue", "green", "yellow", "red"])

_MAX_POINTS = 20000
_CUBE = np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
_DPI = 120


# -------------------------------------------------------------------------------- entry point
def example_figures(ex: ExampleResult, out: str | Path) -> list[Path]:
    """Draw an example's figures into `out`; return the PNG paths.

    Example:
        >>> example_figures(ex, "/tmp/s2")  # doctest: +SKIP
        [PosixPath('/tmp/s2/double_pendulum.png')]
    """
    out = Path(out)
    name = ex.example.name
    if name == "three_bodies" and len({r.run.h for r in ex.runs}) > 1:
        paths = [_step_size_figure(ex, out / f"{name}.png")]
    else:
        paths = [_time_figure(ex, out / f"{name}.png")]
    if name == "molecular":
        paths.append(_kinetic_figure(ex, out / f"{name}_kinetic.png"))
    return paths


def _save(fig: Figure, path: Path) -> Path:
    fig.savefig(path, dpi=_DPI)
    return path


def _with_trajectory(ex: ExampleResult) -> list[RunResult]:
    return [r for r in ex.runs if r.trajectory is not None and len(r.trajectory.t) > 1]


def _motion_run(ex: ExampleResult) -> RunResult:
    """The run whose motion is drawn: VI with the smallest step, else the first available."""
    runs = _with_trajectory(ex)
    vi = sorted((r for r in runs if r.run.method == "vi"), key=lambda r: r.run.h)
    return (vi or runs)[0]


def _stride(n: int) -> int:
    return max(1, n // _MAX_POINTS)


def _energy_unit(ex: ExampleResult) -> str:
    """The printed energies' unit, for axis labels."""
    return ENERGY_UNITS.get(ex.example.name, "N m") or "dimensionless"


# ------------------------------------------------------------------------- time-history figure
def _time_figure(ex: ExampleResult, path: Path) -> Path:
    """(a) motion, (b) total energy, (c) unit-length error against time."""
    fig = Figure(figsize=(16, 4.8), layout="constrained")
    motion = fig.add_subplot(1, 3, 1, projection="3d")
    energy, unit = fig.add_subplot(1, 3, 2), fig.add_subplot(1, 3, 3)
    run = _motion_run(ex)
    assert ex.system is not None
    MOTIONS.get(ex.example.name, _motion_sphere)(motion, ex.system, run)
    for r in _with_trajectory(ex):
        _energy_curve(energy, r, ex.example.energy_unit)
        _unit_curve(unit, r)
    energy.set(
        xlabel="time (s)",
        ylabel=f"total energy ({_energy_unit(ex)})",
        title="(b) Computed total energy",
    )
    energy.ticklabel_format(axis="y", useOffset=False)
    unit.set(xlabel="time (s)", ylabel="mean unit-length error |q·q − 1|", yscale="log")
    unit.set_title("(c) Unit-length error")
    for ax in (energy, unit):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best")
    fig.suptitle(f"{ex.example.title}{' (quick runs)' if ex.quick else ''}", fontsize=14)
    return _save(fig, path)


def _run_label(r: RunResult) -> str:
    label = str(STYLES.get(r.run.method, {"label": r.run.method})["label"])
    return label + ("" if r.error is None else " (failed)")


def _style(method: str) -> dict[str, Any]:
    return {k: v for k, v in STYLES.get(method, {}).items() if k != "label"}


def _energy_curve(ax: Axes, r: RunResult, energy_unit: float) -> None:
    tr = r.trajectory
    assert tr is not None
    s = _stride(len(tr.t))
    ax.plot(tr.t[::s], tr.energy[::s] / energy_unit, label=_run_label(r), **_style(r.run.method))


def _unit_curve(ax: Axes, r: RunResult) -> None:
    """Mean over bodies of |q·q − 1| per sample; exact zeros (t = 0) are left out of the log."""
    tr = r.trajectory
    assert tr is not None
    err = np.abs(np.einsum("kic,kic->ki", tr.q, tr.q) - 1.0).mean(axis=1)
    s = _stride(len(tr.t))
    err = np.where(err > 0, err, np.nan)[::s]
    ax.plot(tr.t[::s], err, label=_run_label(r), **_style(r.run.method))


# ------------------------------------------------------------------------------------ motions
def _param(system: System, name: str, default: float) -> float:
    return float(system.parameters.get(name, default))


def _setup_3d(ax: Any, title: str, points: np.ndarray, gravity_down: bool = False) -> None:
    """Axis labels, title, and equal scales around the (k, 3) points; with `gravity_down`
    the z axis is flipped (gravity acts along +e3), so hanging bodies are drawn below."""
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)" + (", gravity ↓" if gravity_down else ""))
    ax.set_title(title)
    lo, hi = np.nanmin(points, axis=0), np.nanmax(points, axis=0)
    mid, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-12)
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    z = (mid[2] + half, mid[2] - half) if gravity_down else (mid[2] - half, mid[2] + half)
    ax.set_zlim(*z)
    ax.set_box_aspect((1, 1, 1))


def _sphere_wire(ax: Any, radius: float = 1.0) -> None:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 25), np.linspace(0, np.pi, 13))
    x, y, z = np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)
    ax.plot_wireframe(radius * x, radius * y, radius * z, color="0.8", linewidth=0.4)


def _motion_sphere(ax: Any, system: System, r: RunResult) -> None:
    """Each body's direction q_i(t) traced on the unit sphere."""
    tr = r.trajectory
    assert tr is not None
    _sphere_wire(ax)
    s = _stride(len(tr.t))
    for i in range(system.n):
        line = ax.plot(*tr.q[::s, i].T, linewidth=1.0, label=f"q{i + 1}")
        ax.scatter(*tr.q[0, i], color=line[0].get_color(), s=20)
    if system.n <= 8:
        ax.legend(loc="upper left", fontsize=8)
    _setup_3d(ax, f"(a) Trajectories on the sphere ({r.run.method.upper()})", _CUBE)
    ax.set(xlabel="x", ylabel="y", zlabel="z", xticks=[-1, 0, 1], yticks=[-1, 0, 1])
    ax.set_zticks([-1, 0, 1])


def _motion_double_pendulum(ax: Any, system: System, r: RunResult) -> None:
    """The two masses in 3-D: x1 = l1 q1, x2 = x1 + l2 q2 (pivot at the origin)."""
    tr = r.trajectory
    assert tr is not None
    l1, l2 = _param(system, "l1", 1.0), _param(system, "l2", 1.0)
    x1 = l1 * tr.q[:, 0]
    x2 = x1 + l2 * tr.q[:, 1]
    s = _stride(len(tr.t))
    ax.plot(*x1[::s].T, color="tab:orange", linewidth=0.7, label="mass 1")
    ax.plot(*x2[::s].T, color="tab:purple", linewidth=0.7, label="mass 2")
    ax.plot(*np.array([np.zeros(3), x1[0], x2[0]]).T, "k-o", markersize=4, label="t = 0")
    ax.legend(loc="upper left", fontsize=8)
    pts = np.vstack([x1, x2, np.zeros((1, 3))])
    _setup_3d(ax, f"(a) Trajectory of the pendulum ({r.run.method.upper()})", pts, True)


def _pendula_pivots(system: System) -> tuple[np.ndarray, np.ndarray]:
    """Pivots and lengths of the four pendula: pivots on a square of side l (paper's r_ij)."""
    n = system.n
    lengths = np.array([_param(system, f"l{i + 1}", _param(system, "l", 0.1)) for i in range(n)])
    side = float(lengths[0])
    square = np.array([[0, 0, 0], [side, 0, 0], [side, -side, 0], [0, -side, 0]], dtype=float)
    if n == 4:
        return square, lengths
    return np.array([[side * i, 0.0, 0.0] for i in range(n)]), lengths


def _motion_pendula(ax: Any, system: System, r: RunResult) -> None:
    """The tips p_i + l_i q_i of the pendula, with the links at t = 0."""
    tr = r.trajectory
    assert tr is not None
    pivots, lengths = _pendula_pivots(system)
    tips = pivots[None] + lengths[None, :, None] * tr.q
    s = _stride(len(tr.t))
    for i in range(system.n):
        line = ax.plot(*tips[::s, i].T, linewidth=0.8, label=f"tip {i + 1}")
        ax.plot(*np.array([pivots[i], tips[0, i]]).T, "-", color=line[0].get_color(), lw=2)
    ax.scatter(*pivots.T, color="black", s=15, label="pivots")
    ax.legend(loc="upper left", fontsize=8)
    pts = np.vstack([tips.reshape(-1, 3), pivots])
    _setup_3d(ax, f"(a) Motion of the pendula ({r.run.method.upper()})", pts, True)


def _motion_rod(ax: Any, system: System, r: RunResult) -> None:
    """Snapshots of the chain: a fixed element along e1 at the wall, then l_i q_i(t)."""
    tr = r.trajectory
    assert tr is not None
    n = system.n
    seg = _param(system, "l", 1.1) / (n + 1)
    base = np.array([seg, 0.0, 0.0])
    joints = base + np.cumsum(seg * tr.q, axis=1)  # (N+1, n, 3)
    wall = np.zeros((len(tr.t), 1, 3))
    chain = np.concatenate([wall, wall + base, joints], axis=1)
    times = np.linspace(0, len(tr.t) - 1, 9).astype(int)
    when = Normalize(float(tr.t[0]), float(tr.t[-1]))
    for k in times:
        ax.plot(*chain[k].T, "-o", color=KINETIC_CMAP(when(tr.t[k])), markersize=2, lw=1.2)
    ax.plot(*chain[:, -1][:: _stride(len(tr.t))].T, color="0.6", lw=0.5)
    pts = chain.reshape(-1, 3)
    title = f"(a) Deformation of the rod ({r.run.method.upper()})\ngrey: path of the free end"
    _setup_3d(ax, title, pts, True)
    # the snapshots' times as a colour bar beside the panel: a legend covered the rod
    bar = ax.figure.colorbar(_mappable(when), ax=ax, shrink=0.6, pad=0.0, location="left")
    bar.set_label("snapshot time (s)")
    bar.set_ticks(tr.t[times[::2]])
    bar.ax.yaxis.set_major_formatter(lambda v, _: f"{v:.3g}")


def _dipole_grid(system: System) -> tuple[np.ndarray, float]:
    """Pivots of the dipoles and their length l: from the pair offsets r_1j (in units of the
    spacing 1.2 l) of the system's pair term, else a row-major square grid."""
    n = system.n
    length = _param(system, "l", 0.02)
    pos = np.full((n, 3), np.nan)
    pos[0] = 0.0
    for term in system.terms:
        offsets = [d for d in term.data if d.name == "r" and d.width == 3]
        if term.kind == "pair" and offsets:
            for k, (i, j) in enumerate(term.member_list(n)):
                if i == 0:
                    pos[j] = offsets[0].values[3 * k : 3 * k + 3]
    if np.isnan(pos).any():
        side = max(1, round(np.sqrt(n)))
        idx = np.arange(n)
        pos = np.stack([idx % side, idx // side, np.zeros(n)], axis=1).astype(float)
    return 1.2 * length * pos, length


def _motion_dipoles(ax: Any, system: System, r: RunResult) -> None:
    """Each dipole's north-pole tip (pivot + l/2 q_i) over time, and its direction at the end."""
    tr = r.trajectory
    assert tr is not None
    grid, length = _dipole_grid(system)
    tips = grid[None] + 0.5 * length * tr.q
    s = _stride(len(tr.t))
    for i in range(system.n):
        ax.plot(*tips[::s, i].T, color="tab:blue", linewidth=0.6)
    d0, d1 = 0.5 * length * tr.q[0], 0.5 * length * tr.q[-1]
    ax.quiver(*grid.T, *d0.T, color="0.5", linewidth=0.8, label="t = 0")
    ax.quiver(*grid.T, *d1.T, color="red", linewidth=1.0, label=f"t = {tr.t[-1]:g} s")
    ax.scatter(*grid.T, color="black", s=8)
    ax.legend(loc="upper left", fontsize=8)
    pts = np.vstack([tips.reshape(-1, 3), grid])
    _setup_3d(ax, f"(a) Motion of the dipoles ({r.run.method.upper()}), tips ±l/2 in z", pts)
    ax.set_zlim(-length, length)  # the grid is flat: no need for a cube
    ax.set_zticks([])  # flat grid; a z label would run into the next panel
    ax.set_zlabel("")
    ax.set_box_aspect((1, 1, 0.35))


def _motion_molecules(ax: Any, system: System, r: RunResult) -> None:
    """Initial trajectories (t ≤ 1) of the molecules on the hemisphere facing the camera,
    which looks at the vortices from at most 50° above the equator."""
    tr = r.trajectory
    assert tr is not None
    k = min(len(tr.t), int(np.searchsorted(tr.t, 1.0)) + 1)
    view = _view_direction(system, tr.q[0], tr.omega[0])
    elev = min(50.0, float(np.degrees(np.arcsin(np.clip(view[2], -1, 1)))))
    azim = float(np.degrees(np.arctan2(view[1], view[0]))) if abs(view[2]) < 0.999 else -60.0
    e, a = np.radians(elev), np.radians(azim)
    camera = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    front = tr.q[0] @ camera > 0.05
    _sphere_wire(ax, 0.99)
    for i in np.flatnonzero(front):
        ax.plot(*tr.q[:k, i].T, color="tab:blue", linewidth=1.5)
    ax.scatter(*tr.q[0, front].T, color="0.3", s=2, label="t = 0")
    ax.view_init(elev=elev, azim=azim)
    _setup_3d(ax, f"(a) Initial trajectories, 0 ≤ t ≤ {tr.t[k - 1]:.3g}", _CUBE)
    ax.set_axis_off()
    ax.set_box_aspect((1, 1, 1), zoom=1.4)
    ax.legend(loc="upper left", fontsize=8)


MOTIONS: dict[str, Callable[[Any, System, RunResult], None]] = {
    "double_pendulum": _motion_double_pendulum,
    "three_bodies": _motion_sphere,
    "four_pendula": _motion_pendula,
    "elastic_rod": _motion_rod,
    "dipoles": _motion_dipoles,
    "molecular": _motion_molecules,
}


# --------------------------------------------------------------------------- step-size figure
def _step_size_figure(ex: ExampleResult, path: Path) -> Path:
    """(a) trajectories, (b) energy error and (c) unit-length error against step size."""
    fig = Figure(figsize=(16, 4.8), layout="constrained")
    motion = fig.add_subplot(1, 3, 1, projection="3d")
    energy, unit = fig.add_subplot(1, 3, 2), fig.add_subplot(1, 3, 3)
    assert ex.system is not None
    _motion_sphere(motion, ex.system, _motion_run(ex))
    _against_h(energy, ex.runs, "mean_dE")
    _against_h(unit, ex.runs, "mean_dot")
    energy.set(xlabel="step size h (s)", ylabel=f"mean |E − E0| ({_energy_unit(ex)})")
    energy.set_title("(b) Total energy error vs step size")
    unit.set(xlabel="step size h (s)", ylabel="mean unit-length error |q·q − 1|")
    unit.set_title("(c) Unit-length error vs step size")
    fig.suptitle(f"{ex.example.title}{' (quick runs)' if ex.quick else ''}", fontsize=14)
    return _save(fig, path)


def _against_h(ax: Axes, runs: Sequence[RunResult], metric: str) -> None:
    """One log-log line per method (metric against h), plus the paper's printed values."""
    for method in dict.fromkeys(r.run.method for r in runs):
        pts = sorted((r.run.h, r.metrics[metric]) for r in runs if r.run.method == method and
                     metric in r.metrics and r.error is None)  # fmt: skip
        if pts:
            h, y = np.array(pts).T
            style = STYLES.get(method, {})
            ax.plot(h, y, marker=MARKERS.get(method, "o"), color=style.get("color"),
                    linestyle="-", label=style.get("label", method))  # fmt: skip
    printed = [(r.run.h, r.paper[metric]) for r in runs if r.comparable and metric in r.paper]
    if printed:
        h, y = np.array(printed).T
        ax.plot(h, y, "kx", markersize=10, mew=2, linestyle="none", label="paper")
    ax.set(xscale="log", yscale="log")
    _label_step_sizes(ax, sorted({r.run.h for r in runs}))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best")


def _label_step_sizes(ax: Axes, steps: Sequence[float]) -> None:
    """x tick labels at the measured step sizes only (matplotlib's default labels every minor
    tick of a log axis spanning about a decade, and 2e-3, 3e-3, 4e-3 ran into each other)."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ax.xaxis.set_major_locator(FixedLocator(list(steps)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda h, _: _power_of_ten(h)))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _power_of_ten(x: float) -> str:
    r"""A positive number as mathtext m×10^e (m omitted when 1).

    Example:
        >>> print(_power_of_ten(5e-4), _power_of_ten(1e-3))
        $5\times10^{-4}$ $10^{-3}$
    """
    e = int(np.floor(np.log10(x) + 1e-12))
    m = x / 10.0**e
    return f"$10^{{{e}}}$" if abs(m - 1) < 1e-9 else f"${m:.3g}\\times10^{{{e}}}$"


# ----------------------------------------------------------------------- kinetic distribution
def kinetic_energy(system: System, q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Per-body kinetic energy ½ M_ii |ω_i × q_i|² for a diagonal inertia matrix.

    Example:
        >>> from s2gen import paper
        >>> s = paper.three_bodies()  # unit masses
        >>> kinetic_energy(s, s.q0, s.omega0).round(3).tolist()
        [0.605, 0.5, 0.5]
    """
    values = dict(zip(system.parameter_symbols, system.parameter_values))
    mass = np.array([float(system.inertia[i, i].xreplace(values)) for i in range(system.n)])
    v = np.cross(omega, q)
    return 0.5 * mass * np.einsum("ic,ic->i", v, v)


def _face_of(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Index of the face whose cone contains each unit vector (nearest centroid on a tie)."""
    tri = vertices[faces]  # (F, 3, 3)
    centroids = tri.mean(axis=1)
    centroids /= np.linalg.norm(centroids, axis=1, keepdims=True)
    candidates = np.argsort(-(points @ centroids.T), axis=1)[:, :6]
    edge_normals = np.cross(tri, np.roll(tri, -1, axis=1))  # (F, 3, 3): a×b, b×c, c×a
    orient = np.sign(np.einsum("fkc,fc->fk", edge_normals, centroids))
    out = candidates[:, 0].copy()
    for k, p in enumerate(points):
        for f in candidates[k]:
            if np.all(orient[f] * (edge_normals[f] @ p) >= -1e-12):
                out[k] = f
                break
    return out


def face_kinetic_energy(
    points: np.ndarray, energies: np.ndarray, vertices: np.ndarray, faces: np.ndarray
) -> np.ndarray:
    """Per face: mean energy of the points within the face or a face sharing a vertex with it.

    A face with no point in that neighbourhood takes the mean over the next ring of faces
    (the neighbours' neighbourhoods), so sparse regions show no holes; NaN if still empty.

    Example:
        >>> v = np.eye(3); f = np.array([[0, 1, 2]])
        >>> face_kinetic_energy(np.array([[1, 1, 1]]) / np.sqrt(3), np.array([2.0]), v, f)
        array([2.])
    """
    from scipy import sparse

    nf = len(faces)
    owner = _face_of(points, vertices, faces)
    total = np.bincount(owner, weights=energies, minlength=nf)
    count = np.bincount(owner, minlength=nf).astype(float)
    rows = np.repeat(np.arange(nf), 3)
    incidence = sparse.csr_matrix((np.ones(3 * nf), (rows, faces.ravel())))
    near = (incidence @ incidence.T).astype(bool).astype(float)  # faces sharing a vertex
    s, c = near @ total, near @ count
    wider = near @ near
    s2, c2 = wider @ total, wider @ count
    s, c = np.where(c > 0, s, s2), np.where(c > 0, c, c2)
    return np.where(c > 0, s / np.maximum(c, 1), np.nan)


def _view_direction(system: System, q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Look at the kinetic-energy-weighted mean position (the vortices), else along (1, 1, 1)."""
    v = np.cross(omega, q)
    weight = np.einsum("ic,ic->i", v, v)
    centre = weight @ q
    norm = float(np.linalg.norm(centre))
    if norm < 1e-9 * max(float(weight.sum()), 1e-300):
        return np.ones(3) / np.sqrt(3)
    return centre / norm


def _view_basis(view: np.ndarray) -> np.ndarray:
    """Rows u, v, w: screen right, screen up, towards the viewer (w = view)."""
    up = np.array([0.0, 0.0, 1.0]) if abs(view[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(up, view)
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(view, u), view])


def plot_kinetic_distribution(
    ax: Axes,
    values: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    view: np.ndarray,
    norm: Normalize,
) -> None:
    """Draw the near hemisphere's faces, orthographically, coloured by `values` (NaN: grey).

    Example:
        >>> from s2gen import paper
        >>> v, f = paper.icosphere(1)
        >>> ax = Figure().add_subplot()
        >>> plot_kinetic_distribution(ax, np.ones(len(f)), v, f, np.array([0, 0, 1.0]),
        ...                           Normalize(0, 2))
        >>> len(ax.collections[0].get_paths())  # the 36 of 80 faces facing the viewer
        36
    """
    basis = _view_basis(view)
    xyz = vertices @ basis.T
    tri = xyz[faces]
    front = tri.mean(axis=1)[:, 2] > 0
    colours = KINETIC_CMAP(norm(np.nan_to_num(values[front], nan=0.0)))
    colours[np.isnan(values[front])] = (0.85, 0.85, 0.85, 1.0)
    polys = PolyCollection(list(tri[front][:, :, :2]), facecolors=colours, edgecolors=colours)
    polys.set_linewidth(0.3)
    ax.add_collection(polys)
    ax.set(xlim=(-1.02, 1.02), ylim=(-1.02, 1.02), aspect="equal")
    ax.set_axis_off()


def _kinetic_figure(ex: ExampleResult, path: Path) -> Path:
    """Kinetic-energy distributions at the paper's times (those within the run's horizon)."""
    from s2gen import paper

    assert ex.system is not None
    r = _motion_run(ex)
    tr = r.trajectory
    assert tr is not None
    vertices, faces = (np.asarray(a) for a in paper.icosphere(4))
    times = [t for t in KINETIC_TIMES if t <= tr.t[-1] + 1e-12] or [float(tr.t[-1])]
    if times[-1] < tr.t[-1] - 1e-12 and len(times) < len(KINETIC_TIMES):
        times.append(float(tr.t[-1]))
    idx = [int(np.argmin(np.abs(tr.t - t))) for t in times]
    values = [
        face_kinetic_energy(
            tr.q[k] / np.linalg.norm(tr.q[k], axis=1, keepdims=True),
            kinetic_energy(ex.system, tr.q[k], tr.omega[k]),
            vertices,
            faces,
        )
        for k in idx
    ]
    norm = Normalize(0.0, float(np.nanmax(np.concatenate(values))) or 1.0)
    view = _view_direction(ex.system, tr.q[0], tr.omega[0])
    fig = Figure(figsize=(3.3 * len(idx) + 1.2, 4.0), layout="constrained")
    axes = fig.subplots(1, len(idx), squeeze=False)[0]
    for ax, k, vals in zip(axes, idx, values):
        plot_kinetic_distribution(ax, vals, vertices, faces, view, norm)
        ax.set_title(f"t = {tr.t[k]:g}")
    _axes_triad(axes[0], _view_basis(view))
    bar = fig.colorbar(_mappable(norm), ax=list(axes), shrink=0.85)
    bar.set_label("mean kinetic energy per molecule")
    fig.supxlabel(_view_caption(view), fontsize=9, color="0.25")
    fig.suptitle(
        f"Kinetic energy distribution over a {len(faces)}-face icosphere ({r.run.method.upper()}"
        f", h = {r.run.h:g})",
        fontsize=13,
    )
    return _save(fig, path)


def _view_caption(view: np.ndarray) -> str:
    """Where the sphere is seen from, in words (the kinetic figure's caption).

    Example:
        >>> print(_view_caption(np.array([0.0, 0.0, 1.0])))  # doctest: +NORMALIZE_WHITESPACE
        Seen from outside the sphere along (x, y, z) = (0.00, 0.00, 1.00) (elevation 90°,
        azimuth 0°): ...
    """
    import textwrap

    elev = float(np.degrees(np.arcsin(np.clip(view[2], -1.0, 1.0))))
    azim = float(np.degrees(np.arctan2(view[1], view[0]))) if abs(view[2]) < 1 - 1e-9 else 0.0
    x, y, z = (round(float(c), 2) + 0.0 for c in view)  # + 0.0: no "-0.00"
    up = "+z" if abs(view[2]) < 0.9 else "+y"
    text = (
        f"Seen from outside the sphere along (x, y, z) = ({x:.2f}, {y:.2f}, {z:.2f}) (elevation "
        f"{elev:.0f}°, azimuth {azim:.0f}°): the kinetic-energy-weighted mean direction of the "
        f"molecules at t = 0, where the vortices are. Orthographic view of the near hemisphere, "
        f"{up} towards the top of the page (axes at the lower left of the first panel); grey: "
        "no molecule within two rings of faces."
    )
    return textwrap.fill(text, 125)


def _axes_triad(ax: Axes, basis: np.ndarray) -> None:
    """The x, y, z axes as seen in the panel (orthographic: their screen components), drawn
    in the panel's lower-left corner; an axis pointing nearly at the viewer shows as a dot."""
    ox, oy = -0.94, -0.94  # the corner outside the disk
    for k, name in enumerate("xyz"):
        dx, dy = (0.17 * float(basis[row, k]) for row in (0, 1))
        if np.hypot(dx, dy) < 0.03:
            towards = basis[2, k] > 0
            ax.plot(ox, oy, "o" if towards else "x", color="black", markersize=4)
            label = f"{name} {'towards' if towards else 'away from'} viewer"
            ax.annotate(label, (ox, oy), xytext=(-4, -10), textcoords="offset points", fontsize=7)
            continue
        arrow = {"arrowstyle": "->", "color": "black", "lw": 1}
        ax.annotate("", (ox + dx, oy + dy), (ox, oy), arrowprops=arrow)
        ax.text(ox + 1.45 * dx, oy + 1.45 * dy, name, fontsize=8, ha="center", va="center")


def _mappable(norm: Normalize) -> Any:
    from matplotlib.cm import ScalarMappable

    return ScalarMappable(norm=norm, cmap=KINETIC_CMAP)
