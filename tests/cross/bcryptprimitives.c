/* Test infrastructure for tests/python/test_platforms.py, never shipped: Wine 8 (Debian 12)
 * has no bcryptprimitives.dll, from which Rust's standard library imports ProcessPrng (the
 * random source of its hash maps). This stand-in, put beside the harness only, answers it
 * with RtlGenRandom (advapi32's SystemFunction036), which Wine has. */
#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x10000000 ? 0x10000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk))
            return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
