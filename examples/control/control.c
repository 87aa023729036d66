/* Keep an inverted spherical pendulum (single or double) upright by accelerating its support,
 * with a discrete LQR state feedback.
 *
 * The emitted NAME.c integrates the pendulum in the support's frame, the support's
 * acceleration being its input. gains.h (written by lqr_gains.py from the same spec) names the
 * system's C API (the LQR_* macros) and holds the upright equilibrium x_eq (q_i = e3,
 * omega = 0), the orthonormal tangent basis E of T(S^2)^n there (6n x 4n) and the gain K of
 * the linearized step z+ = A z + B u. Before every step the controller computes the 4n tangent
 * coordinates z = E^T (x - x_eq) of the state x = (q, omega) and holds u = u_eq - K z over one
 * call of NAME_step() (one variational-integrator step).
 *
 *     control [TILT [TRACE]]
 *
 * starts with the first link TILT rad (default 0.2) from upright, towards the azimuth 0.5 rad,
 * every other link upright and at rest, and runs 10 s. It prints the tilt of each link (its
 * angle from e3) and |u| once per second, and with TRACE > 0 the state after each of the
 * first TRACE steps ("state k t q... omega..." , full precision). It exits with status 1
 * unless every link ends within 1e-6 rad of the top with |q_i| = 1 to 1e-12 throughout, 2 if
 * a step fails or the arguments are wrong.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "gains.h"

#define N LQR_NBODIES
#define NS LQR_NSTATE
#define NZ LQR_NTANGENT
#define NU LQR_NINPUTS

/* the feedback u = u_eq - K E^T (x - x_eq), x = (q, w) */
static void feedback(const double *q, const double *w, double *u)
{
    double dx[2 * NS], z[NZ];
    int i, j;
    for (i = 0; i < NS; ++i) {
        dx[i] = q[i] - LQR_X_EQ[i];
        dx[NS + i] = w[i] - LQR_X_EQ[NS + i];
    }
    for (j = 0; j < NZ; ++j) {
        z[j] = 0.0;
        for (i = 0; i < 2 * NS; ++i) {
            z[j] += LQR_BASIS[i][j] * dx[i];
        }
    }
    for (i = 0; i < NU; ++i) {
        u[i] = LQR_U_EQ[i];
        for (j = 0; j < NZ; ++j) {
            u[i] -= LQR_K[i][j] * z[j];
        }
    }
}

/* the angle of link i from e3 */
static double tilt(const double *q, int i)
{
    return atan2(sqrt(q[3 * i] * q[3 * i] + q[3 * i + 1] * q[3 * i + 1]), q[3 * i + 2]);
}

static void report(double t, const double *q, const double *u)
{
    double norm = 0.0;
    int i;
    printf("%5.2f", t);
    for (i = 0; i < N; ++i) {
        printf("  %12.3e", tilt(q, i));
    }
    for (i = 0; i < NU; ++i) {
        norm += u[i] * u[i];
    }
    printf("  %12.3e\n", sqrt(norm));
}

int main(int argc, char **argv)
{
    const double h = LQR_H, duration = 10.0;
    const long nsteps = lround(duration / h), every = lround(1.0 / h);
    double p[LQR_NPARAMS], q[NS] = {0}, w[NS] = {0}, qn[NS], wn[NS], u[NU];
    double work[LQR_WORK_SIZE], t = 0.0, tilt0 = 0.2, worst = 0.0, unit = 0.0;
    long k, trace = 0;
    int i;
    char *end;
    if (argc > 1) {
        tilt0 = strtod(argv[1], &end);
        if (*end != '\0' || !(fabs(tilt0) < 3.0)) {
            fprintf(stderr, "usage: %s [TILT [TRACE]]: TILT in rad, |TILT| < 3\n", argv[0]);
            return 2;
        }
    }
    if (argc > 2) {
        trace = strtol(argv[2], &end, 10);
        if (*end != '\0' || trace < 0) {
            fprintf(stderr, "usage: %s [TILT [TRACE]]: TRACE a number of steps\n", argv[0]);
            return 2;
        }
    }
    lqr_default_params(p);
    for (i = 0; i < N; ++i) {
        q[3 * i + 2] = 1.0;
    }
    q[0] = sin(tilt0) * cos(0.5), q[1] = sin(tilt0) * sin(0.5), q[2] = cos(tilt0);
    printf("%s: LQR from a %.2f rad tilt, h = %g s\n", LQR_NAME, tilt0, h);
    printf("    t");
    for (i = 0; i < N; ++i) {
        printf("  tilt %d [rad]", i + 1);
    }
    printf("   |u| [m/s^2]\n");
    feedback(q, w, u);
    report(t, q, u);
    for (k = 0; k < nsteps; ++k) {
        int status;
        feedback(q, w, u);
        status = lqr_step(p, NULL, LQR_METHOD, t, h, u, q, w, qn, wn, NULL, work, NULL);
        if (status != LQR_OK) {
            fprintf(stderr, "step %ld failed with status %d\n", k, status);
            return 2;
        }
        t = (double)(k + 1) * h;
        for (i = 0; i < NS; ++i) {
            q[i] = qn[i], w[i] = wn[i];
        }
        for (i = 0; i < N; ++i) {
            const double *qi = q + 3 * i;
            const double err = fabs(sqrt(qi[0] * qi[0] + qi[1] * qi[1] + qi[2] * qi[2]) - 1.0);
            unit = err > unit ? err : unit;
        }
        if (k < trace) {
            printf("state %ld %.17g", k + 1, t);
            for (i = 0; i < NS; ++i) {
                printf(" %.17g", q[i]);
            }
            for (i = 0; i < NS; ++i) {
                printf(" %.17g", w[i]);
            }
            printf("\n");
        }
        if ((k + 1) % every == 0) {
            report(t, q, u);
        }
    }
    for (i = 0; i < N; ++i) {
        worst = tilt(q, i) > worst ? tilt(q, i) : worst;
    }
    printf("after %ld steps (%.2f s): tilt %.3e rad, max | |q_i| - 1 | = %.1e\n", nsteps, t,
           worst, unit);
    return worst < 1e-6 && unit < 1e-12 ? 0 : 1;
}
