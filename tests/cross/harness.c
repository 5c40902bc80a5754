/* A plain C co-simulation master for the cross-platform tests (tests/python/test_platforms.py)
 * and the Debian 11 proof (scripts/debian11.sh): it loads an FMU's shared library for one
 * platform (dlopen, or LoadLibrary on Windows, where it runs under Wine), speaks FMI 2.0 or
 * FMI 3.0 Co-Simulation to it and prints what it computed, one sample a line.
 *
 *   harness 2|3 check LIB TOKEN INPUT_CSV VR_E VR_NE VR_X VR_ENC
 *       the plant alone, driven by the DAC columns 2-4 of INPUT_CSV (the check trace of
 *       tests/data, 2 ms samples): prints the encoder count after every sample.
 *   harness 2|3 fig5 PLANT_LIB PLANT_TOKEN CTRL_LIB CTRL_TOKEN full|feedback STEPS
 *           P_E P_NE P_X P_ENC C_E C_NE C_X C_ENC C_REF C_FF C_SF C_BD
 *       the Fig. 5 loop: plant and controller coupled by a 2 ms Jacobi loop, reference
 *       100 um; `feedback` switches off feedforward and both estimates (parameters C_FF,
 *       C_SF, C_BD). Prints "counts dac_earth dac_nonearth dac_extension" after each step.
 *
 * Value references and tokens come from the model description (the test reads it with
 * FMPy), so the harness parses no XML. Written against the standards' C signatures only;
 * it includes no FMI header so it builds with any C compiler for any target.
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
static void *open_library(const char *path) { return (void *)LoadLibraryA(path); }
static void *symbol(void *lib, const char *name) {
    return (void *)GetProcAddress((HMODULE)lib, name);
}
static const char *load_error(void) { return "LoadLibraryA failed"; }
#else
#include <dlfcn.h>
static void *open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(void *lib, const char *name) { return dlsym(lib, name); }
static const char *load_error(void) { return dlerror(); }
#endif

#define H 0.002

static void die(const char *what, const char *detail) {
    fprintf(stderr, "harness: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(2);
}

/* ---------------------------------------------------------------- FMI 2.0 */
typedef void (*fmi2Logger)(void *, const char *, int, const char *, const char *, ...);
typedef struct {
    fmi2Logger logger;
    void *(*allocate)(size_t, size_t);
    void (*free)(void *);
    void (*step_finished)(void *, int);
    void *env;
} fmi2Callbacks;

static void logger2(void *env, const char *inst, int status, const char *cat, const char *msg, ...) {
    (void)env;
    if (status >= 2) { /* warnings and errors only */
        va_list ap;
        va_start(ap, msg);
        fprintf(stderr, "[%s %s] ", inst, cat);
        vfprintf(stderr, msg, ap);
        fputc('\n', stderr);
        va_end(ap);
    }
}

/* ---------------------------------------------------------------- FMI 3.0 */
static void logger3(void *env, int status, const char *cat, const char *msg) {
    (void)env;
    if (status >= 1)
        fprintf(stderr, "[%s] %s\n", cat, msg);
}

/* One instance of either standard, behind the calls the two masters need. FMI 3.0's
 * getters and setters take the number of values after the values, FMI 2.0's do not. */
typedef struct {
    int fmi;
    void *lib, *c;
    int (*set_real2)(void *, const unsigned *, size_t, const double *);
    int (*get_real2)(void *, const unsigned *, size_t, double *);
    int (*set_int2)(void *, const unsigned *, size_t, const int *);
    int (*get_int2)(void *, const unsigned *, size_t, int *);
    int (*set_real3)(void *, const unsigned *, size_t, const double *, size_t);
    int (*get_real3)(void *, const unsigned *, size_t, double *, size_t);
    int (*set_int3)(void *, const unsigned *, size_t, const int *, size_t);
    int (*get_int3)(void *, const unsigned *, size_t, int *, size_t);
} Fmu;

static void *need(Fmu *f, const char *name) {
    void *p = symbol(f->lib, name);
    if (!p)
        die("missing export", name);
    return p;
}

static void check(int status, const char *call) {
    if (status != 0)
        die("call did not return OK", call);
}

static void instantiate(Fmu *f, int fmi, const char *lib, const char *token, const char *name) {
    f->fmi = fmi;
    f->lib = open_library(lib);
    if (!f->lib)
        die(lib, load_error());
    if (fmi == 2) {
        static fmi2Callbacks cb = {logger2, calloc, free, NULL, NULL};
        void *(*inst)(const char *, int, const char *, const char *, const fmi2Callbacks *, int,
                      int) = need(f, "fmi2Instantiate");
        f->c = inst(name, 1 /* fmi2CoSimulation */, token, "file:///", &cb, 0, 0);
        if (!f->c)
            die("fmi2Instantiate returned NULL", name);
        int (*setup)(void *, int, double, double, int, double) = need(f, "fmi2SetupExperiment");
        check(setup(f->c, 0, 0.0, 0.0, 0, 0.0), "fmi2SetupExperiment");
        f->set_real2 = need(f, "fmi2SetReal");
        f->get_real2 = need(f, "fmi2GetReal");
        f->set_int2 = need(f, "fmi2SetInteger");
        f->get_int2 = need(f, "fmi2GetInteger");
    } else {
        void *(*inst)(const char *, const char *, const char *, bool, bool, bool, bool,
                      const unsigned *, size_t, void *, void *, void *) =
            need(f, "fmi3InstantiateCoSimulation");
        f->c = inst(name, token, NULL, false, false, false, false, NULL, 0, NULL, (void *)logger3,
                    NULL);
        if (!f->c)
            die("fmi3InstantiateCoSimulation returned NULL", name);
        f->set_real3 = need(f, "fmi3SetFloat64");
        f->get_real3 = need(f, "fmi3GetFloat64");
        f->set_int3 = need(f, "fmi3SetInt32");
        f->get_int3 = need(f, "fmi3GetInt32");
    }
}

static void set_real(Fmu *f, unsigned vr, double v) {
    check(f->fmi == 2 ? f->set_real2(f->c, &vr, 1, &v) : f->set_real3(f->c, &vr, 1, &v, 1),
          "set float");
}
static double get_real(Fmu *f, unsigned vr) {
    double v;
    check(f->fmi == 2 ? f->get_real2(f->c, &vr, 1, &v) : f->get_real3(f->c, &vr, 1, &v, 1),
          "get float");
    return v;
}
static void set_int(Fmu *f, unsigned vr, int v) {
    check(f->fmi == 2 ? f->set_int2(f->c, &vr, 1, &v) : f->set_int3(f->c, &vr, 1, &v, 1),
          "set int");
}
static int get_int(Fmu *f, unsigned vr) {
    int v;
    check(f->fmi == 2 ? f->get_int2(f->c, &vr, 1, &v) : f->get_int3(f->c, &vr, 1, &v, 1),
          "get int");
    return v;
}

static void set_bool(Fmu *f, unsigned vr, bool v) {
    if (f->fmi == 2) {
        int (*set)(void *, const unsigned *, size_t, const int *) = need(f, "fmi2SetBoolean");
        int i = v;
        check(set(f->c, &vr, 1, &i), "fmi2SetBoolean");
    } else {
        int (*set)(void *, const unsigned *, size_t, const bool *, size_t) =
            need(f, "fmi3SetBoolean");
        check(set(f->c, &vr, 1, &v, 1), "fmi3SetBoolean");
    }
}

static void initialize(Fmu *f) {
    if (f->fmi == 2) {
        int (*enter)(void *) = need(f, "fmi2EnterInitializationMode");
        int (*exit_)(void *) = need(f, "fmi2ExitInitializationMode");
        check(enter(f->c), "fmi2EnterInitializationMode");
        check(exit_(f->c), "fmi2ExitInitializationMode");
    } else {
        int (*enter)(void *, bool, double, double, bool, double) =
            need(f, "fmi3EnterInitializationMode");
        int (*exit_)(void *) = need(f, "fmi3ExitInitializationMode");
        check(enter(f->c, false, 0.0, 0.0, false, 0.0), "fmi3EnterInitializationMode");
        check(exit_(f->c), "fmi3ExitInitializationMode");
    }
}

static void do_step(Fmu *f, double t) {
    if (f->fmi == 2) {
        int (*step)(void *, double, double, int) = need(f, "fmi2DoStep");
        check(step(f->c, t, H, 1), "fmi2DoStep");
    } else {
        int (*step)(void *, double, double, bool, bool *, bool *, bool *, double *) =
            need(f, "fmi3DoStep");
        bool event = false, terminate = false, early = false;
        double last = 0.0;
        check(step(f->c, t, H, true, &event, &terminate, &early, &last), "fmi3DoStep");
    }
}

static void release(Fmu *f) {
    const char *term = f->fmi == 2 ? "fmi2Terminate" : "fmi3Terminate";
    int (*terminate)(void *) = need(f, term);
    check(terminate(f->c), term);
    void (*free_instance)(void *) = need(f, f->fmi == 2 ? "fmi2FreeInstance" : "fmi3FreeInstance");
    free_instance(f->c);
}

static unsigned vr(const char *s) { return (unsigned)strtoul(s, NULL, 10); }

static int run_check(int fmi, char **a) {
    Fmu plant;
    instantiate(&plant, fmi, a[0], a[1], "plant");
    initialize(&plant);
    FILE *in = fopen(a[2], "r");
    if (!in)
        die("cannot open", a[2]);
    unsigned e = vr(a[3]), ne = vr(a[4]), x = vr(a[5]), enc = vr(a[6]);
    char line[512];
    if (!fgets(line, sizeof line, in)) /* the header */
        die("empty input", a[2]);
    int k = 0;
    while (fgets(line, sizeof line, in)) {
        double t, de, dne, dx;
        if (sscanf(line, "%lf,%lf,%lf,%lf", &t, &de, &dne, &dx) != 4)
            die("bad input row", line);
        set_real(&plant, e, de);
        set_real(&plant, ne, dne);
        set_real(&plant, x, dx);
        do_step(&plant, k * H);
        printf("%d\n", get_int(&plant, enc));
        k++;
    }
    fclose(in);
    release(&plant);
    return 0;
}

static int run_fig5(int fmi, char **a) {
    Fmu plant, ctrl;
    instantiate(&plant, fmi, a[0], a[1], "plant");
    instantiate(&ctrl, fmi, a[2], a[3], "controller");
    bool feedback_only = strcmp(a[4], "feedback") == 0;
    if (!feedback_only && strcmp(a[4], "full") != 0)
        die("the variant is full or feedback", a[4]);
    int steps = atoi(a[5]);
    unsigned p[4], c[8];
    for (int i = 0; i < 4; i++)
        p[i] = vr(a[6 + i]);
    for (int i = 0; i < 8; i++)
        c[i] = vr(a[10 + i]);
    if (feedback_only)
        for (int i = 5; i < 8; i++)
            set_bool(&ctrl, c[i], false);
    initialize(&plant);
    initialize(&ctrl);
    for (int k = 0; k < steps; k++) {
        int counts = get_int(&plant, p[3]);
        double volts[3];
        for (int i = 0; i < 3; i++)
            volts[i] = get_real(&ctrl, c[i]);
        for (int i = 0; i < 3; i++)
            set_real(&plant, p[i], volts[i]);
        set_int(&ctrl, c[3], counts);
        set_real(&ctrl, c[4], 100e-6);
        do_step(&plant, k * H);
        do_step(&ctrl, k * H);
        printf("%d %.17g %.17g %.17g\n", get_int(&plant, p[3]), volts[0], volts[1], volts[2]);
    }
    release(&plant);
    release(&ctrl);
    return 0;
}

int main(int argc, char **argv) {
    int fmi = argc > 1 ? atoi(argv[1]) : 0;
    if (fmi != 2 && fmi != 3)
        die("usage: harness 2|3 check|fig5 ... (see tests/cross/harness.c)", NULL);
    if (argc == 10 && strcmp(argv[2], "check") == 0)
        return run_check(fmi, argv + 3);
    if (argc == 21 && strcmp(argv[2], "fig5") == 0)
        return run_fig5(fmi, argv + 3);
    die("usage: harness 2|3 check|fig5 ... (see tests/cross/harness.c)", NULL);
    return 2;
}
