/* integrate: run a system emitted by s2gen from a C program, through the header's API only.
 *
 * Usage: integrate INITIAL METHOD H NSTEPS [RTOL ATOL]
 *   INITIAL  a text file: q (NSTATE numbers, body-major), then omega (NSTATE numbers), or
 *            "spec" for the spec's initial state (the header's initial_state())
 *   METHOD   vi, vi4, vi6, vi8, rattle, rattle4, rattle6, rattle8, rk45, dop853, rk2, rk2-proj
 *            or rk4
 *   H        step size (rk45, dop853: spacing of the output samples; their steps are adaptive)
 *   NSTEPS   number of steps (the trajectory holds NSTEPS + 1 samples)
 *   RTOL, ATOL  rk45 and dop853 tolerances (default: the header's default options)
 * Prints the final sample (t, q, omega, energy) with %.17g, then the integrator's counts.
 * Exit status: 0 on success, 1 if the integration failed (the last valid sample is printed),
 * 2 on bad arguments. The file is C99 that also compiles as C++ (a C++ project may build it as
 * my_program.cpp against the same library target).
 *
 * The system is chosen at compile time: -DS2GEN_SYSTEM=name -DS2GEN_SYSTEM_UPPER=NAME (the
 * Makefile and CMakeLists.txt pass both; default double_pendulum). SYS(_integrate) is then
 * name_integrate, SYS_MACRO(_NSTATE) is NAME_NSTATE, and so on.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef S2GEN_SYSTEM
#define S2GEN_SYSTEM double_pendulum
#define S2GEN_SYSTEM_UPPER DOUBLE_PENDULUM
#endif

#define S2_STR_(x) #x
#define S2_STR(x) S2_STR_(x)
#define S2_CAT_(a, b) a##b
#define S2_CAT(a, b) S2_CAT_(a, b)
#define SYS(suffix) S2_CAT(S2GEN_SYSTEM, suffix)
#define SYS_MACRO(suffix) S2_CAT(S2GEN_SYSTEM_UPPER, suffix)

#include S2_STR(S2GEN_SYSTEM.h)

#define NSTATE SYS_MACRO(_NSTATE)

static const struct {
    const char *name;
    int code;
} methods[] = {
    {"vi", SYS_MACRO(_METHOD_VI)},           {"vi4", SYS_MACRO(_METHOD_VI4)},
    {"vi6", SYS_MACRO(_METHOD_VI6)},         {"vi8", SYS_MACRO(_METHOD_VI8)},
    {"rattle", SYS_MACRO(_METHOD_RATTLE)},   {"rattle4", SYS_MACRO(_METHOD_RATTLE4)},
    {"rattle6", SYS_MACRO(_METHOD_RATTLE6)}, {"rattle8", SYS_MACRO(_METHOD_RATTLE8)},
    {"rk45", SYS_MACRO(_METHOD_RK45)},       {"dop853", SYS_MACRO(_METHOD_DOP853)},
    {"rk2", SYS_MACRO(_METHOD_RK2)},         {"rk2-proj", SYS_MACRO(_METHOD_RK2_PROJ)},
    {"rk4", SYS_MACRO(_METHOD_RK4)},
};

static int usage(const char *why)
{
    fprintf(stderr, "integrate: %s\nusage: integrate INITIAL METHOD H NSTEPS [RTOL ATOL]\n", why);
    return 2;
}

static int parse_double(const char *text, double *value)
{
    char *end;
    errno = 0;
    *value = strtod(text, &end);
    return errno == 0 && end != text && *end == '\0';
}

static int read_initial(const char *path, double *q0, double *w0)
{
    FILE *f = fopen(path, "r");
    int i, ok = f != NULL;
    for (i = 0; ok && i < 2 * NSTATE; ++i)
        ok = fscanf(f, "%lf", i < NSTATE ? &q0[i] : &w0[i - NSTATE]) == 1;
    if (f)
        fclose(f);
    return ok;
}

static void print_vector(const char *label, const double *x)
{
    int i;
    printf("%s", label);
    for (i = 0; i < NSTATE; ++i)
        printf(" %.17g", x[i]);
    printf("\n");
}

int main(int argc, char **argv)
{
    double p[SYS_MACRO(_NPARAMS)], q0[NSTATE], w0[NSTATE], h, value;
    double *q, *w, *energy, *work;
    SYS(_options) opt;
    SYS(_stats) stats;
    long nsteps, last;
    char *end;
    int method = -1, status;
    size_t i, samples;

    if (argc != 5 && argc != 7)
        return usage("wrong number of arguments");
    if (strcmp(argv[1], "spec") == 0) {
        if (SYS(_initial_state)(q0, w0) != SYS_MACRO(_OK))
            return usage("the spec gives no initial state");
    } else if (!read_initial(argv[1], q0, w0)) {
        return usage("cannot read 2 * NSTATE numbers from INITIAL");
    }
    for (i = 0; i < sizeof methods / sizeof methods[0]; ++i)
        if (strcmp(argv[2], methods[i].name) == 0)
            method = methods[i].code;
    if (method < 0)
        return usage("unknown METHOD");
    if (!parse_double(argv[3], &h) || !(h > 0))
        return usage("H must be a positive number");
    errno = 0;
    nsteps = strtol(argv[4], &end, 10);
    if (errno || *end != '\0' || nsteps < 1 || (unsigned long)nsteps > 100000000UL)
        return usage("NSTEPS must be an integer from 1 to 10^8");

    SYS(_default_params)(p);
    SYS(_default_options)(&opt);
    if (argc == 7) {
        if (!parse_double(argv[5], &value) || !(value > 0))
            return usage("RTOL must be a positive number");
        opt.rtol = value;
        if (!parse_double(argv[6], &value) || !(value > 0))
            return usage("ATOL must be a positive number");
        opt.atol = value;
    }

    samples = (size_t)nsteps + 1;
    q = (double *)malloc(samples * NSTATE * sizeof *q);
    w = (double *)malloc(samples * NSTATE * sizeof *w);
    energy = (double *)malloc(samples * sizeof *energy);
    work = (double *)malloc(SYS_MACRO(_WORK_SIZE) * sizeof *work);
    if (!q || !w || !energy || !work) {
        fprintf(stderr, "integrate: out of memory for %lu samples\n", (unsigned long)samples);
        return 2;
    }

    status = SYS(_integrate)(p, &opt, method, h, nsteps, q0, w0, q, w, energy, work, &stats);
    last = status == SYS_MACRO(_OK) ? nsteps : stats.fail_step - 1;
    if (status != SYS_MACRO(_OK))
        fprintf(stderr, "integrate: failed with status %d; samples before %ld are valid\n",
                status, stats.fail_step);
    if (last >= 0) {
        printf("t %.17g\n", (double)last * h);
        print_vector("q", q + (size_t)last * NSTATE);
        print_vector("omega", w + (size_t)last * NSTATE);
        printf("energy %.17g\n", energy[last]);
    }
    printf("steps %ld rejected %ld gradient_evals %ld newton_iters %ld\n", stats.steps,
           stats.rejected, stats.gradient_evals, stats.newton_iters);

    free(q);
    free(w);
    free(energy);
    free(work);
    return status == SYS_MACRO(_OK) ? 0 : 1;
}
