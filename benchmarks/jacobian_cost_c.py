"""``python benchmarks/jacobian_cost_c.py``: a step's exact Jacobian against the step, timed in C.

Input: command-line options (``--cases``, ``--h``, ``--calls``, ``--repeats``, ``--keep``,
``--opt``, ``--against``). Output: a table on stdout: per system and method, the time per call
of the emitted step (``NAME_vi_step`` / ``NAME_rk_step``, or a driven module's ``NAME_step``),
of ``NAME_step_jacobian`` (the same step and A in the embedding coordinates; A only, A and B,
A, B and P: the columns of B and P are computed only when they are asked for) and of
``NAME_field_jacobian`` (the field and its J, Ju), and the ratios Jacobian / step, with the
CPU model (from /proc/cpuinfo) and the load (/proc/loadavg) in the header. ``--against DIR``
times, alternately with this checkout's programs, those a run with ``--keep DIR`` built
earlier (e.g. this script run by another checkout's Python: its step and its step_jacobian
with A and B) and prints the ratio old / new of the Jacobians' times. Unlike ``jacobian_cost.py`` (ctypes, about 10
µs of call overhead in both columns), a small C driver written here calls each function in a
loop inside C: the module (emitted with ``System.with_jacobians``) and the driver are compiled
separately with the library's flags (``s2gen.build.DEFAULT_FLAGS``, no link-time
optimization, so no call is folded away) and linked into one program per system, which prints
the best of `repeats` batches of `calls` calls from the spec's initial state, in the
process's CPU time (on a shared machine, the time other processes take counts less than in
wall-clock time). Numbers only: no
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
from s2gen.build import FLAG_SETS, compiler
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
#: calls, repeats and (optional) the Jacobian's columns (0: A, 1: A and B, the default, 2: A, B
#: and P); prints the best seconds per call of the step, step_jacobian, field_jacobian.
DRIVER = r"""#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "NAME.h"

static const double p[] = {PARAMS};
static const double q[] = {Q};
static const double w[] = {W};
static double qn[UPPER_NSTATE], wn[UPPER_NSTATE], A[4 * UPPER_NSTATE * UPPER_NSTATE];
static double B[2 * UPPER_NSTATE * (NINPUTS + 1)], J[4 * UPPER_NSTATE * UPPER_NSTATE];
static double P[2 * UPPER_NSTATE * (NPARAMS + 1)];
static int columns = 1;
static double Ju[2 * UPPER_NSTATE * (NINPUTS + 1)];
static double work[UPPER_WORK_SIZE + 1], jwork[UPPER_JACOBIAN_WORK_SIZE + 1];

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int call(int what, int kind, int code, double h, const NAME_options *opt)
{
    if (what == 1) {
        return NAME_step_jacobian(p, opt, code, 0.0, h, NULL, q, w, qn, wn, A,
                columns >= 1 && NINPUTS ? B : NULL, columns == 2 ? P : NULL, jwork);
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
    columns = argc > 6 ? atoi(argv[6]) : 1;
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
    ap.add_argument("--opt", choices=sorted(FLAG_SETS), default="portable", help="flag set")
    ap.add_argument("--against", help="a --keep folder of another checkout's programs")
    ap.add_argument("--rounds", type=int, default=3, help="alternations with --against")
    return ap.parse_args(argv)


def _literals(values: np.ndarray) -> str:
    return ", ".join(repr(float(v)) for v in np.ravel(values)) or "0.0"


def _flags(opt: str) -> list[str]:
    """The flag set `opt` for a program: no -fPIC -shared, GNU C for clock_gettime."""
    flags = [f for f in FLAG_SETS[opt] if f not in ("-fPIC", "-shared")]
    return [f for f in flags if f != "-std=c99"] + ["-std=gnu99"]


def build(spec: str, folder: Path, opt: str = "portable") -> tuple[Path, s2gen.System]:
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
    driver = driver.replace("NPARAMS", str(len(system.parameter_names)))
    driver = driver.replace("{PARAMS}", "{" + _literals(np.asarray(system.parameter_values)) + "}")
    driver = driver.replace("{Q}", "{" + _literals(system.q0) + "}")
    driver = driver.replace("{W}", "{" + _literals(system.omega0) + "}")
    driver = driver.replace("UPPER", upper).replace("NAME", name)
    (folder / "driver.c").write_text(driver)
    cc = compiler()[0]
    objects = []
    for source in (f"{name}.c", "driver.c"):
        obj = folder / (source[:-2] + ".o")
        subprocess.run([cc, *_flags(opt), "-c", str(folder / source), "-o", str(obj)], check=True)
        objects.append(str(obj))
    program = folder / f"{name}_timing"
    subprocess.run([cc, *objects, "-o", str(program), "-lm"], check=True)
    return program, system


def measure(
    program: Path, system: s2gen.System, name: str, args: argparse.Namespace, columns: int = 1
) -> list[float]:
    """Seconds per call: step, step_jacobian (`columns` 0: A, 1: A and B, 2: A, B and P),
    field_jacobian."""
    kind = 2 if system.driven else (0 if name == "vi" else 1)
    argv = [str(method(name).code), str(kind), repr(args.h), str(args.calls), str(args.repeats)]
    if columns != 1:  # a program built by an older checkout reads five arguments
        argv.append(str(columns))
    out = subprocess.run([str(program), *argv], capture_output=True, text=True, check=True)
    return [float(x) for x in out.stdout.split()]


def _row(program: Path, system: s2gen.System, name: str, args: argparse.Namespace) -> str:
    """One line of the table: this checkout's program, and alternately with it the old one."""
    runs = {c: measure(program, system, name, args, c) for c in (0, 1, 2)}
    ts, tf = runs[1][0], runs[1][2]
    ta, tab, tabp = (runs[c][1] for c in (0, 1, 2))
    line = (
        f"{system.name:18} {system.n:2} {name:6} {ts * 1e6:8.3f} {ta * 1e6:8.3f} {ta / ts:5.1f} "
        f"{tab / ts:6.1f} {tabp / ts:6.1f} {tf * 1e6:8.3f}"
    )
    if args.against:
        old = Path(args.against) / program.parent.name / program.name
        new_t, old_t = [runs[1]], []
        for _ in range(args.rounds):
            old_t.append(measure(old, system, name, args))
            new_t.append(measure(program, system, name, args))
        ns, nj = min(r[0] for r in new_t), min(r[1] for r in new_t)
        os_, oj = min(r[0] for r in old_t), min(r[1] for r in old_t)
        line += f" {oj * 1e6:8.3f} {oj / os_:5.1f} {nj / ns:5.1f} {oj / nj:5.2f}"
    return line


def main(argv: list[str] | None = None) -> int:
    """Print the table: times in µs, ratios to the step."""
    args = parse_args(argv)
    print(f"# step_jacobian and field_jacobian against the step, timed in C; CPU: {cpu_model()}")
    print(f"# h = {args.h}, best of {args.repeats} batches of {args.calls} calls; flags "
          f"{' '.join(_flags(args.opt))}; load {Path('/proc/loadavg').read_text().split()[:3]}")  # fmt: skip
    print("# A, AB, ABP: step_jacobian writing A; A and B (when there are inputs); A, B and P")
    head = f"{'system':18} {'n':>2} {'method':6} {'step':>8} {'A':>8} {'A/st':>5} "
    head += f"{'AB/st':>6} {'ABP/st':>6} {'field J':>8}"
    if args.against:
        head += f" {'old AB':>8} {'old/st':>5} {'new/st':>5} {'old/new':>5}"
        print(f"# old: the programs in {args.against}, alternated {args.rounds} times with new; "
              "old/st and new/st from the alternation's best times")  # fmt: skip
    print(head)
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.keep) if args.keep else Path(tmp)
        programs: dict[str, tuple[Path, s2gen.System]] = {}
        for case in args.cases:
            spec, _, name = case.rpartition(":")
            if spec not in programs:
                programs[spec] = build(spec, root / Path(spec).stem, args.opt)
            program, system = programs[spec]
            print(_row(program, system, name, args), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
