"""FMI export: a system as a Functional Mock-up Unit (FMI 2 or 3; Co-Simulation, Model
Exchange or both) that FMPy and other importers load.

Input: a `System` and the export choices. Output: the .fmu file: modelDescription.xml
(`description`), the emitted C with its FMI wrapper (`wrapper`, from `templates/fmu/`) as a
source FMU, and a binary for this platform (`archive`). What the FMU declares (variables,
value references, start values, default experiment) is one record (`model`).

Variables: parameters (tunable), outputs q1_x .. wn_z, energy, J_x, J_y, J_z, and in
Co-Simulation the sub-step `stepSize`. A driven system (forces, inputs or time t) has its
inputs as FMI inputs (held over each step), its time is the FMU's, and it has the output
`work` (Co-Simulation; its Model Exchange hands out the driven field).

Example:
    >>> import s2gen, tempfile, zipfile
    >>> out = Path(tempfile.mkdtemp()) / "double_pendulum.fmu"
    >>> path = export(s2gen.load("double_pendulum"), out, fmi=2, kind="cs")
    >>> zipfile.ZipFile(path).namelist()[0]
    'modelDescription.xml'
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from s2gen.system import System

__all__ = ["FMI_VERSIONS", "KINDS", "export", "fmu_files"]


def __getattr__(name: str) -> Any:
    """`FMI_VERSIONS` and `KINDS` from `model`, imported on first use: the command line's
    parser imports `s2gen.fmi.command` through this package and needs none of the rest."""
    if name in ("FMI_VERSIONS", "KINDS"):
        from s2gen.fmi import model

        return getattr(model, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def fmu_files(
    system: System,
    fmi: int = 2,
    kind: str | None = None,
    method: str = "vi",
    h: float | None = None,
) -> dict[str, bytes]:
    """The entries of the FMU of `system` ({path in the archive: content}, in archive order).

    Example:
        >>> import s2gen
        >>> files = fmu_files(s2gen.load("double_pendulum"), fmi=3, kind="me")
        >>> [name for name in files if name.startswith("binaries/")]
        ['binaries/x86_64-linux/double_pendulum.so']
    """
    from s2gen.emit import emit
    from s2gen.fmi.archive import entries
    from s2gen.fmi.model import describe
    from s2gen.fmi.wrapper import wrapper_files

    model = describe(system, fmi, kind, method, h)
    return entries(model, emit(system, "c"), wrapper_files(model))


def export(
    system: System,
    out: str | Path,
    fmi: int = 2,
    kind: str | None = None,
    method: str = "vi",
    h: float | None = None,
) -> Path:
    """Write the FMU of `system` to `out` and return its path: FMI `fmi` (2 or 3), `kind`
    "cs", "me" or "both" (None: "both", "cs" for a driven system), Co-Simulation by `method` (any method of the emitted C; fixed-step
    ones sub-step each communication interval with `h`, default the spec's [run] h, which the
    FMU's `stepSize` parameter can change).

    Example:
        >>> import s2gen, tempfile
        >>> out = Path(tempfile.mkdtemp()) / "pendulum.fmu"
        >>> export(s2gen.load("double_pendulum"), out, fmi=3).name
        'pendulum.fmu'
    """
    from s2gen.fmi.archive import write_zip

    return write_zip(fmu_files(system, fmi, kind, method, h), Path(out))
