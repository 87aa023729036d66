/* Hand-written C99: the explicit variational integrator of Lee, Leok & McClamroch for the
 * "mixture" benchmark system (mixture.toml), written for speed on one core, IEEE arithmetic.
 *
 *   V = sum_{i<j, r_ij < rc} 4 e_ij ((s_ij^2/r_ij^2)^6 - (s_ij^2/r_ij^2)^3) - (the same at rc)
 *   s_ij = (s_i + s_j)/2, e_ij = sqrt(e_i e_j), r_ij = |q_i - q_j|,   M = diag(m_1 .. m_n)
 *
 * One step (paper, eqs. qikpexp and wikpexp), with g = dV/dq:
 *   a_i    = h w_i - h^2/(2 m_i) q_i x g_i
 *   q_i+   = a_i x q_i + sqrt(1 - |a_i|^2) q_i
 *   w_i+   = w_i - h/(2 m_i) (q_i x g_i + q_i+ x g_i+)
 * The gradient at q+ is the next step's gradient at q: one gradient per step.
 *
 * Neighbours: a grid of NC^3 cells over [-1, 1]^3, each at least rc wide. Every gradient sorts
 * the bodies by cell (a counting sort) into structure-of-arrays copies of the positions and of
 * the per-body data, so that a cell's bodies, and their sizes and strengths, are contiguous.
 * Each pair is visited once: a cell with itself (j > i) and with the 13 cells of a half
 * stencil; the inner loop runs over the partner cell's contiguous range as a SIMD loop with
 * the cutoff as a mask. The sorted gradient is scattered back to the bodies' order.
 *
 * System data (n, rc, the cells per axis, masses, sizes s, strengths e, initial state, h)
 * come from mixture_data.h, which the benchmark writes from mixture.toml; sizes are
 * compile-time constants.
 *
 * usage: mixture NSTEPS REPEATS
 * prints ns_per_step and cpu_ns_per_step (medians over REPEATS runs of the NSTEPS steps,
 * every state stored: wall-clock and CPU time), newton_per_step (0: explicit), the relative
 * energy change over the run, and the final state q, w (body-major, 17 significant digits). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "mixture_data.h"

#define N BENCH_N
/* component-major arrays are padded to a multiple of 8 doubles (64 bytes) */
#define NP ((N + 7) / 8 * 8)
/* cells per axis (floor(2 / rc), from the header): each at least rc wide */
#define NC MX_NC
#define CELLS (NC * NC * NC)

typedef struct {
    double x[NP], y[NP], z[NP];
} vec3s;

/* per body, folded once: s_i / 2, 2 sqrt(e_i), h/(2 m_i), h^2/(2 m_i) */
static double half_s[NP], root_e[NP], hm[NP], h2m[NP];

/* the cell list of one gradient: bodies sorted by cell (cell c holds sorted positions
 * start[c] .. start[c + 1] - 1), their original index, and sorted copies of the data */
static int cell[NP], start[CELLS + 1], order[NP];
static double sx[NP], sy[NP], sz[NP], ss[NP], se[NP], gx[NP], gy[NP], gz[NP];

static void setup(double h)
{
    int i;
    for (i = 0; i < N; ++i) {
        half_s[i] = 0.5 * MX_SIGMA[i];
        root_e[i] = 2.0 * sqrt(MX_EPS[i]);
        hm[i] = h / (2.0 * MX_MASS[i]);
        h2m[i] = h * h / (2.0 * MX_MASS[i]);
    }
}

static int axis(double x)
{
    const int v = (int)((x + 1.0) * (0.5 * NC));
    return v < 0 ? 0 : (v >= NC ? NC - 1 : v);
}

/* counting sort of the bodies by cell into the sorted copies */
static void sort_cells(const vec3s *q)
{
    int i, c;
    memset(start, 0, sizeof start);
    for (i = 0; i < N; ++i) {
        cell[i] = (axis(q->x[i]) * NC + axis(q->y[i])) * NC + axis(q->z[i]);
        ++start[cell[i] + 1];
    }
    for (c = 0; c < CELLS; ++c) {
        start[c + 1] += start[c];
    }
    for (i = 0; i < N; ++i) {
        const int k = start[cell[i]]++;
        order[k] = i;
        sx[k] = q->x[i];
        sy[k] = q->y[i];
        sz[k] = q->z[i];
        ss[k] = half_s[i];
        se[k] = root_e[i];
    }
    /* the placing loop moved each start to the next cell's: shift back */
    for (c = CELLS; c > 0; --c) {
        start[c] = start[c - 1];
    }
    start[0] = 0;
}

/* the forces of sorted body i on the sorted range [j0, j1): for r^2 < rc^2, with u = 1/r^2,
 * s6 = (s_ij^2 u)^3 and E = 4 e_ij,
 *   dV/dq_i = -6 E u s6 (2 s6 - 1) d = -dV/dq_j,   d = q_i - q_j. */
static void interact(int i, int j0, int j1)
{
    const double xi = sx[i], yi = sy[i], zi = sz[i], si = ss[i], ei = se[i];
    const double rc2 = MX_RC * MX_RC;
    double fx = 0.0, fy = 0.0, fz = 0.0;
    int j;
#pragma omp simd reduction(+ : fx, fy, fz)
    for (j = j0; j < j1; ++j) {
        const double dx = xi - sx[j], dy = yi - sy[j], dz = zi - sz[j];
        const double r2 = dx * dx + dy * dy + dz * dz;
        const double sij = si + ss[j];
        const double u = 1.0 / r2;
        const double s2 = sij * sij * u;
        const double s6 = s2 * s2 * s2;
        const double c = r2 < rc2 ? -6.0 * ei * se[j] * u * s6 * (2.0 * s6 - 1.0) : 0.0;
        fx += c * dx;
        fy += c * dy;
        fz += c * dz;
        gx[j] -= c * dx;
        gy[j] -= c * dy;
        gz[j] -= c * dz;
    }
    gx[i] += fx;
    gy[i] += fy;
    gz[i] += fz;
}

/* the 13 neighbour cells of a half stencil: (dx, dy, dz) after (0, 0, 0) in lexicographic order */
static const int HALF[13][3] = {{0, 0, 1},  {0, 1, -1}, {0, 1, 0},  {0, 1, 1},  {1, -1, -1},
                                {1, -1, 0}, {1, -1, 1}, {1, 0, -1}, {1, 0, 0},  {1, 0, 1},
                                {1, 1, -1}, {1, 1, 0},  {1, 1, 1}};

/* g = dV/dq at q */
static void gradient(const vec3s *q, vec3s *g)
{
    int cx, cy, cz, k, i;
    sort_cells(q);
    memset(gx, 0, sizeof gx);
    memset(gy, 0, sizeof gy);
    memset(gz, 0, sizeof gz);
    for (cx = 0; cx < NC; ++cx) {
        for (cy = 0; cy < NC; ++cy) {
            for (cz = 0; cz < NC; ++cz) {
                const int c = (cx * NC + cy) * NC + cz, i0 = start[c], i1 = start[c + 1];
                if (i0 == i1) {
                    continue;
                }
                for (i = i0; i < i1; ++i) {
                    interact(i, i + 1, i1);
                }
                for (k = 0; k < 13; ++k) {
                    const int x = cx + HALF[k][0], y = cy + HALF[k][1], z = cz + HALF[k][2];
                    int d;
                    if (x >= NC || y < 0 || y >= NC || z < 0 || z >= NC) {
                        continue;
                    }
                    d = (x * NC + y) * NC + z;
                    if (start[d] == start[d + 1]) {
                        continue;
                    }
                    for (i = i0; i < i1; ++i) {
                        interact(i, start[d], start[d + 1]);
                    }
                }
            }
        }
    }
    for (k = 0; k < N; ++k) {
        i = order[k];
        g->x[i] = gx[k];
        g->y[i] = gy[k];
        g->z[i] = gz[k];
    }
}

/* the energy by the definition (all pairs, outside the timed runs) */
static double energy(const vec3s *q, const vec3s *w)
{
    const double rc2 = MX_RC * MX_RC;
    double e = 0.0;
    int i, j;
    for (i = 0; i < N; ++i) {
        const double vx = w->y[i] * q->z[i] - w->z[i] * q->y[i];
        const double vy = w->z[i] * q->x[i] - w->x[i] * q->z[i];
        const double vz = w->x[i] * q->y[i] - w->y[i] * q->x[i];
        e += 0.5 * MX_MASS[i] * (vx * vx + vy * vy + vz * vz);
        for (j = i + 1; j < N; ++j) {
            const double dx = q->x[i] - q->x[j], dy = q->y[i] - q->y[j], dz = q->z[i] - q->z[j];
            const double r2 = dx * dx + dy * dy + dz * dz;
            if (r2 < rc2) {
                const double s2 = 0.25 * (MX_SIGMA[i] + MX_SIGMA[j]) * (MX_SIGMA[i] + MX_SIGMA[j]);
                const double x = s2 / r2, xc = s2 / rc2;
                const double x3 = x * x * x, xc3 = xc * xc * xc;
                e += 4.0 * sqrt(MX_EPS[i] * MX_EPS[j]) * (x3 * x3 - x3 - xc3 * xc3 + xc3);
            }
        }
    }
    return e;
}

/* One step (q, w, g) -> (qn, wn, gn). Returns 0, or 1 when |a_i| > 1 (or a_i is not finite)
 * for some body. */
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
    const long nsteps = argc > 1 ? atol(argv[1]) : 400;
    const int repeats = argc > 2 ? atoi(argv[2]) : 3;
    const double h = BENCH_H;
    static vec3s buf[6];
    vec3s *traj_q, *traj_w;
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
