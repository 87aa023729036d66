/* Hand-written C99: the implicit variational integrator of Lee, Leok & McClamroch for the
 * "chain" benchmark system (chain.toml), written for speed on one core, IEEE arithmetic.
 *
 * n spherical pendula in series: M_ij = l_i l_j mu_max(i,j), mu_k = m_k + ... + m_n;
 *   V = -g sum_i mu_i l_i e3 . q_i + sum_i k_i (1 - q_i . q_i+1).
 *
 * One step (paper, eqs. imp/impf and DELw2m). With v_j = w_j x q_j and g = dV/dq at q:
 *   d_i   = h q_i x sum_j M_ij v_j - (h^2/2) q_i x g_i,
 *   r_i(f) = 2 M_ii (q_i . q_i) f_i / (1 + |f_i|^2) + q_i x sum_{j != i} M_ij D_j - d_i = 0,
 *   D_j   = F_j q_j - q_j = 2 (f_j x q_j - |f_j|^2 q_j) / (1 + |f_j|^2)
 * is solved for the Cayley parameters f by Newton's method (dense LU with partial pivoting of
 * the 3n x 3n Jacobian), started from the previous step's f (the first step from
 * d_i / (2 M_ii)) and stopped when max|delta f| <= 1e-14 max|f|, or when the next update
 * that quadratic convergence predicts (max|delta f|^3 / max|previous delta f|^2) is, or when
 * max|delta f| <= 1e-11 max|f| once the update stops shrinking (it is more than half the
 * previous one). Then q_i+ = F_i q_i and
 *   A(q+) w+ = c,  c_i = (1/h) [2 M_ii (q_i . q_i) f_i / (1 + |f_i|^2) + q_i+ x sum_{j != i} M_ij D_j]
 *                      - (h/2) q_i+ x g_i(q+),
 *   A_ii = M_ii (q_i+ . q_i+) I,  A_ij = -M_ij hat(q_i+) hat(q_j+),
 * by Cholesky. The gradient at q+ is the next step's gradient at q: one gradient per step.
 *
 * System data (n, masses, lengths, springs, g, initial state, h) come from chain_data.h, which
 * the benchmark writes from chain.toml; sizes are compile-time constants.
 *
 * usage: chain NSTEPS REPEATS
 * prints ns_per_step and cpu_ns_per_step (medians over REPEATS runs of the NSTEPS steps,
 * every state stored: wall-clock and CPU time), newton_per_step (mean Newton iterations per step), the relative energy change over the
 * run, and the final state q, w (body-major, 17 significant digits). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "chain_data.h"

#define N BENCH_N
#define D (3 * N)            /* unknowns */
#define LD ((D + 4) / 4 * 4) /* padded leading dimension: room for the right side */
#define NEWTON_TOL 1e-14
#define NEWTON_MAXITER 50

/* constants folded once per run */
static double mij[N][N];   /* M */
static double weight[N];   /* g mu_i l_i: the gravity force on link i is -weight_i e3 */

static void setup(void)
{
    double mu[N + 1];
    int i, j;
    mu[N] = 0.0;
    for (i = N - 1; i >= 0; --i) {
        mu[i] = mu[i + 1] + CH_MASS[i];
    }
    for (i = 0; i < N; ++i) {
        for (j = 0; j < N; ++j) {
            mij[i][j] = CH_LEN[i] * CH_LEN[j] * mu[i > j ? i : j];
        }
        weight[i] = CH_G * mu[i] * CH_LEN[i];
    }
}

/* g = dV/dq, body-major */
static void gradient(const double *q, double *g)
{
    int i, c;
    for (i = 0; i < N; ++i) {
        g[3 * i] = 0.0;
        g[3 * i + 1] = 0.0;
        g[3 * i + 2] = -weight[i];
    }
    for (i = 0; i + 1 < N; ++i) {
        for (c = 0; c < 3; ++c) {
            g[3 * i + c] -= CH_SPRING[i] * q[3 * (i + 1) + c];
            g[3 * (i + 1) + c] -= CH_SPRING[i] * q[3 * i + c];
        }
    }
}

static void cross(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* u_i = sum_{j != i} M_ij x_j (x, u: body-major 3-vectors) */
static void couple(const double *x, double *u)
{
    int i, j;
    for (i = 0; i < N; ++i) {
        double s0 = 0.0, s1 = 0.0, s2 = 0.0;
        for (j = 0; j < N; ++j) {
            if (j != i) {
                s0 += mij[i][j] * x[3 * j];
                s1 += mij[i][j] * x[3 * j + 1];
                s2 += mij[i][j] * x[3 * j + 2];
            }
        }
        u[3 * i] = s0;
        u[3 * i + 1] = s1;
        u[3 * i + 2] = s2;
    }
}

static double energy(const double *q, const double *w)
{
    double v[D], e = 0.0;
    int i, j;
    for (i = 0; i < N; ++i) {
        cross(w + 3 * i, q + 3 * i, v + 3 * i);
    }
    for (i = 0; i < N; ++i) {
        for (j = 0; j < N; ++j) {
            e += 0.5 * mij[i][j] * dot(v + 3 * i, v + 3 * j);
        }
        e -= weight[i] * q[3 * i + 2];
        if (i + 1 < N) {
            e += CH_SPRING[i] * (1.0 - dot(q + 3 * i, q + 3 * i + 3));
        }
    }
    return e;
}

/* Solve a x = r by LU with partial pivoting, on the augmented matrix: a is row-major with
 * leading dimension LD, its column D holds r on entry and x on exit. Each row update runs over
 * the whole padded row from the 4-aligned column below the pivot (entries left of the pivot
 * are dead), so it is a fixed-width vector loop with no remainder. Returns 0, or 1 for a zero
 * pivot. */
static int lu_solve(double a[D][LD])
{
    int i, j, k;
    for (k = 0; k < D; ++k) {
        const int k0 = k & ~3;
        int piv = k;
        double best = fabs(a[k][k]), inv;
        for (i = k + 1; i < D; ++i) {
            if (fabs(a[i][k]) > best) {
                best = fabs(a[i][k]);
                piv = i;
            }
        }
        if (!(best > 0.0)) {
            return 1;
        }
        if (piv != k) {
#pragma omp simd
            for (j = k0; j < LD; ++j) {
                const double t = a[k][j];
                a[k][j] = a[piv][j];
                a[piv][j] = t;
            }
        }
        inv = 1.0 / a[k][k];
        for (i = k + 1; i < D; ++i) {
            const double l = a[i][k] * inv;
#pragma omp simd
            for (j = k0; j < LD; ++j) {
                a[i][j] -= l * a[k][j];
            }
        }
    }
    for (i = D - 1; i >= 0; --i) {
        double t = 0.0;
#pragma omp simd reduction(+ : t)
        for (j = i + 1; j < D; ++j) {
            t += a[i][j] * a[j][D];
        }
        a[i][D] = (a[i][D] - t) / a[i][i];
    }
    return 0;
}

/* Solve a x = b in place for symmetric positive definite a (lower triangle used): Cholesky,
 * its dot products as SIMD reductions. Returns 0, or 1 when a is not positive definite. */
static int cholesky_solve(double a[D][LD], double *b)
{
    int i, j, k;
    for (j = 0; j < D; ++j) {
        double s = 0.0, piv;
#pragma omp simd reduction(+ : s)
        for (k = 0; k < j; ++k) {
            s += a[j][k] * a[j][k];
        }
        s = a[j][j] - s;
        if (!(s > 0.0)) {
            return 1;
        }
        piv = sqrt(s);
        a[j][j] = piv;
        for (i = j + 1; i < D; ++i) {
            double t = 0.0;
#pragma omp simd reduction(+ : t)
            for (k = 0; k < j; ++k) {
                t += a[i][k] * a[j][k];
            }
            a[i][j] = (a[i][j] - t) / piv;
        }
    }
    for (i = 0; i < D; ++i) { /* L y = b */
        double t = 0.0;
#pragma omp simd reduction(+ : t)
        for (k = 0; k < i; ++k) {
            t += a[i][k] * b[k];
        }
        b[i] = (b[i] - t) / a[i][i];
    }
    for (i = D - 1; i >= 0; --i) { /* L^T x = y */
        double t = b[i];
        for (k = i + 1; k < D; ++k) {
            t -= a[k][i] * b[k];
        }
        b[i] = t / a[i][i];
    }
    return 0;
}

/* One step (q, w, g) -> (qn, wn, gn); f: Newton's start on entry (when warm), the solution
 * on exit. Returns 0, or 1 when Newton fails, 2 when the velocity solve fails. */
static int step(double h, const double *q, const double *w, const double *g, double *qn,
                double *wn, double *gn, double *f, int warm, int *iters)
{
    static double jm[D][LD];
    double v[D], u[D], d[D], dq[D], dd[N][9], ds[N], self[N], prev = INFINITY;
    int i, j, a, b, it, converged = 0;
    /* the known side d */
    for (i = 0; i < N; ++i) {
        cross(w + 3 * i, q + 3 * i, v + 3 * i);
        self[i] = 2.0 * mij[i][i] * dot(q + 3 * i, q + 3 * i);
    }
    for (i = 0; i < N; ++i) {
        double s0 = 0.0, s1 = 0.0, s2 = 0.0, t[3], qg[3];
        for (j = 0; j < N; ++j) {
            s0 += mij[i][j] * v[3 * j];
            s1 += mij[i][j] * v[3 * j + 1];
            s2 += mij[i][j] * v[3 * j + 2];
        }
        u[3 * i] = s0;
        u[3 * i + 1] = s1;
        u[3 * i + 2] = s2;
        cross(q + 3 * i, u + 3 * i, t);
        cross(q + 3 * i, g + 3 * i, qg);
        for (a = 0; a < 3; ++a) {
            d[3 * i + a] = h * t[a] - 0.5 * h * h * qg[a];
            if (!warm) {
                f[3 * i + a] = d[3 * i + a] / (2.0 * mij[i][i]);
            }
        }
    }
    /* Newton's method on the Cayley parameters */
    for (it = 1; it <= NEWTON_MAXITER && !converged; ++it) {
        double stepmax = 0.0, size = 1e-300, chk = 0.0;
        for (j = 0; j < N; ++j) {
            /* D_j and its derivative dD_j/df_j = -2 (q_j f_j^T + hat(q_j) + (F_j q_j) f_j^T)/(1+s) */
            const double *fj = f + 3 * j, *qj = q + 3 * j;
            const double s = dot(fj, fj), inv = 1.0 / (1.0 + s);
            double fq[3], fqj[3];
            cross(fj, qj, fq);
            for (a = 0; a < 3; ++a) {
                dq[3 * j + a] = 2.0 * (fq[a] - s * qj[a]) * inv;
                fqj[a] = qj[a] + dq[3 * j + a]; /* F_j q_j */
            }
            for (a = 0; a < 3; ++a) {
                for (b = 0; b < 3; ++b) {
                    dd[j][3 * a + b] = -2.0 * inv * (qj[a] + fqj[a]) * fj[b];
                }
            }
            /* - 2/(1+s) hat(q_j) */
            dd[j][1] += 2.0 * inv * qj[2];
            dd[j][2] -= 2.0 * inv * qj[1];
            dd[j][3] -= 2.0 * inv * qj[2];
            dd[j][5] += 2.0 * inv * qj[0];
            dd[j][6] += 2.0 * inv * qj[1];
            dd[j][7] -= 2.0 * inv * qj[0];
            ds[j] = inv;
        }
        couple(dq, u);
        for (i = 0; i < N; ++i) {
            const double *qi = q + 3 * i, *fi = f + 3 * i;
            const double inv = ds[i], c = self[i] * inv, c2 = 2.0 * c * inv;
            double t[3];
            cross(qi, u + 3 * i, t);
            for (a = 0; a < 3; ++a) {
                jm[3 * i + a][D] = d[3 * i + a] - (c * fi[a] + t[a]); /* -residual */
            }
            /* J_ii = M_ii (q_i.q_i) (2 I/(1+s) - 4 f f^T/(1+s)^2) */
            for (a = 0; a < 3; ++a) {
                for (b = 0; b < 3; ++b) {
                    jm[3 * i + a][3 * i + b] = (a == b ? c : 0.0) - c2 * fi[a] * fi[b];
                }
            }
            /* J_ij = M_ij hat(q_i) dD_j/df_j, column by column: q_i x (column b) */
            for (j = 0; j < N; ++j) {
                if (j == i) {
                    continue;
                }
                for (b = 0; b < 3; ++b) {
                    const double *e = dd[j];
                    const double c0 = e[b], c1 = e[3 + b], cz = e[6 + b];
                    const double m = mij[i][j];
                    jm[3 * i][3 * j + b] = m * (qi[1] * cz - qi[2] * c1);
                    jm[3 * i + 1][3 * j + b] = m * (qi[2] * c0 - qi[0] * cz);
                    jm[3 * i + 2][3 * j + b] = m * (qi[0] * c1 - qi[1] * c0);
                }
            }
        }
        if (lu_solve(jm)) {
            *iters = it;
            return 1;
        }
        for (i = 0; i < D; ++i) {
            const double delta = jm[i][D];
            f[i] += delta;
            stepmax = fabs(delta) > stepmax ? fabs(delta) : stepmax;
            size = fabs(f[i]) > size ? fabs(f[i]) : size;
            chk += delta * 0.0; /* NaN unless delta is finite */
        }
        *iters = it;
        if (chk != 0.0) {
            return 1;
        }
        converged = stepmax <= NEWTON_TOL * size
                    || (it > 1 && stepmax < prev
                        && stepmax * (stepmax / prev) * (stepmax / prev) <= NEWTON_TOL * size)
                    || (stepmax <= 1e3 * NEWTON_TOL * size && stepmax > 0.5 * prev);
        prev = stepmax;
    }
    if (!converged) {
        return 1;
    }
    /* q+ = F q, from f: q+ = q + D */
    for (j = 0; j < N; ++j) {
        const double *fj = f + 3 * j, *qj = q + 3 * j;
        const double s = dot(fj, fj), inv = 1.0 / (1.0 + s);
        double fq[3];
        cross(fj, qj, fq);
        ds[j] = inv;
        for (a = 0; a < 3; ++a) {
            dq[3 * j + a] = 2.0 * (fq[a] - s * qj[a]) * inv;
            qn[3 * j + a] = qj[a] + dq[3 * j + a];
        }
    }
    gradient(qn, gn);
    /* the new angular velocities: A(q+) w+ = c */
    couple(dq, u);
    for (i = 0; i < N; ++i) {
        const double *qi = qn + 3 * i, *fi = f + 3 * i;
        const double c = self[i] * ds[i] / h;
        double t[3], qg[3];
        cross(qi, u + 3 * i, t);
        cross(qi, gn + 3 * i, qg);
        for (a = 0; a < 3; ++a) {
            wn[3 * i + a] = c * fi[a] + t[a] / h - 0.5 * h * qg[a];
        }
        for (j = 0; j <= i; ++j) {
            const double *qj = qn + 3 * j;
            if (j == i) {
                const double m = mij[i][i] * dot(qi, qi);
                for (a = 0; a < 3; ++a) {
                    for (b = 0; b <= a; ++b) {
                        jm[3 * i + a][3 * i + b] = a == b ? m : 0.0;
                    }
                }
            } else {
                /* -M_ij hat(q_i) hat(q_j) = M_ij ((q_i . q_j) I - q_j q_i^T) */
                const double m = mij[i][j], qq = dot(qi, qj);
                for (a = 0; a < 3; ++a) {
                    for (b = 0; b < 3; ++b) {
                        jm[3 * i + a][3 * j + b] = m * ((a == b ? qq : 0.0) - qj[a] * qi[b]);
                    }
                }
            }
        }
    }
    return cholesky_solve(jm, wn) ? 2 : 0;
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

int main(int argc, char **argv)
{
    const long nsteps = argc > 1 ? atol(argv[1]) : 5000;
    const int repeats = argc > 2 ? atoi(argv[2]) : 3;
    const double h = BENCH_H;
    double *traj_q, *traj_w, times[64], cpu[64], e0, e1;
    long k, newton = 0;
    int r, i;
    if (nsteps < 1 || repeats < 1 || repeats > 64) {
        fprintf(stderr, "usage: %s NSTEPS REPEATS (1..64)\n", argv[0]);
        return 2;
    }
    /* the trajectory: every state, as the emitted integrate stores it */
    traj_q = calloc((size_t)(nsteps + 1) * D, sizeof(double));
    traj_w = calloc((size_t)(nsteps + 1) * D, sizeof(double));
    if (!traj_q || !traj_w) {
        fprintf(stderr, "out of memory\n");
        return 2;
    }
    for (r = 0; r < repeats; ++r) {
        double g[2][D], f[D];
        double t0, c0;
        int cur = 0;
        newton = 0;
        t0 = now(CLOCK_MONOTONIC);
        c0 = now(CLOCK_PROCESS_CPUTIME_ID);
        setup();
        memcpy(traj_q, BENCH_Q0, sizeof(double) * D);
        memcpy(traj_w, BENCH_W0, sizeof(double) * D);
        gradient(traj_q, g[0]);
        for (k = 0; k < nsteps; ++k) {
            int iters = 0, status;
            status = step(h, traj_q + k * D, traj_w + k * D, g[cur], traj_q + (k + 1) * D,
                          traj_w + (k + 1) * D, g[1 - cur], f, k > 0, &iters);
            newton += iters;
            if (status) {
                fprintf(stderr, "step %ld: %s\n", k + 1,
                        status == 1 ? "Newton's method failed" : "velocity solve failed");
                return 1;
            }
            cur = 1 - cur;
        }
        times[r] = (now(CLOCK_MONOTONIC) - t0) * 1e9 / (double)nsteps;
        cpu[r] = (now(CLOCK_PROCESS_CPUTIME_ID) - c0) * 1e9 / (double)nsteps;
    }
    qsort(times, (size_t)repeats, sizeof(double), by_value);
    qsort(cpu, (size_t)repeats, sizeof(double), by_value);
    e0 = energy(traj_q, traj_w);
    e1 = energy(traj_q + nsteps * D, traj_w + nsteps * D);
    printf("ns_per_step %.1f\ncpu_ns_per_step %.1f\nnewton_per_step %.3f\nenergy_change %.3e\n",
           times[repeats / 2], cpu[repeats / 2], (double)newton / (double)nsteps,
           fabs(e1 - e0) / fabs(e0));
    printf("q");
    for (i = 0; i < D; ++i) {
        printf(" %.17g", traj_q[nsteps * D + i]);
    }
    printf("\nw");
    for (i = 0; i < D; ++i) {
        printf(" %.17g", traj_w[nsteps * D + i]);
    }
    printf("\n");
    free(traj_q);
    free(traj_w);
    return 0;
}
