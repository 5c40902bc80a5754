/* The FMI 2.0 logger callback, which is C-variadic (fmi2CallbackLogger): formats the
 * message with vsnprintf and hands the finished text to the Rust side
 * (inchworm_fmi_import_log in src/logger.rs), which sends it to the `log` crate.
 * Stable Rust can call C-variadic functions but not define them, hence this file. */
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>

void inchworm_fmi_import_log(void *environment, const char *instance_name, int status,
                             const char *category, const char *message);

void inchworm_fmi_import_logger(void *environment, const char *instance_name, int status,
                                const char *category, const char *message, ...) {
    char small[1024];
    va_list args;
    int n;
    if (message == NULL) {
        inchworm_fmi_import_log(environment, instance_name, status, category, "");
        return;
    }
    va_start(args, message);
    n = vsnprintf(small, sizeof small, message, args);
    va_end(args);
    if (n < 0) {
        /* An encoding error in the format: pass the format itself rather than nothing. */
        inchworm_fmi_import_log(environment, instance_name, status, category, message);
        return;
    }
    if ((size_t)n < sizeof small) {
        inchworm_fmi_import_log(environment, instance_name, status, category, small);
        return;
    }
    {
        char *big = (char *)malloc((size_t)n + 1);
        if (big == NULL) {
            /* Out of memory: the truncated text is better than none. */
            inchworm_fmi_import_log(environment, instance_name, status, category, small);
            return;
        }
        va_start(args, message);
        vsnprintf(big, (size_t)n + 1, message, args);
        va_end(args);
        inchworm_fmi_import_log(environment, instance_name, status, category, big);
        free(big);
    }
}
