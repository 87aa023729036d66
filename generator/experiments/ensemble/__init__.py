"""`s2gen ensemble`: ensembles of perturbed initial states and parameter sweeps on Dask.

`ensemble(system, members=..., perturb=..., sweep=..., method, h, T, every, client=None, ...)`
integrates every member with the emitted C on a Dask cluster (a `distributed.LocalCluster` of
worker processes by default, or any running scheduler given by `client`) and streams the
results into one Zarr store; `summarize` writes the tables and figures; `chaos_band` runs a
paper example's runs as 64-member ensembles; `benchmark` times the machinery.

The package, one responsibility per module: `members` (the member table: perturbations and
sweep values, seeded), `worker` (the task run on a worker), `cluster` (which cluster),
`dispatch` (`ensemble`: submitting, collecting, writing), `store` (the on-disk Zarr store),
`summary` (divergence, Lyapunov fit, tables) and `figures` (PNGs), `band` (chaos bands),
`bench` (the benchmark), `command` (the argparse parser only) and `driver` (the CLI's `run`).
Public names are re-exported here and imported on first use, so the command-line parser does
not import the rest.

Example:
    >>> from s2gen.experiments.ensemble import ensemble
    >>> r = ensemble("double_pendulum", members=4, perturb={"omega": 1e-13}, T=0.2,
    ...              workers=2)  # doctest: +SKIP
    >>> r.written, r.path.name  # doctest: +SKIP
    (4, 'ensemble.zarr')
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "Band": "band",
    "EnsembleError": "members",
    "EnsembleResult": "dispatch",
    "EnsembleStore": "store",
    "Member": "members",
    "MemberResult": "worker",
    "MemberTable": "members",
    "add_parser": "command",
    "benchmark": "bench",
    "chaos_band": "band",
    "connect": "cluster",
    "ensemble": "dispatch",
    "fit_lyapunov": "summary",
    "initial_state": "members",
    "member_table": "members",
    "run": "driver",
    "run_member": "worker",
    "summarize": "summary",
}

__all__ = list(_WHERE)


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)
