/* The speed anchor of benches/closed_loop.rs: classical fixed-step RK4 of the plant's
 * quiet linear system z' = A z, the 14 states of crates/plant/src/linear.rs (the
 * mechanics, the extension channel and its constant inputs as states) in HOLD with every
 * hysteresis element sticking, the system a quiet 2 ms step propagates exactly. No events,
 * no brakes, no hysteresis updates: what a plain integrator written in C pays for the
 * propagation alone.
 *
 * Reads from stdin: the 196 entries of A (row-major), the 14 of z(0), the RK4 step h (s)
 * and the number of steps. Prints the wall time and the CPU time of the integration loop
 * (s), then z at the end, one value a line with every digit, for the bench to check
 * against the exact propagation. */
#define _POSIX_C_SOURCE 199309L /* clock_gettime under -std=c99 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#define N 14

static void rate(const double a[N][N], const double z[N], double out[N]) {
    for (int i = 0; i < N; i++) {
        double s = 0.0;
        for (int j = 0; j < N; j++) s += a[i][j] * z[j];
        out[i] = s;
    }
}

int main(void) {
    double a[N][N], z[N], h;
    long steps;
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            if (scanf("%lf", &a[i][j]) != 1) return 2;
    for (int i = 0; i < N; i++)
        if (scanf("%lf", &z[i]) != 1) return 2;
    if (scanf("%lf %ld", &h, &steps) != 2 || steps < 1) return 2;

    struct timespec t0, t1, c0, c1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c0);
    double k1[N], k2[N], k3[N], k4[N], w[N];
    for (long n = 0; n < steps; n++) {
        rate(a, z, k1);
        for (int i = 0; i < N; i++) w[i] = z[i] + 0.5 * h * k1[i];
        rate(a, w, k2);
        for (int i = 0; i < N; i++) w[i] = z[i] + 0.5 * h * k2[i];
        rate(a, w, k3);
        for (int i = 0; i < N; i++) w[i] = z[i] + h * k3[i];
        rate(a, w, k4);
        for (int i = 0; i < N; i++) z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c1);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    printf("%.9f\n", (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec));
    printf("%.9f\n", (double)(c1.tv_sec - c0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - c0.tv_nsec));
    for (int i = 0; i < N; i++) printf("%.17g\n", z[i]);
    return 0;
}
