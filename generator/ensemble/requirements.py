"""The third-party packages ensembles run on, checked before any work starts.

Input: the names of the packages an entry point needs (`PACKAGES` by default). Output:
nothing when all are importable; otherwise `MissingDependency`, whose message is one line
naming the missing packages and the command that installs them. It is an `ImportError` (for
Python callers) and an `EnsembleError`, a ValueError (so the command line prints it as one
``error:`` line with exit status 2, not a traceback).

Example:
    >>> require("numpy")
    >>> require("no_such_package_s2gen")
    Traceback (most recent call last):
    ...
    s2gen.ensemble.requirements.MissingDependency: s2gen.ensemble needs no_such_package_s2gen, which is not installed: pip install no_such_package_s2gen
"""

from __future__ import annotations

import importlib.util

from .members import EnsembleError

__all__ = ["PACKAGES", "MissingDependency", "require"]

#: What ensembles need: Dask and its distributed scheduler (the cluster), Zarr (the store).
#: The import name of each is also its name on PyPI.
PACKAGES = ("dask", "distributed", "zarr")


class MissingDependency(EnsembleError, ImportError):
    """A package ensembles need is not installed (one line: what, and how to install it)."""


def _installed(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):  # a broken entry in sys.modules counts as missing
        return False


def require(*names: str) -> None:
    """Raise `MissingDependency` unless every package of `names` (default `PACKAGES`) can be
    imported; nothing is imported here."""
    missing = [n for n in names or PACKAGES if not _installed(n)]
    if missing:
        which = " and ".join(missing)
        verb = "which is" if len(missing) == 1 else "which are"
        raise MissingDependency(
            f"s2gen.ensemble needs {which}, {verb} not installed: pip install {' '.join(missing)}"
        )
