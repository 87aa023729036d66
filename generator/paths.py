"""Output files: checked before any work, written atomically, never through a symbolic link.

Input: a path the user named (a trajectory, an emitted file). Output: `check_output_file`
raises `OutputPathError` (a ValueError with one line naming the path and the reason) when the
file could not be written: the path is a folder, a symbolic link (even one pointing to a
harmless place: refusing is the only rule that cannot be turned against the user), not a
regular file, below something that is not a folder, or in a folder where a file cannot be
created (this is tried, not guessed from permission bits, which root ignores).
`write_atomic` writes into a temporary file in the target's folder and moves it into place with
`os.replace`, so a reader never sees half a file and an interrupted write leaves the old file.

Example:
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> write_atomic(d / "a.txt", lambda f: f.write(b"hi")).read_bytes()
    b'hi'
    >>> try:
    ...     check_output_file(d)
    ... except OutputPathError as exc:
    ...     print(str(exc).endswith("is a directory, not a file"))
    True
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

__all__ = ["OutputPathError", "check_output_file", "write_atomic", "write_text_atomic"]


class OutputPathError(ValueError):
    """An output path that cannot (or must not) be written; the message is one line."""


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__


def _existing_ancestor(path: Path) -> Path:
    """The nearest ancestor of `path` (itself excluded) that exists."""
    for parent in path.parents:
        if parent.exists() or parent.is_symlink():
            return parent
    return Path(".")


def check_output_file(path: str | Path, create_parents: bool = True) -> Path:
    """Check that `path` can be written as a regular file, before any work is done.

    Creates the missing parent folders (unless `create_parents` is false) and tries creating
    and removing a temporary file beside the target. Raises `OutputPathError` otherwise.

    Example:
        >>> import tempfile, pathlib
        >>> d = pathlib.Path(tempfile.mkdtemp())
        >>> check_output_file(d / "sub" / "traj.npz").name
        'traj.npz'
    """
    p = Path(path)
    if str(path) == "":
        raise OutputPathError("'': the output path is empty")
    if p.is_symlink():
        raise OutputPathError(f"{p}: is a symbolic link; refusing to write through it")
    if p.is_dir():
        raise OutputPathError(f"{p}: is a directory, not a file")
    if p.exists() and not stat.S_ISREG(p.stat().st_mode):
        raise OutputPathError(f"{p}: exists and is not a regular file")
    folder = p.parent
    ancestor = _existing_ancestor(p)
    if not ancestor.is_dir():
        raise OutputPathError(f"{p}: {ancestor} is not a directory")
    if not folder.is_dir():
        if not create_parents:
            raise OutputPathError(f"{p}: folder {folder} does not exist")
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputPathError(f"{p}: cannot create folder {folder}: {_reason(exc)}") from None
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=f".{p.name}.", suffix=".probe")
    except OSError as exc:
        raise OutputPathError(f"{p}: cannot write in folder {folder}: {_reason(exc)}") from None
    os.close(fd)
    os.unlink(probe)
    return p


def _new_file_mode() -> int:
    """The mode an ordinary open() would give a new file (0o666 less the umask)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def _temporary_beside(p: Path) -> Iterator[tuple[IO[bytes], str]]:
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            yield f, tmp
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_atomic(path: str | Path, write: Callable[[IO[bytes]], Any]) -> Path:
    """Write a file by calling `write(f)` on a temporary file beside it, then `os.replace`.

    Refuses a symbolic link at `path` (never writes through one); keeps an existing file's
    permission bits. Returns the path written, exactly as given.

    Example:
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "x.bin"
        >>> write_atomic(p, lambda f: f.write(b"\\x00")).stat().st_size
        1
    """
    p = check_output_file(path)
    mode = p.stat().st_mode & 0o7777 if p.exists() else _new_file_mode()
    try:
        with _temporary_beside(p) as (f, tmp):
            write(f)
            f.flush()
            os.fchmod(f.fileno(), mode)
        if p.is_symlink():  # appeared meanwhile: still refuse
            os.unlink(tmp)
            raise OutputPathError(f"{p}: is a symbolic link; refusing to write through it")
        os.replace(tmp, p)
    except OSError as exc:
        raise OutputPathError(f"{p}: cannot write: {_reason(exc)}") from None
    return p


def write_text_atomic(path: str | Path, text: str) -> Path:
    """`write_atomic` of a UTF-8 text.

    Example:
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.c"
        >>> write_text_atomic(p, "int x;\\n").read_text()
        'int x;\\n'
    """
    data = text.encode("utf-8")
    return write_atomic(path, lambda f: f.write(data))
