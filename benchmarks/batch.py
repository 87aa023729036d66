"""integrate_batch() against one member per call of integrate(), inside C, same flags, same run.

For each system and method: K members (different parameters and initial states; with
--shared one parameter vector for all, as in an ensemble of perturbed initial states, where
the lanes of a quadratic form share its matrix K) through NAME_integrate_batch in one call,
and the same K members through NAME_integrate one at a time, both timed by one C program built from the emitted module with the flag set's flags
(`s2gen.build.FLAG_SETS`, "portable" = -O2 and "native" = -O3 -march=native, without -shared),
best of `--repeats`; the program first checks that the two give the same final states bit for
bit (exit status 1 otherwise). Prints member-steps per second per core for both, their ratio,
and the fraction of the core's peak the batch reaches, with the CPU model. Peak = the clock
(the largest "cpu MHz" of /proc/cpuinfo) x the double-precision flops a core can retire per
cycle (2 FMA pipes x 2 flops x the vector width: 8 doubles with AVX-512 F, 4 with AVX2, 2
otherwise); the emitted code has no fused multiply-adds (-std=c99 keeps gcc from contracting),
so at most half of it is reachable. The flops of a member-step are counted from the lowered
kernels (`flops_per_member_step`). With a dense M (the double pendulum) the count takes the
solves as (2/3) N3^3 + 2 N3^2 flops (LU) and (1/3) N3^3 + 2 N3^2 (Cholesky) and the Newton VI's
iterations per step as the batch's members took them (their mean, which the program prints);
with a max-index M (the 10-link rope), and for RATTLE with a coupled M (its Newton on the
multipliers), no flops are counted and no fraction of peak printed.

    python benchmarks/batch.py [--systems four_pendula double_pendulum rope:n=10]
        [--methods vi rk4 rattle rattle4 rk45 dop853] [--members 1024] [--repeats 3] [--shared]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from s2gen.build import FLAG_SETS
from s2gen.emit import emit
from s2gen.inspect import kernel_profile, lowered
from s2gen.methods import method as method_of
from s2gen.runtime.model import Model
from s2gen.system import System
from s2gen.systems import resolve

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
    const long K = atol(argv[1]), nsteps = atol(argv[2]), every = nsteps;
    const int method = atoi(argv[3]), repeats = atoi(argv[4]), shared = atoi(argv[5]);
    const double hout = atof(argv[6]);
    const long N = @P@_NSTATE, P = @P@_NPARAMS, S = nsteps / every + 1;
    double *p = malloc(sizeof(double) * (P > 0 ? P : 1) * K), *pk = malloc(sizeof(double) * (P + 1));
    double *q0 = malloc(sizeof(double) * N * K), *w0 = malloc(sizeof(double) * N * K);
    double *qb = malloc(sizeof(double) * S * N * K), *wb = malloc(sizeof(double) * S * N * K);
    double *qs = malloc(sizeof(double) * S * N), *ws = malloc(sizeof(double) * S * N);
    double *qk = malloc(sizeof(double) * N), *wk = malloc(sizeof(double) * N);
    double *qe = malloc(sizeof(double) * N * K);
    double *work = malloc(sizeof(double) * @P@_WORK_SIZE);
    double *bwork = malloc(sizeof(double) * @P@_BATCH_WORK_SIZE);
    @NAME@_stats *stats = malloc(sizeof(@NAME@_stats) * K), one;
    int *status = malloc(sizeof(int) * K);
    @NAME@_options opt;
    double best_one = 1e300, best_batch = 1e300;
    long k, e, r, same = 1, iters = 0, steps = 0, rejected = 0;
    @NAME@_default_options(&opt);
    opt.every = every;
    @NAME@_default_params(pk);
    @NAME@_initial_state(qk, wk);
    for (k = 0; k < K; ++k) {
        for (e = 0; e < P; ++e) {
            p[e * K + k] = shared ? pk[e] : pk[e] * (1.0 + 0.01 * (double)k / (double)K);
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
            @NAME@_integrate(pk, &opt, method, hout, nsteps, qk, wk, qs, ws, NULL, work, &one);
            for (e = 0; e < N; ++e) qe[e * K + k] = qs[(S - 1) * N + e];
        }
        t = now() - t;
        best_one = t < best_one ? t : best_one;
        t = now();
        @NAME@_integrate_batch(K, p, &opt, method, hout, nsteps, q0, w0, qb, wb, NULL, bwork,
                stats, status);
        t = now() - t;
        best_batch = t < best_batch ? t : best_batch;
    }
    for (k = 0; k < K; ++k) {
        for (e = 0; e < N; ++e) {
            same &= memcmp(&qe[e * K + k], &qb[((S - 1) * N + e) * K + k], sizeof(double)) == 0;
        }
    }
    for (k = 0; k < K; ++k) {
        iters += stats[k].newton_iters;
        steps += stats[k].steps;
        rejected += stats[k].rejected;
    }
    printf("%.6e %.6e %ld %.6e %ld %ld\n", best_one, best_batch, same,
            (double)iters / (double)(steps > 0 ? steps : 1), steps, rejected);
    return same ? 0 : 1;
}
"""


def cpu() -> tuple[str, float, int]:
    """CPU model, the largest clock (MHz) and double flops per cycle per core (2 FMA pipes x
    vector doubles x 2) from /proc/cpuinfo."""
    text = Path("/proc/cpuinfo").read_text()
    model = re.search(r"model name\s*:\s*(.*)", text)
    mhz = max(float(v) for v in re.findall(r"cpu MHz\s*:\s*([\d.]+)", text) or ["0"])
    flags = set((re.search(r"flags\s*:\s*(.*)", text) or re.search("", "")).group(1).split())
    width = 8 if "avx512f" in flags else 4 if "avx2" in flags else 2
    return (model.group(1) if model else "unknown"), mhz, 2 * width * 2


def flops_per_member_step(system: System, method: str, iters: float = 0.0) -> int | None:
    """Floating-point operations of one member-step, from the lowered kernels' op counts
    (`s2gen.inspect.kernel_profile`; a square root or a division counts as one): dV/dq (the
    general kernel, each term's gradient kernel times its members, a quadratic form's
    2 n^2 per block of K that is not zero: `k_blocks`) plus, for the VI, each body's position and velocity updates, for RK4 four
    evaluations of the field (dV/dq and each body's rhs_diag) and the stage sums, for RATTLE
    and its compositions dV/dq and each body's rattle_pos and rattle_vel per substep. A dense
    M: `newton_flops` (`iters` Newton iterations per step) or four fields of the coupled kind
    (rhs_body, rhs_pair, A(q) and an LU solve); None for another coupled M and for RATTLE
    with a coupled M."""
    module = lowered(system)
    if "vi_newton" in module.parts and not method.startswith("rattle"):
        return newton_flops(system, method, iters)
    if "vi_explicit" not in module.parts:
        return None

    def ops(name: str) -> int:
        return int(kernel_profile(module.kernel(name)).total)  # type: ignore[arg-type]

    n3 = 3 * module.n
    gradient = ops("gradient") if dict(module.facts).get("general") else 0
    for t in module.terms:
        gradient += (
            2 * module.n**2 * k_blocks(system) // len(module.terms)
            if t.quadratic
            else t.loop.count * ops(t.gradient)
        )
    if method == "vi":
        return gradient + module.n * (ops("vi_pos") + ops("vi_vel"))
    if method.startswith("rattle"):  # per substep; omega = q x v once per step
        count = max(1, len(method_of(method).substeps))
        return (
            count * (gradient + module.n * (ops("rattle_pos") + ops("rattle_vel"))) + 9 * module.n
        )
    return 4 * (gradient + module.n * ops("rhs_diag")) + 2 * n3 * (2 + 2 + 2 + 8)


def k_blocks(system: System) -> int:
    """How many of the quadratic matrix K's nine n x n component blocks are not zero (the
    product skips the others), at the default parameters: dV/dq = Kq + b is linear in q, so
    column k of K is dV/dq(e_k) - dV/dq(0) (NumPy backend); a block counts as zero where all
    its entries are below 1e-12 of K's largest."""
    model = Model(system, "numpy")
    n = system.n
    zero = model.gradient(np.zeros((n, 3))).reshape(-1)
    cols = []
    for k in range(3 * n):
        e = np.zeros(3 * n)
        e[k] = 1.0
        cols.append(model.gradient(e.reshape(n, 3)).reshape(-1) - zero)
    k_body = np.array(cols).T  # body-major rows and columns: entry (3 i + u, 3 j + v)
    blocks = np.abs(k_body).reshape(n, 3, n, 3).max(axis=(0, 2))
    return int(np.count_nonzero(blocks > 1e-12 * blocks.max()))


def newton_flops(system: System, method: str, iters: float) -> int:
    """Flops of one member-step with a dense M: for the VI, the known side d (d_body, d_pair),
    `iters` times the residual and Jacobian (res_body, res_pair) and an LU solve, then the
    Cayley map, dV/dq, the right side c (c_body, c_pair), A(q+) (a_body, a_pair) and its
    Cholesky solve; for RK4, four fields (dV/dq, rhs_body, rhs_pair, A(q), an LU solve) and
    the stage sums."""
    module = lowered(system)

    def ops(name: str) -> int:
        return int(kernel_profile(module.kernel(name)).total)  # type: ignore[arg-type]

    n, pairs, n3 = module.n, len(module.pairs), 3 * module.n
    gradient = ops("gradient") if dict(module.facts).get("general") else 0
    for t in module.terms:
        gradient += t.loop.count * ops(t.gradient)
    lu, cholesky = 2 * n3**3 // 3 + 2 * n3 * n3, n3**3 // 3 + 2 * n3 * n3
    a = n * ops("a_body") + pairs * ops("a_pair")
    if method == "vi":
        d = n * ops("d_body") + pairs * ops("d_pair")
        newton = n * ops("res_body") + pairs * ops("res_pair") + lu
        c = n * ops("c_body") + pairs * ops("c_pair")
        return round(d + iters * newton + n * ops("cayley") + gradient + c + a + cholesky)
    field = gradient + n * ops("rhs_body") + pairs * ops("rhs_pair") + a + lu
    return 4 * field + 2 * n3 * (2 + 2 + 2 + 8)


def run(
    system: str, method: str, flags: str, members: int, steps: int, repeats: int, shared: bool
) -> None:
    s = resolve(system).with_batch()
    files = emit(s, "c")
    adaptive = method in ("rk45", "dop853")  # output spacing 0.05: T = 0.05 steps
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        for fname, text in files.items():
            (d / fname).write_text(text)
        (d / "main.c").write_text(DRIVER.replace("@NAME@", s.name).replace("@P@", s.name.upper()))
        cflags = [f for f in FLAG_SETS[flags] if f not in ("-shared", "-fPIC")]
        subprocess.run(
            [
                "gcc",
                *cflags,
                "-D_POSIX_C_SOURCE=199309L",
                "-o",
                str(d / "bench"),
                str(d / "main.c"),
                str(d / f"{s.name}.c"),
                "-lm",
            ],
            check=True,
        )
        out = subprocess.run(
            [
                str(d / "bench"),
                str(members),
                str(steps),
                str(method_of(method).code),
                str(repeats),
                str(int(shared)),
                "0.05" if adaptive else "0.001",
            ],
            check=False,
            capture_output=True,
            text=True,
        )
    one, batch, same, iters, taken, rejected = out.stdout.split()
    if same != "1":
        print(f"{system} {method} {flags}: batch and one-at-a-time differ", file=sys.stderr)
        sys.exit(1)
    # the adaptive methods: the members' accepted steps (the same in both runs)
    done = int(taken) if adaptive else members * steps
    rate_one = done / float(one)
    rate_batch = done / float(batch)
    _, mhz, per_cycle = cpu()
    ops = None if adaptive else flops_per_member_step(s, method, float(iters))
    peak = mhz * 1e6 * per_cycle
    of_peak = (
        f"~{ops} flops/member-step: {100 * rate_batch * ops / peak:6.2f} % of peak"
        if ops is not None
        else f"{done / members:.1f} steps, {int(rejected) / members:.2f} rejected per member"
        if adaptive
        else "flops not counted (max-index M, or RATTLE with a coupled M)"
    )
    print(
        f"{system:15s} {method:6s} {flags:8s} one/call {rate_one:11.4g}  batch {rate_batch:11.4g}"
        f"  ratio {rate_batch / rate_one:5.2f}  {of_peak}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--systems",
        nargs="*",
        default=["four_pendula", "three_bodies", "dipoles", "double_pendulum", "rope:n=10"],
    )
    ap.add_argument("--methods", nargs="*", default=["vi", "rk4"])
    ap.add_argument("--members", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument(
        "--shared",
        action="store_true",
        help="the members share one parameter vector (only their initial states differ)",
    )
    args = ap.parse_args()
    model, mhz, per_cycle = cpu()
    print(f"CPU: {model}, {mhz:.0f} MHz, peak {mhz * per_cycle / 1e3:.1f} GFLOP/s per core")
    print(
        "member-steps per second per core (one thread); parameters "
        + ("shared by all members" if args.shared else "each member's own")
    )
    for system in args.systems:
        for method in args.methods:
            if system in ("dipoles", "rope:n=10") and method != "vi":
                continue  # the targets: the VI alone
            for flags in ("portable", "native"):
                run(system, method, flags, args.members, args.steps, args.repeats, args.shared)


if __name__ == "__main__":
    main()
