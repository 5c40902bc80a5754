/* A small Model Exchange FMU for the importer's and the master's tests, FMI 2.0 by default
 * and FMI 3.0 with -DFMI3: x' = -a x + u, an event indicator x - level (each crossing
 * counted), a time event every `period` seconds (counted, and x jumps by `jump`), the exact
 * Jacobian -a as directional derivative, and `mode` for the hostile cases: 1 the
 * derivatives return Error, 2 they are NaN, 3 the event iteration never converges, 4 the
 * next event time is defined and NaN, 5 the state's nominal is NaN. The
 * FMI 2.0 build has a Co-Simulation interface too, stepped with the exact solution for a
 * held input and its events at the start of each step, where the master handles those of
 * a Model Exchange component at a communication point. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <stddef.h>

enum { X, DX, A, U, LEVEL, PERIOD, JUMP, NREAL };
enum { CROSSINGS = NREAL, TICKS, MODE, NVARS };

typedef struct {
    double t, r[NREAL], next;
    int i[NVARS - NREAL];
    double z; /* the event indicator at the last event */
} M;

static double der(M *m) { return -m->r[A] * m->r[X] + m->r[U]; }

static void reset(M *m) {
    memset(m, 0, sizeof *m);
    m->r[X] = 1.0; m->r[A] = 1.0; m->r[LEVEL] = 0.5; m->r[PERIOD] = 0.25;
}

static void schedule(M *m) {
    m->next = m->r[PERIOD] > 0 ? (floor(m->t / m->r[PERIOD] + 1e-9) + 1) * m->r[PERIOD] : -1;
}

/* One pass of the event iteration: *again if another pass is needed. */
static void event(M *m, bool *again, bool *jumped) {
    double z = m->r[X] - m->r[LEVEL];
    if ((z >= 0) != (m->z >= 0)) m->i[CROSSINGS - NREAL]++;
    m->z = z;
    *jumped = false;
    if (m->next >= 0 && m->t >= m->next - 1e-12) {
        m->i[TICKS - NREAL]++;
        if (m->r[JUMP] != 0) { m->r[X] += m->r[JUMP]; *jumped = true; m->z = m->r[X] - m->r[LEVEL]; }
        schedule(m);
    }
    *again = m->i[MODE - NREAL] == 3;
}

static int get_r(M *m, const unsigned *vr, size_t n, double *v) {
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= NREAL) return 3;
        v[k] = vr[k] == DX ? der(m) : m->r[vr[k]];
    }
    return 0;
}
static int set_r(M *m, const unsigned *vr, size_t n, const double *v) {
    for (size_t k = 0; k < n; k++) {
        if (vr[k] >= NREAL || vr[k] == DX) return 3;
        m->r[vr[k]] = v[k];
    }
    return 0;
}
static int get_i(M *m, const unsigned *vr, size_t n, int *v) {
    for (size_t k = 0; k < n; k++) {
        if (vr[k] < NREAL || vr[k] >= NVARS) return 3;
        v[k] = m->i[vr[k] - NREAL];
    }
    return 0;
}
static int set_i(M *m, const unsigned *vr, size_t n, const int *v) {
    for (size_t k = 0; k < n; k++) {
        if (vr[k] != MODE) return 3;
        m->i[vr[k] - NREAL] = v[k];
    }
    return 0;
}
static int derivatives(M *m, double *dx, size_t n) {
    if (n != 1) return 3;
    if (m->i[MODE - NREAL] == 1) return 3;
    dx[0] = m->i[MODE - NREAL] == 2 ? NAN : der(m);
    return 0;
}
static int indicators(M *m, double *z, size_t n) {
    if (n != 1) return 3;
    z[0] = m->r[X] - m->r[LEVEL];
    return 0;
}
static int jacobian(M *m, const unsigned *u, size_t nu, const unsigned *k, size_t nk,
                    const double *seed, double *out) {
    if (nu != 1 || nk != 1 || u[0] != DX || k[0] != X) return 3;
    out[0] = -m->r[A] * seed[0];
    return 0;
}
static M *create(void) { M *m = calloc(1, sizeof(M)); if (m) reset(m); return m; }
static void exit_init(M *m) { m->z = m->r[X] - m->r[LEVEL]; schedule(m); }

#define F(name) EXPORT int name
#define EXPORT __attribute__((visibility("default")))

#ifndef FMI3
typedef struct { int needed, terminate, nominals, values, next_defined; double next; } EventInfo;
EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
EXPORT const char *fmi2GetVersion(void) { return "2.0"; }
F(fmi2SetDebugLogging)(void *c, int on, size_t n, const char **cats) { return 0; }
EXPORT void *fmi2Instantiate(const char *n, int type, const char *g, const char *r, const void *cb, int v, int l) {
    return create();
}
F(fmi2DoStep)(void *c, double t, double h, int np) {
    M *m = c; bool again, jumped;
    event(m, &again, &jumped);
    double a = m->r[A], u = m->r[U], e = exp(-a * h);
    m->r[X] = a != 0 ? m->r[X] * e + u / a * (1 - e) : m->r[X] + u * h;
    m->t = t + h;
    return m->i[MODE - NREAL] == 1 ? 3 : 0;
}
/* Asynchronous stepping is not offered: these refuse. */
F(fmi2CancelStep)(void *c) { return 3; }
F(fmi2GetStatus)(void *c, int k, int *v) { return 3; }
F(fmi2GetRealStatus)(void *c, int k, double *v) { return 3; }
F(fmi2GetIntegerStatus)(void *c, int k, int *v) { return 3; }
F(fmi2GetBooleanStatus)(void *c, int k, int *v) { return 3; }
F(fmi2GetStringStatus)(void *c, int k, const char **v) { return 3; }
EXPORT void fmi2FreeInstance(void *c) { free(c); }
F(fmi2SetupExperiment)(void *c, int a, double b, double t0, int d, double e) { ((M *)c)->t = t0; return 0; }
F(fmi2EnterInitializationMode)(void *c) { return 0; }
F(fmi2ExitInitializationMode)(void *c) { exit_init(c); return 0; }
F(fmi2Terminate)(void *c) { return 0; }
F(fmi2Reset)(void *c) { reset(c); return 0; }
F(fmi2GetReal)(void *c, const unsigned *vr, size_t n, double *v) { return get_r(c, vr, n, v); }
F(fmi2SetReal)(void *c, const unsigned *vr, size_t n, const double *v) { return set_r(c, vr, n, v); }
F(fmi2GetInteger)(void *c, const unsigned *vr, size_t n, int *v) { return get_i(c, vr, n, v); }
F(fmi2SetInteger)(void *c, const unsigned *vr, size_t n, const int *v) { return set_i(c, vr, n, v); }
F(fmi2GetBoolean)(void *c, const unsigned *vr, size_t n, int *v) { return n ? 3 : 0; }
F(fmi2SetBoolean)(void *c, const unsigned *vr, size_t n, const int *v) { return n ? 3 : 0; }
F(fmi2GetString)(void *c, const unsigned *vr, size_t n, const char **v) { return n ? 3 : 0; }
F(fmi2SetString)(void *c, const unsigned *vr, size_t n, const char **v) { return n ? 3 : 0; }
F(fmi2EnterEventMode)(void *c) { return 0; }
F(fmi2NewDiscreteStates)(void *c, EventInfo *e) {
    M *m = c; bool again, jumped;
    event(m, &again, &jumped);
    e->needed = again; e->terminate = 0; e->nominals = 0; e->values = jumped;
    e->next_defined = m->next >= 0; e->next = m->next;
    if (m->i[MODE - NREAL] == 4) { e->next_defined = 1; e->next = NAN; }
    return 0;
}
F(fmi2EnterContinuousTimeMode)(void *c) { return 0; }
F(fmi2CompletedIntegratorStep)(void *c, int np, int *enter, int *term) { *enter = 0; *term = 0; return 0; }
F(fmi2SetTime)(void *c, double t) { ((M *)c)->t = t; return 0; }
F(fmi2SetContinuousStates)(void *c, const double *x, size_t n) {
    if (n != 1 || isnan(x[0])) return 3;
    ((M *)c)->r[X] = x[0]; return 0;
}
F(fmi2GetDerivatives)(void *c, double *dx, size_t n) { return derivatives(c, dx, n); }
F(fmi2GetEventIndicators)(void *c, double *z, size_t n) { return indicators(c, z, n); }
F(fmi2GetContinuousStates)(void *c, double *x, size_t n) { if (n != 1) return 3; x[0] = ((M *)c)->r[X]; return 0; }
F(fmi2GetNominalsOfContinuousStates)(void *c, double *x, size_t n) {
    if (n != 1) return 3;
    x[0] = ((M *)c)->i[MODE - NREAL] == 5 ? NAN : 1.0; return 0;
}
F(fmi2GetDirectionalDerivative)(void *c, const unsigned *u, size_t nu, const unsigned *k, size_t nk,
                                const double *seed, double *out) { return jacobian(c, u, nu, k, nk, seed, out); }
#else
EXPORT const char *fmi3GetVersion(void) { return "3.0"; }
F(fmi3SetDebugLogging)(void *c, bool on, size_t n, const char **cats) { return 0; }
EXPORT void *fmi3InstantiateModelExchange(const char *n, const char *tok, const char *r, bool v, bool l,
                                          void *env, void *log) { return create(); }
EXPORT void fmi3FreeInstance(void *c) { free(c); }
F(fmi3EnterInitializationMode)(void *c, bool a, double b, double t0, bool d, double e) { ((M *)c)->t = t0; return 0; }
F(fmi3ExitInitializationMode)(void *c) { exit_init(c); return 0; }
F(fmi3Terminate)(void *c) { return 0; }
F(fmi3Reset)(void *c) { reset(c); return 0; }
F(fmi3GetFloat64)(void *c, const unsigned *vr, size_t n, double *v, size_t nv) { return get_r(c, vr, n, v); }
F(fmi3SetFloat64)(void *c, const unsigned *vr, size_t n, const double *v, size_t nv) { return set_r(c, vr, n, v); }
F(fmi3GetInt32)(void *c, const unsigned *vr, size_t n, int *v, size_t nv) { return get_i(c, vr, n, v); }
F(fmi3SetInt32)(void *c, const unsigned *vr, size_t n, const int *v, size_t nv) { return set_i(c, vr, n, v); }
F(fmi3GetBoolean)(void *c, const unsigned *vr, size_t n, bool *v, size_t nv) { return n ? 3 : 0; }
F(fmi3SetBoolean)(void *c, const unsigned *vr, size_t n, const bool *v, size_t nv) { return n ? 3 : 0; }
F(fmi3GetString)(void *c, const unsigned *vr, size_t n, const char **v, size_t nv) { return n ? 3 : 0; }
F(fmi3SetString)(void *c, const unsigned *vr, size_t n, const char **v, size_t nv) { return n ? 3 : 0; }
F(fmi3EnterEventMode)(void *c) { return 0; }
F(fmi3UpdateDiscreteStates)(void *c, bool *needed, bool *term, bool *nominals, bool *values, bool *defined, double *next) {
    M *m = c; bool again, jumped;
    event(m, &again, &jumped);
    *needed = again; *term = false; *nominals = false; *values = jumped;
    *defined = m->next >= 0; *next = m->next;
    if (m->i[MODE - NREAL] == 4) { *defined = true; *next = NAN; }
    return 0;
}
F(fmi3EnterContinuousTimeMode)(void *c) { return 0; }
F(fmi3CompletedIntegratorStep)(void *c, bool np, bool *enter, bool *term) { *enter = false; *term = false; return 0; }
F(fmi3SetTime)(void *c, double t) { ((M *)c)->t = t; return 0; }
F(fmi3SetContinuousStates)(void *c, const double *x, size_t n) {
    if (n != 1 || isnan(x[0])) return 3;
    ((M *)c)->r[X] = x[0]; return 0;
}
F(fmi3GetContinuousStateDerivatives)(void *c, double *dx, size_t n) { return derivatives(c, dx, n); }
F(fmi3GetEventIndicators)(void *c, double *z, size_t n) { return indicators(c, z, n); }
F(fmi3GetContinuousStates)(void *c, double *x, size_t n) { if (n != 1) return 3; x[0] = ((M *)c)->r[X]; return 0; }
F(fmi3GetNominalsOfContinuousStates)(void *c, double *x, size_t n) {
    if (n != 1) return 3;
    x[0] = ((M *)c)->i[MODE - NREAL] == 5 ? NAN : 1.0; return 0;
}
F(fmi3GetDirectionalDerivative)(void *c, const unsigned *u, size_t nu, const unsigned *k, size_t nk,
                                const double *seed, size_t ns, double *out, size_t no) {
    return jacobian(c, u, nu, k, nk, seed, out);
}
#endif
