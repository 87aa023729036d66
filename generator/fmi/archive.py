"""The FMU archive: model description, sources and a binary for this platform, in a zip that
is byte-reproducible apart from the binary.

Input: an `FmuModel`, the emitted C files of its system and the wrapper source. Output: the
archive's entries ({path in the zip: bytes}) and the zip file itself. The binary is built by
`s2gen.build.compile_shared` (the same compiler, flags and cache as the runtime's libraries)
with the FMI headers that FMPy ships on the include path; entries are written in a fixed
order with a fixed timestamp and fixed permissions.

Example:
    >>> sorted(binary_folder(fmi) for fmi in (2, 3))
    ['linux64', 'x86_64-linux']
"""

from __future__ import annotations

import importlib.util
import io
import platform
import zipfile
from pathlib import Path

from s2gen.build import DEFAULT_FLAGS, compile_shared
from s2gen.fmi.description import build_description, model_description
from s2gen.fmi.model import FmuModel
from s2gen.version import __version__

__all__ = ["ZIP_TIME", "binary_folder", "entries", "fmi_headers", "write_zip"]

#: The timestamp of every zip entry (the earliest a zip can hold).
ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def fmi_headers() -> Path:
    """The folder of the FMI 2 and 3 headers that the installed FMPy ships (ValueError when
    FMPy is not installed: ``pip install fmpy``, or the extra ``s2gen[fmu]``)."""
    spec = importlib.util.find_spec("fmpy")
    if spec is None or spec.origin is None:
        raise ValueError("an FMU needs the FMI headers that FMPy ships: pip install fmpy")
    folder = Path(spec.origin).parent / "c-code"
    if not (folder / "fmi2Functions.h").is_file() or not (folder / "fmi3Functions.h").is_file():
        raise ValueError(f"no FMI headers in {folder} (reinstall fmpy)")
    return folder


def binary_folder(fmi: int) -> str:
    """The folder under binaries/ of this machine's platform in FMI `fmi`'s naming."""
    machine = platform.machine().lower()
    if platform.system() != "Linux" or machine not in ("x86_64", "amd64"):
        raise ValueError(
            f"FMU binaries are built for x86-64 Linux only (this is {platform.system()} "
            f"{machine}); the FMU's sources compile elsewhere"
        )
    return "linux64" if fmi == 2 else "x86_64-linux"


def entries(model: FmuModel, emitted: dict[str, str], wrapper: dict[str, str]) -> dict[str, bytes]:
    """{path in the archive: content}, in the order they are written: the description, the
    sources (FMI 3: with their build description), the binary."""
    sources = {**emitted, **wrapper}
    c_files = tuple(sorted(n for n in sources if n.endswith(".c")))
    tool = f"s2gen {__version__}"
    out = {"modelDescription.xml": model_description(model, c_files, tool).encode()}
    if model.fmi == 3:
        out["sources/buildDescription.xml"] = build_description(model, c_files).encode()
    for name in sorted(sources):
        out[f"sources/{name}"] = sources[name].encode()
    flags = (*DEFAULT_FLAGS, "-I" + str(fmi_headers()))
    library = compile_shared(sources, flags).path
    out[f"binaries/{binary_folder(model.fmi)}/{model.name}.so"] = library.read_bytes()
    return out


def write_zip(files: dict[str, bytes], out: Path) -> Path:
    """Write `files` as a zip to `out` (through a temporary file moved into place)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, data in files.items():
            info = zipfile.ZipInfo(name, date_time=ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.create_system = 3
            info.external_attr = 0o644 << 16
            archive.writestr(info, data, compresslevel=9)
    tmp = out.with_name(out.name + ".part")
    tmp.write_bytes(buffer.getvalue())
    tmp.replace(out)
    return out
