/* A Model Exchange FMU (FMI 2.0) with NX continuous states (-DNX=1000), for the master's
 * size caps and what a wide FMU costs: x_i' = -(1 + i % 7) x_i + x_{i-1} (x_{-1} = 0),
 * x(0) = 1, no event indicators, no time events, the exact Jacobian as directional
 * derivative. States have value references 0..NX-1, their derivatives NX..2NX-1.
 * -DSLOW (with NX=2): an oscillator x0' = 100 x1, x1' = -100 x0 whose every derivative
 * evaluation sleeps 20 ms, so that one long communication step lasts for minutes (a test
 * of stopping inside a step). */
#include <stdlib.h>
#include <string.h>
#include <stddef.h>
#ifdef SLOW
#include <time.h>
#endif

#ifndef NX
#define NX 1000
#endif

typedef struct { double t, x[NX], seed[NX]; } M;

static double coefficient(size_t i) { return -(double)(1 + i % 7); }

static void derivatives(M *m, const double *x, double *dx) {
#ifdef SLOW
    struct timespec ms = {0, 20000000};
    nanosleep(&ms, NULL);
    dx[0] = 100 * x[1];
    dx[1] = -100 * x[0];
#else
    for (size_t i = 0; i < NX; i++) dx[i] = coefficient(i) * x[i] + (i ? x[i - 1] : 0.0);
#endif
}

#define EXPORT __attribute__((visibility("default")))
#define F(name) EXPORT int name
typedef struct { int needed, terminate, nominals, values, next_defined; double next; } EventInfo;

EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }
F(fmi2SetDebugLogging)(void *c, int on, size_t n, const char **cats) { return 0; }
EXPORT void *fmi2Instantiate(const char *n, int type, const char *g, const char *r, const void *cb, int v, int l) {
    M *m = calloc(1, sizeof(M));
    if (m) for (size_t i = 0; i < NX; i++) m->x[i] = 1.0;
    return m;
}
EXPORT void fmi2FreeInstance(void *c) { free(c); }
F(fmi2SetupExperiment)(void *c, int a, double b, double t0, int d, double e) { ((M *)c)->t = t0; return 0; }
F(fmi2EnterInitializationMode)(void *c) { return 0; }
F(fmi2ExitInitializationMode)(void *c) { return 0; }
F(fmi2Terminate)(void *c) { return 0; }
F(fmi2Reset)(void *c) { return 3; }
F(fmi2GetReal)(void *c, const unsigned *vr, size_t n, double *v) {
    M *m = c;
    double dx[NX];
    derivatives(m, m->x, dx);
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= 2 * NX) return 3;
        v[k] = vr[k] < NX ? m->x[vr[k]] : dx[vr[k] - NX];
    }
    return 0;
}
F(fmi2SetReal)(void *c, const unsigned *vr, size_t n, const double *v) { return n ? 3 : 0; }
F(fmi2GetInteger)(void *c, const unsigned *vr, size_t n, int *v) { return n ? 3 : 0; }
F(fmi2SetInteger)(void *c, const unsigned *vr, size_t n, const int *v) { return n ? 3 : 0; }
F(fmi2GetBoolean)(void *c, const unsigned *vr, size_t n, int *v) { return n ? 3 : 0; }
F(fmi2SetBoolean)(void *c, const unsigned *vr, size_t n, const int *v) { return n ? 3 : 0; }
F(fmi2GetString)(void *c, const unsigned *vr, size_t n, const char **v) { return n ? 3 : 0; }
F(fmi2SetString)(void *c, const unsigned *vr, size_t n, const char **v) { return n ? 3 : 0; }
F(fmi2EnterEventMode)(void *c) { return 0; }
F(fmi2NewDiscreteStates)(void *c, EventInfo *e) {
    memset(e, 0, sizeof *e);
    return 0;
}
F(fmi2EnterContinuousTimeMode)(void *c) { return 0; }
F(fmi2CompletedIntegratorStep)(void *c, int np, int *enter, int *term) { *enter = 0; *term = 0; return 0; }
F(fmi2SetTime)(void *c, double t) { ((M *)c)->t = t; return 0; }
F(fmi2SetContinuousStates)(void *c, const double *x, size_t n) {
    if (n != NX) return 3;
    memcpy(((M *)c)->x, x, sizeof(double) * NX);
    return 0;
}
F(fmi2GetDerivatives)(void *c, double *dx, size_t n) {
    if (n != NX) return 3;
    derivatives(c, ((M *)c)->x, dx);
    return 0;
}
F(fmi2GetEventIndicators)(void *c, double *z, size_t n) { return n ? 3 : 0; }
F(fmi2GetContinuousStates)(void *c, double *x, size_t n) {
    if (n != NX) return 3;
    memcpy(x, ((M *)c)->x, sizeof(double) * NX);
    return 0;
}
F(fmi2GetNominalsOfContinuousStates)(void *c, double *x, size_t n) {
    if (n != NX) return 3;
    for (size_t i = 0; i < NX; i++) x[i] = 1.0;
    return 0;
}
/* out_j = sum_k d(der x_{u_j}) / d(x_{k}) seed_k: the seeds scattered into a state vector
 * first, so that a product is O(NX) whatever the lists. */
F(fmi2GetDirectionalDerivative)(void *c, const unsigned *u, size_t nu, const unsigned *k, size_t nk,
                                const double *seed, double *out) {
    M *m = c;
    memset(m->seed, 0, sizeof m->seed);
    for (size_t i = 0; i < nk; i++) {
        if (k[i] >= NX) return 3;
        m->seed[k[i]] = seed[i];
    }
    for (size_t j = 0; j < nu; j++) {
        if (u[j] < NX || u[j] >= 2 * NX) return 3;
        size_t i = u[j] - NX;
#ifdef SLOW
        out[j] = i == 0 ? 100 * m->seed[1] : -100 * m->seed[0];
#else
        out[j] = coefficient(i) * m->seed[i] + (i ? m->seed[i - 1] : 0.0);
#endif
    }
    return 0;
}
/* Co-Simulation and asynchronous stepping are not offered. */
F(fmi2DoStep)(void *c, double t, double h, int np) { return 3; }
F(fmi2CancelStep)(void *c) { return 3; }
F(fmi2GetStatus)(void *c, int k, int *v) { return 3; }
F(fmi2GetRealStatus)(void *c, int k, double *v) { return 3; }
F(fmi2GetIntegerStatus)(void *c, int k, int *v) { return 3; }
F(fmi2GetBooleanStatus)(void *c, int k, int *v) { return 3; }
F(fmi2GetStringStatus)(void *c, int k, const char **v) { return 3; }
