"""Build and run the two programs of a case: hand-written C and a driver of the emitted C.

Input: a `Case`, a working folder and the flavours to build. Output: `Programs` (the paths of
both executables per flavour) from `build`, and `Result`s (ns per step, Newton iterations per
step, relative energy change, final state) from `run`.

Both programs are compiled by the same gcc with the same flags: ``-std=c99 -fno-math-errno
-fopenmp-simd`` and then ``-O2`` (flavour "O2") or ``-O3 -march=native`` ("O3n"); -std=c99
keeps gcc from contracting a*b + c into fused multiply-adds, so both stay IEEE. The emitted
code comes from `s2gen.generate` (what ``s2gen generate SPEC --lang c`` writes) and is driven
through its public ``NAME_integrate`` with the VI, every state stored and energy = NULL; the
hand-written program likewise stores every state and times only the integration.

Example:
    >>> FLAVOURS["O3n"]
    ('-O3', '-march=native')
"""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path
from string import Template

import numpy as np

from unseen_systems.cases import HERE, Case, data_header, state_header

__all__ = ["COMMON", "FLAVOURS", "Programs", "Result", "build", "run"]

COMMON = ("-std=c99", "-fno-math-errno", "-fopenmp-simd")
FLAVOURS: dict[str, tuple[str, ...]] = {"O2": ("-O2",), "O3n": ("-O3", "-march=native")}


@dataclass(frozen=True)
class Programs:
    """The executables of one case, hand[flavour] and emitted[flavour], and the initial state
    both start from (q then w, body-major, as `Result.state`)."""

    case: Case
    initial: np.ndarray
    hand: dict[str, Path]
    emitted: dict[str, Path]


@dataclass(frozen=True)
class Result:
    """What one launch printed: the median ns per step over its runs on the wall clock and in
    CPU time, Newton iterations per step, |E_end - E_0| / |E_0| and the final state (q then
    w, body-major)."""

    ns_per_step: float
    cpu_ns_per_step: float
    newton_per_step: float
    energy_change: float
    state: np.ndarray


def _gcc(out: Path, sources: list[Path], flags: tuple[str, ...], include: Path) -> None:
    cmd = ["gcc", *COMMON, *flags, "-I", str(include), "-o", str(out), *map(str, sources), "-lm"]
    done = subprocess.run(cmd, check=False, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"gcc failed for {out.name}:\n{done.stderr}")


def build(case: Case, folder: Path, flavours: tuple[str, ...] = tuple(FLAVOURS)) -> Programs:
    """Emit the case's C, write the data headers and compile both programs per flavour into
    `folder` (created if needed)."""
    import s2gen

    folder.mkdir(parents=True, exist_ok=True)
    system = s2gen.load(str(case.spec))
    s2gen.generate(system, "c", out=folder)
    name = system.name
    (folder / f"{name}_state.h").write_text(state_header(system), encoding="utf-8")
    (folder / f"{name}_data.h").write_text(data_header(case, system), encoding="utf-8")
    template = Template((HERE / "emitted_driver.c").read_text(encoding="utf-8"))
    driver = folder / f"{name}_driver.c"
    driver.write_text(
        template.substitute(name=name, upper=name.upper(), data=f"{name}_state.h"),
        encoding="utf-8",
    )
    hand: dict[str, Path] = {}
    emitted: dict[str, Path] = {}
    for flavour in flavours:
        flags = FLAVOURS[flavour]
        hand[flavour] = folder / f"{name}_hand.{flavour}"
        _gcc(hand[flavour], [case.hand], flags, folder)
        emitted[flavour] = folder / f"{name}_emitted.{flavour}"
        _gcc(emitted[flavour], [driver, folder / f"{name}.c"], flags, folder)
    initial = np.concatenate([np.ravel(system.q0), np.ravel(system.omega0)])
    return Programs(case, initial, hand, emitted)


def _parse(text: str, program: Path) -> Result:
    fields: dict[str, list[str]] = {}
    for line in text.splitlines():
        key, _, rest = line.partition(" ")
        fields[key] = rest.split()
    try:
        return Result(
            float(fields["ns_per_step"][0]),
            float(fields["cpu_ns_per_step"][0]),
            float(fields["newton_per_step"][0]),
            float(fields["energy_change"][0]),
            np.array([float(x) for x in fields["q"] + fields["w"]]),
        )
    except (KeyError, IndexError, ValueError) as exc:
        raise RuntimeError(f"{program.name}: unexpected output ({exc}):\n{text[:400]}") from None


def run(program: Path, steps: int, repeats: int) -> Result:
    """Run one program for `steps` steps, `repeats` times in one launch; parse its output."""
    done = subprocess.run(
        [str(program), str(steps), str(repeats)], check=False, capture_output=True, text=True
    )
    if done.returncode != 0:
        raise RuntimeError(f"{program.name} failed ({done.returncode}): {done.stderr.strip()}")
    return _parse(done.stdout, program)
