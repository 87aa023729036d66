/* Hand-written C99: the explicit variational integrator of Lee, Leok & McClamroch for the
 * "yukawa" benchmark system (yukawa.toml), written for speed on one core, IEEE arithmetic.
 *
 *   V = sum_{i<j} A c_i c_j exp(-kappa r_ij) / r_ij  -  E sum_i c_i e3 . q_i,  r_ij = |q_i - q_j|
 *   M = diag(m_1 .. m_n)
 *
 * One step (paper, eqs. qikpexp and wikpexp), with g = dV/dq:
 *   a_i    = h w_i - h^2/(2 m_i) q_i x g_i
 *   q_i+   = a_i x q_i + sqrt(1 - |a_i|^2) q_i
 *   w_i+   = w_i - h/(2 m_i) (q_i x g_i + q_i+ x g_i+)
 * The gradient at q+ is the next step's gradient at q: one gradient per step.
 *
 * System data (n, parameters, masses, charges, initial state, h) come from yukawa_data.h,
 * which the benchmark writes from yukawa.toml; sizes are compile-time constants.
 *
 * usage: yukawa NSTEPS REPEATS
 * prints ns_per_step and cpu_ns_per_step (medians over REPEATS runs of the NSTEPS steps,
 * every state stored: wall-clock and CPU time), newton_per_step (0: explicit), the relative energy change over the run, and the final
 * state q, w (body-major, 17 significant digits). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "yukawa_data.h"

#define N BENCH_N
/* component-major arrays are padded to a multiple of 8 doubles (64 bytes) */
#define NP ((N + 7) / 8 * 8)

typedef struct {
    double x[NP], y[NP], z[NP];
} vec3s;

/* constants folded once: A c_i, the field force E c_i, h/(2 m_i), h^2/(2 m_i) */
static double ac[NP], ch[NP], field[NP], hm[NP], h2m[NP];

static void setup(double h)
{
    int i;
    for (i = 0; i < N; ++i) {
        ac[i] = YK_A * YK_CHARGE[i];
        ch[i] = YK_CHARGE[i];
        field[i] = -YK_E * YK_CHARGE[i];
        hm[i] = h / (2.0 * YK_MASS[i]);
        h2m[i] = h * h / (2.0 * YK_MASS[i]);
    }
}

/* g = dV/dq at q. For a pair, with r = |d|, d = q_i - q_j, u = 1/r:
 *   dV/dq_i = -A c_i c_j exp(-kappa r) u^2 (kappa + u) d = -dV/dq_j.
 * Row i runs over the partners j > i in three contiguous loops: distances and 1/r (vector
 * sqrt and division), then exp (a libm call: no vector exp without -ffast-math), then the
 * forces, accumulated on i by a SIMD reduction and subtracted from j. */
static void gradient(const vec3s *q, vec3s *g)
{
    const double kappa = YK_KAPPA;
    double ek[NP], u[NP];
    int i, j;
    for (i = 0; i < N; ++i) {
        g->x[i] = 0.0;
        g->y[i] = 0.0;
        g->z[i] = field[i];
    }
    for (i = 0; i < N - 1; ++i) {
        const double xi = q->x[i], yi = q->y[i], zi = q->z[i], ai = ac[i];
        double sx = 0.0, sy = 0.0, sz = 0.0;
#pragma omp simd
        for (j = i + 1; j < N; ++j) {
            const double dx = xi - q->x[j], dy = yi - q->y[j], dz = zi - q->z[j];
            const double r = sqrt(dx * dx + dy * dy + dz * dz);
            ek[j] = -kappa * r;
            u[j] = 1.0 / r;
        }
        for (j = i + 1; j < N; ++j) {
            ek[j] = exp(ek[j]);
        }
#pragma omp simd reduction(+ : sx, sy, sz)
        for (j = i + 1; j < N; ++j) {
            const double dx = xi - q->x[j], dy = yi - q->y[j], dz = zi - q->z[j];
            const double uj = u[j];
            const double s = ai * ch[j] * ek[j] * uj * uj * (kappa + uj);
            const double fx = s * dx, fy = s * dy, fz = s * dz;
            sx += fx;
            sy += fy;
            sz += fz;
            g->x[j] += fx;
            g->y[j] += fy;
            g->z[j] += fz;
        }
        g->x[i] -= sx;
        g->y[i] -= sy;
        g->z[i] -= sz;
    }
}

static double energy(const vec3s *q, const vec3s *w)
{
    double e = 0.0;
    int i, j;
    for (i = 0; i < N; ++i) {
        const double vx = w->y[i] * q->z[i] - w->z[i] * q->y[i];
        const double vy = w->z[i] * q->x[i] - w->x[i] * q->z[i];
        const double vz = w->x[i] * q->y[i] - w->y[i] * q->x[i];
        e += 0.5 * YK_MASS[i] * (vx * vx + vy * vy + vz * vz) + field[i] * q->z[i];
        for (j = i + 1; j < N; ++j) {
            const double dx = q->x[i] - q->x[j], dy = q->y[i] - q->y[j], dz = q->z[i] - q->z[j];
            const double r = sqrt(dx * dx + dy * dy + dz * dz);
            e += ac[i] * ch[j] * exp(-YK_KAPPA * r) / r;
        }
    }
    return e;
}

/* One step (q, w, g) -> (qn, wn, gn). Returns 0, or 1 when |a_i| > 1 (or a_i is not finite) for some body. */
static int step(double h, const vec3s *q, const vec3s *w, const vec3s *g, vec3s *qn, vec3s *wn,
                vec3s *gn)
{
    int i, bad = 0;
    /* no early exit inside the loop, so that it vectorises: the check follows it */
#pragma omp simd reduction(| : bad)
    for (i = 0; i < N; ++i) {
        const double qx = q->x[i], qy = q->y[i], qz = q->z[i];
        const double tx = qy * g->z[i] - qz * g->y[i]; /* q x g */
        const double ty = qz * g->x[i] - qx * g->z[i];
        const double tz = qx * g->y[i] - qy * g->x[i];
        const double ax = h * w->x[i] - h2m[i] * tx;
        const double ay = h * w->y[i] - h2m[i] * ty;
        const double az = h * w->z[i] - h2m[i] * tz;
        const double s = 1.0 - (ax * ax + ay * ay + az * az);
        const double c = sqrt(s);
        bad |= !(s >= 0.0);
        qn->x[i] = ay * qz - az * qy + c * qx;
        qn->y[i] = az * qx - ax * qz + c * qy;
        qn->z[i] = ax * qy - ay * qx + c * qz;
        wn->x[i] = w->x[i] - hm[i] * tx;
        wn->y[i] = w->y[i] - hm[i] * ty;
        wn->z[i] = w->z[i] - hm[i] * tz;
    }
    if (bad) {
        return 1;
    }
    gradient(qn, gn);
#pragma omp simd
    for (i = 0; i < N; ++i) {
        const double qx = qn->x[i], qy = qn->y[i], qz = qn->z[i];
        wn->x[i] -= hm[i] * (qy * gn->z[i] - qz * gn->y[i]);
        wn->y[i] -= hm[i] * (qz * gn->x[i] - qx * gn->z[i]);
        wn->z[i] -= hm[i] * (qx * gn->y[i] - qy * gn->x[i]);
    }
    return 0;
}

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

static void load(const double *body_major, vec3s *v)
{
    int i;
    memset(v, 0, sizeof *v);
    for (i = 0; i < N; ++i) {
        v->x[i] = body_major[3 * i];
        v->y[i] = body_major[3 * i + 1];
        v->z[i] = body_major[3 * i + 2];
    }
}

int main(int argc, char **argv)
{
    const long nsteps = argc > 1 ? atol(argv[1]) : 2000;
    const int repeats = argc > 2 ? atoi(argv[2]) : 3;
    const double h = BENCH_H;
    vec3s buf[6], *traj_q, *traj_w;
    double times[64], cpu[64], e0, e1;
    long k;
    int r, i;
    if (nsteps < 1 || repeats < 1 || repeats > 64) {
        fprintf(stderr, "usage: %s NSTEPS REPEATS (1..64)\n", argv[0]);
        return 2;
    }
    /* the trajectory: every state, as the emitted integrate stores it */
    traj_q = malloc(sizeof(vec3s) * (size_t)(nsteps + 1));
    traj_w = malloc(sizeof(vec3s) * (size_t)(nsteps + 1));
    if (!traj_q || !traj_w) {
        fprintf(stderr, "out of memory\n");
        return 2;
    }
    memset(traj_q, 0, sizeof(vec3s) * (size_t)(nsteps + 1));
    memset(traj_w, 0, sizeof(vec3s) * (size_t)(nsteps + 1));
    for (r = 0; r < repeats; ++r) {
        vec3s *q = &buf[0], *w = &buf[1], *g = &buf[2];
        vec3s *qn = &buf[3], *wn = &buf[4], *gn = &buf[5], *t;
        const double t0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_PROCESS_CPUTIME_ID);
        setup(h);
        load(BENCH_Q0, q);
        load(BENCH_W0, w);
        traj_q[0] = *q;
        traj_w[0] = *w;
        gradient(q, g);
        for (k = 0; k < nsteps; ++k) {
            if (step(h, q, w, g, qn, wn, gn)) {
                fprintf(stderr, "step %ld infeasible (|a| > 1)\n", k + 1);
                return 1;
            }
            t = q, q = qn, qn = t;
            t = w, w = wn, wn = t;
            t = g, g = gn, gn = t;
            traj_q[k + 1] = *q;
            traj_w[k + 1] = *w;
        }
        times[r] = (now(CLOCK_MONOTONIC) - t0) * 1e9 / (double)nsteps;
        cpu[r] = (now(CLOCK_PROCESS_CPUTIME_ID) - c0) * 1e9 / (double)nsteps;
    }
    qsort(times, (size_t)repeats, sizeof(double), by_value);
    qsort(cpu, (size_t)repeats, sizeof(double), by_value);
    e0 = energy(&traj_q[0], &traj_w[0]);
    e1 = energy(&traj_q[nsteps], &traj_w[nsteps]);
    printf("ns_per_step %.1f\ncpu_ns_per_step %.1f\nnewton_per_step 0.000\nenergy_change %.3e\n",
           times[repeats / 2], cpu[repeats / 2], fabs(e1 - e0) / fabs(e0));
    printf("q");
    for (i = 0; i < N; ++i) {
        printf(" %.17g %.17g %.17g", traj_q[nsteps].x[i], traj_q[nsteps].y[i],
               traj_q[nsteps].z[i]);
    }
    printf("\nw");
    for (i = 0; i < N; ++i) {
        printf(" %.17g %.17g %.17g", traj_w[nsteps].x[i], traj_w[nsteps].y[i],
               traj_w[nsteps].z[i]);
    }
    printf("\n");
    free(traj_q);
    free(traj_w);
    return 0;
}
