"""`s2gen.ensemble`: ensembles of perturbed initial states and parameter sweeps on Dask.

`ensemble(system, members=..., perturb=..., sweep=..., method, h, T, every, client=None, ...)`
integrates every member with the emitted C on a Dask cluster (a `distributed.LocalCluster` of
worker processes by default, or any running scheduler given by `client`; ``workers=0`` runs
them in this process) and streams the results into one Zarr store; `summarize` writes the
tables and figures; `benchmark` times the machinery. Ensembles need dask, distributed and zarr
(dependencies of s2gen); when one is missing, the first call that needs it raises
`MissingDependency`, one line naming the package and the ``pip install`` command.

The package, one responsibility per module: `members` (the member table: perturbations and
sweep values, seeded, and the limits on their number and size), `worker` (the task run on a
worker), `cluster` (which cluster), `admission` (TLS, and workers that run the client's s2gen),
`requirements` (the packages checked before work starts), `dispatch` (`ensemble`:
submitting, collecting, writing), `store` (the on-disk Zarr store), `divergence` (divergence
curves and the Lyapunov fit), `figures` (PNGs), `summary` (tables and the report), `bench`
(the benchmark), `command` (the argparse parser only) and `driver` (the CLI's `run`). Public
names are re-exported here and imported on first use, so the command-line parser does not
import the rest. (The chaos bands of the paper's examples are an experiment of `s2gen
reproduce`, built on this API.)

Example:
    >>> import s2gen.ensemble
    >>> r = s2gen.ensemble.ensemble("double_pendulum", sweep={"g": [1.0, 9.81]}, T=0.1,
    ...                             workers=0)
    >>> r.written, r.path.name
    (2, 'ensemble.zarr')
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "CONNECT_TIMEOUT": "cluster",
    "DASHBOARD": "command",
    "DEFAULT_OUT": "command",
    "MAX_MEMBERS": "members",
    "MAX_PERTURBATION": "members",
    "MAX_STORE_BYTES": "store",
    "PACKAGES": "requirements",
    "Divergence": "divergence",
    "EnsembleError": "members",
    "EnsembleResult": "dispatch",
    "EnsembleStore": "store",
    "Identity": "admission",
    "LyapunovFit": "divergence",
    "Member": "members",
    "MemberResult": "worker",
    "MemberTable": "members",
    "MissingDependency": "requirements",
    "Progress": "dispatch",
    "ProgressBar": "driver",
    "Summary": "summary",
    "add_parser": "command",
    "batch_size_for": "dispatch",
    "benchmark": "bench",
    "check_sizes": "dispatch",
    "check_workers": "admission",
    "connect": "cluster",
    "ensemble": "dispatch",
    "fit_lyapunov": "divergence",
    "identity": "admission",
    "initial_state": "members",
    "initial_states": "members",
    "member_table": "members",
    "require": "requirements",
    "run": "driver",
    "run_member": "worker",
    "run_members": "batched",
    "summarize": "summary",
    "tls_security": "admission",
}

__all__ = list(_WHERE)


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
