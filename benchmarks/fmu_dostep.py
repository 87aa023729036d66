"""``python benchmarks/fmu_dostep.py``: the cost of the FMU's doStep against the bare step.

Input: command-line options (``--intervals``, ``--repeats``, ``--fmi``). Output: a table on
stdout naming the machine (CPU model from /proc/cpuinfo) and gcc: the time per VI step of the
double pendulum when a C loop calls the emitted `double_pendulum_step` 100 times per
communication interval (as a program embedding the emitted C would), and when it calls the
FMU's `fmi2DoStep`/`fmi3DoStep` once per interval of 100 steps (the wrapper sub-steps it), and
their ratio. Both are compiled into one program from the FMU's own sources with the flags of
the runtime's library, run alternately on the same state, and must end in the same state bit
for bit (exit status 1 otherwise). The FMI headers come from FMPy.

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

from python_step import cpu_model

import s2gen

#: Steps per communication interval.
SUBSTEPS = 100

#: The timing program: argv = GUID, intervals, repeats; prints "bare_ns fmu_ns max_diff".
DRIVER = r"""
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "fmi@V@Functions.h"
#include "double_pendulum.h"

#define N DOUBLE_PENDULUM_NSTATE
#define SUB @SUB@

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

@CALLBACKS@

static double bare(long intervals, double h, double *q, double *w)
{
    static double carry[DOUBLE_PENDULUM_STEP_CARRY], work[DOUBLE_PENDULUM_WORK_SIZE];
    double p[DOUBLE_PENDULUM_NPARAMS], qn[N], wn[N], start;
    double_pendulum_stepper st;
    long k;
    double_pendulum_default_params(p);
    double_pendulum_initial_state(q, w);
    double_pendulum_step_start(&st, DOUBLE_PENDULUM_METHOD_VI, 0.0);
    start = now();
    for (k = 0; k < intervals * SUB; ++k) {
        if (double_pendulum_step(p, NULL, &st, h, q, w, qn, wn, carry, work, NULL) != 0) {
            exit(2);
        }
        memcpy(q, qn, sizeof qn);
        memcpy(w, wn, sizeof wn);
    }
    return now() - start;
}

int main(int argc, char **argv)
{
    long intervals = atol(argv[2]), repeats = atol(argv[3]), r, i;
    double h = 0.01, best_bare = 1e300, best_fmu = 1e300, q[N], w[N], x[2 * N], diff = 0.0;
    for (r = 0; r < repeats; ++r) {
        double t = bare(intervals, h, q, w);
        double f = fmu(argv[1], intervals, h, x);
        best_bare = t < best_bare ? t : best_bare;
        best_fmu = f < best_fmu ? f : best_fmu;
    }
    for (i = 0; i < N; ++i) {
        double a = q[i] - x[i], b = w[i] - x[N + i];
        diff = a * a > diff ? a * a : diff;
        diff = b * b > diff ? b * b : diff;
    }
    printf("%.6g %.6g %.3g\n", 1e9 * best_bare / (double)(intervals * SUB),
           1e9 * best_fmu / (double)(intervals * SUB), diff);
    return 0;
}
"""

#: The FMU side of the driver per FMI version: instantiate, initialize, doStep, read q and w
#: by their value references (@Q@: the first).
FMU_SIDE = {
    2: r"""
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env; (void)name; (void)status; (void)category;
    fprintf(stderr, "%s\n", message);
}

static void *allocate(size_t n, size_t size) { return calloc(n, size); }

static double fmu(const char *guid, long intervals, double h, double *x)
{
    fmi2CallbackFunctions cb = {logger, allocate, free, NULL, NULL};
    fmi2ValueReference vr[2 * N];
    fmi2Component c = fmi2Instantiate("bench", fmi2CoSimulation, guid, "", &cb, 0, 0);
    double start, t = 0.0, elapsed;
    long k;
    for (k = 0; k < 2 * N; ++k) vr[k] = (fmi2ValueReference)(@Q@ + k);
    fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    fmi2EnterInitializationMode(c);
    fmi2ExitInitializationMode(c);
    start = now();
    for (k = 0; k < intervals; ++k, t += SUB * h) {
        if (fmi2DoStep(c, t, SUB * h, 1) != fmi2OK) exit(3);
    }
    elapsed = now() - start;
    fmi2GetReal(c, vr, 2 * N, x);
    fmi2FreeInstance(c);
    return elapsed;
}
""",
    3: r"""
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message)
{
    (void)env; (void)status; (void)category;
    fprintf(stderr, "%s\n", message);
}

static double fmu(const char *token, long intervals, double h, double *x)
{
    fmi3ValueReference vr[2 * N];
    fmi3Instance c = fmi3InstantiateCoSimulation("bench", token, "", 0, 0, 0, 0, NULL, 0, NULL,
                                                 logger, NULL);
    fmi3Boolean event, terminate, early;
    double start, t = 0.0, last, elapsed;
    long k;
    for (k = 0; k < 2 * N; ++k) vr[k] = (fmi3ValueReference)(@Q@ + k);
    fmi3EnterInitializationMode(c, 0, 0.0, 0.0, 0, 0.0);
    fmi3ExitInitializationMode(c);
    start = now();
    for (k = 0; k < intervals; ++k, t += SUB * h) {
        if (fmi3DoStep(c, t, SUB * h, 1, &event, &terminate, &early, &last) != fmi3OK) exit(3);
    }
    elapsed = now() - start;
    fmi3GetFloat64(c, vr, 2 * N, x, 2 * N);
    fmi3FreeInstance(c);
    return elapsed;
}
""",
}


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The command line's options."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--intervals", type=int, default=200, help="communication intervals (200)")
    p.add_argument("--repeats", type=int, default=7, help="alternating runs, best kept (7)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version (2)")
    return p.parse_args(argv)


def build(folder: Path, fmi: int) -> tuple[Path, str]:
    """The timing program built from the double pendulum FMU's sources; and its GUID."""
    import fmpy

    from s2gen.build import DEFAULT_FLAGS, compiler

    path = s2gen.fmu(s2gen.load("double_pendulum"), folder / "dp.fmu", fmi=fmi, kind="cs")
    with zipfile.ZipFile(path) as z:
        z.extractall(folder / "fmu")
    md = fmpy.read_model_description(str(path))
    q = next(v.valueReference for v in md.modelVariables if v.name == "q1_x")
    driver = DRIVER.replace("@V@", str(fmi)).replace("@SUB@", str(SUBSTEPS))
    driver = driver.replace("@CALLBACKS@", FMU_SIDE[fmi]).replace("@Q@", str(q))
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
    bare_ns, fmu_ns, diff = (float(x) for x in out.split())
    from s2gen.build import compiler

    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; compiler: {compiler()[1]}")
    print(f"double_pendulum, VI, h = 0.01, {SUBSTEPS} steps per communication interval, "
          f"{args.intervals} intervals, best of {args.repeats}, FMI {args.fmi}")  # fmt: skip
    print(f"{'loop':<34}{'ns/step':>10}")
    print(f"{'double_pendulum_step (bare)':<34}{bare_ns:>10.1f}")
    print(f"{f'fmi{args.fmi}DoStep (wrapper)':<34}{fmu_ns:>10.1f}")
    print(f"doStep / bare: {fmu_ns / bare_ns:.3f}; final states differ by {diff:.3g}")
    return 0 if diff == 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
