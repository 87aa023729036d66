"""``python benchmarks/fmu_dostep_driven.py``: a driven FMU's doStep against the bare step.

Input: command-line options (``--intervals``, ``--repeats``, ``--fmi``). Output: a table on
stdout naming the machine (CPU model from /proc/cpuinfo) and gcc: the time per VI step of the
forced double pendulum (damping and a periodic torque: forces and time) when a C loop calls
the emitted driven `forced_double_pendulum_step` 100 times per communication interval, adding
up the work W of its steps per interval (as a program embedding the emitted C would), and when it calls
the FMU's `fmi2DoStep`/`fmi3DoStep` once per interval of 100 steps (the wrapper runs the
driven `integrate()` over it, keeping the work), and their ratio. Both are compiled into one
program from the FMU's own sources with the flags of the runtime's library, run alternately,
and must end in the same state and work bit for bit (exit status 1 otherwise). The FMU side
(instantiate, initialize, doStep, read the state) is `fmu_dostep.py`'s.

Example:
    >>> parse_args(["--intervals", "50"]).intervals
    50
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Sequence
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fmu_dostep import FMU_SIDE, SUBSTEPS, cpu_model

import s2gen

#: The timing program: argv = GUID, intervals, repeats; prints "bare_ns fmu_ns max_diff
#: work_diff".
DRIVER = r"""
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "fmi@V@Functions.h"
#include "forced_double_pendulum.h"

#define N FORCED_DOUBLE_PENDULUM_NSTATE
#define SUB @SUB@

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

@CALLBACKS@

static double bare(long intervals, double h, double *q, double *w, double *done)
{
    static double work[FORCED_DOUBLE_PENDULUM_WORK_SIZE];
    double p[FORCED_DOUBLE_PENDULUM_NPARAMS], qn[N], wn[N], W, t = 0.0, start;
    long i, k;
    forced_double_pendulum_default_params(p);
    forced_double_pendulum_initial_state(q, w);
    *done = 0.0;
    start = now();
    for (i = 0; i < intervals; ++i, t += SUB * h) {
        double part = 0.0; /* the work of the interval, added up as doStep does */
        for (k = 0; k < SUB; ++k) {
            if (forced_double_pendulum_step(p, NULL, FORCED_DOUBLE_PENDULUM_METHOD_VI,
                    t + (double)k * h, h, NULL, q, w, qn, wn, &W, work, NULL) != 0) {
                exit(2);
            }
            part += W;
            memcpy(q, qn, sizeof qn);
            memcpy(w, wn, sizeof wn);
        }
        *done += part;
    }
    return now() - start;
}

int main(int argc, char **argv)
{
    long intervals = atol(argv[2]), repeats = atol(argv[3]), r, i;
    double h = 0.01, best_bare = 1e300, best_fmu = 1e300, q[N], w[N], x[2 * N + 1];
    double done = 0.0, diff = 0.0;
    for (r = 0; r < repeats; ++r) {
        double t = bare(intervals, h, q, w, &done);
        double f = fmu(argv[1], intervals, h, x);
        best_bare = t < best_bare ? t : best_bare;
        best_fmu = f < best_fmu ? f : best_fmu;
    }
    for (i = 0; i < N; ++i) {
        double a = q[i] - x[i], b = w[i] - x[N + i];
        diff = a * a > diff ? a * a : diff;
        diff = b * b > diff ? b * b : diff;
    }
    (void)argc;
    printf("%.6g %.6g %.3g %.3g\n", 1e9 * best_bare / (double)(intervals * SUB),
           1e9 * best_fmu / (double)(intervals * SUB), diff, @WORK@);
    return 0;
}
"""


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line's options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--intervals", type=int, default=200, help="communication intervals (200)")
    p.add_argument("--repeats", type=int, default=7, help="alternating runs, best kept (7)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version (2)")
    return p.parse_args(argv)


def build(folder: Path, fmi: int) -> tuple[Path, str]:
    """The timing program built from the forced double pendulum FMU's sources; its GUID."""
    import fmpy

    from s2gen.build import DEFAULT_FLAGS, compiler

    system = s2gen.load("forced_double_pendulum")
    path = s2gen.fmu(system, folder / "fdp.fmu", fmi=fmi, method="vi")
    with zipfile.ZipFile(path) as z:
        z.extractall(folder / "fmu")
    md = fmpy.read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    # the FMU side reads 2 N values from q1_x; the work is read after them by its own reference
    side = FMU_SIDE[fmi].replace("fmi2FreeInstance(c);", "fmi2GetReal(c, &work_vr, 1, x + 2 * N);\n"
                                 "    fmi2FreeInstance(c);")  # fmt: skip
    side = side.replace("fmi3FreeInstance(c);", "fmi3GetFloat64(c, &work_vr, 1, x + 2 * N, 1);\n"
                        "    fmi3FreeInstance(c);")  # fmt: skip
    side = f"static const unsigned int work_vr = {vr['work']};\n" + side
    driver = DRIVER.replace("@V@", str(fmi)).replace("@SUB@", str(SUBSTEPS))
    driver = driver.replace("@CALLBACKS@", side).replace("@Q@", str(vr["q1_x"]))
    driver = driver.replace("@WORK@", "done - x[2 * N]")
    (folder / "driver.c").write_text(driver)
    sources = sorted(str(p) for p in (folder / "fmu" / "sources").glob("*.c"))
    flags = [f for f in DEFAULT_FLAGS if f not in ("-shared", "-fPIC")]
    headers = Path(fmpy.__file__).parent / "c-code"
    exe = folder / "bench"
    cmd = [compiler()[0], *flags, "-D_POSIX_C_SOURCE=199309L", f"-I{headers}",
           f"-I{folder / 'fmu' / 'sources'}", str(folder / "driver.c"), *sources, "-lm",
           "-o", str(exe)]  # fmt: skip
    subprocess.run(cmd, check=True)
    token = md.guid if fmi == 2 else md.instantiationToken
    return exe, token


def main(argv: Sequence[str] | None = None) -> int:
    """Build, run and print the table; 1 when the two loops end in different states."""
    args = parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        exe, token = build(Path(tmp), args.fmi)
        out = subprocess.run([str(exe), token, str(args.intervals), str(args.repeats)],
                             check=True, capture_output=True, text=True).stdout  # fmt: skip
    bare_ns, fmu_ns, diff, work_diff = (float(x) for x in out.split())
    from s2gen.build import compiler

    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; compiler: {compiler()[1]}")
    print(f"forced_double_pendulum, VI, h = 0.01, {SUBSTEPS} steps per communication interval, "
          f"{args.intervals} intervals, best of {args.repeats}, FMI {args.fmi}")  # fmt: skip
    print(f"{'loop':<40}{'ns/step':>10}")
    print(f"{'forced_double_pendulum_step (bare)':<40}{bare_ns:>10.1f}")
    print(f"{f'fmi{args.fmi}DoStep (wrapper)':<40}{fmu_ns:>10.1f}")
    print(f"doStep / bare: {fmu_ns / bare_ns:.3f}; final states differ by {diff:.3g}, "
          f"the work by {work_diff:.3g}")  # fmt: skip
    return 0 if diff == 0.0 and work_diff == 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
