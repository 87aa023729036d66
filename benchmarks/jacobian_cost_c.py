"""``python benchmarks/jacobian_cost_c.py``: a step's exact Jacobian against the step, timed in C.

Input: command-line options (``--cases``, ``--h``, ``--calls``, ``--repeats``, ``--keep``).
Output: a table on stdout: per system and method, the time per call of the emitted step
(``NAME_vi_step`` / ``NAME_rk_step``, or a driven module's ``NAME_step``), of
``NAME_step_jacobian`` (the same step and A, B in the embedding coordinates) and of
``NAME_field_jacobian`` (the field and its J, Ju), and the ratio Jacobian / step, with the
CPU model (from /proc/cpuinfo) in the header. Unlike ``jacobian_cost.py`` (ctypes, about 10
µs of call overhead in both columns), a small C driver written here calls each function in a
loop inside C: the module (emitted with ``System.with_jacobians``) and the driver are compiled
separately with the library's flags (``s2gen.build.DEFAULT_FLAGS``, no link-time
optimization, so no call is folded away) and linked into one program per system, which prints
the best of `repeats` batches of `calls` calls from the spec's initial state. Numbers only: no
test times them. The issue's aim is a ratio of at most 3 for n <= 8.

Example:
    >>> parse_args(["--cases", "double_pendulum:vi", "--calls", "10"]).calls
    10
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from python_step import cpu_model

import s2gen
from s2gen.build import DEFAULT_FLAGS, compiler
from s2gen.emit import emit
from s2gen.methods import method

#: (spec, method) measured by default: the issue's n <= 8 cases
CASES = (
    "double_pendulum:vi",
    "double_pendulum:rk4",
    "four_pendula:vi",
    "four_pendula:rk4",
    "three_bodies:vi",
    "tests/specs/driven_double.toml:vi",
    "tests/specs/driven_double.toml:rk4",
)

#: The driver: argv = method code, kind (0 vi_step, 1 rk_step, 2 a driven module's step), h,
#: calls, repeats; prints the best seconds per call of the step, step_jacobian, field_jacobian.
DRIVER = r"""#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "NAME.h"

static const double p[] = {PARAMS};
static const double q[] = {Q};
static const double w[] = {W};
static double qn[UPPER_NSTATE], wn[UPPER_NSTATE], A[4 * UPPER_NSTATE * UPPER_NSTATE];
static double B[2 * UPPER_NSTATE * (NINPUTS + 1)], J[4 * UPPER_NSTATE * UPPER_NSTATE];
static double Ju[2 * UPPER_NSTATE * (NINPUTS + 1)];
static double work[UPPER_WORK_SIZE + 1], jwork[UPPER_JACOBIAN_WORK_SIZE + 1];

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int call(int what, int kind, int code, double h, const NAME_options *opt)
{
    if (what == 1) {
        return NAME_step_jacobian(p, opt, code, 0.0, h, NULL, q, w, qn, wn, A, NINPUTS ? B : NULL, NULL, jwork);
    }
    if (what == 2) {
        return NAME_field_jacobian(p, 0.0, NULL, q, w, qn, wn, J, NINPUTS ? Ju : NULL, NULL, jwork);
    }
    STEP_CALL
}

int main(int argc, char **argv)
{
    const int code = atoi(argv[1]), kind = atoi(argv[2]);
    const double h = atof(argv[3]);
    const long calls = atol(argv[4]);
    const int repeats = atoi(argv[5]);
    NAME_options opt;
    int what, r;
    long k;
    NAME_default_options(&opt);
    for (what = 0; what < 3; ++what) {
        double best = 1e300, sink = 0.0;
        if (call(what, kind, code, h, &opt) != 0) {
            fprintf(stderr, "call %d failed\n", what);
            return 1;
        }
        for (r = 0; r < repeats; ++r) {
            const double start = now();
            for (k = 0; k < calls; ++k) {
                call(what, kind, code, h, &opt);
                sink += qn[0];
            }
            const double per = (now() - start) / (double)calls;
            best = per < best ? per : best;
        }
        printf("%.9e %s", best, sink == 0.12345 ? "!" : "");
    }
    printf("\n");
    return 0;
}
"""

CLOSED_STEP = """(void)kind;
    if (code == UPPER_METHOD_VI) {
        return NAME_vi_step(p, opt, h, q, w, qn, wn, work, NULL);
    }
    return NAME_rk_step(p, code, h, q, w, qn, wn, work);"""

DRIVEN_STEP = """(void)kind;
    return NAME_step(p, opt, code, 0.0, h, NULL, q, w, qn, wn, NULL, work, NULL);"""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The options of the module docstring."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), metavar="SPEC:METHOD")
    ap.add_argument("--h", type=float, default=0.001)
    ap.add_argument("--calls", type=int, default=20000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--keep", help="folder to keep the programs in (default: a temporary one)")
    return ap.parse_args(argv)


def _literals(values: np.ndarray) -> str:
    return ", ".join(repr(float(v)) for v in np.ravel(values)) or "0.0"


def build(spec: str, folder: Path) -> tuple[Path, s2gen.System]:
    """The timing program of one system (emitted with its Jacobians) in `folder`."""
    checkout = Path(__file__).resolve().parent.parent / spec  # the test specs, from any folder
    system = s2gen.load(str(checkout) if checkout.is_file() else spec).with_jacobians()
    name, upper = system.name, system.name.upper()
    folder.mkdir(parents=True, exist_ok=True)
    for fname, text in emit(system, "c").items():
        (folder / fname).write_text(text)
    step = DRIVEN_STEP if system.driven else CLOSED_STEP
    driver = DRIVER.replace("STEP_CALL", step)
    driver = driver.replace("NINPUTS", str(len(system.inputs.names)))
    driver = driver.replace("{PARAMS}", "{" + _literals(np.asarray(system.parameter_values)) + "}")
    driver = driver.replace("{Q}", "{" + _literals(system.q0) + "}")
    driver = driver.replace("{W}", "{" + _literals(system.omega0) + "}")
    driver = driver.replace("UPPER", upper).replace("NAME", name)
    (folder / "driver.c").write_text(driver)
    cc = compiler()[0]
    flags = [f for f in DEFAULT_FLAGS if f not in ("-fPIC", "-shared")]
    flags = [f for f in flags if f != "-std=c99"] + ["-std=gnu99"]  # clock_gettime
    objects = []
    for source in (f"{name}.c", "driver.c"):
        obj = folder / (source[:-2] + ".o")
        subprocess.run([cc, *flags, "-c", str(folder / source), "-o", str(obj)], check=True)
        objects.append(str(obj))
    program = folder / f"{name}_timing"
    subprocess.run([cc, *objects, "-o", str(program), "-lm"], check=True)
    return program, system


def measure(
    program: Path, system: s2gen.System, name: str, args: argparse.Namespace
) -> list[float]:
    """Seconds per call: step, step_jacobian, field_jacobian."""
    kind = 2 if system.driven else (0 if name == "vi" else 1)
    argv = [str(method(name).code), str(kind), repr(args.h), str(args.calls), str(args.repeats)]
    out = subprocess.run([str(program), *argv], capture_output=True, text=True, check=True)
    return [float(x) for x in out.stdout.split()]


def main(argv: list[str] | None = None) -> int:
    """Print the table."""
    args = parse_args(argv)
    print(f"# step_jacobian and field_jacobian against the step, timed in C; CPU: {cpu_model()}")
    print(f"# h = {args.h}, best of {args.repeats} batches of {args.calls} calls; flags "
          f"{' '.join(DEFAULT_FLAGS[:-2])}")  # fmt: skip
    print(f"{'system':18} {'n':>2} {'method':6} {'step µs':>9} {'jacobian µs':>12} "
          f"{'ratio':>6} {'field J µs':>11}")  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.keep) if args.keep else Path(tmp)
        programs: dict[str, tuple[Path, s2gen.System]] = {}
        for case in args.cases:
            spec, _, name = case.rpartition(":")
            if spec not in programs:
                programs[spec] = build(spec, root / Path(spec).stem)
            program, system = programs[spec]
            ts, tj, tf = measure(program, system, name, args)
            print(
                f"{system.name:18} {system.n:2} {name:6} {ts * 1e6:9.3f} {tj * 1e6:12.3f} "
                f"{tj / ts:6.1f} {tf * 1e6:11.3f}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
