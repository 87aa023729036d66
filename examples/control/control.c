/* Keep an inverted spherical pendulum upright by accelerating its support.
 *
 * The emitted inverted_pendulum.c integrates the pendulum in the support's frame, the
 * support's acceleration a = (ax, ay, az) being its input. Near the top, with x = q[0] and
 * y = q[1], the motion is x'' = (g x - ax) / l (and the same in y), so the state feedback
 *     ax = g x + l (kp x + kd x'),   ay = g y + l (kp y + kd y'),   az = 0
 * gives x'' = -kp x - kd x': the tilt decays like a damped oscillator. Every step of the
 * variational integrator is one call of inverted_pendulum_step() with the inputs held over
 * it; the program prints the tilt and the support's acceleration once per 0.25 s, and fails
 * (exit 1) unless the pendulum ends within 1e-6 rad of the top.
 */
#include <math.h>
#include <stdio.h>

#include "inverted_pendulum.h"

int main(void)
{
    const double kp = 25.0, kd = 10.0, h = 0.005;
    double p[INVERTED_PENDULUM_NPARAMS], q[3], w[3], qn[3], wn[3], u[3];
    double work[INVERTED_PENDULUM_WORK_SIZE], t = 0.0, tilt = 0.0;
    long k;
    inverted_pendulum_default_params(p);
    if (inverted_pendulum_initial_state(q, w) != INVERTED_PENDULUM_OK) {
        return 2;
    }
    printf("    t    tilt [rad]     ax [m/s^2]     ay [m/s^2]\n");
    for (k = 0; k < 1000; ++k) {
        const double l = p[1], g = p[2];
        /* the bob's velocity q' = w x q: its x and y components are the tilt rates */
        const double vx = w[1] * q[2] - w[2] * q[1], vy = w[2] * q[0] - w[0] * q[2];
        int status;
        u[0] = g * q[0] + l * (kp * q[0] + kd * vx);
        u[1] = g * q[1] + l * (kp * q[1] + kd * vy);
        u[2] = 0.0;
        status = inverted_pendulum_step(p, NULL, INVERTED_PENDULUM_METHOD_VI, t, h, u, q, w, qn,
                                        wn, NULL, work, NULL);
        if (status != INVERTED_PENDULUM_OK) {
            fprintf(stderr, "step %ld failed with status %d\n", k, status);
            return 2;
        }
        t += h;
        q[0] = qn[0], q[1] = qn[1], q[2] = qn[2];
        w[0] = wn[0], w[1] = wn[1], w[2] = wn[2];
        tilt = atan2(sqrt(q[0] * q[0] + q[1] * q[1]), q[2]);
        if ((k + 1) % 50 == 0) {
            printf("%5.2f  %12.3e  %13.3e  %13.3e\n", t, tilt, u[0], u[1]);
        }
    }
    printf("after %ld steps: tilt %.3e rad, | |q| - 1 | = %.1e\n", k, tilt,
           fabs(sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]) - 1.0));
    return tilt < 1e-6 ? 0 : 1;
}
