"""A driven system's integrate_batch() against one member per call, in C and from Python.

For each method: K members of forced_double_pendulum (each its own damping and amplitude and
initial angular velocity) over `--steps` steps from t0 = 0.25, every 10th sample kept,
(1) in C: one program built from the emitted module with the flag set's flags
(`s2gen.build.FLAG_SETS`, "portable" = -O2, "native" = -O3 -march=native) calls
NAME_integrate once per member and NAME_integrate_batch once for all, alternating, best of
`--repeats` (it first checks that both give the same final states and work bit for bit: exit
status 1 otherwise); (2) from Python: `Model.integrate` once per member against
`Model.integrate_batch` once, alternating, best of `--repeats`. Prints member-steps per second
and the batch's ratio, with the CPU model and the load (one thread). The batch runs the
members one after the other through the one-member driven step (no SIMD lanes): in C it can
only save the calls; from Python it saves each member's trip through ctypes and the
trajectory's checks.

    python benchmarks/batch_driven.py [--members 256] [--steps 1000] [--repeats 5]
        [--methods vi rk4 vi4 rk45]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from s2gen.build import FLAG_SETS
from s2gen.emit import emit
from s2gen.methods import method as method_of
from s2gen.runtime.model import Model
from s2gen.systems import builtin

NAME = "forced_double_pendulum"
T0, H, EVERY = 0.25, 0.001, 10

DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "@NAME@.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv)
{
    const long K = atol(argv[1]), nsteps = atol(argv[2]), every = atol(argv[3]);
    const int method = atoi(argv[4]), repeats = atoi(argv[5]);
    const double t0 = atof(argv[6]), h = atof(argv[7]);
    const long N = @P@_NSTATE, P = @P@_NPARAMS, S = nsteps / every + 1;
    double *p = malloc(sizeof(double) * P * K), *pk = malloc(sizeof(double) * P);
    double *q0 = malloc(sizeof(double) * N * K), *w0 = malloc(sizeof(double) * N * K);
    double *qb = malloc(sizeof(double) * S * N * K), *wb = malloc(sizeof(double) * S * N * K);
    double *eb = malloc(sizeof(double) * S * K), *Wb = malloc(sizeof(double) * S * K);
    double *qs = malloc(sizeof(double) * S * N), *ws = malloc(sizeof(double) * S * N);
    double *es = malloc(sizeof(double) * S), *Ws = malloc(sizeof(double) * S);
    double *qk = malloc(sizeof(double) * N), *wk = malloc(sizeof(double) * N);
    double *qe = malloc(sizeof(double) * N * K), *We = malloc(sizeof(double) * K);
    double *work = malloc(sizeof(double) * @P@_WORK_SIZE);
    double *bwork = malloc(sizeof(double) * @P@_BATCH_WORK_SIZE);
    @NAME@_stats *stats = malloc(sizeof(@NAME@_stats) * K), one;
    int *status = malloc(sizeof(int) * K);
    @NAME@_options opt;
    double best_one = 1e300, best_batch = 1e300;
    long k, e, r, same = 1;
    @NAME@_default_options(&opt);
    opt.every = every;
    @NAME@_default_params(pk);
    @NAME@_initial_state(qk, wk);
    for (k = 0; k < K; ++k) {
        for (e = 0; e < P; ++e) {
            p[e * K + k] = pk[e] * (1.0 + 0.01 * (double)k / (double)K);
        }
        for (e = 0; e < N; ++e) {
            q0[e * K + k] = qk[e];
            w0[e * K + k] = wk[e] * (1.0 + 0.01 * (double)k / (double)K);
        }
    }
    for (r = 0; r < repeats; ++r) {
        double t = now();
        for (k = 0; k < K; ++k) {
            for (e = 0; e < P; ++e) pk[e] = p[e * K + k];
            for (e = 0; e < N; ++e) {
                qk[e] = q0[e * K + k];
                wk[e] = w0[e * K + k];
            }
            @NAME@_integrate(pk, &opt, method, t0, h, nsteps, NULL, NULL, NULL, qk, wk, qs, ws,
                    es, Ws, work, &one);
            for (e = 0; e < N; ++e) qe[e * K + k] = qs[(S - 1) * N + e];
            We[k] = Ws[S - 1];
        }
        t = now() - t;
        best_one = t < best_one ? t : best_one;
        t = now();
        @NAME@_integrate_batch(K, p, &opt, method, t0, h, nsteps, NULL, q0, w0, qb, wb, eb, Wb,
                bwork, stats, status);
        t = now() - t;
        best_batch = t < best_batch ? t : best_batch;
    }
    for (k = 0; k < K; ++k) {
        for (e = 0; e < N; ++e) {
            same &= memcmp(&qe[e * K + k], &qb[((S - 1) * N + e) * K + k], sizeof(double)) == 0;
        }
        same &= memcmp(&We[k], &Wb[(S - 1) * K + k], sizeof(double)) == 0;
    }
    printf("%.6e %.6e %ld\n", best_one, best_batch, same);
    return same ? 0 : 1;
}
"""


def cpu_model() -> str:
    match = re.search(r"model name\s*:\s*(.*)", Path("/proc/cpuinfo").read_text())
    return match.group(1) if match else "unknown"


def in_c(method: str, flags: str, members: int, steps: int, repeats: int) -> tuple[float, float]:
    """Member-steps per second, one member per call and the batch, in one C program."""
    s = builtin(NAME).with_batch()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for fname, text in emit(s, "c").items():
            (d / fname).write_text(text)
        (d / "main.c").write_text(DRIVER.replace("@NAME@", s.name).replace("@P@", s.name.upper()))
        cflags = [f for f in FLAG_SETS[flags] if f not in ("-shared", "-fPIC")]
        subprocess.run(
            ["gcc", *cflags, "-D_POSIX_C_SOURCE=199309L", "-o", str(d / "bench")]
            + [str(d / "main.c"), str(d / f"{s.name}.c"), "-lm"],
            check=True,
        )
        args = (members, steps, EVERY, method_of(method).code, repeats, T0, H)
        out = subprocess.run(
            [str(d / "bench"), *map(str, args)], check=False, capture_output=True, text=True
        )
    one, batch, same = out.stdout.split()
    if same != "1":
        print(f"{method} {flags}: batch and one member per call differ", file=sys.stderr)
        sys.exit(1)
    return members * steps / float(one), members * steps / float(batch)


def in_python(method: str, members: int, steps: int, repeats: int) -> tuple[float, float]:
    """Member-steps per second, Model.integrate per member and Model.integrate_batch."""
    model = Model(builtin(NAME))
    s = model.system
    c = s.parameter_values[s.parameter_names.index("c")] * (1 + 0.5 * np.linspace(0, 1, members))
    w0 = s.omega0[None] * (1 + 0.01 * np.linspace(0, 1, members))[:, None, None]
    T = steps * H
    best_one = best_batch = float("inf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.integrate(method, h=H, T=T, t0=T0, every=EVERY)  # builds both modules first
        model.integrate_batch(method, h=H, T=T, t0=T0, every=EVERY, params={"c": c[:2]})
        for _ in range(repeats):
            t = time.perf_counter()
            last = [
                model.integrate(
                    method, h=H, T=T, t0=T0, every=EVERY, omega0=w0[k], params={"c": c[k]}
                ).q[-1]
                for k in range(members)
            ]
            best_one = min(best_one, time.perf_counter() - t)
            t = time.perf_counter()
            b = model.integrate_batch(
                method, h=H, T=T, t0=T0, every=EVERY, omega0=w0, params={"c": c}
            )
            best_batch = min(best_batch, time.perf_counter() - t)
    if not np.array_equal(np.array(last), b.q[:, -1]):
        print(f"{method} python: batch and one member per call differ", file=sys.stderr)
        sys.exit(1)
    return members * steps / best_one, members * steps / best_batch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", nargs="*", default=["vi", "rk4", "vi4", "rk45"])
    ap.add_argument("--members", type=int, default=256)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(f"CPU: {cpu_model()}; load average {os.getloadavg()[0]:.2f} (1 min)")
    print(f"{NAME}: {args.members} members x {args.steps} steps, member-steps per second")
    for m in args.methods:
        for flags in ("portable", "native"):
            one, batch = in_c(m, flags, args.members, args.steps, args.repeats)
            print(
                f"{m:6s} C {flags:8s}  one/call {one:10.4g}  batch {batch:10.4g}"
                f"  ratio {batch / one:5.2f}"
            )
        one, batch = in_python(m, args.members, args.steps, args.repeats)
        print(
            f"{m:6s} Python          one/call {one:10.4g}  batch {batch:10.4g}"
            f"  ratio {batch / one:5.2f}"
        )
    print(f"load average after: {os.getloadavg()[0]:.2f} (1 min)")


if __name__ == "__main__":
    main()
