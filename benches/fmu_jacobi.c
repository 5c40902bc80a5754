/* The C Jacobi loop of benches/closed_loop.rs: the plant and controller FMUs' FMI 2.0
 * libraries, loaded with dlopen and stepped by a plain 2 ms Jacobi loop written in C, the
 * loop of benches/fmpy_jacobi.py without Python between the calls: per step the plant's
 * encoder count and the controller's three DAC volts read, set on the other FMU with the
 * staircase reference, both FMUs stepped. What the FMUs cost through the bare FMI 2.0 API,
 * with no master.
 *
 * Reads from stdin, one item a line: for the plant, then the controller, the library path,
 * the GUID and the resource URI; then the value references: the plant's three DAC inputs
 * and its encoder output, the controller's three DAC outputs, its encoder input, its
 * reference input and its prefilter parameter; then the simulated seconds. Prints the wall
 * time and the CPU time of the loop (s) and the final encoder count. The function types
 * below are the FMI 2.0 signatures the loop calls, written here from the standard's text. */
#define _POSIX_C_SOURCE 200809L /* clock_gettime, getline */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *Component;
typedef unsigned int Vr;
typedef int Status; /* fmi2OK = 0 */

typedef struct {
    void (*logger)(void *, const char *, Status, const char *, const char *, ...);
    void *(*allocate)(size_t, size_t);
    void (*free)(void *);
    void (*step_finished)(void *, Status);
    void *environment;
} Callbacks;

typedef struct {
    Component c;
    Component (*instantiate)(const char *, int, const char *, const char *, const Callbacks *, int, int);
    Status (*setup)(Component, int, double, double, int, double);
    Status (*enter_init)(Component);
    Status (*exit_init)(Component);
    Status (*get_real)(Component, const Vr *, size_t, double *);
    Status (*get_integer)(Component, const Vr *, size_t, int *);
    Status (*set_real)(Component, const Vr *, size_t, const double *);
    Status (*set_integer)(Component, const Vr *, size_t, const int *);
    Status (*set_boolean)(Component, const Vr *, size_t, const int *);
    Status (*do_step)(Component, double, double, int);
} Fmu;

static void quiet_logger(void *env, const char *name, Status s, const char *cat, const char *msg, ...) {
    (void)env, (void)name, (void)s, (void)cat, (void)msg;
}

static char *line(void) {
    char *buf = NULL;
    size_t cap = 0;
    ssize_t n = getline(&buf, &cap, stdin);
    if (n <= 0) {
        fprintf(stderr, "fmu_jacobi: input ends early\n");
        exit(2);
    }
    if (buf[n - 1] == '\n') buf[n - 1] = '\0';
    return buf;
}

static void *sym(void *lib, const char *name) {
    void *f = dlsym(lib, name);
    if (!f) {
        fprintf(stderr, "fmu_jacobi: %s missing\n", name);
        exit(2);
    }
    return f;
}

static void ok(Status s, const char *what) {
    if (s != 0) {
        fprintf(stderr, "fmu_jacobi: %s returned status %d\n", what, s);
        exit(3);
    }
}

static Fmu load(const char *name, const Callbacks *cb) {
    char *path = line(), *guid = line(), *resources = line();
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "fmu_jacobi: %s\n", dlerror());
        exit(2);
    }
    Fmu f;
    *(void **)&f.instantiate = sym(lib, "fmi2Instantiate");
    *(void **)&f.setup = sym(lib, "fmi2SetupExperiment");
    *(void **)&f.enter_init = sym(lib, "fmi2EnterInitializationMode");
    *(void **)&f.exit_init = sym(lib, "fmi2ExitInitializationMode");
    *(void **)&f.get_real = sym(lib, "fmi2GetReal");
    *(void **)&f.get_integer = sym(lib, "fmi2GetInteger");
    *(void **)&f.set_real = sym(lib, "fmi2SetReal");
    *(void **)&f.set_integer = sym(lib, "fmi2SetInteger");
    *(void **)&f.set_boolean = sym(lib, "fmi2SetBoolean");
    *(void **)&f.do_step = sym(lib, "fmi2DoStep");
    f.c = f.instantiate(name, 1 /* fmi2CoSimulation */, guid, resources, cb, 0, 0);
    if (!f.c) {
        fprintf(stderr, "fmu_jacobi: fmi2Instantiate of %s failed\n", path);
        exit(3);
    }
    ok(f.setup(f.c, 0, 0.0, 0.0, 0, 0.0), "fmi2SetupExperiment");
    return f;
}

int main(void) {
    static const Callbacks cb = {quiet_logger, calloc, free, NULL, NULL};
    Fmu plant = load("plant", &cb), ctrl = load("controller", &cb);
    Vr p_dac[3], p_enc, c_dac[3], c_enc, c_ref, c_prefilter;
    double duration;
    for (int i = 0; i < 3; i++) p_dac[i] = (Vr)strtoul(line(), NULL, 10);
    p_enc = (Vr)strtoul(line(), NULL, 10);
    for (int i = 0; i < 3; i++) c_dac[i] = (Vr)strtoul(line(), NULL, 10);
    c_enc = (Vr)strtoul(line(), NULL, 10);
    c_ref = (Vr)strtoul(line(), NULL, 10);
    c_prefilter = (Vr)strtoul(line(), NULL, 10);
    duration = strtod(line(), NULL);

    ok(plant.enter_init(plant.c), "plant fmi2EnterInitializationMode");
    ok(ctrl.enter_init(ctrl.c), "controller fmi2EnterInitializationMode");
    const int on = 1;
    ok(ctrl.set_boolean(ctrl.c, &c_prefilter, 1, &on), "fmi2SetBoolean prefilter");
    ok(plant.exit_init(plant.c), "plant fmi2ExitInitializationMode");
    ok(ctrl.exit_init(ctrl.c), "controller fmi2ExitInitializationMode");

    /* The staircase of benches/fmpy_jacobi.py: a level every 100 s. */
    static const double levels[] = {100e-6, 60e-6, 250e-6, 245e-6, 130e-6, 131.5e-6, 20e-6};
    const long n_levels = sizeof levels / sizeof levels[0];
    const double h = 0.002;
    const long n = (long)(duration / h + 0.5);
    int enc;
    double volts[3];
    struct timespec t0, t1, c0, c1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c0);
    for (long k = 0; k < n; k++) {
        double t = (double)k * h;
        long level = (long)(t / 100.0);
        double ref = levels[level < n_levels ? level : n_levels - 1];
        ok(plant.get_integer(plant.c, &p_enc, 1, &enc), "fmi2GetInteger");
        ok(ctrl.get_real(ctrl.c, c_dac, 3, volts), "fmi2GetReal");
        ok(plant.set_real(plant.c, p_dac, 3, volts), "fmi2SetReal");
        ok(ctrl.set_integer(ctrl.c, &c_enc, 1, &enc), "fmi2SetInteger");
        ok(ctrl.set_real(ctrl.c, &c_ref, 1, &ref), "fmi2SetReal reference");
        ok(plant.do_step(plant.c, t, h, 1), "plant fmi2DoStep");
        ok(ctrl.do_step(ctrl.c, t, h, 1), "controller fmi2DoStep");
    }
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c1);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    ok(plant.get_integer(plant.c, &p_enc, 1, &enc), "fmi2GetInteger");
    printf("%.9f\n", (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec));
    printf("%.9f\n", (double)(c1.tv_sec - c0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - c0.tv_nsec));
    printf("%d\n", enc);
    return 0;
}
