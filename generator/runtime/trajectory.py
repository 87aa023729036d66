"""The result of an integration: samples, statistics, metadata, and the error that keeps a
partial run.

Input: arrays and counts from a backend, and what produced them (system, spec hash, method,
backend, step, tolerances). Output: `Trajectory` (t, q, omega, energy, stats, wall time and
that metadata), which saves itself to and loads itself from a .npz file, rebuilds its system,
computes its angular momentum, converts to an xarray Dataset and plots its motion and its
energy and unit-length errors; and
`IntegrationError` (raised on failure, holding the valid samples in `.partial`).

File format (`save`): a NumPy .npz with the arrays ``t`` (N+1), ``q`` and ``omega``
(N+1, n, 3), ``energy`` (N+1), ``angular_momentum`` (N+1, 3) when present, a driven run's
``work`` (N+1) and ``inputs`` (steps, n_inputs), and ``metadata``,
a JSON text (system, spec_hash, method, backend, h, rtol, atol, control, version, stats,
wall_time; spec, the text or built-in name that `s2gen.load` rebuilds the system from, and
params, the run's parameter values by name; energy_warn, energy_scale and drift_sample, the
run's energy check, see `s2gen.runtime.diagnostics`). Readers that only want the arrays (``np.load(path)["q"]``) need nothing else.

Example:
    >>> import numpy as np
    >>> tr = Trajectory(np.zeros(1), np.zeros((1, 1, 3)), np.zeros((1, 1, 3)), np.zeros(1),
    ...                 "vi", "c", 0.1)
    >>> tr.q.shape
    (1, 1, 3)
"""

from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from s2gen.methods import NAMES
from s2gen.methods import method as method_record
from s2gen.version import __version__

if TYPE_CHECKING:
    from s2gen.system import System

__all__ = ["IntegrationError", "Trajectory", "stat_counts"]

#: Metadata fields written to and read from a saved trajectory, in order.
METADATA_FIELDS = (
    "system",
    "spec_hash",
    "method",
    "backend",
    "h",
    "rtol",
    "atol",
    "control",
    "version",
    "stats",
    "wall_time",
    "spec",
    "spec_folder",
    "params",
    "energy_warn",
    "energy_scale",
    "drift_sample",
)

#: The reference backend counts under other names: rhs_evaluations (of the continuous field,
#: one gradient each; the VI and RATTLE there evaluate gradients uncounted) and
#: newton_iterations_total.
_REFERENCE_NAMES = {"rhs_evaluations": "gradient_evals", "newton_iterations_total": "newton_iters"}


def stat_counts(stats: dict[str, int], method: str = "") -> dict[str, int | None]:
    """Accepted steps, rejected steps, gradient evaluations and Newton iterations of a run,
    whatever backend counted them; None for a count the backend does not keep (the
    reference's VI and RATTLE do not count their gradient evaluations; its time-transformed
    methods count them as ``gradient_evaluations``).

    Example:
        >>> stat_counts({"steps": 5, "rhs_evaluations": 30, "newton_iterations_total": 0}, "rk45")
        {'steps': 5, 'rejected': 0, 'gradient_evals': 30, 'newton_iters': 0}
        >>> stat_counts({"steps": 5, "rhs_evaluations": 0, "newton_iterations_total": 9}, "vi")
        {'steps': 5, 'rejected': 0, 'gradient_evals': None, 'newton_iters': 9}
    """
    named: dict[str, int | None] = {k: int(v) for k, v in stats.items()}
    if "rhs_evaluations" in stats and "gradient_evals" not in stats:
        for old, new in _REFERENCE_NAMES.items():
            named[new] = named.pop(old, None)
        if method in NAMES and method_record(method).geometric:
            named["gradient_evals"] = named.get("gradient_evaluations")  # time-transformed only
    keys = ("steps", "rejected", "gradient_evals", "newton_iters")
    return {k: named.get(k, 0) if k != "gradient_evals" else named.get(k) for k in keys}


@dataclass(frozen=True)
class Trajectory:
    """Samples on the grid t_k = k h every: q and omega (N+1, n, 3), energy (N+1,) or None when
    it was not asked for, and what made them (metadata fields after `wall_time` are keywords
    with defaults; `rtol`, `atol` and `control` are set for adaptive methods only)."""

    t: np.ndarray
    q: np.ndarray
    omega: np.ndarray
    energy: np.ndarray | None
    method: str
    backend: str
    h: float
    stats: dict[str, Any] = field(default_factory=dict)
    wall_time: float = 0.0
    system: str = ""
    spec_hash: str = ""
    rtol: float | None = None
    atol: float | None = None
    control: str | None = None
    version: str = __version__
    #: J per sample (N+1, 3) when the producer computed it (see `angular_momentum`).
    momentum: np.ndarray | None = field(default=None, compare=False)
    #: What `s2gen.load` rebuilds the system from (`System.source`; "" if unknown).
    spec: str = ""
    #: The folder of the spec's file (`System.source_folder`): its data files are read from
    #: there when the system is rebuilt ("" for built-ins, Python systems and older files).
    spec_folder: str = ""
    #: The parameter values of the run, by name ({} if unknown: then the spec's).
    params: dict[str, float] = field(default_factory=dict)
    #: The relative energy error the run was checked against (`Options.energy_warn`), the
    #: energy scale S of its initial state and the first sample past it (None: none, or the
    #: run was not checked); see `s2gen.runtime.diagnostics`.
    energy_warn: float | None = None
    energy_scale: float | None = None
    drift_sample: int | None = None
    #: A driven run's work done on the system since t[0] per sample (N+1,), and the inputs
    #: held over each step (steps, n_inputs); None for a closed system.
    work: np.ndarray | None = field(default=None, compare=False)
    inputs: np.ndarray | None = field(default=None, compare=False)

    @property
    def balance(self) -> np.ndarray | None:
        """The energy-balance error E_k - E_0 - W_k of a driven run (E_k - E_0 of a closed
        one; None without energy).

        Example:
            >>> z = np.zeros((2, 1, 3))
            >>> tr = Trajectory(np.arange(2.0), z, z, np.array([1.0, 3.0]), "vi", "c", 1.0,
            ...                 work=np.array([0.0, 1.5]))
            >>> tr.balance.tolist()
            [0.0, 0.5]
        """
        if self.energy is None:
            return None
        change = self.energy - self.energy[0]
        return change if self.work is None else change - self.work

    # ------------------------------------------------------------------------ metadata
    @property
    def metadata(self) -> dict[str, Any]:
        """The metadata fields as plain JSON values.

        Example:
            >>> import numpy as np
            >>> z = np.zeros((1, 1, 3))
            >>> Trajectory(np.zeros(1), z, z, np.zeros(1), "vi", "c", 0.1).metadata["h"]
            0.1
        """
        meta = {k: getattr(self, k) for k in METADATA_FIELDS}
        meta["stats"] = {k: int(v) for k, v in self.stats.items()}
        meta["params"] = {k: float(v) for k, v in self.params.items()}
        meta["h"] = float(self.h)
        meta["wall_time"] = float(self.wall_time)
        return meta

    def with_momentum(self, momentum: np.ndarray) -> Trajectory:
        """A copy carrying the angular momentum per sample (saved with the trajectory).

        Example:
            >>> import numpy as np
            >>> z = np.zeros((1, 1, 3))
            >>> tr = Trajectory(np.zeros(1), z, z, np.zeros(1), "vi", "c", 0.1)
            >>> tr.with_momentum(np.zeros((1, 3))).momentum.shape
            (1, 3)
        """
        momentum = np.asarray(momentum, dtype=float)
        if momentum.shape != (len(self.t), 3):
            raise ValueError(f"angular momentum must have shape {(len(self.t), 3)}")
        return dataclasses.replace(self, momentum=momentum)

    # ------------------------------------------------------------------------ save / load
    def save(self, path: str | Path) -> Path:
        """Write the trajectory to exactly `path` (.npz format, whatever the suffix), through a
        temporary file moved into place; refuses a symbolic link or a folder at `path`.

        Example:
            >>> import numpy as np, tempfile, pathlib
            >>> z = np.zeros((2, 1, 3))
            >>> tr = Trajectory(np.arange(2.0), z, z, np.zeros(2), "vi", "c", 1.0, system="p")
            >>> p = tr.save(pathlib.Path(tempfile.mkdtemp()) / "run.npz")
            >>> Trajectory.load(p).system
            'p'
        """
        from s2gen.paths import write_atomic

        arrays: dict[str, Any] = {"t": self.t, "q": self.q, "omega": self.omega}
        if self.energy is not None:
            arrays["energy"] = self.energy
        if self.momentum is not None:
            arrays["angular_momentum"] = self.momentum
        for name in ("work", "inputs"):
            if getattr(self, name) is not None:
                arrays[name] = getattr(self, name)
        arrays["metadata"] = np.array(json.dumps(self.metadata, sort_keys=True))
        return write_atomic(path, lambda f: np.savez(f, **arrays))

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """Read a trajectory written by `save` (or the arrays t, q, omega, energy of an older
        file, whose metadata is then empty; method and backend read "unknown").

        Example:
            >>> Trajectory.load("missing.npz")
            Traceback (most recent call last):
            ...
            FileNotFoundError: [Errno 2] No such file or directory: 'missing.npz'
        """
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: np.array(data[k]) for k in data.files}
        meta: dict[str, Any] = {}
        if "metadata" in arrays:
            meta = json.loads(str(arrays.pop("metadata")))
        t = arrays["t"]
        h = meta.get("h", float(t[1] - t[0]) if len(t) > 1 else 0.0)
        return cls(
            t=t,
            q=arrays["q"],
            omega=arrays["omega"],
            energy=arrays.get("energy"),
            method=meta.get("method", "unknown"),
            backend=meta.get("backend", "unknown"),
            h=h,
            stats={
                k: v if isinstance(v, float) else int(v) for k, v in meta.get("stats", {}).items()
            },
            wall_time=float(meta.get("wall_time", 0.0)),
            system=meta.get("system", ""),
            spec_hash=meta.get("spec_hash", ""),
            rtol=meta.get("rtol"),
            atol=meta.get("atol"),
            control=meta.get("control"),
            version=meta.get("version", ""),
            momentum=arrays.get("angular_momentum"),
            spec=meta.get("spec", ""),
            spec_folder=meta.get("spec_folder", ""),
            params={k: float(v) for k, v in meta.get("params", {}).items()},
            energy_warn=meta.get("energy_warn"),
            energy_scale=meta.get("energy_scale"),
            drift_sample=meta.get("drift_sample"),
            work=arrays.get("work"),
            inputs=arrays.get("inputs"),
        )

    # ------------------------------------------------------------------------ derived values
    def angular_momentum(self, model: Any = None, params: Any = None) -> np.ndarray:
        """J_k = sum_i q_i x sum_j M_ij (omega_j x q_j) at every sample, shape (N+1, 3).

        `model` is a `System` or anything with a `.system` (a `Model`, a backend); by default
        the system rebuilt from `spec`. M is taken at `params` (a sequence in declared order
        or a mapping by name; default the run's `params`, else the spec's). Computed here with
        NumPy from M's nonzero entries, independently of the backends.

        Example:
            >>> from s2gen.runtime import simulate
            >>> from s2gen.systems import builtin
            >>> tr = simulate(builtin("three_bodies"), "vi", h=0.01, T=0.1)
            >>> J = tr.angular_momentum()
            >>> bool(abs(J - J[0]).max() < 1e-12)
            True
        """
        system = getattr(model, "system", model) if model is not None else self.rebuild()
        if params is None and self.params:
            params = self.params
        n = self.q.shape[1]
        dense = None
        if system.matrix is None and system.chain is not None:
            # a chain's M from its per-body generators, never its n^2 symbolic entries
            dense = system.chain.dense(n, _parameter_values(system, params))
            width = n
        else:
            entries = _inertia_entries(system, params)
            rows, cols = (np.array([k[i] for k in entries], dtype=int) for i in (0, 1))
            vals = np.array(list(entries.values()))
            width = max(n, len(vals))
        J = np.empty((len(self.t), 3))
        block = max(1, 2**20 // max(width, 1))  # bounded temporaries on long runs
        for k in range(0, len(self.t), block):
            q, w = self.q[k : k + block], self.omega[k : k + block]
            v = np.cross(w, q)  # qdot_j = omega_j x q_j, (samples, n, 3)
            if dense is not None:  # one matrix product over every sample and component
                s = len(v)
                p = (dense @ v.transpose(1, 0, 2).reshape(n, -1)).reshape(n, s, 3).swapaxes(0, 1)
            else:  # p_i = sum_j M_ij v_j over M's nonzero entries
                p = np.zeros_like(v)
                by_body = p.swapaxes(0, 1)  # a view: (n, samples, 3)
                np.add.at(by_body, rows, vals[:, None, None] * v[:, cols].swapaxes(0, 1))
            J[k : k + block] = np.cross(q, p).sum(axis=1)
        return J

    def rebuild(self) -> System:
        """The system of this trajectory, rebuilt from `spec` with the spec's own parameter
        defaults (the run's values are `params`, which `angular_momentum` uses); ValueError
        when no spec was recorded (a system defined in Python, or an older file).

        Example:
            >>> from s2gen.runtime import simulate
            >>> from s2gen.systems import builtin
            >>> simulate(builtin("rope", n=3), "vi", h=0.01, T=0.01).rebuild().n
            3
        """
        if not self.spec:
            raise ValueError(
                f"trajectory of {self.system or 'an unnamed system'} does not record its spec "
                "(a system defined in Python): pass the System"
            )
        from s2gen import load

        if self.spec_folder and "\n" in self.spec:  # spec text whose data files live there
            from s2gen.spec import load_spec_text

            origin = f"{self.system or 'the trajectory'}'s spec"
            return load_spec_text(self.spec, origin=origin, folder=self.spec_folder)
        return load(self.spec)

    def unit_length_error(self) -> np.ndarray:
        """max over bodies of | |q_i| - 1 | at every sample, shape (N+1,).

        Example:
            >>> import numpy as np
            >>> q = np.array([[[1.0, 0, 0]], [[0, 2.0, 0]]])
            >>> Trajectory(np.arange(2.0), q, q, np.zeros(2), "vi", "c", 1.0).unit_length_error()
            array([0., 1.])
        """
        if self.q.shape[1] == 0:
            return np.zeros(len(self.t))
        return np.asarray(np.abs(np.linalg.norm(self.q, axis=2) - 1.0).max(axis=1))

    # ------------------------------------------------------------------------ views
    def to_xarray(self) -> Any:
        """An `xarray.Dataset` (coordinates t, body, component; variables q, omega, energy and
        angular_momentum when present; metadata as attributes). Needs the `xarray` extra.

        Example:
            >>> import numpy as np
            >>> z = np.zeros((2, 1, 3))
            >>> ds = Trajectory(np.arange(2.0), z, z, np.zeros(2), "vi", "c", 1.0).to_xarray()
            >>> ds["q"].dims  # doctest: +SKIP
            ('t', 'body', 'component')
        """
        try:
            import xarray as xr
        except ImportError:
            raise ImportError(
                "Trajectory.to_xarray needs xarray: pip install 's2gen[xarray]'"
            ) from None
        body = np.arange(1, self.q.shape[1] + 1)
        comp = ["x", "y", "z"]
        data: dict[str, Any] = {
            "q": (("t", "body", "component"), self.q),
            "omega": (("t", "body", "component"), self.omega),
        }
        if self.energy is not None:
            data["energy"] = (("t",), self.energy)
        momentum = self.momentum
        if momentum is None and self.spec:
            momentum = self.angular_momentum()
        if momentum is not None:
            data["angular_momentum"] = (("t", "component"), momentum)
        skip = ("stats", "params")
        attrs = {k: v for k, v in self.metadata.items() if v is not None and k not in skip}
        attrs.update({f"stats_{k}": v for k, v in self.stats.items()})
        attrs.update({f"param_{k}": v for k, v in self.params.items()})
        return xr.Dataset(data, coords={"t": self.t, "body": body, "component": comp}, attrs=attrs)

    def plot(self, path: str | Path | None = None) -> Any:
        """The motion and the errors against t: each body's tip path on the unit sphere (seen
        from above and from the side), q's components, |E - E_0| and max_i | |q_i| - 1 | (see
        `s2gen.runtime.plotting`). Writes a PNG to `path` when given; returns the matplotlib
        Figure (drawn without pyplot: no backend is chosen or switched).

        Example:
            >>> import numpy as np
            >>> q = np.tile([[[1.0, 0, 0]]], (3, 1, 1))
            >>> tr = Trajectory(np.arange(3.0), q, q, np.array([1.0, 1.1, 0.9]), "vi", "c", 1.0)
            >>> len(tr.plot().axes)
            5
        """
        from s2gen.runtime.plotting import trajectory_figure

        return trajectory_figure(self, path)


def _parameter_values(system: System, params: Any) -> dict[Any, float]:
    """{parameter symbol: value} at the given parameters (default the spec's)."""
    if params is None:
        values = tuple(system.parameter_values)
    elif isinstance(params, dict):
        merged = {**system.parameters, **{k: float(v) for k, v in params.items()}}
        values = tuple(merged[n] for n in system.parameter_names)
    else:
        values = tuple(float(v) for v in params)
    return dict(zip(system.parameter_symbols, values))


def _inertia_entries(system: System, params: Any) -> dict[tuple[int, int], float]:
    """M's nonzero entries {(row, col): value} at the given parameters (default the spec's)."""
    values = tuple(_parameter_values(system, params).values())
    return dict(_entries_at(system, values))


@functools.lru_cache(maxsize=64)
def _entries_at(system: System, values: tuple[float, ...]) -> tuple[tuple[Any, float], ...]:
    """M's nonzero entries at parameter values in declared order (kept: every run of a system
    computes its angular momentum, and SymPy's evaluation costs more than a short run)."""
    import sympy as sp

    subs = dict(zip(system.parameter_symbols, values))
    out: dict[tuple[int, int], float] = {}
    cache: dict[Any, float] = {}
    for key, entry in system.inertia.todok().items():
        if entry not in cache:
            cache[entry] = float(sp.sympify(sp.sympify(entry).xreplace(subs)).evalf())
        out[key] = cache[entry]
    return tuple(out.items())


class IntegrationError(RuntimeError):
    """An integration failed; `.partial` holds the valid samples computed before the failure,
    `.status` the `s2gen.methods.Status` code and `.step` the first sample not computed."""

    def __init__(self, message: str, status: int, step: int, partial: Trajectory) -> None:
        super().__init__(message)
        self.status = status
        self.step = step
        self.partial = partial
