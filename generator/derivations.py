"""The disk cache of derivations: what one process derived, the next one reads back.

It holds the generic kernels (the same for every system with one inertia solver), the
`factor` and `cse` passes' result for each kernel definition (keyed by the whole definition,
so a term another system had is not factored again) and the compiled templates
(`s2gen.render.TemplateCache`); SymPy is still imported by every derivation (the system's own
kernels and the spec's expressions are SymPy).

Input: a namespace, a key text (what the value was derived from) and a function that derives
the value. Output: the value, read back from ``derived/<namespace>/<digest>.pickle`` under the
build cache folder (`s2gen.build.cache_dir`) when an intact entry exists, else derived, then
written there. The digest covers the key text, the generator's fingerprint
(`s2gen.version.fingerprint`: every core source and template), the SymPy and Python versions,
so an entry is never read by another generator or library than the one that wrote it.

An entry is a header line, the sha256 of the payload and the payload (a pickle of frozen IR
records holding SymPy expressions). The payload's checksum is verified before it is unpickled:
a truncated, emptied or overwritten entry is logged, derived again and rewritten, never
trusted. (Pickle, not text: rebuilding SymPy trees from text costs about what deriving them
does; the folder is the user's own, as are the shared libraries loaded from it.) Entries are written to a private temporary file and renamed into place
(`os.replace`), so concurrent writers leave one whole entry and readers never see half of one.

Example:
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> cached(folder, "demo", "squares", lambda: tuple(k * k for k in range(4)))
    (0, 1, 4, 9)
    >>> cached(folder, "demo", "squares", lambda: ())  # read back, not derived again
    (0, 1, 4, 9)
"""

from __future__ import annotations

import functools
import hashlib
import logging
import os
import pickle
import platform
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from s2gen.version import fingerprint

if TYPE_CHECKING:
    from s2gen.ir import KernelDef

__all__ = [
    "cached",
    "enabled",
    "entry_path",
    "kernel_key",
    "read_payload",
    "structural_text",
    "uncached",
    "write_payload",
]

log = logging.getLogger("s2gen.derivations")

T = TypeVar("T")

_HEADER = b"s2gen derivation 1\n"

#: False inside `uncached()`: every derivation is done again and nothing is written.
_ENABLED: ContextVar[bool] = ContextVar("s2gen_derivation_cache", default=True)


@contextmanager
def uncached() -> Iterator[None]:
    """Within the block, derive everything again: no entry is read or written (what
    `s2gen.emit.emit(..., cache=False)` measures).

    Example:
        >>> import tempfile
        >>> with uncached():
        ...     cached(Path(tempfile.mkdtemp()), "demo", "one", lambda: 1)
        1
    """
    token = _ENABLED.set(False)
    try:
        yield
    finally:
        _ENABLED.reset(token)


def kernel_key(kdef: KernelDef) -> str:
    """Everything a kernel definition is, as text: its name, doc, flags, the full SymPy form
    of its inputs and outputs (`structural_text`, assumptions included); two definitions have
    the same key exactly when they are equal.

    Example:
        >>> import sympy as sp
        >>> from s2gen.ir import Argument, KernelDef, Output
        >>> x = sp.Symbol("x", real=True)
        >>> k = KernelDef("k", "doc", (Argument("x", (x,), True),), (Output("y", (x**2,), True),))
        >>> kernel_key(k) == kernel_key(KernelDef("k", "doc", k.inputs, k.outputs))
        True
    """
    memo: dict[int, str] = {}
    inputs = [(a.name, a.scalar, a.shared, structural_text(a.symbols, memo)) for a in kdef.inputs]
    outputs = [(o.name, o.scalar, structural_text(o.exprs, memo)) for o in kdef.outputs]
    return repr((kdef.name, kdef.doc, kdef.system, kdef.stages, inputs, outputs))


def structural_text(obj: object, memo: dict[int, str] | None = None) -> str:
    """A text that two SymPy objects (or tuples and lists of them) share exactly when they are
    equal: a node whose equality is its class and arguments is written as its class and its
    arguments' texts, anything else (symbols with their assumptions, numbers, undefined
    functions) as `sympy.srepr` writes it. It costs a fraction of `srepr` of the whole tree;
    `memo` (by object id, for objects alive during the call) shares subtrees met twice.

    Example:
        >>> import sympy as sp
        >>> x = sp.Symbol("x", positive=True)
        >>> structural_text((sp.sin(x) + 1,))
        "(sympy.core.add.Add(Integer(1),sympy.functions.elementary.trigonometric.sin(Symbol('x', positive=True))),)"
    """
    from sympy import srepr
    from sympy.core.basic import Basic
    from sympy.core.expr import Expr
    from sympy.core.function import AppliedUndef

    plain = (Basic._hashable_content, Expr._hashable_content)
    memo = {} if memo is None else memo

    def text(node: object) -> str:
        known = memo.get(id(node))
        if known is not None:
            return known
        if isinstance(node, Basic):
            cls = type(node)
            if node.args and cls._hashable_content in plain and not isinstance(node, AppliedUndef):
                inner = ",".join([text(a) for a in node.args])
                out = f"{cls.__module__}.{cls.__qualname__}({inner})"
            else:
                out = srepr(node)
        elif isinstance(node, (tuple, list)):
            inner = "".join([text(a) + "," for a in node])
            out = f"({inner})" if isinstance(node, tuple) else f"[{inner}]"
        elif node is None or isinstance(node, (bool, int, float, str)):
            out = repr(node)
        else:
            out = srepr(node)
        memo[id(node)] = out
        return out

    return text(obj)


@functools.cache
def _versions() -> str:
    """What every entry's digest covers beside its own key: generator, SymPy and Python."""
    import sympy

    return f"{fingerprint()}\0{sympy.__version__}\0{platform.python_version()}"


def _digest(namespace: str, key: str) -> str:
    text = f"{namespace}\0{key}\0{_versions()}"
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def entry_path(root: Path, namespace: str, key: str) -> Path:
    """The file of one cache entry under the cache folder `root`.

    Example:
        >>> entry_path(Path("/c"), "kernels", "dense").parent
        PosixPath('/c/derived/kernels')
    """
    return root / "derived" / namespace / f"{_digest(namespace, key)}.pickle"


def read_payload(path: Path) -> bytes | None:
    """The payload of an intact entry file, or None (missing, or damaged: logged).

    Example:
        >>> import tempfile
        >>> path = Path(tempfile.mkdtemp()) / "entry"
        >>> write_payload(path, b"abc"); read_payload(path)
        b'abc'
    """
    try:
        data = path.read_bytes()
    except OSError:
        return None
    head, _, rest = data.partition(b"\n")
    digest, _, payload = rest.partition(b"\n")
    if head + b"\n" != _HEADER or hashlib.sha256(payload).hexdigest().encode() != digest:
        log.warning("derivation cache entry %s is damaged; deriving again", path.name)
        return None
    return payload


def write_payload(path: Path, payload: bytes) -> None:
    """Write an entry file atomically (a private temporary file renamed into place) with its
    header and checksum; best effort: a cache that cannot be written only costs the next
    process a derivation."""
    data = _HEADER + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
    except OSError as exc:
        log.info("derivation not cached (%s)", exc)
        return
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError as exc:
        log.info("derivation not cached (%s)", exc)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _read(path: Path) -> object | None:
    """The value of an intact entry, or None (missing, or damaged: logged)."""
    payload = read_payload(path)
    if payload is None:
        return None
    try:
        return pickle.loads(payload)
    except (pickle.UnpicklingError, AttributeError, ImportError, EOFError, TypeError) as exc:
        log.warning("derivation cache entry %s does not load (%s); deriving again", path.name, exc)
        return None


def _write(path: Path, value: object) -> None:
    """Write a value's entry (`write_payload` of its pickle)."""
    write_payload(path, pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))


def enabled() -> bool:
    """False inside `uncached()`.

    Example:
        >>> enabled()
        True
    """
    return _ENABLED.get()


def cached(root: Path, namespace: str, key: str, derive: Callable[[], T]) -> T:
    """`derive()`, read from the entry (`namespace`, `key`) under the cache folder `root` when
    it is intact, else derived and written there. `key` must name everything the value
    depends on beyond the generator's sources (which the entry's digest covers)."""
    if not _ENABLED.get():
        return derive()
    path = entry_path(root, namespace, key)
    value = _read(path)
    if value is not None:
        log.info("reused derivation %s/%s", namespace, path.name)
        return value  # type: ignore[return-value]
    value = derive()
    _write(path, value)
    return value
