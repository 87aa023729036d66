"""The generator's version and the fingerprint of its own sources.

Input: nothing. Output: `__version__` (the package version) and `fingerprint()`, a sha256 over
the generator's core sources and templates. Emitted files are cached under the spec's hash and
this fingerprint, so any change to the generator invalidates them and nothing else does.

Example:
    >>> len(fingerprint())
    64
"""

from __future__ import annotations

import functools
import hashlib
from importlib import resources
from pathlib import Path

__all__ = ["__version__", "fingerprint"]

__version__ = "0.2.0"


@functools.cache
def fingerprint() -> str:
    """sha256 of the version, every core module (not the experiments) and every template."""
    h = hashlib.sha256(__version__.encode())
    package = Path(__file__).resolve().parent
    sources = sorted(
        p for p in package.rglob("*.py") if "experiments" not in p.relative_to(package).parts
    )
    for path in sources:
        h.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes() + b"\0")
    templates = Path(str(resources.files("s2gen.templates")))
    for path in sorted(templates.rglob("*.jinja")):
        h.update(str(path.relative_to(templates)).encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()
