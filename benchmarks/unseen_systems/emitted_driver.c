/* Drives the emitted C of one benchmark system through its public API, as a user would:
 * NAME_integrate with the VI over NSTEPS steps from the initial state of DATA_HEADER, every
 * state stored, energy = NULL. The benchmark writes a copy of this file with ${name},
 * ${upper} and ${data} filled in.
 *
 * usage: driver NSTEPS REPEATS
 * prints ns_per_step and cpu_ns_per_step (medians over REPEATS integrate calls: wall-clock
 * and CPU time), newton_per_step (from the
 * statistics of the last call), the relative energy change over the run (NAME_energy,
 * outside the timed call) and the final state q, w (body-major, 17 significant digits). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "${name}.h"
#include "${data}"

/* seconds on the wall clock (clock CLOCK_MONOTONIC) or of this process's CPU time
 * (CLOCK_PROCESS_CPUTIME_ID: insensitive to other jobs sharing the machine) */
static double now(clockid_t clock)
{
    struct timespec t;
    clock_gettime(clock, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int by_value(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    const long nsteps = argc > 1 ? atol(argv[1]) : 1000;
    const int repeats = argc > 2 ? atoi(argv[2]) : 3;
    const size_t ns = ${upper}_NSTATE;
    double p[${upper}_NPARAMS], times[64], cpu[64], e0, e1, *q, *w, *work;
    const double *qe, *we;
    ${name}_options opt;
    ${name}_stats stats;
    int r, status = 0;
    size_t i;
    if (nsteps < 1 || repeats < 1 || repeats > 64) {
        fprintf(stderr, "usage: %s NSTEPS REPEATS (1..64)\n", argv[0]);
        return 2;
    }
    ${name}_default_params(p);
    ${name}_default_options(&opt);
    q = calloc(ns * (size_t)(nsteps + 1), sizeof(double));
    w = calloc(ns * (size_t)(nsteps + 1), sizeof(double));
    work = calloc(${upper}_WORK_SIZE > 0 ? ${upper}_WORK_SIZE : 1, sizeof(double));
    if (!q || !w || !work) {
        fprintf(stderr, "out of memory\n");
        return 2;
    }
    for (r = 0; r < repeats; ++r) {
        const double t0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_PROCESS_CPUTIME_ID);
        status = ${name}_integrate(p, &opt, ${upper}_METHOD_VI, BENCH_H, nsteps, BENCH_Q0,
                                   BENCH_W0, q, w, NULL, work, &stats);
        times[r] = (now(CLOCK_MONOTONIC) - t0) * 1e9 / (double)nsteps;
        cpu[r] = (now(CLOCK_PROCESS_CPUTIME_ID) - c0) * 1e9 / (double)nsteps;
        if (status != ${upper}_OK) {
            fprintf(stderr, "integrate: status %d at sample %ld\n", status, stats.fail_step);
            return 1;
        }
    }
    qsort(times, (size_t)repeats, sizeof(double), by_value);
    qsort(cpu, (size_t)repeats, sizeof(double), by_value);
    qe = q + ns * (size_t)nsteps;
    we = w + ns * (size_t)nsteps;
    e0 = ${name}_energy(p, q, w);
    e1 = ${name}_energy(p, qe, we);
    printf("ns_per_step %.1f\ncpu_ns_per_step %.1f\nnewton_per_step %.3f\nenergy_change %.3e\n",
           times[repeats / 2], cpu[repeats / 2], (double)stats.newton_iters / (double)nsteps,
           fabs(e1 - e0) / fabs(e0));
    printf("q");
    for (i = 0; i < ns; ++i) {
        printf(" %.17g", qe[i]);
    }
    printf("\nw");
    for (i = 0; i < ns; ++i) {
        printf(" %.17g", we[i]);
    }
    printf("\n");
    free(q);
    free(w);
    free(work);
    return 0;
}
